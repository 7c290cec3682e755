//! Mesh loaders: a file in, triangles out, numbered as `docs/formats.md`
//! says (faces in file order, an n-gon fanned as `(v0, v[i], v[i+1])`).
//! A face of fewer than three corners and a mesh of no triangles are
//! errors; glTF point and line primitives are skipped and reported.

mod gltf;
mod obj;
mod ply;

use kdray_kernel::Triangle;
use std::fmt;
use std::path::{Path, PathBuf};

pub use gltf::{buffer_files, load_gltf, load_gltf_instanced, InstancedGltf};
pub use obj::{load_obj, obj_text};
pub use ply::load_ply;

/// A mesh that could not be loaded: the file, the line when known, and why.
#[derive(Debug)]
pub struct MeshError {
    /// The file.
    pub path: PathBuf,
    /// The 1-based line (or element) where the problem was found, if known.
    pub line: Option<usize>,
    /// What is wrong.
    pub message: String,
}

impl MeshError {
    /// An error in `path` at `line`.
    pub fn new(path: &Path, line: Option<usize>, message: impl Into<String>) -> MeshError {
        MeshError {
            path: path.to_path_buf(),
            line,
            message: message.into(),
        }
    }
}

impl fmt::Display for MeshError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.line {
            Some(line) => write!(f, "{}:{line}: {}", self.path.display(), self.message),
            None => write!(f, "{}: {}", self.path.display(), self.message),
        }
    }
}

impl std::error::Error for MeshError {}

/// How [`load_with`] reads a mesh.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LoadOptions {
    /// Let a glTF's buffer URIs name files outside the glTF's own folder
    /// (absolute paths, `..`). Off by default: a downloaded model must not
    /// read `/etc/passwd` into a tree.
    pub allow_outside_uris: bool,
}

/// A loaded mesh.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    /// The triangles, in the documented order.
    pub triangles: Vec<Triangle>,
    /// What the file held that is not triangles and was skipped, one line
    /// each ("mesh 0 primitive 1: a POINTS primitive (4 vertices) skipped").
    pub skipped: Vec<String>,
}

/// Loads a mesh with the default [`LoadOptions`], choosing the format by
/// the file extension; anything skipped (see [`Mesh::skipped`]) is dropped.
///
/// # Errors
/// As [`load_with`].
pub fn load(path: &Path) -> Result<Vec<Triangle>, MeshError> {
    load_with(path, &LoadOptions::default()).map(|m| m.triangles)
}

/// Loads a mesh, choosing the format by the file extension.
///
/// # Errors
/// A [`MeshError`] naming the file (and line) for a missing, unreadable,
/// malformed or unsupported file, a face of fewer than three corners, a
/// file with no triangles, a glTF buffer outside the glTF's folder (unless
/// allowed), or a triangle with a non-finite vertex.
pub fn load_with(path: &Path, options: &LoadOptions) -> Result<Mesh, MeshError> {
    let mut skipped = Vec::new();
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .unwrap_or_default();
    let tris = match ext.as_str() {
        "obj" => load_obj(path)?,
        "ply" => load_ply(path)?,
        "gltf" | "glb" => gltf::read(path, options, &mut skipped)?,
        _ => {
            return Err(MeshError::new(
                path,
                None,
                format!("unsupported mesh format {ext:?} (supported: .obj, .ply, .gltf, .glb)"),
            ))
        }
    };
    if tris.is_empty() {
        return Err(MeshError::new(path, None, "the mesh has no triangles"));
    }
    check_finite(path, &tris)?;
    Ok(Mesh {
        triangles: tris,
        skipped,
    })
}

/// Every file loading `path` reads: the mesh itself and, for a glTF,
/// the buffer files its URIs name ([`buffer_files`]).
#[must_use]
pub fn files_read(path: &Path) -> Vec<PathBuf> {
    let mut files = vec![path.to_path_buf()];
    if is_gltf(path) {
        files.extend(buffer_files(path));
    }
    files
}

/// Whether `path` has a glTF extension (`.gltf`, `.glb`, any case).
fn is_gltf(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("gltf") || e.eq_ignore_ascii_case("glb"))
}

/// Calls `emit` with the triangles of polygon `poly` fanned from its first
/// vertex, `(v0, v[i], v[i+1])` (nothing for fewer than 3 vertices).
pub(crate) fn fan(poly: &[u32], mut emit: impl FnMut([u32; 3])) {
    if let Some((&v0, rest)) = poly.split_first() {
        for pair in rest.windows(2) {
            emit([v0, pair[0], pair[1]]);
        }
    }
}

/// Refuses triangles with NaN or infinite coordinates, naming the first.
///
/// # Errors
/// A [`MeshError`] naming the triangle.
pub fn check_finite(path: &Path, tris: &[Triangle]) -> Result<(), MeshError> {
    match tris.iter().position(|t| !t.is_finite()) {
        None => Ok(()),
        Some(i) => Err(MeshError::new(
            path,
            None,
            format!(
                "triangle {i} has a non-finite vertex coordinate: {:?}",
                tris[i].v
            ),
        )),
    }
}
