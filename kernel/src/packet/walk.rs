//! The packet traversal: the lecture's loop once for all lanes.
//!
//! ```text
//! while not a leaf:
//!     t_split = (split - origin[axis]) * inv_dir[axis]      for every lane
//!     near lanes = lanes with t_split >= lo, far lanes = the others and
//!         near lanes with t_split <= hi (the single ray's tests)
//!     continue with the near child and its lanes, push the far child
//!         with its lanes and their per-lane [lo, hi]
//! ```
//!
//! The packet walks together only when its active lanes share direction
//! signs (`LaneRays::coherent`): then "near" is one child for every lane
//! and each lane meets its cells in its own t order, with exactly the
//! single ray's slack rule ([`Span`](crate::traverse::Span), shared code)
//! on the same pre-widened intervals. A lane still tests a few cells its
//! single ray skips (cells other lanes open, out to the packet's cutoff per
//! lane), which cannot change its answer: triangles are tested over the
//! lane's own `[tmin, best t]` and [`Closest`] does not depend on the order
//! in which hits arrive. Packets whose lanes disagree on a sign, and lanes
//! left alone in a subtree, finish as single rays (`Visit::single`).
//!
//! Tried and slower (camera rays on the bunny, one run, pinned): per-lane
//! near/far for mixed-sign packets (each lane's near child chosen by lane
//! masks and blends of the pushed intervals): random rays ran at ~0.6-0.8x
//! single rays, coherent ones gained nothing from it. Selects instead of
//! the near-or-far branch (node, lanes and interval picked by masks): 8-wide
//! camera tiles ~15-40% slower, as conditional moves were for single rays.

use super::lane_rays::LaneRays;
use super::lanes::Lanes;
use crate::ray::{Hit, MISS};
use crate::traverse::{Closest, LeafIter};
use crate::tree::{TriangleTree, MAX_DEPTH};
use crate::triangle::TriangleHit;

/// A far child waiting on the stack with its lanes and their intervals
/// (widened by the slack, as the single ray keeps them).
#[derive(Clone, Copy)]
struct Pending<V> {
    node: u32,
    lanes: u32,
    lo: V,
    hi: V,
}

/// The packet walk's stack, [`MAX_DEPTH`] entries. The slice entry points
/// make one for all their packets: filling its 6 KiB (8 lanes) anew for
/// every packet was ~7% of an 8-wide camera trace. Entries above the
/// stack pointer are never read, so a stack needs no clearing between
/// walks.
pub(crate) struct LaneStack<V>([Pending<V>; MAX_DEPTH as usize]);

impl<V: Copy> LaneStack<V> {
    /// A stack of entries filled with `fill`.
    #[inline(always)]
    pub(crate) fn new(fill: V) -> Self {
        let empty = Pending {
            node: 0,
            lanes: 0,
            lo: fill,
            hi: fill,
        };
        LaneStack([empty; MAX_DEPTH as usize])
    }
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

/// The closest-hit search: each lane's [`Closest`] kept in lanes (the
/// best `t` and the winning hit's edge functions), so a leaf's hits update
/// all lanes with a few selects; a lane finished as a single ray keeps its
/// scalar `Closest` until a packet hit beats it.
struct ClosestLanes<'t, 'a, V, const N: usize> {
    tree: &'t TriangleTree<'a>,
    lr: &'t LaneRays<V, N>,
    /// Each lane's best `t` (its `tmax` before any hit).
    t: V,
    /// The best hit's `v`, `w` and `det` ([`TriangleHit`]).
    vwd: [V; 3],
    /// The best triangle of each lane ([`MISS`] before any hit).
    prim: [u32; N],
    /// Lanes with a hit.
    found: u32,
    /// Lanes whose best is `alone[l]`, from a single-ray finish.
    alone_bits: u32,
    alone: [Closest; N],
}

impl<V: Lanes<N>, const N: usize> ClosestLanes<'_, '_, V, N> {
    /// Lane `l`'s search as the single ray holds it.
    #[inline]
    fn closest(&self, l: usize) -> Closest {
        if self.alone_bits >> l & 1 == 1 {
            if let Some(c) = self.alone.get(l) {
                return *c;
            }
        }
        let t = self.t.lane(l);
        let mut c = Closest::new(t);
        if let (true, Some(&prim)) = (self.found >> l & 1 == 1, self.prim.get(l)) {
            let [v, w, det] = self.vwd.each_ref().map(|x| x.lane(l));
            // At equal t a found triangle (index below MISS) is kept.
            c.keep(TriangleHit { t, v, w, det }, prim);
        }
        c
    }

    /// Each lane's answer: `TriangleHit::to_hit` in lanes (its two
    /// divisions for all lanes at once), or the lone lane's own `Closest`.
    #[inline(always)]
    fn hits(&self) -> [Hit; N] {
        let [v, w, det] = self.vwd;
        let (u, v) = (v / det, w / det);
        let (alone, found) = (
            self.lr.active & self.alone_bits,
            self.lr.active & self.found,
        );
        core::array::from_fn(|l| {
            if alone >> l & 1 == 1 {
                self.closest(l).hit()
            } else if found >> l & 1 == 1 {
                Hit {
                    t: self.t.lane(l),
                    prim: self.prim.get(l).copied().unwrap_or(MISS),
                    u: u.lane(l),
                    v: v.lane(l),
                }
            } else {
                Hit::MISS
            }
        })
    }
}

impl<'a, V: Lanes<N>, const N: usize> Visit<'a, V> for ClosestLanes<'_, 'a, V, N> {
    #[inline(always)]
    fn leaf(&mut self, prims: LeafIter<'a>, lanes: u32) -> Option<(V, u32)> {
        for p in prims {
            let Some(tri) = self.tree.triangles.get(p as usize) else {
                continue;
            };
            let Some(h) = self.lr.intersect(tri, lanes, self.t) else {
                continue;
            };
            // `Closest::keep` in lanes: the hit lies in [tmin, best t], so
            // it wins when nearer, or at equal t with a lower index.
            let mut wins = h.hit & h.t.lt(self.t);
            let mut ties = h.hit & !wins;
            while ties != 0 {
                let l = ties.trailing_zeros() as usize;
                ties &= ties - 1;
                if self.prim.get(l).is_some_and(|&b| p < b) {
                    wins |= 1 << l;
                }
            }
            if wins == 0 {
                continue;
            }
            let m = V::mask(wins);
            self.t = V::select(m, h.t, self.t);
            self.vwd = [(h.v, self.vwd[0]), (h.w, self.vwd[1]), (h.det, self.vwd[2])]
                .map(|(new, old)| V::select(m, new, old));
            (self.found, self.alone_bits) = (self.found | wins, self.alone_bits & !wins);
            let mut w = wins;
            while w != 0 {
                if let Some(b) = self.prim.get_mut(w.trailing_zeros() as usize) {
                    *b = p;
                }
                w &= w - 1;
            }
        }
        Some((self.t, self.lr.active))
    }

    #[inline(always)]
    fn single(&mut self, l: usize, start: (u32, f32, f32)) -> Option<(V, u32)> {
        let mut best = self.closest(l);
        let one = self.lr.single(l);
        self.tree
            .closest_from(&one.sr, &one.cr, one.tmin, &mut best, start, &mut ());
        if let (Some(a), Some(b)) = (self.alone.get_mut(l), self.prim.get_mut(l)) {
            (*a, *b) = (best, best.prim);
            self.t = V::select(V::mask(1 << l), V::splat(best.t), self.t);
            self.alone_bits |= 1 << l;
            // Equal t then compares against this lane's prim.
            self.found |= u32::from(best.prim != MISS) << l;
        }
        Some((self.t, self.lr.active))
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
        let one = self.lr.single(l);
        if self
            .tree
            .any_from(&one.sr, &one.cr, (one.tmin, one.tmax), start, &mut ())
        {
            self.occluded |= 1 << l;
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
        stack: &mut LaneStack<V>,
    ) -> [Hit; N] {
        let mut visit = ClosestLanes {
            tree: self,
            lr,
            t: lr.tmax,
            vwd: [lr.tmax; 3],
            prim: [MISS; N],
            found: 0,
            alone_bits: 0,
            alone: [Closest::new(0.0); N],
        };
        self.walk_lanes(lr, stack, &mut visit);
        visit.hits()
    }

    /// Bit `l` set when lane `l` of `lr` hits any triangle.
    #[inline(always)]
    pub(crate) fn any_lanes<V: Lanes<N>, const N: usize>(
        &self,
        lr: &LaneRays<V, N>,
        stack: &mut LaneStack<V>,
    ) -> u32 {
        let mut visit = AnyLanes {
            tree: self,
            lr,
            occluded: 0,
        };
        self.walk_lanes(lr, stack, &mut visit);
        visit.occluded
    }

    /// The packet loop: `visit` tests leaves and finishes lone lanes.
    #[inline(always)]
    fn walk_lanes<V: Lanes<N>, const N: usize>(
        &self,
        lr: &LaneRays<V, N>,
        LaneStack(stack): &mut LaneStack<V>,
        visit: &mut impl Visit<'a, V>,
    ) {
        let s2 = lr.s2;
        let mut sp = 0usize;
        let (mut node_idx, mut lanes, mut lo, mut hi) = (0u32, lr.active, lr.lo, lr.hi);
        if lanes == 0 {
            return;
        }
        // Lanes that disagree on a near child go alone from the root: a
        // packet of random rays costs its single rays, not more.
        if !lr.coherent {
            for l in 0..N {
                if lanes >> l & 1 == 1 && visit.single(l, (0, lo.lane(l), hi.lane(l))).is_none() {
                    return;
                }
            }
            return;
        }
        loop {
            let Some(node) = self.nodes.get(node_idx as usize) else {
                return;
            };
            let axis = node.axis_bits();
            let step = if lanes & lanes.wrapping_sub(1) == 0 {
                // One lane left in this subtree: it finishes as a single
                // ray, whose step costs less than a packet step
                // (measured on the bunny, `kdray trace` on
                // `primary_tiled.rays`, interleaved: finishing up to 2
                // lanes alone ran at 12.8 vs 14.4 Mrays/s 8-wide, 8.0 vs
                // 9.7 4-wide).
                let l = lanes.trailing_zeros() as usize;
                visit.single(l, (node_idx, lo.lane(l), hi.lane(l)))
            } else if let (Some(&org), Some(&inv)) = (lr.org.get(axis), lr.inv.get(axis)) {
                // Compute parametric distance along each lane to the split plane.
                let t_split = (V::splat(node.split()) - org) * inv;
                // The single ray's rule lane by lane (`traverse.rs`): a
                // lane visits its near child unless t_split < lo, its far
                // child unless it visits the near one and t_split > hi. A
                // NaN t_split visits both.
                let near = lanes & !t_split.lt(lo);
                let far = lanes & !(near & t_split.gt(hi));
                // The near child by the single ray's one-shift rule (no
                // table load on the node-to-node chain); the far one with
                // the bits flipped.
                let first = node.first_child(lr.above_first_nibbles) as u32;
                let second = node.first_child(!lr.above_first_nibbles) as u32;
                let far_lo = lo.far_lo(t_split, s2);
                // Push the far child unconditionally and keep it only when
                // the packet visits both children (the single ray's way:
                // one branch less per node).
                let Some(slot) = stack.get_mut(sp) else {
                    return; // deeper than MAX_DEPTH: only an unchecked, invalid blob
                };
                *slot = Pending {
                    node: second,
                    lanes: far,
                    lo: far_lo,
                    hi,
                };
                if near == 0 {
                    (node_idx, lanes, lo) = (second, far, far_lo);
                    continue;
                }
                sp += usize::from(far != 0);
                (node_idx, lanes, hi) = (first, near, hi.near_hi(t_split, s2));
                continue;
            } else {
                // A leaf: test its triangles against the lanes' own intervals.
                visit.leaf(LeafIter::new(self.leaf_prims(*node)), lanes)
            };
            let Some((best_t, alive)) = step else {
                return;
            };
            // Advance to the next far cell that can still hold a better hit
            // for some lane.
            let cutoff = best_t.cutoff(s2);
            loop {
                if sp == 0 {
                    return;
                }
                sp -= 1;
                let p = stack[sp];
                let open = p.lanes & alive & p.lo.le(cutoff);
                if open != 0 {
                    (node_idx, lanes, lo, hi) = (p.node, open, p.lo, p.hi.min(cutoff));
                    break;
                }
            }
        }
    }
}
