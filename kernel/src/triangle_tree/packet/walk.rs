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
//! single ray's slack rule ([`Span`](crate::lanes::Span), shared code)
//! on the same pre-widened intervals. A lane still tests a few cells its
//! single ray skips (cells other lanes open, out to the packet's cutoff per
//! lane), which cannot change its answer: triangles are tested over the
//! lane's own `[tmin, best t]` and [`Closest`] does not depend on the order
//! in which hits arrive. Packets whose lanes disagree on a sign are traced
//! lane by lane as single rays (`LaneRays::alone`); a coherent packet walks
//! in lanes to the end, even with one lane left.
//!
//! The step is bound by its node-to-node chain, as the single ray's is.

// Tried and lost (8-wide bunny camera tiles, interleaved, hits identical):
// - per-lane near/far for mixed-sign packets: 0.6-0.8x single rays, because the blends cost more than the lanes share;
// - selects instead of the near-or-far branch: 15-40% slower, because the select chain is longer than the mispredicts;
// - a branch-free step (both children's t_split ahead): 14% slower, for the same reason;
// - pushing only when both children are visited: 3.5% slower (one more branch per node); again at
//   16 lanes (AVX-512) with the far child read lazily: 1-2% slower (tiles16 ratio to the lean walk);
// - the node array and above-first bits held in locals before the loop: instructions within 0.2%
//   (callgrind, 8 lanes), tiles16 within noise, because the leaf's triangle test still takes the
//   general-purpose registers and the step's stack pointer and node array stay spilled;
// - the descent as a loop of its own inside the leaf-and-pop loop: the same machine code;
// - a frustum walk (one scalar interval per packet): 20% slower, because its scalar step costs a lane step;
// - two packets in lockstep: 5% slower, because two walks' state does not fit the registers;
// - shared entry points for groups of packets: 2% slower, the shared descent is ~7 of ~30 steps;
// - the child pair read once and indexed by the near bit: 11% slower; prefetching the far grandchildren: 3% slower;
// - unchecked node and stack reads: slower; going through empty children: 4.8x slower (lanes lose their culling);
// - leaves without the early exit when no lane passes: 6% slower; a lone lane finished as a single ray: 3-11% slower;
// - not built: a mailbox (0.8 of ~10 triangle tests a packet repeat one, about what the check would cost).

use super::super::walk::{LeafIter, STACK};
use super::super::TriangleTree;
use super::lane_rays::LaneRays;
use crate::blob::MAX_DEPTH;
use crate::geometry::{Hit, MISS};
use crate::lanes::Lanes;
use crate::triangle::Closest;

/// A far child waiting on the stack with its lanes and their intervals
/// (widened by the slack, as the single ray keeps them).
#[derive(Clone, Copy)]
struct Pending<V> {
    node: u32,
    lanes: u32,
    lo: V,
    hi: V,
}

/// The packet walk's stack, [`MAX_DEPTH`] entries. A batch call
/// makes one for all its packets: filling its 6 KiB (8 lanes) anew for
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

/// What the packet loop does at a leaf. Both methods return each lane's
/// best `t` (cells starting more than the slack beyond it are skipped)
/// and the lanes still searching, or `None` when all are done.
trait Visit<'a, V> {
    /// Tests a leaf's primitives against `lanes`.
    fn leaf(&mut self, prims: LeafIter<'a>, lanes: u32) -> Option<(V, u32)>;
    /// The state `leaf` returns, with no new leaf tested.
    fn state(&self) -> Option<(V, u32)>;
    /// Take the far child first when the packet visits both (the single
    /// ray's [`super::super::walk::Visit::FAR_FIRST`]).
    const FAR_FIRST: bool = false;
}

/// The closest-hit search: each lane's [`Closest`] kept in lanes (the
/// best `t` and the winning hit's edge functions), so a leaf's hits update
/// all lanes with a few selects.
struct ClosestLanes<'t, 'a, V, const N: usize> {
    tree: &'t TriangleTree<'a>,
    lr: &'t LaneRays<V, N>,
    /// Each lane's best `t` (its `tmax` before any hit).
    t: V,
    /// The best hit's `v`, `w` and `det` ([`TriangleHit`](crate::triangle::TriangleHit)).
    vwd: [V; 3],
    /// The best triangle of each lane ([`MISS`] before any hit), its bits
    /// in an `f32` lane: a win updates it with one select, as `t` (a loop
    /// over the winning lanes mispredicted its exit).
    prim: V,
    /// Lanes with a hit.
    found: u32,
}

impl<V: Lanes<N>, const N: usize> ClosestLanes<'_, '_, V, N> {
    /// Each lane's answer: [`TriangleHit::to_hit`](crate::triangle::TriangleHit::to_hit)
    /// in lanes (its two divisions for all lanes at once), [`Hit::MISS`]
    /// by selects, then transposed into records (a branch per lane on hit
    /// or miss was mispredicted on the silhouette's tiles).
    #[inline(always)]
    fn hits(&self) -> [Hit; N] {
        let [v, w, det] = self.vwd;
        // A lane that never won keeps `prim == MISS`.
        let found = V::mask(self.found);
        // No closures in the lane code: one is compiled without the
        // level's target features, and its vector operations become calls
        // unless LLVM inlines it (`crate::lanes::dispatch`).
        let cols = [
            V::select(found, self.t, V::splat(Hit::MISS.t)),
            self.prim,
            V::select(found, v / det, V::splat(Hit::MISS.u)),
            V::select(found, w / det, V::splat(Hit::MISS.v)),
        ];
        V::records(cols).map(bytemuck::cast)
    }
}

impl<'a, V: Lanes<N>, const N: usize> Visit<'a, V> for ClosestLanes<'_, 'a, V, N> {
    #[inline(always)]
    fn leaf(&mut self, prims: LeafIter<'a>, lanes: u32) -> Option<(V, u32)> {
        let (triangles, lr) = (self.tree.triangles, self.lr);
        let k = lr.k_uniform;
        for p in prims {
            let Some(tri) = triangles.get(p as usize) else {
                continue;
            };
            // Lanes whose best triangle this is would get the same answer
            // again, which cannot win: left out (no `f64` `t`).
            let again = self.prim.eq_mask(V::splat(f32::from_bits(p))).bits();
            let Some(h) = lr.intersect::<false>(k, tri, lanes & !again, self.t) else {
                continue;
            };
            // `Closest::keep` in lanes: the hit lies in [tmin, best t], so
            // it wins when nearer, or at equal t with a lower index.
            let mut wins = h.hit & h.t.lt(self.t);
            let mut ties = h.hit & !wins;
            while ties != 0 {
                let l = ties.trailing_zeros() as usize;
                ties &= ties - 1;
                if p < self.prim.lane(l).to_bits() {
                    wins |= 1 << l;
                }
            }
            if wins == 0 {
                continue;
            }
            let m = V::mask(wins);
            self.t = V::select(m, h.t, self.t);
            self.vwd = [
                V::select(m, h.v, self.vwd[0]),
                V::select(m, h.w, self.vwd[1]),
                V::select(m, h.det, self.vwd[2]),
            ];
            self.prim = V::select(m, V::splat(f32::from_bits(p)), self.prim);
            self.found |= wins;
        }
        self.state()
    }

    #[inline(always)]
    fn state(&self) -> Option<(V, u32)> {
        Some((self.t, self.lr.active))
    }
}

/// The any-hit search: a bitmask of the lanes found occluded.
struct AnyLanes<'t, 'a, V, const N: usize> {
    tree: &'t TriangleTree<'a>,
    lr: &'t LaneRays<V, N>,
    occluded: u32,
}

impl<'a, V: Lanes<N>, const N: usize> Visit<'a, V> for AnyLanes<'_, 'a, V, N> {
    // Back to front, as the single ray's any hit.
    const FAR_FIRST: bool = true;

    #[inline(always)]
    fn state(&self) -> Option<(V, u32)> {
        let alive = self.lr.active & !self.occluded;
        (alive != 0).then_some((self.lr.tmax, alive))
    }

    #[inline(always)]
    fn leaf(&mut self, prims: LeafIter<'a>, lanes: u32) -> Option<(V, u32)> {
        let mut open = lanes & !self.occluded;
        let k = self.lr.k_uniform;
        for p in prims {
            if open == 0 {
                break;
            }
            let Some(tri) = self.tree.triangles.get(p as usize) else {
                continue;
            };
            if let Some(h) = self.lr.intersect::<true>(k, tri, open, self.lr.tmax) {
                self.occluded |= h.hit;
                open &= !h.hit;
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
        stack: &mut LaneStack<V>,
    ) -> [Hit; N] {
        if !lr.coherent {
            return lr.alone(Hit::MISS, |one, start| {
                let mut best = Closest::new(one.tmax);
                self.closest_from::<_, STACK>(
                    &one.sr,
                    &one.cr,
                    one.tmin,
                    &mut best,
                    start,
                    &mut (),
                );
                best.hit(&one.sr, self.triangles)
            });
        }
        let mut visit = ClosestLanes {
            tree: self,
            lr,
            t: lr.tmax,
            vwd: [lr.tmax; 3],
            prim: V::splat(f32::from_bits(MISS)),
            found: 0,
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
        if !lr.coherent {
            let hit = lr.alone(false, |one, start| {
                self.any_from::<_, STACK>(&one.sr, &one.cr, (one.tmin, one.tmax), start, &mut ())
                    .is_some()
            });
            return hit
                .iter()
                .enumerate()
                .fold(0, |m, (l, &h)| m | u32::from(h) << l);
        }
        let mut visit = AnyLanes {
            tree: self,
            lr,
            occluded: 0,
        };
        self.walk_lanes(lr, stack, &mut visit);
        visit.occluded
    }

    /// The packet loop of a coherent packet: `visit` tests leaves.
    #[inline(always)]
    fn walk_lanes<V: Lanes<N>, Vis: Visit<'a, V>, const N: usize>(
        &self,
        lr: &LaneRays<V, N>,
        LaneStack(stack): &mut LaneStack<V>,
        visit: &mut Vis,
    ) {
        let s2 = lr.s2;
        let mut sp = 0usize;
        let (mut lanes, mut lo, mut hi) = (lr.active, lr.lo, lr.hi);
        if lanes == 0 {
            return;
        }
        let Some(mut node) = self.nodes.first().copied() else {
            return;
        };
        loop {
            let axis = node.axis_bits();
            // Even one lane left in a subtree walks on in lanes (finishing it
            // as a single ray lost; see the tries above).
            let step = if let (Some(&org), Some(&inv)) = (lr.org.get(axis), lr.inv.get(axis)) {
                // Compute parametric distance along each lane to the split plane.
                let t_split = (V::splat(node.split()) - org) * inv;
                // The single ray's rule lane by lane (`../walk.rs`): a
                // lane visits its near child unless t_split < lo, its far
                // child unless it visits the near one and t_split > hi. A
                // NaN t_split visits both.
                let near = lanes & !t_split.lt(lo);
                let far = lanes & !(near & t_split.gt(hi));
                // The near child by the single ray's one-shift rule; an
                // empty near child drops its lanes here. A far child that
                // waits is pushed unread and, if empty, skipped when popped:
                // most steps keep to the near child and never read it.
                let first = node.first_child(lr.above_first_nibbles);
                let second = node.other_child(first);
                let Some(&near_node) = self.nodes.get(first) else {
                    return;
                };
                let near = if near_node.is_empty_leaf() { 0 } else { near };
                let far_lo = lo.far_lo(t_split, s2);
                // Push the far child unconditionally and keep it only when
                // the packet visits both children (the single ray's way:
                // one branch less per node).
                let Some(slot) = stack.get_mut(sp) else {
                    return; // deeper than MAX_DEPTH: only an unchecked, invalid blob
                };
                *slot = Pending {
                    node: second as u32,
                    lanes: far,
                    lo: far_lo,
                    hi,
                };
                // The far child is read where the packet may go there at
                // once: no near lanes, or back to front.
                let far = if near == 0 || (Vis::FAR_FIRST && far != 0) {
                    let Some(&far_node) = self.nodes.get(second) else {
                        return;
                    };
                    let far = if far_node.is_empty_leaf() { 0 } else { far };
                    if far != 0 {
                        if near != 0 {
                            // Both visited, back to front: the near child waits.
                            *slot = Pending {
                                node: first as u32,
                                lanes: near,
                                lo,
                                hi: hi.near_hi(t_split, s2),
                            };
                            sp += 1;
                        }
                        (node, lanes, lo) = (far_node, far, far_lo);
                        continue;
                    }
                    far
                } else {
                    far
                };
                if near == 0 {
                    visit.state()
                } else {
                    sp += usize::from(far != 0);
                    (node, lanes, hi) = (near_node, near, hi.near_hi(t_split, s2));
                    continue;
                }
            } else {
                // A leaf: test its triangles against the lanes' own intervals.
                visit.leaf(LeafIter::new(self.leaf_prims(node)), lanes)
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
                    (lanes, lo, hi) = (open, p.lo, p.hi.min(cutoff));
                    let Some(&n) = self.nodes.get(p.node as usize) else {
                        return;
                    };
                    // A far child pushed unread may be an empty cell.
                    if n.is_empty_leaf() {
                        continue;
                    }
                    node = n;
                    break;
                }
            }
        }
    }
}
