//! The one search loop every point query runs: descend into the near child
//! first, push the far child if its box may hold a better point, scan the
//! leaf, backtrack, and prune every subtree whose box is farther than the
//! current bound. What "better" and "bound" mean is the query's
//! [`Accumulator`].

use super::{box_distance2, distance2, PointTree};
use crate::blob::MAX_DEPTH;

/// What a query keeps while the search runs.
pub(crate) trait Accumulator {
    /// Subtrees whose box is at a squared distance *above* this are pruned
    /// (equal is kept: it may hold an equally distant, lower-index point).
    fn bound(&self) -> f32;

    /// Offers the point `index` at squared distance `d2`; `false` if it was
    /// rejected (not within the bound, or after the k-th best).
    fn offer(&mut self, d2: f32, index: u32) -> bool;
}

impl PointTree<'_> {
    /// Runs the search for `q` (not NaN: checked by the callers) into `acc`.
    ///
    /// The stack holds at most one far child per level, so [`MAX_DEPTH`]
    /// entries suffice for a validated tree; for an unvalidated one a full
    /// stack drops the far child (a wrong answer, never a panic).
    #[inline(always)]
    pub(crate) fn search<A: Accumulator>(&self, q: &[f32; 3], acc: &mut A) {
        // (far child, lower bound on its points' squared distances)
        let mut stack = [(0u32, 0f32); MAX_DEPTH as usize];
        let mut len = 0usize;
        // Indexing q by a node's 2-bit axis field needs 4 lanes to be total.
        let q4 = [q[0], q[1], q[2], 0.0];
        let mut node_idx = 0u32;
        let Some(root) = self.bounds.first() else {
            return;
        };
        // The lower bound of the subtree being descended: its box distance.
        let mut lower = box_distance2(root, q);
        if lower > acc.bound() {
            return;
        }
        'descend: loop {
            // Walk down to a leaf, near child first. No box is read here:
            // the far child's bound is the larger of the split plane's gap
            // (every far point is beyond the plane, validated) and the
            // subtree's own bound; its box is read only if it is popped.
            let leaf = loop {
                let Some(&node) = self.nodes.get(node_idx as usize) else {
                    break None;
                };
                if node.is_leaf() {
                    break Some(node);
                }
                let gap = q4[node.axis_bits() & 3] - node.split();
                // Near child: the one on the query's side of the split
                // plane (below for coordinates <= split).
                let above_near = u32::from(gap > 0.0);
                let child = node.upper();
                let far_d = (gap * gap).max(lower);
                if far_d <= acc.bound() {
                    if let Some(slot) = stack.get_mut(len) {
                        *slot = (child + 1 - above_near, far_d);
                        len += 1;
                    }
                }
                node_idx = child + above_near;
            };
            if let Some(node) = leaf {
                self.scan_leaf(node_idx, node, q, acc);
            }
            // Backtrack: the nearest pending far child whose box is still
            // within the bound (the tight box prunes empty space).
            while len > 0 {
                len -= 1;
                // `get`: `len` counts pushed entries, but an index would
                // leave a panic path the optimiser cannot remove (firmware/).
                let Some(&(far, far_d)) = stack.get(len) else {
                    return;
                };
                if far_d > acc.bound() {
                    continue;
                }
                let Some(far_box) = self.bounds.get(far as usize) else {
                    continue;
                };
                lower = box_distance2(far_box, q).max(far_d);
                if lower <= acc.bound() {
                    node_idx = far;
                    continue 'descend;
                }
            }
            return;
        }
    }

    /// Offers every point of a leaf to `acc`.
    #[inline(always)]
    fn scan_leaf<A: Accumulator>(
        &self,
        node_idx: u32,
        node: crate::blob::Node,
        q: &[f32; 3],
        acc: &mut A,
    ) {
        let start = node.word0() as usize;
        let run = start..start.saturating_add(node.upper() as usize);
        let (Some(points), Some(indices)) = (self.points.get(run.clone()), self.indices.get(run))
        else {
            return;
        };
        let pile = self
            .bounds
            .get(node_idx as usize)
            .is_some_and(|b| b.min == b.max);
        if pile {
            // All points at one location, indices increasing: once one is
            // rejected, so is every later one (module docs, "Ties").
            let Some(p) = points.first() else { return };
            let d2 = distance2(p, q);
            for &i in indices {
                if !acc.offer(d2, i) {
                    break;
                }
            }
        } else {
            for (j, p) in points.iter().enumerate() {
                let d2 = distance2(p, q);
                // Most points lose; only a winner's index is read.
                if d2 <= acc.bound() {
                    if let Some(&i) = indices.get(j) {
                        acc.offer(d2, i);
                    }
                }
            }
        }
    }
}
