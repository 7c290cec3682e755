//! Watching a build from another thread: progress and working memory.
//!
//! Progress is measured in fractions of the root: the root holds
//! [`BuildMonitor::WHOLE`] units, each split hands them to its children in
//! proportion to their triangle counts, and each leaf adds its share to the
//! counter. So the counter only grows and ends exactly at `WHOLE`.
//!
//! Memory is the builder's working sets (event lists or clipped boxes)
//! counted as they are made and dropped (a subtree of fewer than
//! `JOIN_MIN` triangles is counted as its root's set until it is built, and
//! reports its progress then); the peak is what the build needed
//! beyond its input and output (reported per triangle by `kdray bench`).
//! The peak depends on how the threads interleave; the tree does not.

use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};

/// Progress and memory of a build, readable while it runs.
#[derive(Debug, Default)]
pub struct BuildMonitor {
    done: AtomicU64,
    live: AtomicUsize,
    peak: AtomicUsize,
}

impl BuildMonitor {
    /// The progress units of the whole tree.
    pub const WHOLE: u64 = 1 << 40;

    /// A monitor at zero.
    #[must_use]
    pub fn new() -> BuildMonitor {
        BuildMonitor::default()
    }

    /// The fraction of the tree finished, 0 to 1.
    #[must_use]
    pub fn fraction(&self) -> f64 {
        self.done.load(Ordering::Relaxed) as f64 / Self::WHOLE as f64
    }

    /// The most working-set bytes alive at once so far.
    #[must_use]
    pub fn peak_bytes(&self) -> usize {
        self.peak.load(Ordering::Relaxed)
    }

    pub(super) fn finished(&self, units: u64) {
        self.done.fetch_add(units, Ordering::Relaxed);
    }

    pub(super) fn allocated(&self, bytes: usize) {
        let now = self.live.fetch_add(bytes, Ordering::Relaxed) + bytes;
        self.peak.fetch_max(now, Ordering::Relaxed);
    }

    pub(super) fn freed(&self, bytes: usize) {
        self.live.fetch_sub(bytes, Ordering::Relaxed);
    }
}
