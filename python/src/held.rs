//! The bytes of a blob a tree reads: copied into an aligned [`Blob`], or
//! borrowed from a read-only Python buffer without a copy; and the
//! validated views that borrow them for as long as the Python object lives.

use crate::BlobError as PyBlobError;
use kdray_kernel::{Scene, Treelet, TreeletTree, TriangleTree};
use kdray_tools::blob::Blob;
use pyo3::buffer::PyBuffer;
use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyBytes;
use std::path::Path;

/// Where a tree's blob lives.
pub(crate) enum Bytes {
    /// A copy, cache-line aligned.
    Owned(Blob),
    /// A read-only, C-contiguous buffer exported by a Python object (a
    /// `bytes`, a read-only `memoryview` or `mmap`, a pickle's out-of-band
    /// buffer), aligned as the kernel needs. The object is kept alive and
    /// its export held until the tree is dropped.
    Borrowed(PyBuffer<u8>),
}

impl Bytes {
    /// The bytes of `obj` (anything with the buffer protocol over bytes):
    /// borrowed when its buffer is read-only, C-contiguous and `align`-byte
    /// aligned and `copy` is false, else copied once.
    pub(crate) fn from_buffer(obj: &Bound<'_, PyAny>, align: usize, copy: bool) -> PyResult<Bytes> {
        let buf = PyBuffer::<u8>::get(obj).map_err(|e| {
            pyo3::exceptions::PyTypeError::new_err(format!(
                "buffer: expected bytes or a buffer of bytes (uint8), got {}: {e}",
                obj.get_type()
                    .name()
                    .map_or_else(|_| "?".into(), |n| n.to_string())
            ))
        })?;
        let borrow = !copy
            && buf.readonly()
            && buf.is_c_contiguous()
            && (buf.buf_ptr() as usize).is_multiple_of(align);
        if borrow {
            return Ok(Bytes::Borrowed(buf));
        }
        let bytes = buf.to_vec(obj.py())?;
        Ok(Bytes::Owned(Blob::from_bytes(&bytes)))
    }

    /// A built blob, handed to Python as a `bytes` object that the tree
    /// then borrows (so `to_bytes()` and pickling return it without a
    /// copy); kept as the blob where that object is not aligned.
    pub(crate) fn from_blob(py: Python<'_>, blob: Blob, align: usize) -> Bytes {
        let obj = PyBytes::new(py, blob.as_bytes());
        match PyBuffer::<u8>::get(obj.as_any()) {
            Ok(buf) if (buf.buf_ptr() as usize).is_multiple_of(align) => Bytes::Borrowed(buf),
            _ => Bytes::Owned(blob),
        }
    }

    /// The bytes, for as long as `self` lives.
    pub(crate) fn as_slice(&self) -> &[u8] {
        match self {
            Bytes::Owned(blob) => blob.as_bytes(),
            Bytes::Borrowed(buf) if buf.len_bytes() == 0 => &[],
            // SAFETY: the exporter keeps `len_bytes` bytes at `buf_ptr`
            // alive and in place until the export held by `buf` is
            // released (when `self` is dropped); the buffer is read-only
            // and C-contiguous (checked in `from_buffer`), so nothing
            // writes it through this export. (A caller who writes the
            // memory by another path while the tree lives breaks the
            // contract `from_bytes` documents, as with `numpy.frombuffer`.)
            Bytes::Borrowed(buf) => unsafe {
                std::slice::from_raw_parts(buf.buf_ptr().cast::<u8>(), buf.len_bytes())
            },
        }
    }

    /// The blob as a `bytes` object: the one borrowed where it is one,
    /// else a copy.
    pub(crate) fn to_pybytes<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        if let Bytes::Borrowed(buf) = self {
            if let Some(obj) = buf.obj(py) {
                if obj.is_exact_instance_of::<PyBytes>() {
                    return obj.clone();
                }
            }
        }
        PyBytes::new(py, self.as_slice()).into_any()
    }

    /// A blob file, read by the tools' reader with the GIL released (an
    /// `OSError` naming the path when it cannot be read).
    pub(crate) fn read(py: Python<'_>, path: &Path) -> PyResult<Bytes> {
        py.detach(|| Blob::read(path))
            .map(Bytes::Owned)
            .map_err(|e| PyOSError::new_err(format!("{}: {e}", path.display())))
    }

    /// Writes the bytes to `path` with the tools' writer (a temporary file
    /// renamed into place), the GIL released.
    pub(crate) fn save(&self, py: Python<'_>, path: &Path) -> PyResult<()> {
        let bytes = self.as_slice();
        py.detach(|| kdray_tools::io::write_bytes(path, bytes))
            .map_err(|e| PyOSError::new_err(e.to_string()))
    }
}

/// A validated view over a blob's bytes: what every tree class opens from
/// a buffer or a file, the validation run with the GIL released.
pub(crate) trait Held: Sized + Send {
    /// The alignment the view needs of bytes it borrows.
    const ALIGN: usize;

    /// Validates `bytes`.
    fn new(bytes: Bytes) -> PyResult<Self>;

    /// The blob of `buffer` (borrowed when read-only, C-contiguous and
    /// aligned and `copy` is false; copied otherwise), validated.
    fn from_buffer(buffer: &Bound<'_, PyAny>, copy: bool) -> PyResult<Self> {
        let bytes = Bytes::from_buffer(buffer, Self::ALIGN, copy)?;
        buffer.py().detach(|| Self::new(bytes))
    }

    /// A blob file, read and validated.
    fn load(py: Python<'_>, path: &Path) -> PyResult<Self> {
        let bytes = Bytes::read(py, path)?;
        py.detach(|| Self::new(bytes))
    }
}

/// `bytes` with the lifetime of the holder that owns them.
///
/// # Safety
/// The caller keeps `bytes` alive, unmoved in memory, for as long as it
/// uses the slice: both variants keep their data on the heap (the blob's
/// lines, the exporter's buffer), so moving the [`Bytes`] value itself is
/// fine.
unsafe fn extend(bytes: &Bytes) -> &'static [u8] {
    let s = bytes.as_slice();
    // SAFETY: the caller's contract above.
    unsafe { std::slice::from_raw_parts(s.as_ptr(), s.len()) }
}

/// A validated triangle tree with its treelets, over bytes it owns or
/// borrows. Fields drop in order: the views before what they borrow.
pub(crate) struct HeldTree {
    /// Borrows `lines` and `bytes`.
    tree: TreeletTree<'static>,
    /// Never touched after `new` but to drop it.
    _lines: Vec<Treelet>,
    _bytes: Bytes,
}

impl Held for HeldTree {
    /// A triangle tree's (the kernel checks 4; a `bytes` object's data is
    /// 16-aligned).
    const ALIGN: usize = 4;

    /// Validates `bytes` as a triangle tree ([`TriangleTree::from_bytes`])
    /// and writes its treelets (for scattered rays, as `kdray trace` does).
    fn new(bytes: Bytes) -> PyResult<HeldTree> {
        // SAFETY: `bytes` moves into the returned value, which drops `tree`
        // first; its data stays where it is (see `extend`).
        let data = unsafe { extend(&bytes) };
        let base = TriangleTree::from_bytes(data).map_err(blob_error("triangle tree"))?;
        let mut lines = vec![Treelet::default(); base.treelet_count()];
        // SAFETY: `lines`' heap buffer is not moved by moving the vector,
        // is never read or written through `lines` again (only dropped,
        // after `tree`), and outlives `tree` as above.
        let lined: &'static mut [Treelet] =
            unsafe { std::slice::from_raw_parts_mut(lines.as_mut_ptr(), lines.len()) };
        let tree = base
            .treelets_into(lined)
            .map_err(|e| PyValueError::new_err(format!("triangle tree: {e}")))?;
        Ok(HeldTree {
            tree,
            _lines: lines,
            _bytes: bytes,
        })
    }
}

impl HeldTree {
    /// The tree, with its treelets.
    pub(crate) fn tree(&self) -> &TreeletTree<'_> {
        &self.tree
    }

    /// The blob.
    pub(crate) fn bytes(&self) -> &Bytes {
        &self._bytes
    }
}

/// A validated scene over bytes it owns or borrows.
pub(crate) struct HeldScene {
    /// Borrows `bytes`.
    scene: Scene<'static>,
    bytes: Bytes,
}

impl Held for HeldScene {
    /// A scene's: its meshes' (`MESH_ALIGN`).
    const ALIGN: usize = kdray_kernel::MESH_ALIGN;

    /// Validates `bytes` as a scene blob ([`Scene::from_bytes`]).
    fn new(bytes: Bytes) -> PyResult<HeldScene> {
        // SAFETY: as in `HeldTree::new`.
        let data = unsafe { extend(&bytes) };
        let scene = Scene::from_bytes(data).map_err(blob_error("scene"))?;
        Ok(HeldScene { scene, bytes })
    }
}

impl HeldScene {
    /// The scene.
    pub(crate) fn scene(&self) -> &Scene<'_> {
        &self.scene
    }

    /// The blob.
    pub(crate) fn bytes(&self) -> &Bytes {
        &self.bytes
    }
}

/// The Python exception for a blob that does not validate as `what`.
pub(crate) fn blob_error<E: std::fmt::Display>(what: &'static str) -> impl Fn(E) -> PyErr {
    move |e| PyBlobError::new_err(format!("buffer: not a valid {what} blob: {e}"))
}
