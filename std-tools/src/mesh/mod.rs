//! Mesh loaders: a file in, triangles out, numbered as `formats/RAYS.md`
//! says (faces in file order, an n-gon fanned as `(v0, v[i], v[i+1])`).

mod gltf;
mod obj;
mod ply;

use kdray_kernel::Triangle;
use std::fmt;
use std::path::{Path, PathBuf};

pub use gltf::load_gltf;
pub use obj::load_obj;
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

/// Loads a mesh, choosing the format by the file extension.
///
/// # Errors
/// A [`MeshError`] naming the file (and line) for a missing, unreadable,
/// malformed or unsupported file, or a triangle with a non-finite vertex.
pub fn load(path: &Path) -> Result<Vec<Triangle>, MeshError> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .unwrap_or_default();
    let tris = match ext.as_str() {
        "obj" => load_obj(path)?,
        "ply" => load_ply(path)?,
        "gltf" | "glb" => load_gltf(path)?,
        _ => {
            return Err(MeshError::new(
                path,
                None,
                format!("unsupported mesh format {ext:?} (supported: .obj, .ply, .gltf, .glb)"),
            ))
        }
    };
    check_finite(path, &tris)?;
    Ok(tris)
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
