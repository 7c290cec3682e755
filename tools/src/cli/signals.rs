//! SIGINT, SIGTERM and SIGHUP remove the outputs being written before the
//! process dies (`kdray_tools::io::Output`'s temporaries), then die of the
//! same signal, so the shell sees what killed it. A signal that whoever
//! started us ignores (nohup, a background job's SIGINT) stays ignored.
//! SIGXFSZ is caught and does nothing, so a write past the file size limit
//! fails with an error (and its temporary is removed) instead of killing
//! the process mid-write.
//!
//! `signal-hook` runs the handler (async-signal-safe: it only wakes a
//! thread); the thread does the cleanup in ordinary code, where locks and
//! allocation are allowed.

use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM, SIGXFSZ};
use signal_hook::iterator::Signals;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

/// Installs the handlers and starts the cleanup thread. Quietly does
/// nothing if they cannot be made (outputs are then only cleaned up on
/// errors, as without signals).
pub(crate) fn install() {
    let caught: Vec<i32> = [SIGHUP, SIGINT, SIGTERM]
        .into_iter()
        .filter(|&sig| !ignored(sig))
        .collect();
    let Ok(mut signals) = Signals::new(&caught) else {
        return;
    };
    let cleanup = std::thread::Builder::new()
        .name("kdray-signals".into())
        .spawn(move || {
            if let Some(sig) = signals.forever().next() {
                kdray_tools::io::remove_temporaries_then(|| {
                    // The default action (reset, then raised) ends the
                    // process by this signal.
                    let _ = signal_hook::low_level::emulate_default_handler(sig);
                });
            }
        });
    if cleanup.is_err() {
        return;
    }
    // Caught (not ignored, which would be inherited by any child): a write
    // past the limit then fails with EFBIG, as an error kdray reports.
    let _ = signal_hook::flag::register(SIGXFSZ, Arc::new(AtomicBool::new(false)));
}

/// Whether `sig` is ignored now (set so by whoever started us).
fn ignored(sig: i32) -> bool {
    // SAFETY: `sigaction` with a null new action only reads the current
    // one into `old`, a zeroed `sigaction` record owned by this frame.
    unsafe {
        let mut old: libc::sigaction = std::mem::zeroed();
        libc::sigaction(sig, std::ptr::null(), &mut old) == 0 && old.sa_sigaction == libc::SIG_IGN
    }
}
