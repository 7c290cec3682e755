//! Distance queries on a triangle tree: the closest point of the mesh to a
//! point, or to each of N points, and the signed distance (negative inside).

use crate::handle::{self, KdrayTriangleTree};
use crate::{check_count, check_ptr, status, KdrayStatus};
use bytemuck::{Pod, Zeroable};
use kdray_kernel::{ClosestPoint, TriangleTree, MISS};

/// The closest point of a mesh to a query: 32 bytes.
///
/// The point is `(1 - u - v) * v0 + u * v1 + v * v2` of triangle
/// `prim_id`'s vertices. No triangle within the maximum distance:
/// `prim_id = KDRAY_MISS`, the point, `u` and `v` NaN, `distance2 =
/// INFINITY` (NaN for a query with a NaN or infinite coordinate).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct KdrayClosestPoint {
    /// The closest point, x.
    pub x: f32,
    /// The closest point, y.
    pub y: f32,
    /// The closest point, z.
    pub z: f32,
    /// Index of its triangle in the mesh the blob was built from (the
    /// lowest among equally near ones).
    pub prim_id: u32,
    /// Barycentric weight of vertex 1.
    pub u: f32,
    /// Barycentric weight of vertex 2.
    pub v: f32,
    /// The squared distance from the query, computed in double.
    pub distance2: f64,
}

impl KdrayClosestPoint {
    /// The record of `c`, the closest point to `q` (`None`: no point; the
    /// distance is `inf`, or NaN for a query that is not finite).
    pub(crate) fn of(c: Option<ClosestPoint>, q: &[f32; 3]) -> KdrayClosestPoint {
        match c {
            Some(c) => KdrayClosestPoint {
                x: c.point[0],
                y: c.point[1],
                z: c.point[2],
                prim_id: c.prim,
                u: c.u,
                v: c.v,
                distance2: c.distance2,
            },
            None => KdrayClosestPoint {
                x: f32::NAN,
                y: f32::NAN,
                z: f32::NAN,
                prim_id: MISS,
                u: f32::NAN,
                v: f32::NAN,
                distance2: if q.iter().all(|c| c.is_finite()) {
                    f64::INFINITY
                } else {
                    f64::NAN
                },
            },
        }
    }
}

/// The signed distance from `q`: negative inside by the majority of `rays`
/// rays (clamped to 1..=7; 1 is the parity of one ray, for closed
/// meshes); `INFINITY` for an empty mesh, NaN for a query that is not
/// finite.
fn signed(t: &TriangleTree<'_>, q: [f32; 3], rays: u32) -> f32 {
    let c = KdrayClosestPoint::of(t.closest_point(q), &q);
    let d = libm::sqrt(c.distance2) as f32;
    if t.contains_voting(q, rays) {
        -d
    } else {
        d
    }
}

/// The closest point of `*tree`'s mesh to the point `point[0..3]` among
/// those within `max_distance` (`INFINITY`: no limit; NaN or negative:
/// none), into `*out` (see `KdrayClosestPoint` for no point). Bit for bit
/// the kernel's `TriangleTree::closest_point_within`.
///
/// # Preconditions
/// - `tree`: opened by `kdray_triangles_open` (else `KDRAY_STATUS_NOT_OPEN`),
///   and its blob still alive and unchanged.
/// - `point`: non-null, 4-byte aligned, 3 floats; `out` non-null, 8-byte
///   aligned.
///
/// # Safety
/// As the preconditions.
#[no_mangle]
pub unsafe extern "C" fn kdray_closest_point(
    tree: *const KdrayTriangleTree,
    point: *const f32,
    max_distance: f32,
    out: *mut KdrayClosestPoint,
) -> KdrayStatus {
    // SAFETY: this function's contract is `kdray_closest_points`' for one point.
    unsafe { kdray_closest_points(tree, point, 1, max_distance, out) }
}

/// The closest points of `count` points (`points`: `3 * count` floats, x
/// y z each), into `out[0..count]`: each as `kdray_closest_point`.
///
/// # Preconditions
/// As `kdray_closest_point`, with `points` holding `3 * count` floats and
/// `out` `count` records, not overlapping (non-null even for
/// `count == 0`).
///
/// # Safety
/// As the preconditions.
#[no_mangle]
pub unsafe extern "C" fn kdray_closest_points(
    tree: *const KdrayTriangleTree,
    points: *const f32,
    count: usize,
    max_distance: f32,
    out: *mut KdrayClosestPoint,
) -> KdrayStatus {
    status((|| {
        // SAFETY: `tree`'s contract.
        let t = unsafe { handle::load::<TriangleTree>(tree) }?;
        check_ptr(points)?;
        check_ptr(out.cast_const())?;
        check_count::<[f32; 3]>(count)?;
        check_count::<KdrayClosestPoint>(count)?;
        // SAFETY: non-null, aligned, `count` points by contract, the size
        // fits a slice; `[f32; 3]` has f32's alignment.
        let qs = unsafe { core::slice::from_raw_parts(points.cast::<[f32; 3]>(), count) };
        // SAFETY: as for `points`, writable and not overlapping by contract.
        let out = unsafe { core::slice::from_raw_parts_mut(out, count) };
        for (o, q) in out.iter_mut().zip(qs) {
            *o = KdrayClosestPoint::of(t.closest_point_within(*q, max_distance), q);
        }
        Ok(())
    })())
}

/// The signed distance from the point `point[0..3]` to `*tree`'s mesh,
/// into `*out`: the distance to the closest point, negative inside. Inside
/// is decided by the parity of the crossings of `rays` rays in fixed
/// directions, by majority (clamped to 1..=7: 1 for closed meshes, 3 to 7
/// for open or self-intersecting ones); a shared edge or vertex is crossed
/// once. `INFINITY` for an empty mesh, NaN for a query with a NaN or
/// infinite coordinate.
///
/// # Preconditions
/// As `kdray_closest_point`; `out` non-null and 4-byte aligned.
///
/// # Safety
/// As the preconditions.
#[no_mangle]
pub unsafe extern "C" fn kdray_signed_distance(
    tree: *const KdrayTriangleTree,
    point: *const f32,
    rays: u32,
    out: *mut f32,
) -> KdrayStatus {
    // SAFETY: this function's contract is `kdray_signed_distances`' for one point.
    unsafe { kdray_signed_distances(tree, point, 1, rays, out) }
}

/// The signed distances of `count` points (`points`: `3 * count` floats),
/// into `out[0..count]`: each as `kdray_signed_distance`.
///
/// # Preconditions
/// As `kdray_closest_points`, with `out` holding `count` floats.
///
/// # Safety
/// As the preconditions.
#[no_mangle]
pub unsafe extern "C" fn kdray_signed_distances(
    tree: *const KdrayTriangleTree,
    points: *const f32,
    count: usize,
    rays: u32,
    out: *mut f32,
) -> KdrayStatus {
    status((|| {
        // SAFETY: `tree`'s contract.
        let t = unsafe { handle::load::<TriangleTree>(tree) }?;
        check_ptr(points)?;
        check_ptr(out.cast_const())?;
        check_count::<[f32; 3]>(count)?;
        // SAFETY: as in `kdray_closest_points`.
        let qs = unsafe { core::slice::from_raw_parts(points.cast::<[f32; 3]>(), count) };
        // SAFETY: as for `points`, writable and not overlapping by contract.
        let out = unsafe { core::slice::from_raw_parts_mut(out, count) };
        for (o, q) in out.iter_mut().zip(qs) {
            *o = signed(&t, *q, rays);
        }
        Ok(())
    })())
}
