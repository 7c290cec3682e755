//! Progress bars on stderr, drawn only when stderr is a terminal (quiet
//! in pipes, logs and tests): one polling a build's monitor, one counting
//! steps of a render.

use kdray_tools::builders::BuildMonitor;
use std::io::{IsTerminal, Write};
use std::time::Duration;

/// Runs `work` while a bar shows `monitor`'s progress (after half a second,
/// so quick builds print nothing).
pub(crate) fn with_bar<T: Send>(monitor: &BuildMonitor, work: impl FnOnce() -> T + Send) -> T {
    if !std::io::stderr().is_terminal() {
        return work();
    }
    let done = std::sync::atomic::AtomicBool::new(false);
    std::thread::scope(|s| {
        let bar = s.spawn(|| {
            let mut shown = false;
            let mut waited = 0;
            while !done.load(std::sync::atomic::Ordering::Relaxed) {
                // Parked, not asleep: woken the moment the work is done, so
                // the scope does not wait out a tick (up to 50 ms added to
                // every build on a terminal, and to its `build_ms`).
                std::thread::park_timeout(Duration::from_millis(50));
                waited += 50;
                if waited >= 500 {
                    let f = monitor.fraction().clamp(0.0, 1.0);
                    let bar = (f * 40.0) as usize;
                    eprint!(
                        "\r  building [{}{}] {:3.0}%",
                        "#".repeat(bar),
                        " ".repeat(40 - bar),
                        f * 100.0
                    );
                    let _ = std::io::stderr().flush();
                    shown = true;
                }
            }
            if shown {
                eprint!("\r{}\r", " ".repeat(60));
            }
        });
        let out = work();
        done.store(true, std::sync::atomic::Ordering::Relaxed);
        bar.thread().unpark();
        out
    })
}

/// An `indicatif` bar over `len` steps (`inc` it from any thread); hidden
/// when stderr is not a terminal.
pub(crate) fn counted_bar(len: u64) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new(len);
    if let Ok(style) = indicatif::ProgressStyle::with_template("  rendering {bar:40} {percent:>3}%")
    {
        bar.set_style(style);
    }
    bar
}
