//! The packet traversal: the lecture's loop once for all lanes.
//!
//! ```text
//! while not a leaf:
//!     t_split = (split - origin[axis]) * inv_dir[axis]      for every lane
//!     each lane needs its near child, its far child or both, by the
//!         single ray's tests (widened by the lane's slack)
//!     below lanes = lanes whose near or far child is below, likewise above
//!     continue with the child most lanes enter first, push the other
//!         with its lanes and their per-lane [t0, t1]
//! ```
//!
//! Rays need not share direction signs: "near" is decided per lane
//! (`above_first`), so a lane whose near child is the one pushed visits
//! its cells out of t order. That is harmless: a lane skips a cell only
//! when its interval misses the lane's own range by more than the slack,
//! or starts more than the slack beyond the lane's best hit, exactly the
//! single ray's rules; triangles are tested over the lane's own
//! `[tmin, best t]`, and [`Closest`] does not depend on the order in which
//! hits arrive. So each lane tests every triangle its single ray tests
//! (perhaps more) and keeps the same winner, bit for bit.

use super::lane_rays::LaneRays;
use super::lanes::Lanes;
use crate::ray::Hit;
use crate::traverse::{Closest, LeafIter};
use crate::tree::{TriangleTree, MAX_DEPTH};

/// How many lanes left in a cell make the packet finish them one by one
/// as single rays (measured on the bunny, see `benches/packets.rs`).
const FEW_LANES: u32 = 1;

/// A far child waiting on the stack with its lanes and their intervals.
#[derive(Clone, Copy)]
struct Pending<V> {
    node: u32,
    lanes: u32,
    t0: V,
    t1: V,
}

/// What the packet loop does at a leaf and for a lone lane. Both return
/// each lane's best `t` (cells starting more than the slack beyond it are
/// skipped) and the lanes still searching, or `None` when all are done.
trait Visit<'a, V> {
    /// Tests a leaf's primitives against `lanes`.
    fn leaf(&mut self, prims: LeafIter<'a>, lanes: u32) -> Option<(V, u32)>;
    /// Finishes lane `l` as a single ray through the subtree
    /// `(node, lo, hi)`, its interval widened by the slack as the scalar
    /// loop keeps it.
    fn single(&mut self, l: usize, start: (u32, f32, f32)) -> Option<(V, u32)>;
}

/// The closest-hit search: one [`Closest`] per lane.
struct ClosestLanes<'t, 'a, V, const N: usize> {
    tree: &'t TriangleTree<'a>,
    lr: &'t LaneRays<V, N>,
    best: [Closest; N],
    best_t: V,
}

impl<'a, V: Lanes<N>, const N: usize> Visit<'a, V> for ClosestLanes<'_, 'a, V, N> {
    #[inline(always)]
    fn leaf(&mut self, prims: LeafIter<'a>, lanes: u32) -> Option<(V, u32)> {
        for p in prims {
            let Some(tri) = self.tree.triangles.get(p as usize) else {
                continue;
            };
            if let Some(h) = self.lr.intersect(tri, lanes, self.best_t) {
                for (l, b) in self.best.iter_mut().enumerate() {
                    if h.hit >> l & 1 == 1 {
                        b.keep(h.lane(l), p);
                    }
                }
                self.best_t = V::from_array(self.best.map(|b| b.t));
            }
        }
        Some((self.best_t, self.lr.active))
    }

    #[inline(always)]
    fn single(&mut self, l: usize, start: (u32, f32, f32)) -> Option<(V, u32)> {
        if let (Some(Some(one)), Some(best)) = (self.lr.single.get(l), self.best.get_mut(l)) {
            self.tree
                .closest_from(&one.sr, &one.cr, one.tmin, best, start, &mut ());
            self.best_t = V::from_array(self.best.map(|b| b.t));
        }
        Some((self.best_t, self.lr.active))
    }
}

/// The any-hit search: a bitmask of the lanes found occluded.
struct AnyLanes<'t, 'a, V, const N: usize> {
    tree: &'t TriangleTree<'a>,
    lr: &'t LaneRays<V, N>,
    occluded: u32,
}

impl<'a, V: Lanes<N>, const N: usize> AnyLanes<'_, 'a, V, N> {
    #[inline(always)]
    fn state(&self) -> Option<(V, u32)> {
        let alive = self.lr.active & !self.occluded;
        (alive != 0).then_some((self.lr.tmax, alive))
    }
}

impl<'a, V: Lanes<N>, const N: usize> Visit<'a, V> for AnyLanes<'_, 'a, V, N> {
    #[inline(always)]
    fn leaf(&mut self, prims: LeafIter<'a>, lanes: u32) -> Option<(V, u32)> {
        let mut open = lanes & !self.occluded;
        for p in prims {
            if open == 0 {
                break;
            }
            let tri = self.tree.triangles.get(p as usize);
            if let Some(h) = tri.and_then(|t| self.lr.intersect(t, open, self.lr.tmax)) {
                self.occluded |= h.hit;
                open &= !h.hit;
            }
        }
        self.state()
    }

    #[inline(always)]
    fn single(&mut self, l: usize, start: (u32, f32, f32)) -> Option<(V, u32)> {
        if let Some(Some(one)) = self.lr.single.get(l) {
            if self
                .tree
                .any_from(&one.sr, &one.cr, (one.tmin, one.tmax), start, &mut ())
            {
                self.occluded |= 1 << l;
            }
        }
        self.state()
    }
}

impl<'a> TriangleTree<'a> {
    /// The closest hit of every lane of `lr` (`Hit::MISS` for lanes that
    /// do not take part).
    #[inline(always)]
    pub(crate) fn closest_lanes<V: Lanes<N>, const N: usize>(
        &self,
        lr: &LaneRays<V, N>,
    ) -> [Hit; N] {
        let tmax = lr.tmax.to_array();
        let mut visit = ClosestLanes {
            tree: self,
            lr,
            best: core::array::from_fn(|l| Closest::new(tmax[l])),
            best_t: lr.tmax,
        };
        self.walk_lanes(lr, &mut visit);
        core::array::from_fn(|l| {
            if lr.active >> l & 1 == 1 {
                visit.best[l].hit()
            } else {
                Hit::MISS
            }
        })
    }

    /// Bit `l` set when lane `l` of `lr` hits any triangle.
    #[inline(always)]
    pub(crate) fn any_lanes<V: Lanes<N>, const N: usize>(&self, lr: &LaneRays<V, N>) -> u32 {
        let mut visit = AnyLanes {
            tree: self,
            lr,
            occluded: 0,
        };
        self.walk_lanes(lr, &mut visit);
        visit.occluded
    }

    /// The packet loop: `visit` tests leaves and finishes lone lanes.
    #[inline(always)]
    fn walk_lanes<V: Lanes<N>, const N: usize>(
        &self,
        lr: &LaneRays<V, N>,
        visit: &mut impl Visit<'a, V>,
    ) {
        let s = lr.slack;
        let empty = Pending {
            node: 0,
            lanes: 0,
            t0: s,
            t1: s,
        };
        let mut stack = [empty; MAX_DEPTH as usize];
        let mut sp = 0usize;
        let (mut node_idx, mut lanes, mut t0, mut t1) = (0u32, lr.active, lr.t0, lr.t1);
        if lanes == 0 {
            return;
        }
        loop {
            let Some(&node) = self.nodes.get(node_idx as usize) else {
                return;
            };
            let axis = node.axis_bits();
            let step = if lanes.count_ones() <= FEW_LANES {
                // Few lanes left in this subtree: a packet step would
                // cost as much as several single-ray steps.
                let (lo, hi) = ((t0 - s).to_array(), (t1 + s).to_array());
                let mut step = None;
                for l in 0..N {
                    if lanes >> l & 1 == 1 {
                        step = visit.single(l, (node_idx, lo[l], hi[l]));
                    }
                }
                step
            } else if let (Some(&org), Some(&inv), Some(&af), Some(&af_mask)) = (
                lr.org.get(axis),
                lr.inv.get(axis),
                lr.above_first.get(axis),
                lr.above_first_mask.get(axis),
            ) {
                // Compute parametric distance along each lane to the split plane.
                let t_split = (V::splat(node.split()) - org) * inv;
                // The single ray's two tests, in its order: plane beyond
                // the interval (near child only), else before it (far only).
                let near_only = (t_split - s).gt(t1);
                let far_only = (t_split + s).lt(t0) & !near_only;
                let near = lanes & !far_only;
                let far = lanes & !near_only;
                let below = (near & !af) | (far & af);
                let above = (near & af) | (far & !af);
                let child = node.upper();
                if above == 0 {
                    // One child for every lane: intervals unchanged.
                    (node_idx, lanes) = (child, below);
                    continue;
                }
                if below == 0 {
                    (node_idx, lanes) = (child + 1, above);
                    continue;
                }
                // Both children: the near cell ends at the plane, the far
                // one starts there (each widened by the slack).
                let t1_near = t1.min(t_split + s);
                let t0_far = t0.max(t_split - s);
                let below_cell = Pending {
                    node: child,
                    lanes: below,
                    t0: V::select(af_mask, t0_far, t0),
                    t1: V::select(af_mask, t1, t1_near),
                };
                let above_cell = Pending {
                    node: child + 1,
                    lanes: above,
                    t0: V::select(af_mask, t0, t0_far),
                    t1: V::select(af_mask, t1_near, t1),
                };
                // Visit first the child most lanes enter first.
                let (first, second) = if 2 * (af & lanes).count_ones() > lanes.count_ones() {
                    (above_cell, below_cell)
                } else {
                    (below_cell, above_cell)
                };
                let Some(slot) = stack.get_mut(sp) else {
                    return; // deeper than MAX_DEPTH: only an unchecked, invalid blob
                };
                *slot = second;
                sp += 1;
                (node_idx, lanes, t0, t1) = (first.node, first.lanes, first.t0, first.t1);
                continue;
            } else {
                // A leaf: test its triangles against the lanes' own intervals.
                visit.leaf(LeafIter::new(self.leaf_prims(node)), lanes)
            };
            let Some((best_t, alive)) = step else {
                return;
            };
            // Advance to the next far cell that can still hold a better hit
            // for some lane.
            let cutoff = best_t + s;
            loop {
                if sp == 0 {
                    return;
                }
                sp -= 1;
                let p = stack[sp];
                let open = p.lanes & alive & p.t0.le(cutoff);
                if open != 0 {
                    (node_idx, lanes, t0, t1) = (p.node, open, p.t0, p.t1.min(cutoff));
                    break;
                }
            }
        }
    }
}
