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
use kdray_kernel::{BlobError, PointTree, Scene, SceneError, TriangleTree};

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

/// A tree the C API can keep in a handle.
pub(crate) trait Handle: Sized {
    /// The kernel view the handle holds.
    type Tree: Copy;
    /// The tag word of an opened handle of this kind (ASCII, so a dump reads it).
    const TAG: u64;
    /// Why the kernel refused a blob.
    type Error: core::fmt::Display;
    /// The kernel's validating loader for this kind.
    fn from_bytes(bytes: &'static [u8]) -> Result<Self::Tree, Self::Error>;
}

impl Handle for KdrayTriangleTree {
    type Tree = TriangleTree<'static>;
    const TAG: u64 = u64::from_le_bytes(*b"kdrayTRI");
    type Error = BlobError;
    fn from_bytes(bytes: &'static [u8]) -> Result<Self::Tree, BlobError> {
        TriangleTree::from_bytes(bytes)
    }
}

impl Handle for KdrayPointTree {
    type Tree = PointTree<'static>;
    const TAG: u64 = u64::from_le_bytes(*b"kdrayPTS");
    type Error = BlobError;
    fn from_bytes(bytes: &'static [u8]) -> Result<Self::Tree, BlobError> {
        PointTree::from_bytes(bytes)
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

impl Handle for KdrayScene {
    type Tree = Scene<'static>;
    const TAG: u64 = u64::from_le_bytes(*b"kdraySCN");
    type Error = SceneError;
    fn from_bytes(bytes: &'static [u8]) -> Result<Self::Tree, SceneError> {
        Scene::from_bytes(bytes)
    }
}

// Each view fits its handle, and the handle's alignment suffices.
const _: () = {
    use core::mem::{align_of, size_of};
    assert!(size_of::<Tagged<TriangleTree<'static>>>() <= size_of::<KdrayTriangleTree>());
    assert!(size_of::<Tagged<PointTree<'static>>>() <= size_of::<KdrayPointTree>());
    assert!(align_of::<Tagged<TriangleTree<'static>>>() <= align_of::<KdrayTriangleTree>());
    assert!(align_of::<Tagged<PointTree<'static>>>() <= align_of::<KdrayPointTree>());
    assert!(size_of::<Tagged<Scene<'static>>>() <= size_of::<KdrayScene>());
    assert!(align_of::<Tagged<Scene<'static>>>() <= align_of::<KdrayScene>());
};

/// Marks `handle` not open (so a failed open cannot leave an old tree
/// readable). The pointer was checked by the caller.
///
/// # Safety
/// `handle` is non-null, aligned, and points to a writable `H`.
unsafe fn close<H: Handle>(handle: *mut H) {
    // SAFETY: the caller's contract; the tag is the handle's first word.
    unsafe { handle.cast::<u64>().write(0) };
}

/// Stores `tree` in `handle` with the kind's tag.
///
/// # Safety
/// `handle` is non-null, aligned, and points to a writable `H`; the bytes
/// `tree` borrows stay alive and unchanged while the handle is used (the
/// open functions' precondition, which is why `'static` is acceptable).
unsafe fn store<H: Handle>(handle: *mut H, tree: H::Tree) {
    let tagged = Tagged { tag: H::TAG, tree };
    // SAFETY: `Tagged<H::Tree>` fits in `H` with no stricter alignment
    // (checked at compile time above), and `handle` is writable.
    unsafe { handle.cast::<Tagged<H::Tree>>().write(tagged) };
}

/// The tree in an opened handle: `NULL_POINTER`, `MISALIGNED` or
/// `NOT_OPEN` otherwise.
///
/// # Safety
/// If `handle` is non-null and aligned, it points to a readable `H`; if
/// its tag is `H::TAG` it was written by [`store`] and the blob it borrows
/// is still alive and unchanged (the queries' precondition).
pub(crate) unsafe fn load<H: Handle>(handle: *const H) -> Result<H::Tree, KdrayStatus> {
    check_ptr(handle)?;
    // SAFETY: checked non-null and aligned; readable by the contract.
    let tag = unsafe { handle.cast::<u64>().read() };
    if tag != H::TAG {
        return Err(KdrayStatus::NotOpen);
    }
    // SAFETY: the tag says `store` wrote a `Tagged<H::Tree>` here.
    Ok(unsafe { handle.cast::<Tagged<H::Tree>>().read().tree })
}

/// The body of the open functions: validates `blob[0..len]` into
/// `*handle`, or marks it not open and writes why to `message`
/// (`BlobError`'s sentence, or the status text for a bad argument).
///
/// # Safety
/// As `kdray_triangles_open`'s preconditions.
pub(crate) unsafe fn open<H: Handle>(
    handle: *mut H,
    blob: *const u8,
    len: usize,
    message: *mut c_char,
    message_len: usize,
) -> KdrayStatus {
    let opened = (|| {
        check_ptr(handle.cast_const())?;
        // SAFETY: checked non-null and aligned; writable by the contract.
        unsafe { close(handle) };
        // SAFETY: the blob's contract (`len` readable bytes).
        let bytes = unsafe { blob_slice(blob, len) }?;
        let tree = H::from_bytes(bytes).map_err(|e| {
            // SAFETY: `message`'s contract.
            unsafe { write_message(message, message_len, e) };
            KdrayStatus::InvalidBlob
        })?;
        // SAFETY: checked above; the blob outlives the handle by contract.
        unsafe { store(handle, tree) };
        Ok(())
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
