//! Scenes: open a scene blob, trace one ray against the instances a mask
//! selects.

use crate::handle::{self, KdrayScene};
use crate::rays::KdrayRay;
use crate::{check_count, check_ptr, status, KdrayStatus};
use bytemuck::{Pod, Zeroable};
use core::ffi::c_char;
use kdray_kernel::{Scene, SceneHit};

/// A scene's closest hit: 20 bytes. `prim_id` is the triangle's index in
/// its instance's mesh, `inst_id` the instance's index in the scene (its
/// user id is in the scene blob's instance table); a miss is
/// `t = INFINITY`, `prim_id = inst_id = KDRAY_MISS`, `u = v = 0`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct KdraySceneHit {
    /// Ray parameter of the hit (`INFINITY` for a miss).
    pub t: f32,
    /// Index of the triangle hit in its mesh.
    pub prim_id: u32,
    /// Barycentric weight of vertex 1.
    pub u: f32,
    /// Barycentric weight of vertex 2.
    pub v: f32,
    /// Index of the instance hit.
    pub inst_id: u32,
}

// The record is the kernel's, field for field.
const _: () = assert!(core::mem::size_of::<KdraySceneHit>() == core::mem::size_of::<SceneHit>());

impl From<SceneHit> for KdraySceneHit {
    fn from(h: SceneHit) -> KdraySceneHit {
        bytemuck::cast(h)
    }
}

/// Opens the scene blob `blob[0..len]` into `*scene`, validating all of it
/// (header, sections, checksum, every mesh tree, every instance, the top
/// level): O(len), no allocation, no copy. Statuses and `message` as
/// `kdray_triangles_open`.
///
/// # Preconditions
/// As `kdray_triangles_open`, with `scene` for `tree`.
///
/// # Safety
/// As the preconditions.
#[no_mangle]
pub unsafe extern "C" fn kdray_scene_open(
    scene: *mut KdrayScene,
    blob: *const u8,
    len: usize,
    message: *mut c_char,
    message_len: usize,
) -> KdrayStatus {
    // SAFETY: this function's contract.
    unsafe { handle::open::<Scene>(scene, blob, len, message, message_len) }
}

/// The closest hit of `*ray` among the instances of `*scene` whose mask
/// shares a bit with `mask`, written to `*hit`: the smallest `t`, then the
/// lower instance, then the lower triangle, bit for bit as the Rust API.
///
/// # Preconditions
/// - `scene`: opened by `kdray_scene_open` (else `KDRAY_STATUS_NOT_OPEN`),
///   its blob still alive and unchanged.
/// - `ray`: non-null, 4-byte aligned; `hit`: non-null, 4-byte aligned.
///
/// # Safety
/// As the preconditions.
#[no_mangle]
pub unsafe extern "C" fn kdray_scene_closest_hit(
    scene: *const KdrayScene,
    ray: *const KdrayRay,
    mask: u32,
    hit: *mut KdraySceneHit,
) -> KdrayStatus {
    status((|| {
        // SAFETY: `scene`'s contract.
        let s = unsafe { handle::load::<Scene>(scene) }?;
        check_ptr(ray)?;
        check_ptr(hit.cast_const())?;
        // SAFETY: checked non-null and aligned; whole records by contract.
        let r = unsafe { ray.read() };
        // SAFETY: as for `ray`.
        unsafe { hit.write(s.closest_hit(&r.into(), mask).into()) };
        Ok(())
    })())
}

/// Whether `*ray` hits any instance of `*scene` that `mask` selects, in
/// `[tnear, tfar]`: `*occluded` is 1 if so, else 0.
///
/// # Preconditions
/// As `kdray_scene_closest_hit`; `occluded` non-null and 4-byte aligned.
///
/// # Safety
/// As the preconditions.
#[no_mangle]
pub unsafe extern "C" fn kdray_scene_any_hit(
    scene: *const KdrayScene,
    ray: *const KdrayRay,
    mask: u32,
    occluded: *mut i32,
) -> KdrayStatus {
    status((|| {
        // SAFETY: `scene`'s contract.
        let s = unsafe { handle::load::<Scene>(scene) }?;
        check_ptr(ray)?;
        check_ptr(occluded.cast_const())?;
        // SAFETY: checked non-null and aligned; whole records by contract.
        unsafe { occluded.write(i32::from(s.any_hit(&ray.read().into(), mask))) };
        Ok(())
    })())
}

/// The first hits of `*ray` among the instances of `*scene` that `mask`
/// selects, at most `capacity`: `hits[0..*count]`, sorted by `t`, then
/// instance, then triangle, each instance's triangle once, bit for bit as
/// the Rust API (`Scene::first_hits`); the first is
/// `kdray_scene_closest_hit`'s. `*count` is 0 for a miss; entries past it
/// are left as they were.
///
/// # Preconditions
/// As `kdray_scene_closest_hit`; `count` non-null and aligned; `hits`
/// non-null (even for `capacity == 0`), 4-byte aligned, `capacity`
/// records, not overlapping `ray` or `count`.
///
/// # Safety
/// As the preconditions.
#[no_mangle]
pub unsafe extern "C" fn kdray_scene_first_hits(
    scene: *const KdrayScene,
    ray: *const KdrayRay,
    mask: u32,
    hits: *mut KdraySceneHit,
    capacity: usize,
    count: *mut usize,
) -> KdrayStatus {
    status((|| {
        // SAFETY: `scene`'s contract.
        let s = unsafe { handle::load::<Scene>(scene) }?;
        check_ptr(ray)?;
        check_ptr(hits.cast_const())?;
        check_ptr(count.cast_const())?;
        check_count::<KdraySceneHit>(capacity)?;
        // SAFETY: checked non-null and aligned; a whole record by contract.
        let r = unsafe { ray.read() };
        // SAFETY: non-null, aligned, `capacity` records by contract, the
        // size fits a slice; KdraySceneHit is SceneHit's layout (asserted
        // above), both Pod.
        let hits = unsafe { core::slice::from_raw_parts_mut(hits.cast::<SceneHit>(), capacity) };
        let n = s.first_hits(&r.into(), mask, hits);
        // SAFETY: as for `ray`.
        unsafe { count.write(n) };
        Ok(())
    })())
}
