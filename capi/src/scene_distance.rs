//! Distance queries on a scene: the closest point over the instances a
//! mask selects, in world space, each answer naming its instance.

use crate::distance::KdrayClosestPoint;
use crate::handle::{self, KdrayScene};
use crate::{check_count, check_ptr, status, KdrayStatus};
use bytemuck::{Pod, Zeroable};
use kdray_kernel::{Scene, SceneClosestPoint, MISS};

/// A scene's closest point to a query: 40 bytes.
///
/// The point is in world space; `prim_id` is the triangle's index in its
/// instance's mesh, `inst_id` the instance's index in the scene. No
/// instance within the maximum distance (or none selected):
/// `prim_id = inst_id = KDRAY_MISS`, the point, `u` and `v` NaN,
/// `distance2 = INFINITY` (NaN for a query with a NaN or infinite
/// coordinate).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct KdraySceneClosestPoint {
    /// The closest point, x.
    pub x: f32,
    /// The closest point, y.
    pub y: f32,
    /// The closest point, z.
    pub z: f32,
    /// Index of its triangle in its instance's mesh.
    pub prim_id: u32,
    /// Barycentric weight of vertex 1.
    pub u: f32,
    /// Barycentric weight of vertex 2.
    pub v: f32,
    /// Index of its instance in the scene (the lowest among equally near
    /// ones).
    pub inst_id: u32,
    /// Zero.
    pub reserved: u32,
    /// The world squared distance from the query, computed in double.
    pub distance2: f64,
}

impl KdraySceneClosestPoint {
    /// The tree's record of the same point (one rule for a missing
    /// point), with the instance.
    fn of(c: Option<SceneClosestPoint>, q: &[f32; 3]) -> KdraySceneClosestPoint {
        let KdrayClosestPoint {
            x,
            y,
            z,
            prim_id,
            u,
            v,
            distance2,
        } = KdrayClosestPoint::of(c.map(|c| c.point_only()), q);
        KdraySceneClosestPoint {
            x,
            y,
            z,
            prim_id,
            u,
            v,
            inst_id: c.map_or(MISS, |c| c.instance),
            reserved: 0,
            distance2,
        }
    }
}

/// The closest point to the world point `point[0..3]` over the instances
/// of `*scene` whose mask shares a bit with `mask`, among those within
/// `max_distance` (`INFINITY`: no limit; NaN or negative: none), into
/// `*out` (see `KdraySceneClosestPoint` for no point): the smallest world
/// distance, then the lower instance, then the lower triangle, bit for
/// bit the kernel's `Scene::closest_point_within`.
/// `KDRAY_STATUS_NOT_SIMILAR` when a selected instance is scaled unevenly
/// or sheared (its nearest point in mesh space is not the world's).
///
/// # Preconditions
/// - `scene`: opened by `kdray_scene_open` (else `KDRAY_STATUS_NOT_OPEN`),
///   its blob still alive and unchanged.
/// - `point`: non-null, 4-byte aligned, 3 floats; `out` non-null, 8-byte
///   aligned.
///
/// # Safety
/// As the preconditions.
#[no_mangle]
pub unsafe extern "C" fn kdray_scene_closest_point(
    scene: *const KdrayScene,
    point: *const f32,
    mask: u32,
    max_distance: f32,
    out: *mut KdraySceneClosestPoint,
) -> KdrayStatus {
    // SAFETY: this function's contract is `kdray_scene_closest_points`'
    // for one point.
    unsafe { kdray_scene_closest_points(scene, point, 1, mask, max_distance, out) }
}

/// The closest points of `count` world points (`points`: `3 * count`
/// floats, x y z each), into `out[0..count]`: each as
/// `kdray_scene_closest_point`. On `KDRAY_STATUS_NOT_SIMILAR` nothing is
/// written.
///
/// # Preconditions
/// As `kdray_scene_closest_point`, with `points` holding `3 * count`
/// floats and `out` `count` records, not overlapping (non-null even for
/// `count == 0`).
///
/// # Safety
/// As the preconditions.
#[no_mangle]
pub unsafe extern "C" fn kdray_scene_closest_points(
    scene: *const KdrayScene,
    points: *const f32,
    count: usize,
    mask: u32,
    max_distance: f32,
    out: *mut KdraySceneClosestPoint,
) -> KdrayStatus {
    status((|| {
        // SAFETY: `scene`'s contract.
        let s = unsafe { handle::load::<Scene>(scene) }?;
        check_ptr(points)?;
        check_ptr(out.cast_const())?;
        check_count::<[f32; 3]>(count)?;
        check_count::<KdraySceneClosestPoint>(count)?;
        s.check_similar(mask).map_err(|_| KdrayStatus::NotSimilar)?;
        // SAFETY: non-null, aligned, `count` points by contract, the size
        // fits a slice; `[f32; 3]` has f32's alignment.
        let qs = unsafe { core::slice::from_raw_parts(points.cast::<[f32; 3]>(), count) };
        // SAFETY: as for `points`, writable and not overlapping by contract.
        let out = unsafe { core::slice::from_raw_parts_mut(out, count) };
        for (o, q) in out.iter_mut().zip(qs) {
            // Refused above for a mask selecting a non-similarity.
            let c = s
                .closest_point_within(*q, mask, max_distance)
                .ok()
                .flatten();
            *o = KdraySceneClosestPoint::of(c, q);
        }
        Ok(())
    })())
}
