//! Best, mean and worst of a series of times, for the timing examples.

/// The times of one series, in seconds.
#[derive(Default)]
pub(crate) struct Stat(Vec<f64>);

impl Stat {
    /// One more time.
    pub(crate) fn add(&mut self, t: f64) {
        self.0.push(t);
    }
}

impl std::fmt::Display for Stat {
    /// `best/mean/worst ms`, to the microsecond.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let best = self.0.iter().copied().fold(f64::INFINITY, f64::min);
        let worst = self.0.iter().copied().fold(0.0, f64::max);
        let mean = self.0.iter().sum::<f64>() / self.0.len().max(1) as f64;
        write!(
            f,
            "{:.3}/{:.3}/{:.3} ms",
            best * 1e3,
            mean * 1e3,
            worst * 1e3
        )
    }
}
