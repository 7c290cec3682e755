//! The most worker threads a call starts, for every front end (the CLI's
//! `--threads`, Python's `threads` / `nthreads` / `workers`): past the
//! cores, threads only add overhead, and each reserves a stack (a typo of
//! a million threads would take minutes to start, or exhaust the address
//! space).

/// The most worker threads a pool may have.
pub const MAX_THREADS: usize = 1024;

/// Refuses a thread count past [`MAX_THREADS`], naming it as `name`
/// (`--threads`, `nthreads`).
///
/// # Errors
/// `"{name} {n} is more than 1024 (this machine has N cores)"`.
pub fn check_count(name: &str, n: usize) -> Result<(), String> {
    if n > MAX_THREADS {
        return Err(format!(
            "{name} {n} is more than {MAX_THREADS} (this machine has {} cores)",
            std::thread::available_parallelism().map_or(1, std::num::NonZero::get)
        ));
    }
    Ok(())
}
