//! SIGINT, SIGTERM and SIGHUP remove the outputs being written before the
//! process dies (`kdray_tools::io::Output`'s temporaries), then die of the
//! same signal, so the shell sees what killed it. SIGXFSZ is ignored, so a
//! write past the file size limit fails with an error (and its temporary is
//! removed) instead of killing the process mid-write.
//!
//! The handler only writes the signal's number to a pipe (write(2) is
//! async-signal-safe); a thread reading that pipe does the cleanup in
//! ordinary code, where locks and allocation are allowed. The C library's
//! own `signal`, `write` and `raise` are declared here: Rust's std already
//! links them, so no crate is needed for three calls.

use std::ffi::{c_int, c_void};
use std::io::Read;
use std::os::fd::IntoRawFd;
use std::sync::atomic::{AtomicI32, Ordering};

const SIGHUP: c_int = 1;
const SIGINT: c_int = 2;
const SIGTERM: c_int = 15;
/// SIGXFSZ: the same number on Linux (x86, Arm, RISC-V) and macOS; not
/// touched elsewhere.
const SIGXFSZ: Option<c_int> = if cfg!(any(
    target_os = "macos",
    all(
        target_os = "linux",
        any(
            target_arch = "x86_64",
            target_arch = "x86",
            target_arch = "aarch64",
            target_arch = "arm",
            target_arch = "riscv64"
        )
    )
)) {
    Some(25)
} else {
    None
};

/// `sighandler_t` values.
const SIG_DFL: usize = 0;
const SIG_IGN: usize = 1;

extern "C" {
    fn signal(signum: c_int, handler: usize) -> usize;
    fn write(fd: c_int, buf: *const c_void, count: usize) -> isize;
    fn raise(sig: c_int) -> c_int;
}

/// The pipe's write end, for the handler (-1 before [`install`]).
static PIPE: AtomicI32 = AtomicI32::new(-1);

extern "C" fn on_signal(sig: c_int) {
    let byte = sig as u8;
    // SAFETY: write(2) is async-signal-safe; PIPE holds the write end of a
    // pipe that is never closed (its fd was leaked in `install`), and the
    // buffer is one byte on this stack frame, valid for the call.
    unsafe {
        write(PIPE.load(Ordering::Relaxed), (&raw const byte).cast(), 1);
    }
}

/// Installs the handlers and starts the cleanup thread. Quietly does
/// nothing if the pipe or the thread cannot be made (outputs are then only
/// cleaned up on errors, as without signals).
pub(crate) fn install() {
    let Ok((mut reader, writer)) = std::io::pipe() else {
        return;
    };
    let cleanup = std::thread::Builder::new()
        .name("kdray-signals".into())
        .spawn(move || {
            let mut sig = [0u8];
            if reader.read_exact(&mut sig).is_ok() {
                let sig = c_int::from(sig[0]);
                kdray_tools::io::remove_temporaries_then(|| {
                    // SAFETY: `signal` and `raise` with a valid signal
                    // number and SIG_DFL have no memory effects; the
                    // default action ends the process.
                    unsafe {
                        signal(sig, SIG_DFL);
                        raise(sig);
                    }
                    std::process::exit(128 + sig);
                });
            }
        });
    if cleanup.is_err() {
        return;
    }
    // Leaked on purpose: the handler may write to it until the process ends.
    PIPE.store(writer.into_raw_fd(), Ordering::Relaxed);
    for sig in [SIGHUP, SIGINT, SIGTERM] {
        // SAFETY: `on_signal` is an `extern "C" fn(c_int)` that only makes
        // an async-signal-safe call; `signal` installs it for a valid
        // signal number.
        let previous = unsafe { signal(sig, on_signal as extern "C" fn(c_int) as usize) };
        if previous == SIG_IGN {
            // Ignored by whoever started us (nohup, a background job):
            // keep it ignored.
            // SAFETY: as above, with SIG_IGN.
            unsafe { signal(sig, SIG_IGN) };
        }
    }
    if let Some(sig) = SIGXFSZ {
        // SAFETY: as above, with SIG_IGN.
        unsafe { signal(sig, SIG_IGN) };
    }
}
