//! Tree handles: fixed-size structs in the caller's memory that hold a
//! validated kernel tree (two words per section) behind a tag word.
//!
//! The tag says which kind of tree was opened into the handle; a handle
//! whose tag is wrong (zeroed, never opened, opened as the other kind, or
//! whose open failed) is refused with `KDRAY_STATUS_NOT_OPEN` instead of
//! being read.

use crate::message::write_message;
use crate::{check_count, check_ptr, status, status_text, KdrayStatus};
use core::ffi::c_char;
use core::fmt;
use kdray_kernel::{BlobError, PointTreeN, Scalar, Scene, SceneError, TriangleTree};

/// The size of a tree handle in 64-bit words (room for the kernel's tree
/// view on 64-bit targets, with space to grow).
pub const KDRAY_HANDLE_WORDS: usize = 16;

/// An opened triangle tree. Declare one (on the stack, in a struct, as a
/// global) and pass its address to `kdray_triangles_open`.
///
/// The contents are private: read only by the library. A handle borrows
/// the blob it was opened on; it may be copied with `memcpy` and shared
/// between threads (every query only reads it).
#[repr(C)]
#[derive(Clone, Copy)]
pub struct KdrayTriangleTree {
    /// Private to the library.
    pub opaque: [u64; KDRAY_HANDLE_WORDS],
}

/// An opened point tree, as [`KdrayTriangleTree`] is for triangles; opened
/// by `kdray_points_open`.
#[repr(C)]
#[derive(Clone, Copy)]
pub struct KdrayPointTree {
    /// Private to the library.
    pub opaque: [u64; KDRAY_HANDLE_WORDS],
}

/// What a handle holds: a tag naming the tree's kind, then the tree.
#[repr(C)]
struct Tagged<T> {
    tag: u64,
    tree: T,
}

/// A kernel view the C API can keep in a handle.
pub(crate) trait View: Copy {
    /// The C handle type that holds it.
    type Handle;
    /// The tag word of a handle holding this view (ASCII, so a dump reads it).
    const TAG: u64;
    /// Why the kernel refused a blob.
    type Error: fmt::Display;
    /// The kernel's validating loader for this view.
    fn from_bytes(bytes: &'static [u8]) -> Result<Self, Self::Error>;
    /// What a handle of the right C type but another tag is: not open, or
    /// (a point tree of another shape) the wrong shape for the call.
    fn mismatch(_tag: u64) -> KdrayStatus {
        KdrayStatus::NotOpen
    }
}

impl View for TriangleTree<'static> {
    type Handle = KdrayTriangleTree;
    const TAG: u64 = u64::from_le_bytes(*b"kdrayTRI");
    type Error = BlobError;
    fn from_bytes(bytes: &'static [u8]) -> Result<Self, BlobError> {
        TriangleTree::from_bytes(bytes)
    }
}

/// The first six bytes of every point handle's tag; the last two are D
/// and the scalar's size.
const POINT_TAG: [u8; 6] = *b"kdrayP";

impl<const D: usize, S: Scalar> View for PointTreeN<'static, D, S> {
    type Handle = KdrayPointTree;
    #[allow(clippy::cast_possible_truncation)] // D <= 16, S::BYTES <= 8
    const TAG: u64 = {
        let [a, b, c, d, e, f] = POINT_TAG;
        u64::from_le_bytes([a, b, c, d, e, f, D as u8, S::BYTES as u8])
    };
    type Error = BlobError;
    fn from_bytes(bytes: &'static [u8]) -> Result<Self, BlobError> {
        PointTreeN::from_bytes(bytes)
    }
    fn mismatch(tag: u64) -> KdrayStatus {
        if tag.to_le_bytes()[..6] == POINT_TAG {
            KdrayStatus::WrongShape
        } else {
            KdrayStatus::NotOpen
        }
    }
}

/// An opened scene, as [`KdrayTriangleTree`] is for one mesh; opened by
/// `kdray_scene_open` on a scene blob (`kdray build --instances`).
#[repr(C)]
#[derive(Clone, Copy)]
pub struct KdrayScene {
    /// Private to the library.
    pub opaque: [u64; KDRAY_HANDLE_WORDS],
}

impl View for Scene<'static> {
    type Handle = KdrayScene;
    const TAG: u64 = u64::from_le_bytes(*b"kdraySCN");
    type Error = SceneError;
    fn from_bytes(bytes: &'static [u8]) -> Result<Self, SceneError> {
        Scene::from_bytes(bytes)
    }
}

/// Marks `handle` not open (so a failed open cannot leave an old tree
/// readable). The pointer was checked by the caller.
///
/// # Safety
/// `handle` is non-null, aligned, and points to a writable handle.
unsafe fn close<H>(handle: *mut H) {
    // SAFETY: the caller's contract; the tag is the handle's first word.
    unsafe { handle.cast::<u64>().write(0) };
}

/// Stores `tree` in `handle` with the view's tag.
///
/// # Safety
/// `handle` is non-null, aligned, and points to a writable handle; the
/// bytes `tree` borrows stay alive and unchanged while the handle is used
/// (the open functions' precondition, which is why `'static` is acceptable).
pub(crate) unsafe fn store<V: View>(handle: *mut V::Handle, tree: V) {
    const {
        use core::mem::{align_of, size_of};
        assert!(size_of::<Tagged<V>>() <= size_of::<V::Handle>());
        assert!(align_of::<Tagged<V>>() <= align_of::<V::Handle>());
    }
    let tagged = Tagged { tag: V::TAG, tree };
    // SAFETY: `Tagged<V>` fits in the handle with no stricter alignment
    // (checked at compile time above), and `handle` is writable.
    unsafe { handle.cast::<Tagged<V>>().write(tagged) };
}

/// The tree in an opened handle: `NULL_POINTER`, `MISALIGNED`,
/// `NOT_OPEN` or (a point tree of another shape) `WRONG_SHAPE` otherwise.
///
/// # Safety
/// If `handle` is non-null and aligned, it points to a readable handle; if
/// its tag is `V::TAG` it was written by [`store`] and the blob it borrows
/// is still alive and unchanged (the queries' precondition).
pub(crate) unsafe fn load<V: View>(handle: *const V::Handle) -> Result<V, KdrayStatus> {
    check_ptr(handle)?;
    // SAFETY: checked non-null and aligned; readable by the contract.
    let tag = unsafe { handle.cast::<u64>().read() };
    if tag != V::TAG {
        return Err(V::mismatch(tag));
    }
    // SAFETY: the tag says `store` wrote a `Tagged<V>` here.
    Ok(unsafe { handle.cast::<Tagged<V>>().read().tree })
}

/// The D and scalar size of the point tree in an opened handle (from its
/// tag): `NULL_POINTER`, `MISALIGNED` or `NOT_OPEN` otherwise.
///
/// # Safety
/// If `handle` is non-null and aligned, it points to a readable handle.
pub(crate) unsafe fn point_shape(
    handle: *const KdrayPointTree,
) -> Result<(usize, usize), KdrayStatus> {
    check_ptr(handle)?;
    // SAFETY: checked non-null and aligned; readable by the contract.
    let tag = unsafe { handle.cast::<u64>().read() }.to_le_bytes();
    match tag {
        [a, b, c, d, e, f, dim, bytes] if [a, b, c, d, e, f] == POINT_TAG => {
            Ok((usize::from(dim), usize::from(bytes)))
        }
        _ => Err(KdrayStatus::NotOpen),
    }
}

/// Checks the handle pointer and marks it not open, the first step of
/// every open function.
///
/// # Safety
/// If non-null and aligned, `handle` points to a writable handle.
pub(crate) unsafe fn begin_open<H>(handle: *mut H) -> Result<(), KdrayStatus> {
    check_ptr(handle.cast_const())?;
    // SAFETY: checked non-null and aligned; writable by the contract.
    unsafe { close(handle) };
    Ok(())
}

/// The body of the open functions: validates `blob[0..len]` into
/// `*handle` as a `V`, or marks it not open and writes why to `message`
/// (`BlobError`'s sentence, or the status text for a bad argument).
///
/// # Safety
/// As `kdray_triangles_open`'s preconditions.
pub(crate) unsafe fn open<V: View>(
    handle: *mut V::Handle,
    blob: *const u8,
    len: usize,
    message: *mut c_char,
    message_len: usize,
) -> KdrayStatus {
    // SAFETY: this function's contract.
    unsafe {
        open_with(handle, blob, len, message, message_len, |bytes| {
            let tree = V::from_bytes(bytes)?;
            store(handle, tree);
            Ok::<(), V::Error>(())
        })
    }
}

/// The open functions' message for a blob at an address that is not a
/// multiple of 4 (the address modulo 4), in a C programmer's terms.
struct MisalignedForC(usize);

impl fmt::Display for MisalignedForC {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "blob is not 4-byte aligned (address % 4 = {}); pass the start of memory from malloc or aligned_alloc (or a buffer declared _Alignas(64)), not an offset into it",
            self.0
        )
    }
}

/// [`open`] with the loading step given: `load` validates the blob and
/// stores the view in the (checked, closed) handle.
///
/// # Safety
/// As `kdray_triangles_open`'s preconditions; `load` stores only into
/// `handle`.
pub(crate) unsafe fn open_with<H, E: fmt::Display>(
    handle: *mut H,
    blob: *const u8,
    len: usize,
    message: *mut c_char,
    message_len: usize,
    load: impl FnOnce(&'static [u8]) -> Result<(), E>,
) -> KdrayStatus {
    let opened = (|| {
        // SAFETY: the handle's contract.
        unsafe { begin_open(handle) }?;
        // SAFETY: the blob's contract (`len` readable bytes).
        let bytes = unsafe { blob_slice(blob, len) }?;
        let offset = bytes.as_ptr() as usize % 4;
        if offset != 0 {
            // The kernel's sentence advises a Rust macro; a C caller gets
            // the C way to aligned bytes.
            // SAFETY: `message`'s contract.
            unsafe { write_message(message, message_len, MisalignedForC(offset)) };
            return Err(KdrayStatus::InvalidBlob);
        }
        load(bytes).map_err(|e| {
            // SAFETY: `message`'s contract.
            unsafe { write_message(message, message_len, e) };
            KdrayStatus::InvalidBlob
        })
    })();
    let s = status(opened);
    if s != KdrayStatus::InvalidBlob {
        let text = status_text(s as i32).to_str().unwrap_or("");
        // SAFETY: `message`'s contract.
        unsafe { write_message(message, message_len, text) };
    }
    s
}

/// The blob as a slice, or why it cannot be one. Misalignment is left to
/// the kernel's validation, which reports it as a blob error.
///
/// # Safety
/// If `blob` is non-null, it points to `len` readable bytes that outlive
/// the returned slice's uses.
unsafe fn blob_slice(blob: *const u8, len: usize) -> Result<&'static [u8], KdrayStatus> {
    check_ptr(blob)?;
    check_count::<u8>(len)?;
    // SAFETY: non-null, `len` readable bytes (the caller's contract), and
    // `len <= isize::MAX`.
    Ok(unsafe { core::slice::from_raw_parts(blob, len) })
}
