//! The binary files of `docs/formats.md` (headerless little-endian arrays
//! of fixed-size records: rays 32 B, hits 16 B, points 12 B, neighbours
//! 8 B), and the one way every output of kdray is written ([`Output`]).
//!
//! An output never leaves a half-written or lost file behind. A regular
//! file (or a symlink to one) is replaced atomically: the bytes go to a
//! temporary in the same folder, which is flushed, synced and renamed over
//! the target, with the old file's permissions; on any failure, and on
//! SIGINT, SIGTERM or SIGHUP when the `kdray` binary runs, the temporary is
//! removed and the old file is untouched. Anything else (`/dev/null`, a
//! pipe, a terminal) is written through, as a shell redirection would.

use bytemuck::Pod;
use std::fmt;
use std::fs::{File, OpenOptions, Permissions};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Mutex, MutexGuard, PoisonError};

/// A record file that could not be read or written.
#[derive(Debug)]
pub struct RecordFileError {
    /// The file.
    pub path: PathBuf,
    /// What went wrong.
    pub message: String,
}

impl RecordFileError {
    fn new(path: &Path, message: impl Into<String>) -> RecordFileError {
        RecordFileError {
            path: path.to_path_buf(),
            message: message.into(),
        }
    }
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
/// The file cannot be read, is a kdray tree blob (starts with its magic),
/// or its size is not a multiple of the record size.
pub fn read_records<T: Pod>(path: &Path, what: &str) -> Result<Vec<T>, RecordFileError> {
    use std::io::{Read as _, Seek as _};
    let err = |message: String| RecordFileError::new(path, message);
    let mut file = File::open(path).map_err(|e| err(format!("cannot read: {e}")))?;
    let meta = file
        .metadata()
        .map_err(|e| err(format!("cannot read: {e}")))?;
    let size = std::mem::size_of::<T>();
    let whole = |len: usize| {
        if len.is_multiple_of(size) {
            Ok(len / size)
        } else {
            Err(err(format!(
                "size {len} bytes is not a multiple of the {size}-byte {what} record ({} whole records and {} bytes left over)",
                len / size,
                len % size
            )))
        }
    };
    // A tree blob passed where its source records go (`kdray knn
    // cloud.kdt ...`) would otherwise be read as records, or refused only
    // for its size.
    let not_a_blob = |start: &[u8]| {
        if start.starts_with(&kdray_kernel::format::wire::MAGIC) {
            Err(err(format!(
                "this is a kdray tree blob, not a file of {what} records (docs/formats.md)"
            )))
        } else {
            Ok(())
        }
    };
    let oom = |e: crate::memory::OutOfMemory| err(e.to_string());
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt as _;
        // A character device may never end (`/dev/zero`): reading it
        // would fill the memory, not fail.
        if meta.file_type().is_char_device() {
            return Err(err(format!(
                "is a character device (such as /dev/zero or a terminal), not a file of {what} records: give a file or a pipe"
            )));
        }
    }
    if !meta.is_file() {
        // A pipe or a block device: its length is known only at its end.
        let mut bytes = Vec::new();
        file.read_to_end(&mut bytes)
            .map_err(|e| err(format!("cannot read: {e}")))?;
        not_a_blob(&bytes)?;
        let n = whole(bytes.len())?;
        let mut out =
            crate::memory::filled(n, T::zeroed(), &format!("{what} records")).map_err(oom)?;
        bytemuck::cast_slice_mut::<T, u8>(&mut out).copy_from_slice(&bytes);
        return Ok(out);
    }
    // A regular file is read straight into its records (one copy in
    // memory, reserved fallibly: the file's size decides it).
    let len = usize::try_from(meta.len()).unwrap_or(usize::MAX);
    let mut start = Vec::with_capacity(8);
    (&mut file)
        .take(8)
        .read_to_end(&mut start)
        .and_then(|_| file.rewind())
        .map_err(|e| err(format!("cannot read: {e}")))?;
    not_a_blob(&start)?;
    let n = whole(len)?;
    let mut out = crate::memory::filled(n, T::zeroed(), &format!("{what} records")).map_err(oom)?;
    file.read_exact(bytemuck::cast_slice_mut::<T, u8>(&mut out))
        .map_err(|e| err(format!("cannot read: {e}")))?;
    if file
        .read(&mut [0u8])
        .map_err(|e| err(format!("cannot read: {e}")))?
        != 0
    {
        return Err(err("the file grew while it was read".into()));
    }
    Ok(out)
}

/// Writes `records` to `path` as an [`Output`].
///
/// # Errors
/// The file cannot be written; a regular file at `path` is then unchanged.
pub fn write_records<T: Pod>(path: &Path, records: &[T]) -> Result<(), RecordFileError> {
    write_bytes(path, bytemuck::cast_slice(records))
}

/// Writes `bytes` to `path` as an [`Output`].
///
/// # Errors
/// The file cannot be written; a regular file at `path` is then unchanged.
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<(), RecordFileError> {
    let mut out = Output::create(path)?;
    out.write_all(bytes).map_err(|e| out.error(&e))?;
    out.commit()
}

/// Checks, before any expensive work, that `path` can be an output: its
/// folder exists and it is not itself a folder.
///
/// # Errors
/// Says which of the two is wrong.
pub fn check_output(path: &Path) -> Result<(), RecordFileError> {
    let err = |m: String| RecordFileError::new(path, m);
    if path.as_os_str().is_empty() {
        return Err(err("an empty output path".into()));
    }
    if path.is_dir() {
        return Err(err("is a folder, not a file".into()));
    }
    let dir = folder_of(path);
    if !dir.is_dir() {
        return Err(err(format!(
            "cannot write: the folder {} does not exist",
            dir.display()
        )));
    }
    Ok(())
}

/// [`check_output`], and refuses an output that is one of `inputs`: the
/// same file, by device and inode where the platform has them (so also
/// through a symlink or a hard link), else by canonical path. Writing it
/// would replace an input the command is reading (`build mesh.obj -o
/// mesh.obj` would leave a blob where the mesh was).
///
/// # Errors
/// As [`check_output`], or the output is an input (named).
pub fn check_output_apart(path: &Path, inputs: &[&Path]) -> Result<(), RecordFileError> {
    check_output(path)?;
    for input in inputs {
        if same_file(path, input) {
            return Err(RecordFileError::new(
                path,
                format!(
                    "is the input {} (the same file): writing it would replace the input; choose another output",
                    input.display()
                ),
            ));
        }
    }
    Ok(())
}

/// Whether `a` and `b` both exist and are one file.
fn same_file(a: &Path, b: &Path) -> bool {
    let (Ok(ma), Ok(mb)) = (std::fs::metadata(a), std::fs::metadata(b)) else {
        return false;
    };
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt as _;
        (ma.dev(), ma.ino()) == (mb.dev(), mb.ino())
    }
    #[cfg(not(unix))]
    {
        let _ = (ma, mb);
        matches!(
            (std::fs::canonicalize(a), std::fs::canonicalize(b)),
            (Ok(x), Ok(y)) if x == y
        )
    }
}

/// The folder `path` lives in (`.` for a bare file name).
fn folder_of(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// An output file being written; [`Output::commit`] makes it the file at
/// its path. Dropped without a commit, it leaves the path as it was.
#[derive(Debug)]
pub struct Output {
    /// The path the user named (for messages).
    path: PathBuf,
    file: BufWriter<File>,
    /// The temporary and the file it replaces, or `None` when written through.
    replace: Option<Replace>,
}

#[derive(Debug)]
struct Replace {
    temporary: PathBuf,
    target: PathBuf,
    permissions: Option<Permissions>,
}

/// Temporaries alive in this process, so a signal's cleanup can remove them.
struct Temporaries {
    /// Set by [`remove_temporaries_then`]: no new temporary may start.
    closing: bool,
    paths: Vec<PathBuf>,
}

static TEMPORARIES: Mutex<Temporaries> = Mutex::new(Temporaries {
    closing: false,
    paths: Vec::new(),
});

fn temporaries() -> MutexGuard<'static, Temporaries> {
    TEMPORARIES.lock().unwrap_or_else(PoisonError::into_inner)
}

/// Removes every temporary of an unfinished [`Output`], then calls `end`
/// (which should end the process; if it returns, the process exits with
/// status 1) with the registry still locked, so no output can start or
/// finish in between. For a signal's cleanup thread: the `kdray` binary
/// calls it on SIGINT, SIGTERM and SIGHUP.
pub fn remove_temporaries_then(end: impl FnOnce()) -> ! {
    let mut t = temporaries();
    t.closing = true;
    for p in t.paths.drain(..) {
        let _ = std::fs::remove_file(p);
    }
    end();
    std::process::exit(1)
}

/// Removes every temporary of an unfinished [`Output`] if no other
/// thread is registering one at this moment (it never waits). For the
/// `kdray` binary's failed allocation, which must end the process from
/// wherever it happened, even inside the registry's lock.
pub fn try_remove_temporaries() {
    if let Ok(mut t) = TEMPORARIES.try_lock() {
        t.closing = true;
        for p in t.paths.drain(..) {
            let _ = std::fs::remove_file(p);
        }
    }
}

/// Test hook: `KDRAY_TEST_HOLD_OUTPUT_MS` makes [`Output::commit`] wait
/// that long before renaming, so the CLI tests can signal the process
/// while a temporary exists.
fn test_hold() {
    if let Some(ms) = std::env::var_os("KDRAY_TEST_HOLD_OUTPUT_MS")
        .and_then(|v| v.to_str().and_then(|s| s.parse::<u64>().ok()))
    {
        std::thread::sleep(std::time::Duration::from_millis(ms));
    }
}

impl Output {
    /// Starts writing `path` (see the [module docs](self) for how).
    ///
    /// # Errors
    /// `path` is a folder, its folder does not exist, or the temporary
    /// (or, for a non-regular file, the file) cannot be opened.
    pub fn create(path: &Path) -> Result<Output, RecordFileError> {
        check_output(path)?;
        let err =
            |what: &str, e: std::io::Error| RecordFileError::new(path, format!("{what}: {e}"));
        let through = |p: &Path| -> Result<Output, RecordFileError> {
            let file = OpenOptions::new()
                .write(true)
                .create(true)
                .truncate(true)
                .open(p)
                .map_err(|e| err("cannot write", e))?;
            Ok(Output {
                path: path.to_path_buf(),
                file: BufWriter::new(file),
                replace: None,
            })
        };
        let (target, permissions) = match std::fs::metadata(path) {
            // A symlink's target is replaced, so the link stays a link.
            Ok(m) if m.is_file() => (
                std::fs::canonicalize(path).map_err(|e| err("cannot resolve", e))?,
                Some(m.permissions()),
            ),
            // A device, pipe or socket: its readers see the bytes.
            Ok(_) => return through(path),
            // A dangling symlink: the file is made where it points.
            Err(_) if path.symlink_metadata().is_ok() => return through(path),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => (path.to_path_buf(), None),
            Err(e) => return Err(err("cannot write", e)),
        };
        static COUNTER: AtomicU64 = AtomicU64::new(0);
        let name = target.file_name().unwrap_or_default().to_string_lossy();
        let temporary = folder_of(&target).join(format!(
            ".{name}.{}-{}.tmp",
            std::process::id(),
            COUNTER.fetch_add(1, Ordering::Relaxed)
        ));
        // Created under the lock, so a signal's cleanup either sees it or
        // has already closed the registry.
        let mut t = temporaries();
        if t.closing {
            return Err(RecordFileError::new(path, "interrupted"));
        }
        let file = OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&temporary)
            .map_err(|e| err("cannot write", e))?;
        t.paths.push(temporary.clone());
        drop(t);
        Ok(Output {
            path: path.to_path_buf(),
            file: BufWriter::new(file),
            replace: Some(Replace {
                temporary,
                target,
                permissions,
            }),
        })
    }

    /// The error "cannot write `path`: `e`".
    #[must_use]
    pub fn error(&self, e: &dyn fmt::Display) -> RecordFileError {
        RecordFileError::new(&self.path, format!("cannot write: {e}"))
    }

    /// Flushes and syncs the bytes and, for a replaced file, renames the
    /// temporary over it (with the old file's permissions).
    ///
    /// # Errors
    /// Any of those steps failed; the temporary is removed and a regular
    /// file at the path is unchanged.
    pub fn commit(mut self) -> Result<(), RecordFileError> {
        self.file.flush().map_err(|e| self.error(&e))?;
        let Some(r) = &self.replace else {
            return Ok(());
        };
        self.file.get_ref().sync_all().map_err(|e| self.error(&e))?;
        if let Some(p) = &r.permissions {
            std::fs::set_permissions(&r.temporary, p.clone()).map_err(|e| self.error(&e))?;
        }
        test_hold();
        let mut t = temporaries();
        std::fs::rename(&r.temporary, &r.target).map_err(|e| self.error(&e))?;
        t.paths.retain(|p| *p != r.temporary);
        drop(t);
        // The rename itself is durable once the folder is synced.
        if let Ok(dir) = File::open(folder_of(&r.target)) {
            let _ = dir.sync_all();
        }
        self.replace = None;
        Ok(())
    }
}

impl Write for Output {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.file.write(buf)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.file.flush()
    }
}

impl Drop for Output {
    /// An output dropped before its commit (or whose commit failed) removes
    /// its temporary.
    fn drop(&mut self) {
        if let Some(r) = self.replace.take() {
            let mut t = temporaries();
            let _ = std::fs::remove_file(&r.temporary);
            t.paths.retain(|p| *p != r.temporary);
        }
    }
}
