//! Progress bars on stderr, drawn only when stderr is a terminal (quiet
//! in pipes, logs and tests), in one style: one polling a build's monitor,
//! one counting steps of a render. A bar that finishes is left at 100%.

use kdray_tools::builders::BuildMonitor;
use std::io::IsTerminal;
use std::time::Duration;

/// A hidden-unless-terminal bar over `len` steps, labelled `what`.
fn bar(what: &str, len: u64) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new(len);
    let template = format!("  {what:<9} {{bar:40}} {{percent:>3}}%");
    if let Ok(style) = indicatif::ProgressStyle::with_template(&template) {
        bar.set_style(style);
    }
    bar
}

/// Steps of the build bar: its fraction in thousandths.
const BUILD_STEPS: u64 = 1000;

/// Runs `work` while a bar shows `monitor`'s progress (after half a second,
/// so quick builds print nothing).
pub(crate) fn with_bar<T: Send>(monitor: &BuildMonitor, work: impl FnOnce() -> T + Send) -> T {
    if !std::io::stderr().is_terminal() {
        return work();
    }
    let done = std::sync::atomic::AtomicBool::new(false);
    std::thread::scope(|s| {
        let drawer = s.spawn(|| {
            let mut shown: Option<indicatif::ProgressBar> = None;
            let mut waited = 0;
            while !done.load(std::sync::atomic::Ordering::Relaxed) {
                // Parked, not asleep: woken the moment the work is done, so
                // the scope does not wait out a tick (up to 50 ms added to
                // every build on a terminal, and to its `build_ms`).
                std::thread::park_timeout(Duration::from_millis(50));
                waited += 50;
                if waited >= 500 {
                    let b = shown.get_or_insert_with(|| bar("building", BUILD_STEPS));
                    let f = monitor.fraction().clamp(0.0, 1.0);
                    b.set_position((f * BUILD_STEPS as f64) as u64);
                }
            }
            if let Some(b) = shown {
                b.set_position(BUILD_STEPS);
                b.finish();
            }
        });
        let out = work();
        done.store(true, std::sync::atomic::Ordering::Relaxed);
        drawer.thread().unpark();
        out
    })
}

/// A bar over `len` steps of a render (`inc` it from any thread; `finish`
/// it at the end); hidden when stderr is not a terminal.
pub(crate) fn counted_bar(len: u64) -> indicatif::ProgressBar {
    bar("rendering", len)
}
