//! Point trees: open a blob, then the nearest point, the k nearest, or
//! every point within a radius of a query. Each function is one call of
//! the kernel's 3-D `f32` `PointTree`, so a tree of another dimension or
//! scalar type is a new handle kind and four more functions of this shape.

use crate::handle::{self, KdrayPointTree};
use crate::{check_count, check_ptr, status, KdrayStatus};
use bytemuck::{Pod, Zeroable};
use core::ffi::c_char;
use kdray_kernel::Neighbour;

/// One neighbour: 8 bytes, the record of a `.knn` file. A missing
/// neighbour (fewer points than asked for) is `index = 0xFFFFFFFF`,
/// `d2 = INFINITY`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct KdrayNeighbour {
    /// The point's index in the builder's input.
    pub index: u32,
    /// Its squared Euclidean distance to the query (`dx*dx + dy*dy + dz*dz`
    /// in `float`, summed left to right).
    pub d2: f32,
}

// Both are `repr(C)` `{u32 index, f32 d2}`: the same layout, so the
// caller's records are handed to the kernel in place.
const _: () = assert!(core::mem::size_of::<KdrayNeighbour>() == core::mem::size_of::<Neighbour>());
const _: () =
    assert!(core::mem::align_of::<KdrayNeighbour>() == core::mem::align_of::<Neighbour>());

/// Opens the point-tree blob `blob[0..len]` (written by `kdray
/// build-points`) into `*tree`, validating all of it.
///
/// # Preconditions
/// As `kdray_triangles_open`, for a point-tree blob (a triangle blob is
/// refused: "wrong kind").
///
/// # Safety
/// As the preconditions.
#[no_mangle]
pub unsafe extern "C" fn kdray_points_open(
    tree: *mut KdrayPointTree,
    blob: *const u8,
    len: usize,
    message: *mut c_char,
    message_len: usize,
) -> KdrayStatus {
    // SAFETY: this function's contract.
    unsafe { handle::open(tree, blob, len, message, message_len) }
}

/// Reads a query point after checking its pointer.
///
/// # Safety
/// If non-null and aligned, `query` points to 3 readable floats.
unsafe fn read_query(query: *const f32) -> Result<[f32; 3], KdrayStatus> {
    let q = query.cast::<[f32; 3]>();
    check_ptr(q)?;
    // SAFETY: checked non-null and aligned; 3 floats by the contract.
    Ok(unsafe { q.read() })
}

/// The nearest point to `query[0..3]`, written to `*nearest`: smallest
/// squared distance, at equal distance the lowest index (exactly as brute
/// force). An empty tree or a query with a NaN coordinate gives the
/// missing-neighbour record.
///
/// # Preconditions
/// - `tree`: opened by `kdray_points_open`, its blob alive and unchanged.
/// - `query`: non-null, 4-byte aligned, 3 floats (x, y, z).
/// - `nearest`: non-null, 4-byte aligned.
///
/// # Safety
/// As the preconditions.
#[no_mangle]
pub unsafe extern "C" fn kdray_nearest(
    tree: *const KdrayPointTree,
    query: *const f32,
    nearest: *mut KdrayNeighbour,
) -> KdrayStatus {
    status((|| {
        // SAFETY: `tree`'s contract.
        let t = unsafe { handle::load(tree) }?;
        // SAFETY: `query`'s contract.
        let q = unsafe { read_query(query) }?;
        check_ptr(nearest.cast_const())?;
        let n = t.nearest(q).unwrap_or(Neighbour::NONE);
        // SAFETY: checked non-null and aligned; writable by the contract.
        unsafe {
            nearest.write(KdrayNeighbour {
                index: n.index,
                d2: n.d2,
            })
        };
        Ok(())
    })())
}

/// The `k` nearest points to `query[0..3]`, written to `out[0..*found]`
/// nearest first (equal distance: lower index first), exactly as brute
/// force; `*found` is `k` unless the tree has fewer points. `out[*found..k]`
/// is left unchanged. `k == 0` or a NaN query finds nothing.
///
/// # Preconditions
/// - `tree`, `query`: as `kdray_nearest`.
/// - `out`: non-null, 4-byte aligned, `k` writable records.
/// - `found`: non-null, aligned for `size_t`.
///
/// # Safety
/// As the preconditions.
#[no_mangle]
pub unsafe extern "C" fn kdray_knn(
    tree: *const KdrayPointTree,
    query: *const f32,
    k: usize,
    out: *mut KdrayNeighbour,
    found: *mut usize,
) -> KdrayStatus {
    status((|| {
        // SAFETY: `tree`'s contract.
        let t = unsafe { handle::load(tree) }?;
        // SAFETY: `query`'s contract.
        let q = unsafe { read_query(query) }?;
        // SAFETY: `out`'s and `found`'s contracts.
        let (out, found) = unsafe { outputs(out, k, found) }?;
        *found = t.knn(q, out);
        Ok(())
    })())
}

/// Every point at squared distance `<= r2` from `query[0..3]`, written to
/// `out[0..*found]` nearest first (equal distance: lower index first),
/// exactly as brute force.
///
/// If more than `capacity` points are in range, returns
/// `KDRAY_STATUS_BUFFER_TOO_SMALL` with `*found` set to how many there are
/// (the capacity that suffices); `out` then holds some of them, unordered.
///
/// # Preconditions
/// - `tree`, `query`: as `kdray_nearest`.
/// - `out`: non-null, 4-byte aligned, `capacity` writable records.
/// - `found`: non-null, aligned for `size_t`.
///
/// # Safety
/// As the preconditions.
#[no_mangle]
pub unsafe extern "C" fn kdray_within(
    tree: *const KdrayPointTree,
    query: *const f32,
    r2: f32,
    out: *mut KdrayNeighbour,
    capacity: usize,
    found: *mut usize,
) -> KdrayStatus {
    status((|| {
        // SAFETY: `tree`'s contract.
        let t = unsafe { handle::load(tree) }?;
        // SAFETY: `query`'s contract.
        let q = unsafe { read_query(query) }?;
        // SAFETY: `out`'s and `found`'s contracts.
        let (out, found) = unsafe { outputs(out, capacity, found) }?;
        match t.within(q, r2, out) {
            Ok(n) => {
                *found = n;
                Ok(())
            }
            Err(e) => {
                *found = e.needed;
                Err(KdrayStatus::BufferTooSmall)
            }
        }
    })())
}

/// The output slice and count of the multi-point queries, checked.
///
/// # Safety
/// If non-null and aligned, `out` points to `len` writable records and
/// `found` to a writable `size_t`.
unsafe fn outputs<'a>(
    out: *mut KdrayNeighbour,
    len: usize,
    found: *mut usize,
) -> Result<(&'a mut [Neighbour], &'a mut usize), KdrayStatus> {
    check_ptr(out.cast_const())?;
    check_ptr(found.cast_const())?;
    check_count::<KdrayNeighbour>(len)?;
    // SAFETY: non-null, aligned, `len` writable records by contract, the
    // size fits a slice; KdrayNeighbour is Neighbour's layout (asserted above),
    // and every bit pattern is a valid `u32` and `f32`.
    let out = unsafe { core::slice::from_raw_parts_mut(out.cast::<Neighbour>(), len) };
    // SAFETY: checked non-null and aligned; writable by the contract.
    Ok((out, unsafe { &mut *found }))
}
