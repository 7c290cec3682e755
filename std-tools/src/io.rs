//! The binary files of `formats/RAYS.md`: headerless little-endian arrays
//! of fixed-size records (rays 32 B, hits 16 B, points 12 B, neighbours 8 B).

use bytemuck::Pod;
use std::fmt;
use std::path::{Path, PathBuf};

/// A record file that could not be read or written.
#[derive(Debug)]
pub struct RecordFileError {
    /// The file.
    pub path: PathBuf,
    /// What went wrong.
    pub message: String,
}

impl fmt::Display for RecordFileError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.path.display(), self.message)
    }
}

impl std::error::Error for RecordFileError {}

/// Reads a file of `T` records (`what` names them in errors: "ray").
///
/// # Errors
/// The file cannot be read, or its size is not a multiple of the record size.
pub fn read_records<T: Pod>(path: &Path, what: &str) -> Result<Vec<T>, RecordFileError> {
    let err = |message: String| RecordFileError {
        path: path.to_path_buf(),
        message,
    };
    let bytes = std::fs::read(path).map_err(|e| err(format!("cannot read: {e}")))?;
    let size = std::mem::size_of::<T>();
    if bytes.len() % size != 0 {
        return Err(err(format!(
            "size {} bytes is not a multiple of the {size}-byte {what} record ({} whole records and {} bytes left over)",
            bytes.len(),
            bytes.len() / size,
            bytes.len() % size
        )));
    }
    let mut out = vec![T::zeroed(); bytes.len() / size];
    bytemuck::cast_slice_mut::<T, u8>(&mut out).copy_from_slice(&bytes);
    Ok(out)
}

/// Writes `records` to `path` atomically: to a temporary file beside it,
/// then renamed, so a failure never leaves a half-written output.
///
/// # Errors
/// The file cannot be written.
pub fn write_records<T: Pod>(path: &Path, records: &[T]) -> Result<(), RecordFileError> {
    write_bytes(path, bytemuck::cast_slice(records))
}

/// Writes `bytes` to `path` atomically (see [`write_records`]).
///
/// # Errors
/// The file cannot be written.
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<(), RecordFileError> {
    let err = |message: String| RecordFileError {
        path: path.to_path_buf(),
        message,
    };
    let mut tmp = path.as_os_str().to_owned();
    tmp.push(".tmp");
    let tmp = PathBuf::from(tmp);
    std::fs::write(&tmp, bytes).map_err(|e| err(format!("cannot write: {e}")))?;
    std::fs::rename(&tmp, path).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        err(format!("cannot write: {e}"))
    })
}
