//! The blob writer, and an owned, aligned blob that lends a kernel view.

use crate::builders::BuiltTree;
use crate::points::BuiltPoints;
use kdray_kernel::wire::{
    blob_checksum, Header, CHECKSUM_OFFSET, ENDIAN_CHECK, HEADER_LEN, KIND_POINTS, MAGIC, VERSION,
};
use kdray_kernel::{BlobError, Bounds, PointTree, Triangle, TriangleTree, WriteError};
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

    /// The validated point tree view ([`PointTree::from_bytes`]).
    ///
    /// # Errors
    /// The kernel's [`BlobError`].
    pub fn point_tree(&self) -> Result<PointTree<'_>, BlobError> {
        PointTree::from_bytes(self.as_bytes())
    }
}

/// Serialises a built tree and its triangles into an aligned blob, by the
/// kernel's writer ([`TriangleTree::write_parts_to`], the format's one
/// definition). The same input gives the same bytes on every run.
///
/// # Errors
/// [`WriteError`] when a count does not fit the format's 32-bit fields.
pub fn write_triangle_tree(tree: &BuiltTree, triangles: &[Triangle]) -> Result<Blob, WriteError> {
    let len = TriangleTree::write_parts_len(&tree.nodes, &tree.prims, triangles)?;
    let mut words = vec![0u32; len.div_ceil(4)];
    let written = TriangleTree::write_parts_to(
        &tree.nodes,
        &tree.prims,
        triangles,
        tree.bounds,
        tree.max_depth,
        bytemuck::cast_slice_mut(&mut words),
    )?;
    Ok(Blob {
        words,
        len: written,
    })
}

/// Serialises a built point tree: header, nodes, point indices, points in
/// leaf order, node bounds (the kernel's `PointTree` docs). Byte order and
/// determinism as [`write_triangle_tree`].
#[must_use]
pub fn write_point_tree(tree: &BuiltPoints) -> Blob {
    let root = tree.bounds.first().copied().unwrap_or(Bounds {
        min: [0.0; 3],
        max: [0.0; 3],
    });
    assemble(
        Counts {
            kind: KIND_POINTS,
            max_depth: tree.max_depth,
            nodes: tree.nodes.len(),
            indices: tree.indices.len(),
            items: tree.points.len(),
        },
        root,
        &[
            bytemuck::cast_slice(&tree.nodes),
            &tree.indices,
            bytemuck::cast_slice(&tree.points),
            bytemuck::cast_slice(&tree.bounds),
        ],
    )
}

/// The header fields that differ between blobs.
struct Counts {
    kind: u32,
    max_depth: u32,
    nodes: usize,
    indices: usize,
    items: usize,
}

/// The header (with the checksum of the sections), then the sections.
fn assemble(c: Counts, bounds: Bounds, sections: &[&[u32]]) -> Blob {
    let body_len: usize = sections.iter().map(|s| s.len()).sum();
    let mut words = Vec::with_capacity(HEADER_LEN / 4 + body_len);
    words.resize(HEADER_LEN / 4, 0);
    for s in sections {
        words.extend_from_slice(s);
    }
    let header = Header {
        magic: MAGIC,
        endian: ENDIAN_CHECK,
        version: VERSION,
        kind: c.kind,
        max_depth: c.max_depth,
        node_count: c.nodes as u32,
        index_count: c.indices as u32,
        item_count: c.items as u32,
        checksum: 0,
        bounds_min: bounds.min,
        bounds_max: bounds.max,
    };
    words[..HEADER_LEN / 4].copy_from_slice(bytemuck::cast_slice(&[header]));
    words[CHECKSUM_OFFSET / 4] = blob_checksum(bytemuck::cast_slice(&words));
    let len = words.len() * 4;
    Blob { words, len }
}
