//! The flattened scene: every instance's triangles in world space, in
//! instance order.

use kdray_kernel::{Instance, Triangle};

/// `p` through a 3×4 row-major transform, in `f32`, rows summed left to
/// right (the kernel's [`Instance::local_ray`] arithmetic).
#[must_use]
pub fn transform_point(m: &[f32; 12], p: [f32; 3]) -> [f32; 3] {
    core::array::from_fn(|r| {
        ((m[r * 4] * p[0] + m[r * 4 + 1] * p[1]) + m[r * 4 + 2] * p[2]) + m[r * 4 + 3]
    })
}

/// The flattened scene: every instance's triangles through its transform,
/// in instance order, each mesh's triangles in mesh order. Triangle `p` of
/// instance `i` has index `flattened_offsets(..)[i] + p`.
#[must_use]
pub fn flatten_scene<M: AsRef<[Triangle]>>(meshes: &[M], instances: &[Instance]) -> Vec<Triangle> {
    let mut out = Vec::new();
    for inst in instances {
        let m = inst.to_world();
        if let Some(tris) = meshes.get(inst.mesh() as usize) {
            out.extend(tris.as_ref().iter().map(|t| Triangle {
                v: t.v.map(|p| transform_point(&m, p)),
            }));
        }
    }
    out
}

/// Where each instance's triangles start in the flattened order (the
/// prefix sums of their meshes' triangle counts).
#[must_use]
pub fn flattened_offsets(mesh_sizes: &[usize], instances: &[Instance]) -> Vec<u64> {
    let mut at = 0u64;
    instances
        .iter()
        .map(|i| {
            let start = at;
            at += mesh_sizes.get(i.mesh() as usize).copied().unwrap_or(0) as u64;
            start
        })
        .collect()
}
