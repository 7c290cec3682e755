//! Triangle trees: open a blob, trace one ray, a packet of 4, 8 or 16
//! rays in structure-of-arrays form (the shape of Embree's
//! `rtcIntersect4/8/16`), or a batch of N rays.

use crate::handle::{self, KdrayTriangleTree};
use crate::{check_count, check_ptr, status, KdrayStatus};
use bytemuck::{Pod, Zeroable};
use core::ffi::c_char;
use kdray_kernel::{Batch, Hit, Packet, PacketWidth, Ray, Treelet, TriangleTree};

/// The `prim_id` of a miss.
pub const KDRAY_MISS: u32 = 0xFFFF_FFFF;
/// The `prim_id` of an occluded ray in a `.hits` file of any-hit records
/// (`t = -INFINITY`); the C functions answer occlusion as 1 or 0.
pub const KDRAY_OCCLUDED: u32 = 0xFFFF_FFFE;

// Literals for the header generator, equal to the kernel's markers.
const _: () = assert!(KDRAY_MISS == kdray_kernel::MISS && KDRAY_OCCLUDED == kdray_kernel::OCCLUDED);

/// A ray `org + t * dir` for `t` in `[tnear, tfar]`: 32 bytes, the field
/// order of Embree's `RTCRay` without its time, mask, id and flags, and
/// of a `.rays` file record.
///
/// The direction need not be normalised. A ray with a non-finite origin,
/// a NaN, infinite or zero direction, a NaN bound or `tnear > tfar`
/// misses.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct KdrayRay {
    /// Origin x.
    pub org_x: f32,
    /// Origin y.
    pub org_y: f32,
    /// Origin z.
    pub org_z: f32,
    /// Start of the ray's interval.
    pub tnear: f32,
    /// Direction x.
    pub dir_x: f32,
    /// Direction y.
    pub dir_y: f32,
    /// Direction z.
    pub dir_z: f32,
    /// End of the ray's interval (may be `INFINITY`).
    pub tfar: f32,
}

/// A closest hit: 16 bytes, the record of a `.hits` file.
///
/// The hit point is `(1 - u - v) * v0 + u * v1 + v * v2` of triangle
/// `prim_id`'s vertices; a miss is `t = INFINITY`, `prim_id = KDRAY_MISS`,
/// `u = v = 0`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct KdrayHit {
    /// Ray parameter of the hit (`INFINITY` for a miss).
    pub t: f32,
    /// Index of the triangle hit in the mesh the blob was built from.
    pub prim_id: u32,
    /// Barycentric weight of vertex 1.
    pub u: f32,
    /// Barycentric weight of vertex 2.
    pub v: f32,
}

// The C records are the kernel's records, so a stream is cast, not copied.
const _: () = {
    assert!(core::mem::size_of::<KdrayRay>() == core::mem::size_of::<Ray>());
    assert!(core::mem::size_of::<KdrayHit>() == core::mem::size_of::<Hit>());
};

/// `N` rays in structure-of-arrays form: lane `l` is the ray
/// `(org_x[l], org_y[l], org_z[l]) + t * (dir_x[l], dir_y[l], dir_z[l])`
/// over `[tnear[l], tfar[l]]` (Embree's `RTCRayN` layout, without time,
/// mask, id and flags).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KdrayRayN<const N: usize> {
    /// Origin x of each lane.
    pub org_x: [f32; N],
    /// Origin y of each lane.
    pub org_y: [f32; N],
    /// Origin z of each lane.
    pub org_z: [f32; N],
    /// Start of each lane's interval.
    pub tnear: [f32; N],
    /// Direction x of each lane.
    pub dir_x: [f32; N],
    /// Direction y of each lane.
    pub dir_y: [f32; N],
    /// Direction z of each lane.
    pub dir_z: [f32; N],
    /// End of each lane's interval.
    pub tfar: [f32; N],
}

/// `N` closest hits in structure-of-arrays form, each lane as [`KdrayHit`].
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KdrayHitN<const N: usize> {
    /// Ray parameter of each lane's hit.
    pub t: [f32; N],
    /// Triangle of each lane's hit (`KDRAY_MISS` for a miss or an inactive lane).
    pub prim_id: [u32; N],
    /// Barycentric weight of vertex 1, each lane.
    pub u: [f32; N],
    /// Barycentric weight of vertex 2, each lane.
    pub v: [f32; N],
}

/// A packet of 4 rays (`rtcIntersect4`'s `RTCRay4`).
pub type KdrayRay4 = KdrayRayN<4>;
/// A packet of 8 rays.
pub type KdrayRay8 = KdrayRayN<8>;
/// A packet of 16 rays.
pub type KdrayRay16 = KdrayRayN<16>;
/// The hits of a packet of 4 rays.
pub type KdrayHit4 = KdrayHitN<4>;
/// The hits of a packet of 8 rays.
pub type KdrayHit8 = KdrayHitN<8>;
/// The hits of a packet of 16 rays.
pub type KdrayHit16 = KdrayHitN<16>;

impl From<KdrayHit> for Hit {
    fn from(h: KdrayHit) -> Hit {
        bytemuck::cast(h)
    }
}

impl From<Hit> for KdrayHit {
    fn from(h: Hit) -> KdrayHit {
        bytemuck::cast(h)
    }
}

impl From<KdrayRay> for Ray {
    fn from(r: KdrayRay) -> Ray {
        bytemuck::cast(r)
    }
}

/// Opens the triangle-tree blob `blob[0..len]` into `*tree`, validating
/// all of it (header, sections, checksum, the tree's structure): O(len),
/// no allocation, no copy.
///
/// Returns `KDRAY_STATUS_OK`, or `KDRAY_STATUS_INVALID_BLOB` with the
/// reason (what is wrong and where, e.g. "blob checksum mismatch: ...")
/// written to `message`, or another status for a bad argument (its text,
/// as `kdray_status_text` gives it, goes to `message`). On failure `*tree`
/// is marked not open, so queries on it return `KDRAY_STATUS_NOT_OPEN`.
///
/// # Preconditions
/// - `tree`: non-null, 8-byte aligned (any `KdrayTriangleTree` object is).
/// - `blob`: non-null, 4-byte aligned (else `KDRAY_STATUS_INVALID_BLOB`,
///   "misaligned"), pointing to `len` readable bytes that stay alive and
///   unchanged for as long as `*tree` (or a copy of it) is used.
/// - `message`: null, or `message_len` writable bytes; receives a
///   NUL-terminated sentence, truncated to fit (`message_len` of 256 holds
///   every message).
///
/// # Safety
/// As the preconditions: the library cannot check that `len` bytes are
/// readable or that the blob outlives the handle.
#[no_mangle]
pub unsafe extern "C" fn kdray_triangles_open(
    tree: *mut KdrayTriangleTree,
    blob: *const u8,
    len: usize,
    message: *mut c_char,
    message_len: usize,
) -> KdrayStatus {
    // SAFETY: this function's contract.
    unsafe { handle::open::<TriangleTree>(tree, blob, len, message, message_len) }
}

/// The closest hit of `*ray` in `*tree`, written to `*hit` (a miss record
/// when nothing is hit): the smallest `t` in `[tnear, tfar]`, at equal `t`
/// the lowest triangle index, bit for bit as the Rust API and brute force.
///
/// # Preconditions
/// - `tree`: opened by `kdray_triangles_open` (else `KDRAY_STATUS_NOT_OPEN`),
///   and its blob still alive and unchanged.
/// - `ray`, `hit`: non-null and 4-byte aligned.
///
/// # Safety
/// As the preconditions; `ray` and `hit` point to a whole record each.
#[no_mangle]
pub unsafe extern "C" fn kdray_closest_hit(
    tree: *const KdrayTriangleTree,
    ray: *const KdrayRay,
    hit: *mut KdrayHit,
) -> KdrayStatus {
    status((|| {
        // SAFETY: `tree`'s contract.
        let t = unsafe { handle::load::<TriangleTree>(tree) }?;
        check_ptr(ray)?;
        check_ptr(hit.cast_const())?;
        // SAFETY: checked non-null and aligned; a whole record by contract.
        let r = unsafe { ray.read() };
        // SAFETY: as for `ray`.
        unsafe { hit.write(t.closest_hit(&r.into()).into()) };
        Ok(())
    })())
}

/// Whether `*ray` hits any triangle of `*tree` in `[tnear, tfar]`:
/// `*occluded` is 1 if so, else 0 (the shadow-ray query, Embree's
/// `rtcOccluded1`; stops at the first hit found).
///
/// # Preconditions
/// As `kdray_closest_hit`; `occluded` non-null and 4-byte aligned.
///
/// # Safety
/// As the preconditions.
#[no_mangle]
pub unsafe extern "C" fn kdray_any_hit(
    tree: *const KdrayTriangleTree,
    ray: *const KdrayRay,
    occluded: *mut i32,
) -> KdrayStatus {
    status((|| {
        // SAFETY: `tree`'s contract.
        let t = unsafe { handle::load::<TriangleTree>(tree) }?;
        check_ptr(ray)?;
        check_ptr(occluded.cast_const())?;
        // SAFETY: checked non-null and aligned; whole records by contract.
        unsafe { occluded.write(i32::from(t.any_hit(&ray.read().into()))) };
        Ok(())
    })())
}

/// The kernel packet of `rays`' lanes whose `valid` entry is nonzero.
fn packet<const N: usize>(valid: &[i32; N], rays: &KdrayRayN<N>) -> Packet<N> {
    Packet {
        origin: [rays.org_x, rays.org_y, rays.org_z],
        dir: [rays.dir_x, rays.dir_y, rays.dir_z],
        tmin: rays.tnear,
        tmax: rays.tfar,
        valid: valid.map(|v| v != 0),
    }
}

/// Reads the valid mask and the packet, after checking every pointer.
///
/// # Safety
/// Each pointer, if non-null and aligned, points to a whole readable object.
unsafe fn read_packet<const N: usize>(
    valid: *const [i32; N],
    rays: *const KdrayRayN<N>,
) -> Result<Packet<N>, KdrayStatus> {
    check_ptr(valid)?;
    check_ptr(rays)?;
    // SAFETY: checked non-null and aligned; readable by the contract.
    Ok(unsafe { packet(&valid.read(), &rays.read()) })
}

/// The body of `kdray_closest_hit4/8/16`.
///
/// # Safety
/// As those functions.
unsafe fn closest_packet<const N: usize>(
    valid: *const [i32; N],
    tree: *const KdrayTriangleTree,
    rays: *const KdrayRayN<N>,
    hits: *mut KdrayHitN<N>,
    trace: impl Fn(&TriangleTree<'_>, &Packet<N>) -> [Hit; N],
) -> KdrayStatus {
    status((|| {
        // SAFETY: the callers' contracts.
        let t = unsafe { handle::load::<TriangleTree>(tree) }?;
        // SAFETY: the callers' contracts.
        let p = unsafe { read_packet(valid, rays) }?;
        check_ptr(hits.cast_const())?;
        let h = trace(&t, &p);
        let out = KdrayHitN {
            t: h.map(|h| h.t),
            prim_id: h.map(|h| h.prim),
            u: h.map(|h| h.u),
            v: h.map(|h| h.v),
        };
        // SAFETY: checked non-null and aligned; writable by the contract.
        unsafe { hits.write(out) };
        Ok(())
    })())
}

/// The body of `kdray_any_hit4/8/16`.
///
/// # Safety
/// As those functions.
unsafe fn any_packet<const N: usize>(
    valid: *const [i32; N],
    tree: *const KdrayTriangleTree,
    rays: *const KdrayRayN<N>,
    occluded: *mut [i32; N],
    trace: impl Fn(&TriangleTree<'_>, &Packet<N>) -> [bool; N],
) -> KdrayStatus {
    status((|| {
        // SAFETY: the callers' contracts.
        let t = unsafe { handle::load::<TriangleTree>(tree) }?;
        // SAFETY: the callers' contracts.
        let p = unsafe { read_packet(valid, rays) }?;
        check_ptr(occluded.cast_const())?;
        // SAFETY: checked non-null and aligned; writable by the contract.
        unsafe { occluded.write(trace(&t, &p).map(i32::from)) };
        Ok(())
    })())
}

/// The closest hits of a packet of 4 rays, lane by lane bit for bit as
/// `kdray_closest_hit` on each lane's ray. Lanes whose `valid` entry is 0
/// are not traced and get a miss record; any nonzero entry (Embree's -1,
/// or 1) marks an active lane.
///
/// # Preconditions
/// - `tree`: as `kdray_closest_hit`.
/// - `valid`: non-null, 4-byte aligned, 4 entries.
/// - `rays`, `hits`: non-null, 4-byte aligned, whole structs (Embree's
///   16-byte alignment is welcome, not required).
///
/// # Safety
/// As the preconditions.
#[no_mangle]
pub unsafe extern "C" fn kdray_closest_hit4(
    valid: *const i32,
    tree: *const KdrayTriangleTree,
    rays: *const KdrayRay4,
    hits: *mut KdrayHit4,
) -> KdrayStatus {
    // SAFETY: this function's contract.
    unsafe {
        closest_packet(valid.cast(), tree, rays, hits, |t, p| {
            t.closest_hit_packet(p)
        })
    }
}

/// `kdray_closest_hit4` for a packet of 8 rays (`valid` has 8 entries).
///
/// # Preconditions
/// As `kdray_closest_hit4`, with 8 lanes.
///
/// # Safety
/// As the preconditions.
#[no_mangle]
pub unsafe extern "C" fn kdray_closest_hit8(
    valid: *const i32,
    tree: *const KdrayTriangleTree,
    rays: *const KdrayRay8,
    hits: *mut KdrayHit8,
) -> KdrayStatus {
    // SAFETY: this function's contract.
    unsafe {
        closest_packet(valid.cast(), tree, rays, hits, |t, p| {
            t.closest_hit_packet(p)
        })
    }
}

/// `kdray_closest_hit4` for a packet of 16 rays (`valid` has 16 entries).
///
/// # Preconditions
/// As `kdray_closest_hit4`, with 16 lanes.
///
/// # Safety
/// As the preconditions.
#[no_mangle]
pub unsafe extern "C" fn kdray_closest_hit16(
    valid: *const i32,
    tree: *const KdrayTriangleTree,
    rays: *const KdrayRay16,
    hits: *mut KdrayHit16,
) -> KdrayStatus {
    // SAFETY: this function's contract.
    unsafe {
        closest_packet(valid.cast(), tree, rays, hits, |t, p| {
            t.closest_hit_packet(p)
        })
    }
}

/// Occlusion of a packet of 4 rays: `occluded[l]` is 1 if lane `l` hits
/// anything, else 0 (0 for inactive lanes), as `kdray_any_hit` per lane.
///
/// # Preconditions
/// As `kdray_closest_hit4`; `occluded`: non-null, 4-byte aligned, 4 entries.
///
/// # Safety
/// As the preconditions.
#[no_mangle]
pub unsafe extern "C" fn kdray_any_hit4(
    valid: *const i32,
    tree: *const KdrayTriangleTree,
    rays: *const KdrayRay4,
    occluded: *mut i32,
) -> KdrayStatus {
    // SAFETY: this function's contract.
    unsafe {
        any_packet(valid.cast(), tree, rays, occluded.cast(), |t, p| {
            t.any_hit_packet(p)
        })
    }
}

/// `kdray_any_hit4` for a packet of 8 rays.
///
/// # Preconditions
/// As `kdray_any_hit4`, with 8 lanes.
///
/// # Safety
/// As the preconditions.
#[no_mangle]
pub unsafe extern "C" fn kdray_any_hit8(
    valid: *const i32,
    tree: *const KdrayTriangleTree,
    rays: *const KdrayRay8,
    occluded: *mut i32,
) -> KdrayStatus {
    // SAFETY: this function's contract.
    unsafe {
        any_packet(valid.cast(), tree, rays, occluded.cast(), |t, p| {
            t.any_hit_packet(p)
        })
    }
}

/// `kdray_any_hit4` for a packet of 16 rays.
///
/// # Preconditions
/// As `kdray_any_hit4`, with 16 lanes.
///
/// # Safety
/// As the preconditions.
#[no_mangle]
pub unsafe extern "C" fn kdray_any_hit16(
    valid: *const i32,
    tree: *const KdrayTriangleTree,
    rays: *const KdrayRay16,
    occluded: *mut i32,
) -> KdrayStatus {
    // SAFETY: this function's contract.
    unsafe {
        any_packet(valid.cast(), tree, rays, occluded.cast(), |t, p| {
            t.any_hit_packet(p)
        })
    }
}

/// How a batch is traced (`kdray_closest_hits`, `kdray_any_hits`): the
/// Rust API's `Batch`. Pass NULL for the defaults, which suit most
/// batches; whatever it says, each ray gets its single ray's answer bit
/// for bit.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct KdrayBatch {
    /// The walk: 0 (the default) lets the batch call choose for
    /// each block of 256 rays by timing its walks on the batch (packets
    /// or single rays where origins lie close together, single rays or
    /// rays in turns where they lie far apart); 1, 4, 8 or 16 traces every
    /// block in packets of that many consecutive rays (1: single rays).
    /// Order coherent rays in small image tiles (4x2 pixels for 8 lanes).
    /// Another value is `KDRAY_STATUS_BAD_ARGUMENT`.
    pub width: u32,
    /// Null, or caller memory (8-byte aligned, not overlapping the other
    /// arrays) for an any-hit batch to be traced in the Morton order of
    /// its rays' origins: `2 * count` words. Give it for a large batch of
    /// scattered shadow rays (from random surface points); with fewer
    /// words, or for closest hits, the batch is traced in its own order.
    pub scratch: *mut u64,
    /// The number of 64-bit words at `scratch` (0 when it is null).
    pub scratch_count: usize,
}

/// The Rust `Batch` a caller's `KdrayBatch` (or NULL) asks for.
///
/// # Safety
/// `batch`: null, or a whole `KdrayBatch` whose `scratch` holds
/// `scratch_count` writable words not overlapping the call's other arrays,
/// alive for `'a`.
unsafe fn read_batch<'a>(batch: *const KdrayBatch) -> Result<Batch<'a>, KdrayStatus> {
    if batch.is_null() {
        return Ok(Batch::default());
    }
    check_ptr(batch)?;
    // SAFETY: checked non-null and aligned; a whole record by contract.
    let b = unsafe { batch.read() };
    let width = match b.width {
        0 => None,
        n => Some(PacketWidth::from_lanes(n as usize).ok_or(KdrayStatus::BadArgument)?),
    };
    let scratch: &mut [u64] = if b.scratch.is_null() || b.scratch_count == 0 {
        &mut []
    } else {
        check_ptr(b.scratch.cast_const())?;
        check_count::<u64>(b.scratch_count)?;
        // SAFETY: non-null, aligned, `scratch_count` writable words not
        // overlapping the other arrays by contract; the size fits a slice.
        unsafe { core::slice::from_raw_parts_mut(b.scratch, b.scratch_count) }
    };
    Ok(Batch {
        width,
        scratch,
        ..Batch::default()
    })
}

/// The closest hits of a batch of `count` rays: `hits[i]` is bit for bit
/// `kdray_closest_hit` of `rays[i]`. The library picks the walk per block
/// of rays (packets for coherent blocks, rays in turns for scattered
/// ones), so coherent batches (camera tiles in order) trace fastest.
///
/// # Preconditions
/// - `tree`: as `kdray_closest_hit`.
/// - `rays`, `hits`: non-null (even for `count == 0`), 4-byte aligned,
///   `count` records each, not overlapping.
/// - `batch`: null (the defaults) or a `KdrayBatch` as its fields say.
///
/// # Safety
/// As the preconditions.
#[no_mangle]
pub unsafe extern "C" fn kdray_closest_hits(
    tree: *const KdrayTriangleTree,
    rays: *const KdrayRay,
    hits: *mut KdrayHit,
    count: usize,
    batch: *const KdrayBatch,
) -> KdrayStatus {
    status((|| {
        // SAFETY: `tree`'s contract.
        let t = unsafe { handle::load::<TriangleTree>(tree) }?;
        check_ptr(rays)?;
        check_ptr(hits.cast_const())?;
        check_count::<KdrayRay>(count)?;
        // SAFETY: `batch`'s contract.
        let batch = unsafe { read_batch(batch) }?;
        // SAFETY: non-null, aligned, `count` records by contract, the size
        // fits a slice; KdrayRay is Ray's layout (asserted above) and Pod.
        let rays = unsafe { core::slice::from_raw_parts(rays.cast::<Ray>(), count) };
        // SAFETY: as for `rays`, writable and not overlapping by contract.
        let hits = unsafe { core::slice::from_raw_parts_mut(hits.cast::<Hit>(), count) };
        t.closest_hits(rays, hits, batch);
        Ok(())
    })())
}

/// Occlusion of a batch of `count` rays: `occluded[i]` is 1 if `rays[i]`
/// hits anything, else 0, as `kdray_any_hit` on each ray. With
/// `batch->scratch` of `2 * count` words the rays are traced in the
/// Morton order of their origins (each answer still in its ray's slot):
/// much faster for a large batch of scattered shadow rays, no gain for
/// rays in pixel order (docs/results.md).
///
/// # Preconditions
/// As `kdray_closest_hits`, with `occluded` holding `count` entries.
///
/// # Safety
/// As the preconditions.
#[no_mangle]
pub unsafe extern "C" fn kdray_any_hits(
    tree: *const KdrayTriangleTree,
    rays: *const KdrayRay,
    occluded: *mut i32,
    count: usize,
    batch: *const KdrayBatch,
) -> KdrayStatus {
    status((|| {
        // SAFETY: `tree`'s contract.
        let t = unsafe { handle::load::<TriangleTree>(tree) }?;
        check_ptr(rays)?;
        check_ptr(occluded.cast_const())?;
        check_count::<KdrayRay>(count)?;
        // SAFETY: `batch`'s contract.
        let batch = unsafe { read_batch(batch) }?;
        // SAFETY: as in `kdray_closest_hits`.
        let rays = unsafe { core::slice::from_raw_parts(rays.cast::<Ray>(), count) };
        // SAFETY: as for `rays`, writable and not overlapping by contract.
        let occluded = unsafe { core::slice::from_raw_parts_mut(occluded, count) };
        // The kernel answers in `bool`s, each in its ray's slot: written
        // straight into the caller's `int32_t`s, keeping them out of
        // Rust's `bool` type.
        t.any_hits_each(rays, batch, |i, o| {
            if let Some(x) = occluded.get_mut(i) {
                *x = i32::from(o);
            }
        });
        Ok(())
    })())
}

/// One 64-byte treelet of a triangle tree (`kdray_triangles_treelets`):
/// contents private to the library. Arrays of them must be 64-byte aligned
/// (`aligned_alloc(64, n * sizeof(KdrayTreelet))`).
#[repr(C)]
#[derive(Clone, Copy)]
pub struct KdrayTreelet {
    /// Private to the library.
    pub opaque: [u32; 16],
}

const _: () = assert!(core::mem::size_of::<KdrayTreelet>() == core::mem::size_of::<Treelet>());

/// Gives `*tree` its treelets, written into `treelets`: the tree
/// regrouped three levels to a 64-byte line, which streams of scattered
/// rays (`kdray_closest_hits` over bounce rays, random rays) then walk 7
/// split planes at a time, four rays in turns, on a processor with AVX2:
/// the same answers, bit for bit, up to 1.5x faster on random rays
/// (docs/results.md). Coherent rays (camera tiles) and the other queries
/// are unchanged. `*needed` is
/// always set to the number of treelets the tree has; with `capacity`
/// below it the call returns `KDRAY_STATUS_BUFFER_TOO_SMALL` and changes
/// nothing else (call with `capacity` 0 and `treelets` null to ask).
///
/// # Preconditions
/// - `tree`: as `kdray_closest_hit`, writable.
/// - `needed`: non-null and aligned.
/// - `treelets`: with `capacity` at least `*needed`: non-null, 64-byte
///   aligned (else `KDRAY_STATUS_MISALIGNED`), `capacity` writable
///   records that stay alive and unchanged for as long as `*tree` (or a
///   copy) is used.
///
/// # Safety
/// As the preconditions.
#[no_mangle]
pub unsafe extern "C" fn kdray_triangles_treelets(
    tree: *mut KdrayTriangleTree,
    treelets: *mut KdrayTreelet,
    capacity: usize,
    needed: *mut usize,
) -> KdrayStatus {
    status((|| {
        // SAFETY: `tree`'s contract.
        let t = unsafe { handle::load::<TriangleTree>(tree) }?;
        check_ptr(needed.cast_const())?;
        let count = t.treelet_count();
        // SAFETY: checked non-null and aligned.
        unsafe { needed.write(count) };
        if capacity < count {
            return Err(KdrayStatus::BufferTooSmall);
        }
        if count == 0 {
            return Ok(()); // a tree whose root is a leaf: nothing to walk
        }
        check_ptr(treelets.cast_const())?;
        let align = core::mem::align_of::<Treelet>();
        if !treelets.addr().is_multiple_of(align) {
            return Err(KdrayStatus::Misaligned);
        }
        check_count::<KdrayTreelet>(capacity)?;
        // SAFETY: non-null, aligned for `Treelet` (checked), `capacity`
        // writable records by contract (`Treelet` has `KdrayTreelet`'s
        // size, asserted above, and every bit pattern), alive and unchanged
        // while the handle is used: the `'static` the handle's view needs.
        let lines: &'static mut [Treelet] =
            unsafe { core::slice::from_raw_parts_mut(treelets.cast::<Treelet>(), capacity) };
        let lined = t
            .treelets_into(lines)
            .map_err(|_| KdrayStatus::BufferTooSmall)?;
        // SAFETY: `tree` was loaded (non-null, aligned, open) and is
        // writable by contract; the view borrows the blob and `treelets`,
        // both alive and unchanged while it is used.
        unsafe { handle::store(tree, lined.lined_view()) };
        Ok(())
    })())
}

/// The first hits of `*ray` in `*tree` along the ray, at most
/// `capacity`: `hits[0..*count]`, sorted by `t` in `[tnear, tfar]` and at
/// equal `t` by the lower triangle index, each triangle once, bit for bit
/// as the Rust API (`TriangleTree::first_hits`) and brute force; the
/// first of them is `kdray_closest_hit`'s. `*count` is 0 for a miss;
/// entries past it are left as they were. For transparency, counting the
/// surfaces a ray crosses, or every hit along a line of sight.
///
/// # Preconditions
/// - `tree`: as `kdray_closest_hit`.
/// - `ray`, `count`: non-null and aligned, a whole record each.
/// - `hits`: non-null (even for `capacity == 0`), 4-byte aligned,
///   `capacity` records, not overlapping `ray` or `count`.
///
/// # Safety
/// As the preconditions.
#[no_mangle]
pub unsafe extern "C" fn kdray_first_hits(
    tree: *const KdrayTriangleTree,
    ray: *const KdrayRay,
    hits: *mut KdrayHit,
    capacity: usize,
    count: *mut usize,
) -> KdrayStatus {
    status((|| {
        // SAFETY: `tree`'s contract.
        let t = unsafe { handle::load::<TriangleTree>(tree) }?;
        check_ptr(ray)?;
        check_ptr(hits.cast_const())?;
        check_ptr(count.cast_const())?;
        check_count::<KdrayHit>(capacity)?;
        // SAFETY: checked non-null and aligned; a whole record by contract.
        let r = unsafe { ray.read() };
        // SAFETY: non-null, aligned, `capacity` records by contract, the
        // size fits a slice; KdrayHit is Hit's layout (asserted above).
        let hits = unsafe { core::slice::from_raw_parts_mut(hits.cast::<Hit>(), capacity) };
        let n = t.first_hits(&r.into(), hits);
        // SAFETY: as for `ray`.
        unsafe { count.write(n) };
        Ok(())
    })())
}
