//! The blob writer, and an owned, aligned blob that lends a kernel view.

use crate::builders::BuiltTree;
use crate::points::BuiltPoints;
use kdray_kernel::format::wire::Line;
use kdray_kernel::{
    BlobError, PointTreeN, Scalar, Scene, SceneError, Triangle, TriangleTree, WriteError,
};
use std::path::Path;

/// Blob bytes held in cache lines, so they are always 64-byte aligned and
/// the kernel reads them in place (`f64` point blobs need 8; a triangle
/// tree's child pairs then each sit in one line).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Blob {
    words: Vec<Line>,
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

/// What a blob holds, by its header's kind word (nothing else checked):
/// so a command can say "this is a point tree" rather than "invalid".
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BlobKind {
    /// A triangle tree (kind 1).
    Triangles,
    /// A point tree (kind 3, or the older kind 2).
    Points,
    /// A scene of instanced triangle trees (kind 4).
    Scene,
    /// Not a kdray blob, or a kind this build does not know.
    Unknown,
}

impl BlobKind {
    /// "a triangle tree", "a point tree", "a scene", "not a kdray tree blob".
    #[must_use]
    pub fn describe(self) -> &'static str {
        match self {
            BlobKind::Triangles => "a triangle tree",
            BlobKind::Points => "a point tree",
            BlobKind::Scene => "a scene (instanced triangle trees)",
            BlobKind::Unknown => "not a kdray tree blob",
        }
    }
}

impl Blob {
    /// What the blob holds, by its magic and kind words only (the view
    /// for that kind validates the rest).
    #[must_use]
    pub fn kind(&self) -> BlobKind {
        let b = self.as_bytes();
        if b.get(..8) != Some(&kdray_kernel::format::wire::MAGIC[..]) {
            return BlobKind::Unknown;
        }
        match b
            .get(16..20)
            .map(|w| u32::from_le_bytes([w[0], w[1], w[2], w[3]]))
        {
            Some(kdray_kernel::format::wire::KIND_TRIANGLES) => BlobKind::Triangles,
            Some(2 | kdray_kernel::format::wire::KIND_POINTS) => BlobKind::Points,
            Some(kdray_kernel::KIND_SCENE) => BlobKind::Scene,
            _ => BlobKind::Unknown,
        }
    }

    /// A copy of `bytes`, aligned. (A length that is not a multiple of 4 is
    /// kept exactly; the kernel then reports the truncation.)
    #[must_use]
    pub fn from_bytes(bytes: &[u8]) -> Blob {
        // One pass: each line written once (a zeroed vector and a copy
        // write the whole blob twice).
        let words = bytes
            .chunks(64)
            .map(|c| {
                let mut line = Line([0; 8]);
                bytemuck::bytes_of_mut(&mut line)[..c.len()].copy_from_slice(c);
                line
            })
            .collect();
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

    /// The validated scene view ([`Scene::from_bytes`]).
    ///
    /// # Errors
    /// The kernel's [`SceneError`].
    pub fn scene(&self) -> Result<Scene<'_>, SceneError> {
        Scene::from_bytes(self.as_bytes())
    }

    /// The validated point tree view ([`PointTreeN::from_bytes`]), of the
    /// dimension and scalar type the caller names (3-D `f32` by inference
    /// from a [`kdray_kernel::PointTree`]).
    ///
    /// # Errors
    /// The kernel's [`BlobError`]; [`BlobError::WrongDimension`] or
    /// [`BlobError::WrongScalar`] for a blob of another shape.
    pub fn point_tree<const D: usize, S: Scalar>(&self) -> Result<PointTreeN<'_, D, S>, BlobError> {
        PointTreeN::from_bytes(self.as_bytes())
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
    let mut words = vec![Line([0; 8]); len.div_ceil(64)];
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

/// Serialises a built point tree into an aligned blob, by the kernel's
/// writer ([`PointTreeN::write_to`], the format's one definition; its
/// layout is in `docs/points.md`). The same input gives the same bytes on
/// every run.
///
/// # Errors
/// [`WriteError`] when a count does not fit the format's 32-bit fields.
pub fn write_point_tree<const D: usize, S: Scalar>(
    tree: &BuiltPoints<D, S>,
) -> Result<Blob, WriteError> {
    let (n, s, i, c, b) = (
        &tree.nodes,
        &tree.splits,
        &tree.indices,
        &tree.coords,
        &tree.bounds,
    );
    let len = PointTreeN::write_parts_len(n, s, i, c, b)?;
    let mut words = vec![Line([0; 8]); len.div_ceil(64)];
    let out = bytemuck::cast_slice_mut(&mut words);
    let written = PointTreeN::write_parts_to(n, s, i, c, b, tree.max_depth, out)?;
    Ok(Blob {
        words,
        len: written,
    })
}
