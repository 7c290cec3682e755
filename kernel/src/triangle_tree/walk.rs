//! Single-ray traversal: the lecture's non-recursive loop on a fixed stack.
//!
//! ```text
//! while not a leaf:
//!     t_split = (split - origin[axis]) * inv_dir[axis]
//!     if t_split is beyond t_max: continue with the near child only
//!     if t_split is before t_min: continue with the far child only
//!     push (far child, t_split, t_max); continue with (near child, t_min, t_split)
//! ```
//!
//! with two refinements: the any-hit search takes the far child first and
//! pushes the near one (`Visit::FAR_FIRST`: a shadow ray's occluder is
//! found from the light's end), and a child that is an empty cell is never entered nor
//! pushed (the parent reads both children, `TriangleTree::children`, and
//! skips an empty one there), and the loop moves on to the next far cell
//! when neither child holds anything for the ray.
//!
//! "Near" is the child the ray enters first *in t order*: the below child
//! when the direction component is positive or `+0`, the above child when
//! it is negative or `-0`. Taking the sign of `1/d` (an infinity of the
//! right sign for `d = ±0`) makes the rule hold for negative `t` ranges and
//! for rays parallel to the split plane, where `t_split` is `±inf` (the ray
//! stays on one side) or NaN (origin exactly on the plane: NaN fails both
//! tests, so both children are visited over the whole interval).

// The loop is bound by its node-to-node chain (node load, child index, next
// node load): what paid shortened that chain. Tried and lost (bunny camera rays):
// - conditional moves for near/far: 25-30% slower, because the select chain is longer than the mispredicts;
// - unchecked node loads, the split loaded as a float, a local copy of the best hit: no gain (off the chain);
// - a mailbox: no gain, only 8% of a camera ray's triangle tests repeat one of the last eight;
// - prefetching the far child's children: 7-15% slower on shadow rays, 2-3% on camera rays;
// - entry points for 8 coherent rays (Reshetov et al.): 0.86-0.91x, they part after ~2 of 8-25 steps.

use super::cell_ray::CellRay;
use super::counts::Tally;
use super::leaf_lanes::{self, LANE_LEAF_MIN};
use super::{LeafPrims, TriangleTree};
use crate::blob::{Node, MAX_DEPTH};
use crate::geometry::{Hit, Ray, MISS};
use crate::lanes::Span;
use crate::triangle::{dominant_axis, Closest, ShearedRay, Triangle};
use core::mem::MaybeUninit;

/// A far child waiting on the stack with its interval.
#[derive(Clone, Copy, Debug)]
pub(super) struct Pending {
    pub(super) node: u32,
    /// Start of the cell's interval, less the slack.
    pub(super) lo: f32,
    /// End of the cell's interval, plus the slack.
    pub(super) hi: f32,
}

/// The traversal stack of [`TriangleTree`]'s walks: a pending far cell per
/// level of the deepest tree validation accepts.
pub(crate) const STACK: usize = MAX_DEPTH as usize;

// The traversal stack the docs promise: MAX_DEPTH entries of 12 bytes.
const _: () = assert!(core::mem::size_of::<Pending>() * STACK == 768);

/// What the walk does in a non-empty leaf: the closest-hit or the any-hit
/// search. A trait rather than a closure so that the leaf test is inlined
/// into the loop (as a closure it was an out-of-line call per leaf).
pub(super) trait Visit<'a, T> {
    /// The end of the ray's current interval: cells starting beyond it
    /// (plus the slack) cannot hold a better hit.
    fn bound(&self) -> f32;
    /// Tests the leaf's triangles; `true` when the answer is known.
    fn leaf(&mut self, tris: &'a [Triangle], prims: LeafIter<'a>, tally: &mut T) -> bool;
    /// When the ray visits both children, take the far one first (the
    /// near child waits on the stack): any order finds every hit, so a
    /// search that may stop at any hit chooses where to look first.
    const FAR_FIRST: bool = false;
}

/// Whether leaves are tested in lanes: where `wide` has vector registers
/// to put them in (x86-64 always has SSE2; there `f32x8` is two `f32x4`
/// and still measured ~4% faster than the scalar test on camera rays). On
/// a target without SIMD eight lanes are eight scalar tests without the
/// early exits, and the scalar test is kept.
const LEAF_LANES: bool = cfg!(any(
    target_feature = "sse2",
    target_feature = "neon",
    target_feature = "simd128"
));

/// The closest-hit search: every triangle of a leaf against `[tmin, best.t]`.
pub(super) struct ClosestVisit<'r> {
    pub(super) sr: &'r ShearedRay,
    pub(super) tmin: f32,
    pub(super) best: &'r mut Closest,
}

impl<'a, T: Tally> Visit<'a, T> for ClosestVisit<'_> {
    #[inline(always)]
    fn bound(&self) -> f32 {
        self.best.t
    }

    #[inline(always)]
    fn leaf(&mut self, tris: &'a [Triangle], prims: LeafIter<'a>, tally: &mut T) -> bool {
        if let Some(run) = prims.lane_run() {
            tally.triangles(run.len());
            leaf_lanes::closest_x8(self.sr, tris, run, self.tmin, self.best);
            return false;
        }
        for p in prims {
            if let Some(tri) = tris.get(p as usize) {
                tally.triangles(1);
                self.best.consider(self.sr, tris, tri, p, self.tmin);
            }
        }
        false
    }
}

/// The any-hit search: stops at the first triangle hit in `[tmin, tmax]`.
pub(super) struct AnyVisit<'r> {
    pub(super) sr: &'r ShearedRay,
    pub(super) tmin: f32,
    pub(super) tmax: f32,
    /// The triangle that stopped the walk ([`MISS`] until one does).
    pub(super) occluder: u32,
}

impl<'a, T: Tally> Visit<'a, T> for AnyVisit<'_> {
    /// Back to front. A shadow ray starts on a surface, in small cells
    /// crowded with its own triangle's neighbours, which it leaves without
    /// hitting, and ends at a light in open space; its occluder, if any,
    /// lies between. From the far end the walk crosses empty cells to the
    /// occluder.
    // Tried: a per-node order from the builder (SATO, RTSAH): 0.92-1.01x far-first, so the node carries no order bit.
    const FAR_FIRST: bool = true;

    #[inline(always)]
    fn bound(&self) -> f32 {
        self.tmax
    }

    #[inline(always)]
    fn leaf(&mut self, tris: &'a [Triangle], prims: LeafIter<'a>, tally: &mut T) -> bool {
        if let Some(run) = prims.lane_run() {
            tally.triangles(run.len());
            return leaf_lanes::any_x8(self.sr, tris, run, self.tmin, self.tmax)
                .map(|p| self.occluder = p)
                .is_some();
        }
        for p in prims {
            if let Some(tri) = tris.get(p as usize) {
                tally.triangles(1);
                if self.sr.intersects(tri, self.tmin, self.tmax) {
                    self.occluder = p;
                    return true;
                }
            }
        }
        false
    }
}

impl<'a> TriangleTree<'a> {
    /// The closest hit of `ray` in `[tmin, tmax]`: the smallest `t`, and at
    /// equal `t` the lowest triangle index, exactly as
    /// [`closest_hit_brute`](crate::closest_hit_brute) over all triangles.
    /// [`Hit::MISS`] for a miss or an invalid ray.
    ///
    /// # Panics
    /// Never. No allocation; the stack is [`MAX_DEPTH`] entries.
    ///
    /// # Example
    /// ```
    /// use glam::Vec3;
    /// use kdray_kernel::{closest_hit_brute, Hit, Ray, TriangleTree};
    /// static CUBE: &kdray_kernel::Aligned<[u8]> =
    ///     kdray_kernel::include_aligned!("../../golden/cube-v3.kdt");
    /// let tree = TriangleTree::from_bytes(&CUBE.bytes)?;
    ///
    /// // From below the cube, straight up: the floor at t = 1.
    /// let ray = Ray::new(Vec3::new(0.3, 0.6, -1.0), Vec3::Z);
    /// let hit = tree.closest_hit(&ray);
    /// assert_eq!((hit.t, hit.prim), (1.0, 1));
    /// // Exactly what testing every triangle finds.
    /// assert_eq!(hit.bits(), closest_hit_brute(tree.triangles(), &ray).bits());
    /// // Pointing away, or invalid: a miss.
    /// assert_eq!(tree.closest_hit(&Ray::new(Vec3::new(0.3, 0.6, -1.0), -Vec3::Z)), Hit::MISS);
    /// assert!(!tree.closest_hit(&Ray::new(Vec3::ZERO, Vec3::ZERO)).is_hit());
    /// # Ok::<(), kdray_kernel::BlobError>(())
    /// ```
    #[inline]
    #[must_use]
    pub fn closest_hit(&self, ray: &Ray) -> Hit {
        self.closest_hit_tallied::<_, STACK>(ray, &mut ())
    }

    // Not inlined: the setup and the walk share one frame and one register
    // allocation, whatever loop the caller has (measured faster than
    // inlining into `closest_hits`, and no wide copies of ray structs).
    // `DEPTH`: the stack's entries (`ShallowTree` takes fewer).
    #[inline(never)]
    pub(super) fn closest_hit_tallied<T: Tally, const DEPTH: usize>(
        &self,
        ray: &Ray,
        tally: &mut T,
    ) -> Hit {
        // The root clip first: a ray that misses the tree's box (most
        // instances a scene's ray meets) skips the shear's divisions.
        // Tried: the shear built from this dominant axis: +120 B firmware `.text` and a panic path, no fewer instructions.
        let Some(cr) = CellRay::new(ray, dominant_axis(&ray.dir), &self.bounds) else {
            return Hit::MISS;
        };
        let Some(sr) = ShearedRay::new(ray) else {
            return Hit::MISS;
        };
        let mut best = Closest::new(ray.tmax);
        let (lo, hi) = cr.start();
        let start = (0, lo, hi);
        self.closest_from::<T, DEPTH>(&sr, &cr, ray.tmin, &mut best, start, tally);
        best.hit(&sr, self.triangles)
    }

    /// The closest-hit search of one ray through the subtree at `start` =
    /// `(node, lo, hi)` (interval widened by the slack), into `best`;
    /// triangles are tested over `[tmin, best.t]`. (Packets whose lanes do
    /// not walk together trace each lane with it, from the root.)
    #[inline(always)]
    pub(crate) fn closest_from<T: Tally, const DEPTH: usize>(
        &self,
        sr: &ShearedRay,
        cr: &CellRay,
        tmin: f32,
        best: &mut Closest,
        start: (u32, f32, f32),
        tally: &mut T,
    ) {
        let mut visit = ClosestVisit { sr, tmin, best };
        // The closest-hit visitor never stops the walk early.
        self.walk::<T, _, DEPTH>(cr, start, tally, &mut visit);
    }

    /// Does any triangle hit `ray` in `[tmin, tmax]`? Exactly when
    /// [`any_hit_brute`](crate::any_hit_brute) says so.
    ///
    /// # Panics
    /// Never. No allocation; the stack is [`MAX_DEPTH`] entries.
    ///
    /// # Example
    /// ```
    /// use glam::Vec3;
    /// use kdray_kernel::{Ray, TriangleTree};
    /// static CUBE: &kdray_kernel::Aligned<[u8]> =
    ///     kdray_kernel::include_aligned!("../../golden/cube-v3.kdt");
    /// let tree = TriangleTree::from_bytes(&CUBE.bytes)?;
    ///
    /// // A shadow ray from a point inside the cube to a light outside it:
    /// // the walls are in the way. Stopped short of the wall, it is clear.
    /// let p = Vec3::new(0.9, 0.1, 0.1);
    /// let to_light = Vec3::new(2.0, 0.1, 0.1) - p;
    /// assert!(tree.any_hit(&Ray::with_range(p, to_light, 0.0, 1.0)));
    /// assert!(!tree.any_hit(&Ray::with_range(p, to_light, 0.0, 0.05)));
    /// # Ok::<(), kdray_kernel::BlobError>(())
    /// ```
    #[inline]
    #[must_use]
    pub fn any_hit(&self, ray: &Ray) -> bool {
        self.any_hit_tallied::<_, STACK>(ray, &mut ())
    }

    // Not inlined: see `closest_hit_tallied`.
    #[inline(never)]
    pub(super) fn any_hit_tallied<T: Tally, const DEPTH: usize>(
        &self,
        ray: &Ray,
        tally: &mut T,
    ) -> bool {
        // The root clip first, as in `closest_hit_tallied`.
        CellRay::new(ray, dominant_axis(&ray.dir), &self.bounds).is_some_and(|cr| {
            ShearedRay::new(ray)
                .is_some_and(|sr| self.any_clipped::<T, DEPTH>(ray, &sr, &cr, tally).is_some())
        })
    }

    /// The occluder of `ray` (prepared as `sr`) the walk from the root
    /// finds, if any.
    #[inline(always)]
    fn any_sheared<T: Tally, const DEPTH: usize>(
        &self,
        ray: &Ray,
        sr: &ShearedRay,
        tally: &mut T,
    ) -> Option<u32> {
        let cr = CellRay::new(ray, sr.k[2], &self.bounds)?;
        self.any_clipped::<T, DEPTH>(ray, sr, &cr, tally)
    }

    /// [`TriangleTree::any_sheared`] with the root clip `cr` made.
    #[inline(always)]
    fn any_clipped<T: Tally, const DEPTH: usize>(
        &self,
        ray: &Ray,
        sr: &ShearedRay,
        cr: &CellRay,
        tally: &mut T,
    ) -> Option<u32> {
        let (lo, hi) = cr.start();
        self.any_from::<T, DEPTH>(sr, cr, (ray.tmin, ray.tmax), (0, lo, hi), tally)
    }

    /// The any-hit search of one ray over `[tmin, tmax]` through the
    /// subtree at `start` = `(node, lo, hi)`: the triangle that stopped
    /// it, if one did.
    #[inline(always)]
    pub(crate) fn any_from<T: Tally, const DEPTH: usize>(
        &self,
        sr: &ShearedRay,
        cr: &CellRay,
        (tmin, tmax): (f32, f32),
        start: (u32, f32, f32),
        tally: &mut T,
    ) -> Option<u32> {
        let mut visit = AnyVisit {
            sr,
            tmin,
            tmax,
            occluder: MISS,
        };
        self.walk::<T, _, DEPTH>(cr, start, tally, &mut visit)
            .then_some(visit.occluder)
    }

    /// [`TriangleTree::any_hit`], trying first the triangle in `last`
    /// (a triangle index, or anything else for none) and leaving there the
    /// triangle that occludes `ray`, when one does: an occluder cache of
    /// one triangle. Shadow rays from nearby points towards one light are
    /// often stopped by the same triangle, one triangle test instead of a
    /// walk. The answer is the walk's, since a triangle that hits within
    /// `[tmin, tmax]` is one brute force finds too.
    ///
    /// For an engine that traces shadow rays one at a time, in the order
    /// of the pixels that produced them (one `last` per thread and light;
    /// [`TriangleTree::any_hits`] keeps one itself). On shadow rays in the
    /// Morton order of their origins it answers 40-76% of the occluded
    /// rays of the bunny, sponza and teapot alone (docs/results.md).
    ///
    /// # Panics
    /// Never.
    ///
    /// # Example
    /// ```
    /// use glam::Vec3;
    /// use kdray_kernel::{Ray, TriangleTree, MISS};
    /// static CUBE: &kdray_kernel::Aligned<[u8]> =
    ///     kdray_kernel::include_aligned!("../../golden/cube-v3.kdt");
    /// let tree = TriangleTree::from_bytes(&CUBE.bytes)?;
    ///
    /// // Points on a row inside the cube, towards a light outside it.
    /// let light = Vec3::new(2.0, 0.5, 0.5);
    /// let mut last = MISS;
    /// for i in 0..8 {
    ///     let p = Vec3::new(0.5, 0.1 + i as f32 * 0.1, 0.5);
    ///     let ray = Ray::with_range(p, light - p, 1e-4, 1.0);
    ///     assert_eq!(tree.any_hit_remembering(&ray, &mut last), tree.any_hit(&ray));
    /// }
    /// assert!(last != MISS); // a wall of the cube occluded them
    /// # Ok::<(), kdray_kernel::BlobError>(())
    /// ```
    #[inline]
    #[must_use]
    pub fn any_hit_remembering(&self, ray: &Ray, last: &mut u32) -> bool {
        let Some(sr) = ShearedRay::new(ray) else {
            return false;
        };
        if let Some(tri) = self.triangles.get(*last as usize) {
            if sr.intersects(tri, ray.tmin, ray.tmax) {
                return true;
            }
        }
        self.any_sheared::<(), STACK>(ray, &sr, &mut ())
            .map(|p| *last = p)
            .is_some()
    }

    /// One interior step of the walk at `node`, whose plane the ray
    /// crosses at `t_split` (`above_first` and `s2` as the walk keeps
    /// them), over the interval `[lo, hi]`: the child to
    /// continue with and its index (the interval narrowed to it, the far
    /// child pushed when both are visited), `Some(None)` when neither
    /// holds anything for the ray, `None` for an invalid blob. With
    /// `far_first` ([`Visit::FAR_FIRST`]) the far child is taken first when
    /// both are visited.
    #[inline(always)]
    pub(super) fn split_step(
        &self,
        node: Node,
        (above_first, far_first): (u64, bool),
        (t_split, s2): (f32, f32),
        (lo, hi): (&mut f32, &mut f32),
        stack: &mut [MaybeUninit<Pending>],
        sp: &mut usize,
    ) -> Option<Option<(Node, usize)>> {
        // Empty children are skipped here, at their parent (~4.6 of
        // the ~28 steps of a camera ray through the bunny were such
        // cells).
        let (near, far, second) = self.children(node, above_first)?;
        // The near child's cell ends at t_split, the far child's
        // starts there. Intervals are kept widened by the slack on
        // both ends ([lo, hi] = [t0 - s, t1 + s]), so the tests take
        // t_split as computed, off the critical path of the slack add;
        // a child's new end is t_split + s, widened once more: + 2s.
        // Written as "not outside" so a NaN t_split (origin on the
        // plane, direction parallel to it) visits both over the whole
        // interval. (`lo <= hi` always, so a ray that skips the near
        // cell by t_split < lo is inside the far one.)
        #[allow(clippy::neg_cmp_op_on_partial_ord)] // NaN must visit: see above
        let (visit_near, visit_far) = (!(t_split < *lo), !(t_split > *hi));
        let visit_far = visit_far & !far.is_empty_leaf();
        // Push the far child unconditionally; keep it only when both
        // children are visited.
        // `None` deeper than MAX_DEPTH: only an unchecked, invalid blob.
        let slot = stack.get_mut(*sp)?;
        let far_lo = lo.far_lo(t_split, s2);
        slot.write(Pending {
            node: second as u32,
            lo: far_lo,
            hi: *hi,
        });
        // Branches, not selects: coherent rays take the same side at
        // the same node, so they predict well. Tried conditional moves
        // (mask selects of node, lo, hi): 25-30% slower on bunny
        // camera rays, the same on random rays. Tried prefetching the
        // waiting child's pair (or leaf) when both are visited: random
        // rays 0.87x (bunny) and 0.92x (sponza), shadow rays 0.99-1.03x.
        if far_first && visit_far && visit_near && !near.is_empty_leaf() {
            // Back to front: the near child waits, over its interval.
            slot.write(Pending {
                node: (second ^ 1) as u32,
                lo: *lo,
                hi: hi.near_hi(t_split, s2),
            });
            *sp += 1;
            *lo = far_lo;
            return Some(Some((far, second)));
        }
        if visit_near & !near.is_empty_leaf() {
            *sp += usize::from(visit_far);
            *hi = hi.near_hi(t_split, s2);
            // Pairs start at even indices (treelets): the near
            // child is the far one's neighbour.
            return Some(Some((near, second ^ 1)));
        }
        if visit_far {
            *lo = far_lo;
            return Some(Some((far, second)));
        }
        Some(None)
    }

    /// The traversal loop: `visit` sees each non-empty leaf's primitives,
    /// in front-to-back order of cells (back to front with
    /// [`Visit::FAR_FIRST`]). `true` when `visit` stopped it.
    /// The stack holds `DEPTH` pending far cells, one per level: enough
    /// for a tree of that depth (a deeper, unchecked one ends the walk
    /// where a push finds no room).
    #[inline(always)]
    pub(super) fn walk<T, V, const DEPTH: usize>(
        &self,
        cr: &CellRay,
        start: (u32, f32, f32),
        tally: &mut T,
        visit: &mut V,
    ) -> bool
    where
        T: Tally,
        V: Visit<'a, T>,
    {
        let s = cr.slack;
        let s2 = s + s;
        // Cells starting after `cutoff` (the best hit plus the slack,
        // widened by the slack) are behind the best hit.
        let mut cutoff = visit.bound().cutoff(s2);
        // Left uninitialised: zeroing 768 bytes per ray was a `memset` call
        // costing ~5% of a camera-ray trace. Invariant: entries below `sp`
        // are written (a push writes `stack[sp]` before `sp` grows past it).
        let mut stack = [MaybeUninit::<Pending>::uninit(); DEPTH];
        let mut sp = 0usize;
        let (node0, mut lo, mut hi) = start;
        // Origin and reciprocal direction side by side, filled element by
        // element: copying `cr`'s arrays whole loaded 8 bytes across two
        // smaller stores, a store-forwarding stall per ray.
        let (o, i) = (cr.org, cr.inv);
        let slab = [o[0], o[1], o[2], 0.0, i[0], i[1], i[2], 0.0];
        let Some(&(mut node)) = self.nodes.get(node0 as usize) else {
            return false;
        };
        loop {
            tally.node();
            let axis = node.axis_bits();
            if axis < 3 {
                // Compute parametric distance along ray to split plane.
                let t_split = (node.split() - slab[axis]) * slab[axis + 4];
                let nibbles = cr.above_first_nibbles;
                let step = (t_split, s2);
                match self.split_step(
                    node,
                    (nibbles, V::FAR_FIRST),
                    step,
                    (&mut lo, &mut hi),
                    &mut stack,
                    &mut sp,
                ) {
                    None => return false,
                    Some(Some((next, _))) => {
                        node = next;
                        continue;
                    }
                    Some(None) => {}
                }
                // Neither child holds anything for this ray: next far cell.
            } else if node.upper() != 0 {
                // A leaf: test its triangles against the ray's own interval.
                // (Only an empty root is an empty cell here: the walk never
                // steps into the others, and they leave the cutoff as is.)
                let prims = LeafIter::new(self.leaf_prims(node));
                if visit.leaf(self.triangles, prims, tally) {
                    return true;
                }
                cutoff = visit.bound().cutoff(s2);
            }
            // Advance to the next far cell that can still hold a better hit.
            loop {
                if sp == 0 {
                    return false;
                }
                sp -= 1;
                // `get`, not an index: the optimiser cannot see `sp` in range,
                // and an index would leave a panic path (firmware/).
                let Some(slot) = stack.get(sp) else {
                    return false;
                };
                // SAFETY: `sp` was above this entry, so it was written
                // (the invariant where `stack` is declared).
                let p = unsafe { slot.assume_init() };
                if p.lo <= cutoff {
                    let Some(&n) = self.nodes.get(p.node as usize) else {
                        return false;
                    };
                    (node, lo, hi) = (n, p.lo, Span::min(p.hi, cutoff));
                    break;
                }
            }
        }
    }
}

/// The primitives of a leaf as an iterator.
pub(crate) enum LeafIter<'a> {
    One(Option<u32>),
    Run(core::slice::Iter<'a, u32>),
}

impl<'a> LeafIter<'a> {
    #[inline(always)]
    pub(crate) fn new(p: LeafPrims<'a>) -> Self {
        match p {
            LeafPrims::One(p) => LeafIter::One(Some(p)),
            LeafPrims::Run(r) => LeafIter::Run(r.iter()),
        }
    }

    /// The leaf's primitives as one slice when the leaf is tested in lanes
    /// (`LEAF_LANES`, and at least `LANE_LEAF_MIN` of them).
    #[inline(always)]
    fn lane_run(&self) -> Option<&'a [u32]> {
        match self {
            LeafIter::Run(r) if LEAF_LANES && r.len() >= LANE_LEAF_MIN => Some(r.as_slice()),
            _ => None,
        }
    }
}

impl Iterator for LeafIter<'_> {
    type Item = u32;

    #[inline(always)]
    fn next(&mut self) -> Option<u32> {
        match self {
            LeafIter::One(p) => p.take(),
            LeafIter::Run(r) => r.next().copied(),
        }
    }
}

#[cfg(test)]
mod tests {
    //! The walk on a small hand-built tree, small enough for Miri (which
    //! checks the uninitialised traversal stack): `cargo +nightly miri test
    //! -p kdray-kernel --lib -- triangle_tree::walk::`.
    use super::*;
    use crate::blob::Node;
    use crate::geometry::{Axis, Bounds};
    use crate::test_rng::Rng;
    use crate::triangle::{any_hit_brute, closest_hit_brute};
    use crate::ShallowTree;

    #[test]
    fn walk_equals_brute_force_through_stacked_far_cells() {
        // Four cells along x, [0, .25] [.25, .5] [.5, .75] [.75, 1]: depth 2,
        // so far cells wait on the stack. The triangles straddle the split
        // planes (one lies in x = 0.5) and each leaf lists exactly those
        // its cell's slab touches, so a far cell the walk dropped or popped
        // wrongly loses hits.
        let tri = |x0: f32, x1: f32, y: f32| Triangle {
            v: [[x0, y, 0.1], [x1, y, 0.9], [x1, 1.0 - y, 0.5]],
        };
        let tris = [
            tri(0.1, 0.6, 0.2),
            tri(0.3, 0.9, 0.7),
            tri(0.5, 0.5, 0.1),
            tri(0.05, 0.95, 0.4),
        ];
        let split = |s, c| Node::interior(Axis::X, s, c).unwrap();
        let leaf = |count, at| Node::leaf(count, at).unwrap();
        // x ranges: 0 [.1, .6], 1 [.3, .9], 2 [.5, .5], 3 [.05, .95].
        let prims = [0, 3, 0, 1, 2, 3, 1, 3];
        // Treelet order: root, padding, the root's pair, then both of
        // its children's pairs in the same line.
        let nodes = [
            split(0.5, 2),
            Node::EMPTY_LEAF,
            split(0.25, 4),
            split(0.75, 6),
            leaf(2, 0),
            leaf(4, 2),
            leaf(4, 2),
            leaf(2, 6),
        ];
        let bounds = Bounds {
            min: [0.0; 3],
            max: [1.0; 3],
        };
        let tree = TriangleTree::from_parts(&nodes, &prims, &tris, bounds).unwrap();
        // Depth 2: a stack of two entries walks it (one too few would lose
        // the far cells pushed at depth 1), one is refused.
        let shallow = ShallowTree::<2>::new(tree).unwrap();
        assert!(ShallowTree::<1>::new(tree).is_err());
        // One treelet holds the whole tree (its four leaves fall through
        // to exits); rays walked through it in turns answer as one by one.
        assert_eq!(tree.treelet_count(), 1);
        assert!(tree.treelets_into(&mut []).is_err());
        let mut lines = [crate::Treelet::default(); 2];
        let lined = tree.treelets_into(&mut lines).unwrap();
        let mut rays = [Ray {
            origin: [0.0; 3],
            tmin: 0.0,
            dir: [1.0; 3],
            tmax: f32::INFINITY,
        }; 200];
        let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
        let mut f = || rng.f();
        let mut hits = 0;
        for (k, slot) in rays.iter_mut().enumerate() {
            let origin = [f() * 1.4 - 0.2, f(), f()];
            let mut dir = [f() - 0.5, f() - 0.5, f() - 0.5];
            if k % 5 == 0 {
                dir[0] = 0.0; // parallel to the split planes
            }
            let ray = Ray {
                origin,
                tmin: 0.0,
                dir,
                tmax: f32::INFINITY,
            };
            let want = closest_hit_brute(&tris, &ray);
            hits += usize::from(want.is_hit());
            let any = any_hit_brute(&tris, &ray);
            assert_eq!(tree.closest_hit(&ray).bits(), want.bits(), "{ray:?}");
            assert_eq!(tree.any_hit(&ray), any, "{ray:?}");
            assert_eq!(shallow.closest_hit(&ray).bits(), want.bits(), "{ray:?}");
            assert_eq!(shallow.any_hit(&ray), any, "{ray:?}");
            *slot = ray;
        }
        assert!(
            hits > 20,
            "only {hits} hits: the test would not see a wrong walk"
        );
        let mut scattered = [Hit::MISS; 200];
        lined
            .lined_view()
            .closest_hits_scattered(&rays, &mut scattered);
        for (ray, got) in rays.iter().zip(&scattered) {
            assert_eq!(got.bits(), tree.closest_hit(ray).bits(), "{ray:?}");
        }
        // Shadow rays in the order of their nearby origins, towards one
        // light, some stopped short (`tmax`): remembering the last
        // occluder answers as the walk does, names a triangle that hits,
        // and answers some rays with that triangle alone. `last` starts
        // out of range.
        let mut last = u32::MAX;
        let (mut remembered, mut occluded) = (0, 0);
        for k in 0..300 {
            let origin = [0.02 + f() * 0.1, 0.3 + f() * 0.1, 0.02 + f() * 0.1];
            let light = [1.2, 0.5, 1.1];
            let ray = Ray {
                origin,
                tmin: 1e-4,
                dir: core::array::from_fn(|a| light[a] - origin[a]),
                tmax: if k % 3 == 0 { f() * 0.5 } else { 1.0 },
            };
            let cached = tris.get(last as usize);
            let confirms = cached.is_some_and(|t| any_hit_brute(core::slice::from_ref(t), &ray));
            let want = any_hit_brute(&tris, &ray);
            assert_eq!(tree.any_hit_remembering(&ray, &mut last), want, "{ray:?}");
            if want {
                let tri = tris.get(last as usize).expect("an occluder");
                assert!(any_hit_brute(core::slice::from_ref(tri), &ray), "{ray:?}");
            }
            remembered += usize::from(confirms);
            occluded += usize::from(want);
        }
        assert!(
            remembered > 20 && remembered < occluded,
            "{remembered} of {occluded} occluded rays answered by the last occluder"
        );
    }
}
