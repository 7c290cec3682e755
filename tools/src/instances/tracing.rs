//! A scene traced as its flattened mesh: hit records numbered in the
//! flattened order, for `kdray trace` and the renderer.

use super::flatten::{flatten_scene, flattened_offsets};
use kdray_kernel::{Hit, Ray, Scene, Triangle, KIND_SCENE};

/// Is `bytes` a scene blob (by its header's kind; nothing else checked)?
#[must_use]
pub fn is_scene_blob(bytes: &[u8]) -> bool {
    bytes.get(16..20) == Some(&KIND_SCENE.to_le_bytes()[..])
}

/// Where each instance's triangles start in the flattened order of `scene`.
#[must_use]
pub fn scene_offsets(scene: &Scene<'_>) -> Vec<u64> {
    let sizes: Vec<usize> = (0..scene.mesh_count())
        .map(|m| scene.mesh(m).map_or(0, |t| t.triangles().len()))
        .collect();
    flattened_offsets(&sizes, scene.instances())
}

/// Traces `rays` through `scene` (every instance: mask all ones) on the
/// current rayon pool into `hits`, as hit-file records: `prim` is the
/// triangle's index in the flattened order ([`flatten_scene`]; for a glTF
/// scene, the order `kdray build` without `--instances` uses); `any`
/// writes occlusion records.
pub fn trace_scene(scene: &Scene<'_>, offsets: &[u64], rays: &[Ray], hits: &mut [Hit], any: bool) {
    use rayon::prelude::*;
    hits.par_chunks_mut(1024)
        .zip(rays.par_chunks(1024))
        .for_each(|(hs, rs)| {
            for (h, r) in hs.iter_mut().zip(rs) {
                *h = if any {
                    Hit::occlusion(scene.any_hit(r, u32::MAX))
                } else {
                    flattened_hit(&scene.closest_hit(r, u32::MAX), offsets)
                };
            }
        });
}

/// A scene's hit as a hit-file record, `prim` in the flattened order
/// (`offsets`: [`scene_offsets`]); a miss record for a miss.
fn flattened_hit(s: &kdray_kernel::SceneHit, offsets: &[u64]) -> Hit {
    match offsets.get(s.instance as usize) {
        Some(&at) if s.is_hit() => Hit {
            prim: u32::try_from(at + u64::from(s.prim)).unwrap_or(kdray_kernel::MISS),
            ..s.hit()
        },
        _ => Hit::MISS,
    }
}

/// The first `k` hits of each ray through `scene` (every instance) on the
/// current rayon pool into `hits`, `k` slots a ray, as hit-file records
/// numbered in the flattened order ([`trace_scene`]); unused slots miss
/// records. The scene's order (`t`, then instance, then triangle) is the
/// flattened order's (`t`, then flattened index): instances are flattened
/// in turn. Returns how many hits in all.
pub fn first_hits_scene(
    scene: &Scene<'_>,
    offsets: &[u64],
    rays: &[Ray],
    hits: &mut [Hit],
    k: usize,
) -> usize {
    use kdray_kernel::SceneHit;
    use rayon::prelude::*;
    let k = k.max(1);
    hits.par_chunks_mut(1024 * k)
        .zip(rays.par_chunks(1024))
        .map(|(hs, rs)| {
            let mut found = vec![SceneHit::MISS; k];
            let mut total = 0;
            for (slots, r) in hs.chunks_mut(k).zip(rs) {
                let n = scene.first_hits(r, u32::MAX, &mut found);
                total += n;
                slots.fill(Hit::MISS);
                for (slot, s) in slots.iter_mut().zip(found.iter().take(n)) {
                    *slot = flattened_hit(s, offsets);
                }
            }
            total
        })
        .sum()
}

/// A scene as the renderer's [`Tracer`](crate::render::Tracer): hits
/// numbered in the flattened order, shaded on the flattened triangles.
#[derive(Debug)]
pub struct SceneTracer<'s, 'a> {
    scene: &'s Scene<'a>,
    offsets: Vec<u64>,
    flat: Vec<Triangle>,
}

impl<'s, 'a> SceneTracer<'s, 'a> {
    /// The tracer of `scene` (its flattened triangles are made here).
    #[must_use]
    pub fn new(scene: &'s Scene<'a>) -> SceneTracer<'s, 'a> {
        let meshes: Vec<&[Triangle]> = (0..scene.mesh_count())
            .map(|m| scene.mesh(m).map_or(&[][..], |t| t.triangles()))
            .collect();
        SceneTracer {
            scene,
            offsets: scene_offsets(scene),
            flat: flatten_scene(&meshes, scene.instances()),
        }
    }
}

impl crate::render::Tracer for SceneTracer<'_, '_> {
    fn triangles(&self) -> &[Triangle] {
        &self.flat
    }
    fn packet_width(&self) -> kdray_kernel::PacketWidth {
        kdray_kernel::PacketWidth::One
    }
    fn closest(&self, rays: &[Ray], hits: &mut [Hit]) {
        for (h, r) in hits.iter_mut().zip(rays) {
            *h = flattened_hit(&self.scene.closest_hit(r, u32::MAX), &self.offsets);
        }
    }
    fn occluded(&self, rays: &[Ray], out: &mut [bool]) {
        for (o, r) in out.iter_mut().zip(rays) {
            *o = self.scene.any_hit(r, u32::MAX);
        }
    }
}
