//! Counting a walk's work: nodes visited and triangles tested.

/// The work one traversal did: what a heatmap shows and a cost model predicts.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TraversalCounts {
    /// Nodes visited, interior and leaf.
    pub nodes: u32,
    /// Ray/triangle tests run.
    pub triangles: u32,
}

/// Counts traversal work; `()` counts nothing and compiles away.
pub(crate) trait Tally {
    fn node(&mut self);
    fn triangles(&mut self, n: usize);
}

impl Tally for () {
    #[inline(always)]
    fn node(&mut self) {}
    #[inline(always)]
    fn triangles(&mut self, _: usize) {}
}

impl Tally for TraversalCounts {
    #[inline(always)]
    fn node(&mut self) {
        self.nodes = self.nodes.saturating_add(1);
    }
    #[inline(always)]
    fn triangles(&mut self, n: usize) {
        let n = u32::try_from(n).unwrap_or(u32::MAX);
        self.triangles = self.triangles.saturating_add(n);
    }
}
