//! Point trees of any dimension D (1 to 16) and `float` or `double`
//! coordinates: open a blob, ask its shape, then the nearest point, the k
//! nearest, or every point within a radius of a query.
//!
//! The handle remembers the blob's D and scalar type (in its tag); each
//! query names the D and type it passes (`_f32` / `_f64` and `dim`), so a
//! query of another shape is `KDRAY_STATUS_WRONG_SHAPE`, never a read past
//! the caller's array. `kdray_nearest`, `kdray_knn` and `kdray_within` are
//! the 3-D `float` calls.

use crate::handle::{self, KdrayPointTree};
use crate::{check_count, check_ptr, status, KdrayStatus};
use bytemuck::{Pod, Zeroable};
use core::ffi::c_char;
use core::fmt;
use kdray_kernel::{BlobError, Neighbour, PointShape, PointTreeN, Scalar};

/// One neighbour of a `float` tree: 8 bytes, the record of a `.knn` file.
/// A missing neighbour (fewer points than asked for) is
/// `index = 0xFFFFFFFF`, `d2 = INFINITY`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct KdrayNeighbour {
    /// The point's index in the builder's input.
    pub index: u32,
    /// Its squared Euclidean distance to the query (the squared coordinate
    /// differences in `float`, summed axis by axis from the first).
    pub d2: f32,
}

/// One neighbour of a `double` tree: 16 bytes, as [`KdrayNeighbour`] with
/// the distance in `double` (a missing one is `index = 0xFFFFFFFF`,
/// `d2 = INFINITY`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct KdrayNeighbour64 {
    /// The point's index in the builder's input.
    pub index: u32,
    /// Written as 0.
    pub reserved: u32,
    /// Its squared Euclidean distance to the query, in `double`.
    pub d2: f64,
}

/// A scalar type of the C API: its neighbour record, laid out as the
/// kernel's `Neighbour<S>` so the caller's records are handed to the
/// kernel in place.
trait CScalar: Scalar {
    /// The C record of a neighbour.
    type Record: Pod;
    /// Sets what the kernel's record leaves undefined (padding).
    fn tidy(_record: &mut Self::Record) {}
}

impl CScalar for f32 {
    type Record = KdrayNeighbour;
}

impl CScalar for f64 {
    type Record = KdrayNeighbour64;
    fn tidy(record: &mut KdrayNeighbour64) {
        record.reserved = 0;
    }
}

// Each record is its kernel `Neighbour`'s layout: `{u32 index, S d2}` at
// the same offsets, size and alignment.
const _: () = {
    use core::mem::{align_of, offset_of, size_of};
    assert!(size_of::<KdrayNeighbour>() == size_of::<Neighbour<f32>>());
    assert!(align_of::<KdrayNeighbour>() == align_of::<Neighbour<f32>>());
    assert!(offset_of!(KdrayNeighbour, d2) == offset_of!(Neighbour<f32>, d2));
    assert!(size_of::<KdrayNeighbour64>() == size_of::<Neighbour<f64>>());
    assert!(align_of::<KdrayNeighbour64>() == align_of::<Neighbour<f64>>());
    assert!(offset_of!(KdrayNeighbour64, d2) == offset_of!(Neighbour<f64>, d2));
};

/// The largest D the library reads.
pub const KDRAY_MAX_DIM: usize = 16;

/// Calls the macro `$m` with the list of the dimensions the library is
/// compiled for (each D is one instance of the kernel's queries).
macro_rules! with_dims {
    ($m:ident) => {
        $m!(1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16)
    };
}

/// Why a point blob was not opened.
enum OpenError {
    /// The kernel refused it.
    Blob(BlobError),
    /// A shape the library is not compiled for.
    Shape(PointShape),
}

impl fmt::Display for OpenError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            OpenError::Blob(e) => write!(f, "{e}"),
            OpenError::Shape(s) => write!(
                f,
                "blob holds {}-dimensional points of {}-byte coordinates; this library reads 1 to {KDRAY_MAX_DIM} dimensions of float or double",
                s.dim, s.scalar_bytes
            ),
        }
    }
}

/// Opens the point-tree blob `blob[0..len]` (written by `kdray
/// build-points`, any `--dim` from 1 to 16, `float` or `--f64`) into
/// `*tree`, validating all of it. `kdray_points_shape` then says which.
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
    /// Validates `bytes` as a `D`-dimensional `S` tree into `tree`.
    fn open_as<const D: usize, S: Scalar>(
        tree: *mut KdrayPointTree,
        bytes: &'static [u8],
    ) -> Result<(), OpenError> {
        let view = PointTreeN::<'static, D, S>::from_bytes(bytes).map_err(OpenError::Blob)?;
        // SAFETY: `open_with` checked and closed the handle before calling
        // the loader; the blob outlives the handle by contract.
        unsafe { handle::store(tree, view) };
        Ok(())
    }
    // SAFETY: this function's contract.
    unsafe {
        handle::open_with(tree, blob, len, message, message_len, |bytes| {
            let shape = PointShape::of_blob(bytes).map_err(OpenError::Blob)?;
            macro_rules! arms {
                ($($d:literal)*) => {
                    match (shape.dim, shape.scalar_bytes) {
                        $(($d, 4) => open_as::<$d, f32>(tree, bytes),
                          ($d, 8) => open_as::<$d, f64>(tree, bytes),)*
                        _ => Err(OpenError::Shape(shape)),
                    }
                };
            }
            with_dims!(arms)
        })
    }
}

/// The shape of an opened point tree: `*dim` (1 to 16) and
/// `*scalar_bytes` (4 for `float`, 8 for `double`), the values its queries
/// must name.
///
/// # Preconditions
/// - `tree`: opened by `kdray_points_open`, its blob alive and unchanged.
/// - `dim`, `scalar_bytes`: non-null, aligned for `size_t`.
///
/// # Safety
/// As the preconditions.
#[no_mangle]
pub unsafe extern "C" fn kdray_points_shape(
    tree: *const KdrayPointTree,
    dim: *mut usize,
    scalar_bytes: *mut usize,
) -> KdrayStatus {
    status((|| {
        check_ptr(dim.cast_const())?;
        check_ptr(scalar_bytes.cast_const())?;
        // SAFETY: `tree`'s contract.
        let (d, b) = unsafe { handle::point_shape(tree) }?;
        // SAFETY: checked non-null and aligned; writable by the contract.
        unsafe {
            dim.write(d);
            scalar_bytes.write(b);
        }
        Ok(())
    })())
}

/// A point query, run once the tree and the query point are loaded.
trait Query<S: CScalar> {
    /// Answers `q` on `tree`.
    fn run<const D: usize>(
        self,
        tree: PointTreeN<'static, D, S>,
        q: [S; D],
    ) -> Result<(), KdrayStatus>;
}

/// The body of every query: the tree of `S` points in `dim` dimensions
/// from `tree` (else `WRONG_SHAPE`, `NOT_OPEN`, ...), the query point from
/// `query[0..dim]`, then `q`.
///
/// # Safety
/// `tree`'s and `query`'s contracts: if `tree` is non-null and aligned
/// it is a handle (opened, or not), and if `query` is non-null and
/// aligned it points to `dim` readable `S`.
unsafe fn query<S: CScalar, Q: Query<S>>(
    tree: *const KdrayPointTree,
    query: *const S,
    dim: usize,
    q: Q,
) -> KdrayStatus {
    /// [`query`] at a compiled D.
    unsafe fn at<const D: usize, T: CScalar, Q: Query<T>>(
        tree: *const KdrayPointTree,
        query: *const T,
        q: Q,
    ) -> Result<(), KdrayStatus> {
        // SAFETY: `tree`'s contract.
        let t = unsafe { handle::load::<PointTreeN<'static, D, T>>(tree) }?;
        let p = query.cast::<[T; D]>();
        check_ptr(p)?;
        // SAFETY: checked non-null and aligned; `D = dim` readable scalars
        // by the contract.
        let point = unsafe { p.read() };
        q.run(t, point)
    }
    macro_rules! arms {
        ($($d:literal)*) => {
            match dim {
                // SAFETY: this function's contract.
                $($d => unsafe { at::<$d, S, Q>(tree, query, q) },)*
                // No tree has this shape: the handle decides the status.
                // SAFETY: `tree`'s contract.
                _ => unsafe { handle::point_shape(tree) }.and(Err(KdrayStatus::WrongShape)),
            }
        };
    }
    status(with_dims!(arms))
}

/// `kdray_nearest_*`.
struct Nearest<R>(*mut R);

impl<S: CScalar> Query<S> for Nearest<S::Record> {
    fn run<const D: usize>(
        self,
        tree: PointTreeN<'static, D, S>,
        q: [S; D],
    ) -> Result<(), KdrayStatus> {
        // SAFETY: the caller's contract on `nearest`, checked here.
        let (out, _) = unsafe { outputs::<S>(self.0, 1, None) }?;
        let n = tree.nearest(q).unwrap_or(Neighbour::NONE);
        if let Some(slot) = out.first_mut() {
            *slot = n;
        }
        tidy::<S>(self.0, 1);
        Ok(())
    }
}

/// `kdray_knn_*`.
struct Knn<R> {
    k: usize,
    out: *mut R,
    found: *mut usize,
}

impl<S: CScalar> Query<S> for Knn<S::Record> {
    fn run<const D: usize>(
        self,
        tree: PointTreeN<'static, D, S>,
        q: [S; D],
    ) -> Result<(), KdrayStatus> {
        // SAFETY: the caller's contracts on `out` and `found`, checked here.
        let (out, found) = unsafe { outputs::<S>(self.out, self.k, Some(self.found)) }?;
        let n = tree.knn(q, out);
        if let Some(found) = found {
            *found = n;
        }
        tidy::<S>(self.out, n);
        Ok(())
    }
}

/// `kdray_within_*`.
struct Within<S: CScalar> {
    r2: S,
    out: *mut S::Record,
    capacity: usize,
    found: *mut usize,
}

impl<S: CScalar> Query<S> for Within<S> {
    fn run<const D: usize>(
        self,
        tree: PointTreeN<'static, D, S>,
        q: [S; D],
    ) -> Result<(), KdrayStatus> {
        // SAFETY: the caller's contracts on `out` and `found`, checked here.
        let (out, found) = unsafe { outputs::<S>(self.out, self.capacity, Some(self.found)) }?;
        let (n, result) = match tree.within(q, self.r2, out) {
            Ok(n) => (n, Ok(())),
            Err(e) => (e.needed, Err(KdrayStatus::BufferTooSmall)),
        };
        if let Some(found) = found {
            *found = n;
        }
        tidy::<S>(self.out, n.min(self.capacity));
        result
    }
}

/// The output records (as the kernel's) and the count, checked.
///
/// # Safety
/// If non-null and aligned, `out` points to `len` writable records and
/// `found` (when given) to a writable `size_t`.
unsafe fn outputs<'a, S: CScalar>(
    out: *mut S::Record,
    len: usize,
    found: Option<*mut usize>,
) -> Result<(&'a mut [Neighbour<S>], Option<&'a mut usize>), KdrayStatus> {
    check_ptr(out.cast_const())?;
    if let Some(f) = found {
        check_ptr(f.cast_const())?;
    }
    check_count::<S::Record>(len)?;
    // SAFETY: non-null, aligned, `len` writable records by contract, the
    // size fits a slice; the record is `Neighbour<S>`'s layout (asserted
    // above), and every bit pattern is a valid `u32` and `S`.
    let out = unsafe { core::slice::from_raw_parts_mut(out.cast::<Neighbour<S>>(), len) };
    // SAFETY: checked non-null and aligned; writable by the contract.
    Ok((out, found.map(|f| unsafe { &mut *f })))
}

/// Sets the padding of the first `n` records the kernel wrote.
fn tidy<S: CScalar>(out: *mut S::Record, n: usize) {
    // SAFETY: `outputs` checked `out` for the `n` records just written
    // (`n` is at most the checked length), and no other reference to them
    // is alive.
    let records = unsafe { core::slice::from_raw_parts_mut(out, n) };
    records.iter_mut().for_each(S::tidy);
}

/// The nearest point to `query[0..dim]`, written to `*nearest`: smallest
/// squared distance, at equal distance the lowest index (exactly as brute
/// force). An empty tree or a query with a coordinate that is NaN or
/// beyond the point range (2^61 for 3-D f32, `kdray_kernel::max_point_coord`)
/// gives the missing-neighbour record.
///
/// # Preconditions
/// - `tree`: opened by `kdray_points_open`, its blob alive and unchanged;
///   a `float` tree of `dim` dimensions (else `KDRAY_STATUS_WRONG_SHAPE`).
/// - `query`: non-null, 4-byte aligned, `dim` readable floats.
/// - `nearest`: non-null, 4-byte aligned.
///
/// # Safety
/// As the preconditions.
#[no_mangle]
pub unsafe extern "C" fn kdray_nearest_f32(
    tree: *const KdrayPointTree,
    query: *const f32,
    dim: usize,
    nearest: *mut KdrayNeighbour,
) -> KdrayStatus {
    // SAFETY: this function's contract.
    unsafe { self::query(tree, query, dim, Nearest(nearest)) }
}

/// `kdray_nearest_f32` for a `double` tree: `double` coordinates and
/// distance.
///
/// # Preconditions
/// As `kdray_nearest_f32`, with `double`s (8-byte aligned) and a
/// `KdrayNeighbour64` record.
///
/// # Safety
/// As the preconditions.
#[no_mangle]
pub unsafe extern "C" fn kdray_nearest_f64(
    tree: *const KdrayPointTree,
    query: *const f64,
    dim: usize,
    nearest: *mut KdrayNeighbour64,
) -> KdrayStatus {
    // SAFETY: this function's contract.
    unsafe { self::query(tree, query, dim, Nearest(nearest)) }
}

/// The `k` nearest points to `query[0..dim]`, written to `out[0..*found]`
/// nearest first (equal distance: lower index first), exactly as brute
/// force; `*found` is `k` unless the tree has fewer points. `out[*found..k]`
/// is left unchanged. `k == 0` or a query with a coordinate that is NaN or
/// beyond the point range finds nothing.
///
/// # Preconditions
/// - `tree`, `query`, `dim`: as `kdray_nearest_f32`.
/// - `out`: non-null, 4-byte aligned, `k` writable records.
/// - `found`: non-null, aligned for `size_t`.
///
/// # Safety
/// As the preconditions.
#[no_mangle]
pub unsafe extern "C" fn kdray_knn_f32(
    tree: *const KdrayPointTree,
    query: *const f32,
    dim: usize,
    k: usize,
    out: *mut KdrayNeighbour,
    found: *mut usize,
) -> KdrayStatus {
    // SAFETY: this function's contract.
    unsafe { self::query(tree, query, dim, Knn { k, out, found }) }
}

/// `kdray_knn_f32` for a `double` tree.
///
/// # Preconditions
/// As `kdray_knn_f32`, with `double`s (8-byte aligned) and
/// `KdrayNeighbour64` records.
///
/// # Safety
/// As the preconditions.
#[no_mangle]
pub unsafe extern "C" fn kdray_knn_f64(
    tree: *const KdrayPointTree,
    query: *const f64,
    dim: usize,
    k: usize,
    out: *mut KdrayNeighbour64,
    found: *mut usize,
) -> KdrayStatus {
    // SAFETY: this function's contract.
    unsafe { self::query(tree, query, dim, Knn { k, out, found }) }
}

/// Every point at squared distance `<= r2` from `query[0..dim]`, written
/// to `out[0..*found]` nearest first (equal distance: lower index first),
/// exactly as brute force.
///
/// If more than `capacity` points are in range, returns
/// `KDRAY_STATUS_BUFFER_TOO_SMALL` with `*found` set to how many there are
/// (the capacity that suffices); `out` then holds some of them, unordered.
///
/// # Preconditions
/// - `tree`, `query`, `dim`: as `kdray_nearest_f32`.
/// - `out`: non-null, 4-byte aligned, `capacity` writable records.
/// - `found`: non-null, aligned for `size_t`.
///
/// # Safety
/// As the preconditions.
#[no_mangle]
pub unsafe extern "C" fn kdray_within_f32(
    tree: *const KdrayPointTree,
    query: *const f32,
    dim: usize,
    r2: f32,
    out: *mut KdrayNeighbour,
    capacity: usize,
    found: *mut usize,
) -> KdrayStatus {
    let q = Within {
        r2,
        out,
        capacity,
        found,
    };
    // SAFETY: this function's contract.
    unsafe { self::query(tree, query, dim, q) }
}

/// `kdray_within_f32` for a `double` tree.
///
/// # Preconditions
/// As `kdray_within_f32`, with `double`s (8-byte aligned) and
/// `KdrayNeighbour64` records.
///
/// # Safety
/// As the preconditions.
#[no_mangle]
pub unsafe extern "C" fn kdray_within_f64(
    tree: *const KdrayPointTree,
    query: *const f64,
    dim: usize,
    r2: f64,
    out: *mut KdrayNeighbour64,
    capacity: usize,
    found: *mut usize,
) -> KdrayStatus {
    let q = Within {
        r2,
        out,
        capacity,
        found,
    };
    // SAFETY: this function's contract.
    unsafe { self::query(tree, query, dim, q) }
}

/// `kdray_nearest_f32` in 3-D: the nearest point to `query[0..3]`.
///
/// # Preconditions
/// As `kdray_nearest_f32` with `dim = 3`.
///
/// # Safety
/// As the preconditions.
#[no_mangle]
pub unsafe extern "C" fn kdray_nearest(
    tree: *const KdrayPointTree,
    query: *const f32,
    nearest: *mut KdrayNeighbour,
) -> KdrayStatus {
    // SAFETY: this function's contract.
    unsafe { kdray_nearest_f32(tree, query, 3, nearest) }
}

/// `kdray_knn_f32` in 3-D: the `k` nearest points to `query[0..3]`.
///
/// # Preconditions
/// As `kdray_knn_f32` with `dim = 3`.
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
    // SAFETY: this function's contract.
    unsafe { kdray_knn_f32(tree, query, 3, k, out, found) }
}

/// `kdray_within_f32` in 3-D: every point within `r2` of `query[0..3]`.
///
/// # Preconditions
/// As `kdray_within_f32` with `dim = 3`.
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
    // SAFETY: this function's contract.
    unsafe { kdray_within_f32(tree, query, 3, r2, out, capacity, found) }
}
