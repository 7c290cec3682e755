//! The blob writer, and an owned, aligned blob that lends a kernel view.

use crate::build::BuiltTree;
use kdray_kernel::wire::{
    blob_checksum, Header, CHECKSUM_OFFSET, ENDIAN_CHECK, HEADER_LEN, KIND_TRIANGLES, MAGIC,
    VERSION,
};
use kdray_kernel::{BlobError, Triangle, TriangleTree};
use std::path::Path;

/// Blob bytes held in `u32` words, so they are always 4-byte aligned and
/// the kernel reads them in place.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Blob {
    words: Vec<u32>,
    len: usize,
}

/// Why a blob file could not be read.
#[derive(Debug)]
pub enum BlobFileError {
    /// The file could not be read.
    Io(std::io::Error),
    /// The bytes are not a valid blob.
    Invalid(BlobError),
}

impl std::fmt::Display for BlobFileError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            BlobFileError::Io(e) => write!(f, "cannot read: {e}"),
            BlobFileError::Invalid(e) => write!(f, "invalid tree blob: {e}"),
        }
    }
}

impl std::error::Error for BlobFileError {}

impl Blob {
    /// A copy of `bytes`, aligned. (A length that is not a multiple of 4 is
    /// kept exactly; the kernel then reports the truncation.)
    #[must_use]
    pub fn from_bytes(bytes: &[u8]) -> Blob {
        let mut words = vec![0u32; bytes.len().div_ceil(4)];
        bytemuck::cast_slice_mut::<u32, u8>(&mut words)[..bytes.len()].copy_from_slice(bytes);
        Blob {
            words,
            len: bytes.len(),
        }
    }

    /// Reads a blob file.
    ///
    /// # Errors
    /// [`BlobFileError::Io`] if the file cannot be read.
    pub fn read(path: &Path) -> Result<Blob, BlobFileError> {
        std::fs::read(path)
            .map(|b| Blob::from_bytes(&b))
            .map_err(BlobFileError::Io)
    }

    /// The bytes.
    #[must_use]
    pub fn as_bytes(&self) -> &[u8] {
        &bytemuck::cast_slice(&self.words)[..self.len]
    }

    /// The validated kernel view ([`TriangleTree::from_bytes`]).
    ///
    /// # Errors
    /// The kernel's [`BlobError`].
    pub fn tree(&self) -> Result<TriangleTree<'_>, BlobError> {
        TriangleTree::from_bytes(self.as_bytes())
    }
}

/// Serialises a built tree and its triangles: header, nodes, primitive
/// indices, triangles (`kdray_kernel::wire`). Written in the host's byte
/// order, little-endian on every platform kdray supports; a big-endian
/// reader refuses the blob by its check word. The same input gives the
/// same bytes on every run.
#[must_use]
pub fn write_triangle_tree(tree: &BuiltTree, triangles: &[Triangle]) -> Blob {
    let mut body: Vec<u32> =
        Vec::with_capacity(tree.nodes.len() * 2 + tree.prims.len() + triangles.len() * 9);
    body.extend_from_slice(bytemuck::cast_slice(&tree.nodes));
    body.extend_from_slice(&tree.prims);
    body.extend_from_slice(bytemuck::cast_slice(triangles));
    let header = Header {
        magic: MAGIC,
        endian: ENDIAN_CHECK,
        version: VERSION,
        kind: KIND_TRIANGLES,
        max_depth: tree.max_depth,
        node_count: (tree.nodes.len() as u32),
        index_count: (tree.prims.len() as u32),
        item_count: (triangles.len() as u32),
        checksum: 0,
        bounds_min: tree.bounds.min,
        bounds_max: tree.bounds.max,
    };
    let mut words = Vec::with_capacity(HEADER_LEN / 4 + body.len());
    words.extend_from_slice(bytemuck::cast_slice(&[header]));
    words.extend_from_slice(&body);
    words[CHECKSUM_OFFSET / 4] = blob_checksum(bytemuck::cast_slice(&words));
    let len = words.len() * 4;
    Blob { words, len }
}
