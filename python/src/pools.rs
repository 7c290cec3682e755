//! The rayon pools behind `nthreads` / `workers`: 0 is the global pool
//! (all cores); another count gets a pool of that size, made once and
//! kept, so a call costs no thread start.

use kdray_tools::distance::SERIAL_QUERIES;
use pyo3::exceptions::PyValueError;
use pyo3::PyResult;
use rayon::ThreadPool;
use std::collections::HashMap;
use std::sync::{Arc, Mutex};

/// Pools by thread count.
static POOLS: Mutex<Option<HashMap<usize, Arc<ThreadPool>>>> = Mutex::new(None);

/// Runs `f`, the work of `items` queries, on the calling thread when they
/// are at most [`SERIAL_QUERIES`] (the tools' batch calls answer so few
/// there too, and the hand-off to a pool would cost more than they do),
/// else on `threads` threads as [`install`].
pub(crate) fn install_sized<R: Send>(
    items: usize,
    threads: usize,
    f: impl FnOnce() -> R + Send,
) -> PyResult<R> {
    check(threads)?;
    if items <= SERIAL_QUERIES {
        return Ok(f());
    }
    install(threads, f)
}

/// Refuses a thread count above the tools' `MAX_THREADS`, whatever the
/// batch.
fn check(threads: usize) -> PyResult<()> {
    kdray_tools::threads::check_count("nthreads / workers", threads).map_err(PyValueError::new_err)
}

/// Runs `f` on `threads` threads (0: the global pool, all cores).
pub(crate) fn install<R: Send>(threads: usize, f: impl FnOnce() -> R + Send) -> PyResult<R> {
    if threads == 0 {
        return Ok(f());
    }
    check(threads)?;
    let pool = {
        let mut pools = POOLS.lock().unwrap_or_else(|e| e.into_inner());
        let pools = pools.get_or_insert_with(HashMap::new);
        match pools.get(&threads) {
            Some(p) => Arc::clone(p),
            None => {
                let p = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .map_err(|e| {
                        PyValueError::new_err(format!("cannot start {threads} threads: {e}"))
                    })?;
                let p = Arc::new(p);
                pools.insert(threads, Arc::clone(&p));
                p
            }
        }
    };
    Ok(pool.install(f))
}
