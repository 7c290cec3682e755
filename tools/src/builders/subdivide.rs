//! The recursion every builder shares: pick a split plane for the cell,
//! hand each triangle to the child cells it lies in, recurse, and decide
//! whether the subtree paid for itself. The builders differ only in how
//! they hold a cell's triangles and pick the plane ([`Splitter`]).
//!
//! Termination (PBRT's and Wald & Havran's rules, with a look-ahead):
//! - no triangles, the depth limit, or a cell smaller than the size
//!   threshold makes a leaf;
//! - a split whose cost (children taken as leaves) is not below the leaf's
//!   is still tried, up to `lookahead` such splits in a row, when it
//!   costs at most `lookahead_margin` times the leaf and the cell holds at
//!   least [`LOOKAHEAD_MIN`] triangles, because the
//!   children's own splits may pay; a subtree whose measured cost is not
//!   below the leaf's is then collapsed back into a leaf;
//! - builders without a cost model (the median and middle baselines) stop
//!   by count and depth, and when a split leaves one side with every
//!   triangle or more than half of them straddle the plane.
//!
//! Subtrees of at least [`JOIN_MIN`] triangles are built with `rayon::join`.
//! Every decision depends only on the cell and its triangles, never on
//! which thread runs it, so the tree is the same for any thread count.

use super::cost::CostModel;
use super::monitor::BuildMonitor;
use super::BuildNode;
use kdray_kernel::Axis;
use kdray_kernel::Bounds;

/// Cells with at least this many triangles build their two children in
/// parallel. Far below [`PARALLEL_MIN`](super::thresholds::PARALLEL_MIN): a join costs about a microsecond,
/// and with subtrees of up to 4096 triangles as the smallest tasks one
/// core sat idle for the last of them (and could not help a core slowed
/// by other work).
pub(super) const JOIN_MIN: usize = 512;

/// Cells of fewer triangles never look ahead: on the bunny and sponza,
/// look-ahead splits of cells under 4 triangles never paid off, of 4 to 7
/// one in twelve, and those cells were most of the subtrees built and
/// thrown away (tree costs +0.005% at most, builds 3-20% less CPU).
pub(super) const LOOKAHEAD_MIN: usize = 8;

/// A split plane a builder picked.
#[derive(Clone, Copy, Debug)]
pub(super) struct Choice {
    /// The split axis, 0..3.
    pub(super) axis: usize,
    /// The plane, strictly inside the cell.
    pub(super) pos: f32,
    /// Triangles lying in the plane go below (else above).
    pub(super) planar_below: bool,
    /// The estimated cost of the split, for builders with a cost model.
    pub(super) cost: Option<f64>,
}

/// How a builder holds a cell's triangles and splits them.
pub(super) trait Splitter: Sync {
    /// The triangles of one cell.
    type Set: Send;
    /// How many triangles.
    fn count(&self, set: &Self::Set) -> usize;
    /// Working-set bytes, for the memory report.
    fn bytes(&self, set: &Self::Set) -> usize;
    /// The triangle indices, sorted, for a leaf.
    fn prims(&self, set: Self::Set) -> Vec<u32>;
    /// The split plane for `cell`, or `None` to make a leaf.
    fn choose(&self, set: &Self::Set, cell: &Bounds) -> Option<Choice>;
    /// The triangles of the cells below and above the plane.
    fn partition(&self, set: Self::Set, cell: &Bounds, c: &Choice) -> (Self::Set, Self::Set);
}

/// The limits of one build.
pub(super) struct Limits {
    /// The cost model, also used to decide collapses.
    pub(super) cost: CostModel,
    /// Leaves at this depth at the latest.
    pub(super) depth: u32,
    /// Cells whose largest extent is below this are leaves.
    pub(super) min_extent: f32,
    /// Non-paying splits allowed in a row.
    pub(super) lookahead: u32,
    /// The dearest non-paying split tried, as a factor of the leaf's cost.
    pub(super) lookahead_margin: f64,
}

/// Builds the tree over `set` in `bounds`.
pub(super) fn subdivide<S: Splitter>(
    s: &S,
    set: S::Set,
    bounds: Bounds,
    limits: &Limits,
    monitor: &BuildMonitor,
) -> BuildNode {
    monitor.allocated(s.bytes(&set));
    let walk = Walk {
        s,
        limits,
        monitor: Some(monitor),
    };
    walk.node(set, bounds, 0, 0, BuildMonitor::WHOLE).0
}

struct Walk<'a, S> {
    s: &'a S,
    limits: &'a Limits,
    /// `None` inside a subtree of fewer than [`JOIN_MIN`] triangles: the
    /// subtree's root reports for all of it (see [`Walk::node`]).
    monitor: Option<&'a BuildMonitor>,
}

impl<S: Splitter> Walk<'_, S> {
    /// The subtree for `cell` and its cost per ray entering the cell.
    /// `bad`: non-paying splits just above; `units`: its progress share.
    fn node(
        &self,
        set: S::Set,
        cell: Bounds,
        depth: u32,
        bad: u32,
        units: u64,
    ) -> (BuildNode, f64) {
        let n = self.s.count(&set);
        if let Some(m) = self.monitor.filter(|_| n < JOIN_MIN) {
            // A small subtree (on one thread) builds without touching the
            // shared counters, whose cache line went back and forth
            // between the cores for every cell: its working set is
            // counted as its root's (the cells below it hold less at any
            // time), its progress lands when it is done.
            let bytes = self.s.bytes(&set);
            let quiet = Walk {
                s: self.s,
                limits: self.limits,
                monitor: None,
            };
            let built = quiet.node(set, cell, depth, bad, units);
            m.freed(bytes);
            m.finished(units);
            return built;
        }
        let leaf_cost = self.limits.cost.leaf(n);
        let extent = (0..3).fold(0.0f32, |m, a| m.max(cell.max[a] - cell.min[a]));
        if n == 0 || depth >= self.limits.depth || extent < self.limits.min_extent {
            return (self.leaf(set, units), leaf_cost);
        }
        let Some(c) = self.s.choose(&set, &cell) else {
            return (self.leaf(set, units), leaf_cost);
        };
        let pays = c.cost.is_none_or(|x| x < leaf_cost);
        let hopeless = c
            .cost
            .is_some_and(|x| x > leaf_cost * self.limits.lookahead_margin || n < LOOKAHEAD_MIN);
        if !pays && (bad >= self.limits.lookahead || hopeless) {
            return (self.leaf(set, units), leaf_cost);
        }
        let set_bytes = self.s.bytes(&set);
        let (below, above) = self.s.partition(set, &cell, &c);
        if let Some(m) = self.monitor {
            m.allocated(self.s.bytes(&below) + self.s.bytes(&above));
            m.freed(set_bytes);
        }
        let (nb, na) = (self.s.count(&below), self.s.count(&above));
        if c.cost.is_none() && (nb.max(na) == n || 2 * (nb + na) > 3 * n) {
            // A baseline made no progress (one half holds everything) or
            // more than half the triangles straddle the plane: the cells
            // are already smaller than the triangles, and splitting on
            // would only multiply references.
            if let Some(m) = self.monitor {
                m.freed(self.s.bytes(&below) + self.s.bytes(&above));
                m.finished(units);
            }
            let mut prims = self.s.prims(below);
            prims.extend(self.s.prims(above));
            return (merged_leaf(prims), leaf_cost);
        }
        let ub = if nb + na == 0 {
            units / 2
        } else {
            (u128::from(units) * nb as u128 / (nb + na) as u128) as u64
        };
        let (cb, ca) = cell.split(c.axis, c.pos);
        let bad = bad + u32::from(!pays);
        let go_below = || self.node(below, cb, depth + 1, bad, ub);
        let go_above = || self.node(above, ca, depth + 1, bad, units - ub);
        let ((below, cost_b), (above, cost_a)) = if n >= JOIN_MIN {
            rayon::join(go_below, go_above)
        } else {
            (go_below(), go_above())
        };
        let area = cell.area();
        let (pb, pa) = (cb.area() / area, ca.area() / area);
        let empty = below.is_empty_leaf() || above.is_empty_leaf();
        let cost = self.limits.cost.interior(pb, cost_b, pa, cost_a, empty);
        if c.cost.is_some() && cost >= leaf_cost {
            // The look-ahead did not pay off: back to one leaf.
            let mut prims = Vec::new();
            below.collect_prims(&mut prims);
            above.collect_prims(&mut prims);
            return (merged_leaf(prims), leaf_cost);
        }
        let axis = Axis::from_index(c.axis).unwrap_or(Axis::X);
        (BuildNode::interior(axis, c.pos, below, above), cost)
    }

    fn leaf(&self, set: S::Set, units: u64) -> BuildNode {
        if let Some(m) = self.monitor {
            m.freed(self.s.bytes(&set));
            m.finished(units);
        }
        BuildNode::Leaf(self.s.prims(set))
    }
}

/// One leaf of the children's triangles (a straddler is in both: once).
fn merged_leaf(mut prims: Vec<u32>) -> BuildNode {
    prims.sort_unstable();
    prims.dedup();
    BuildNode::Leaf(prims)
}
