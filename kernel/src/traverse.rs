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
//! with one refinement: a child that is an empty cell is never entered nor
//! pushed (both children are read together, so the test is free of a
//! second load), and the loop moves on to the next far cell when neither
//! child holds anything for the ray.
//!
//! "Near" is the child the ray enters first *in t order*: the below child
//! when the direction component is positive or `+0`, the above child when
//! it is negative or `-0`. Taking the sign of `1/d` (an infinity of the
//! right sign for `d = ±0`) makes the rule hold for negative `t` ranges and
//! for rays parallel to the split plane, where `t_split` is `±inf` (the ray
//! stays on one side) or NaN (origin exactly on the plane: NaN fails both
//! tests, so both children are visited over the whole interval).
//!
//! # Exactness
//! The answer must be the brute-force answer bit for bit, yet `t_split`
//! and the triangle's `t` are rounded. So every cell interval is widened by
//! a slack `s` = [`SLACK`] × (the ray's extent through the scene bounds),
//! far above the few ulps of rounding in either: a cell is skipped only when
//! its interval misses the current `[t_min, t_max]` by more than `s`, and a
//! far cell popped after a hit is skipped only when it starts more than `s`
//! beyond the best hit. Triangles are always tested against the ray's own
//! `[tmin, best t]`, never the cell's, so a triangle referenced by several
//! leaves gives the same answer in each, and a hit beyond the current cell
//! never ends the search early. The cost is a few extra cells within
//! `s` of a hit: nothing measurable.

use crate::leaf_lanes::{self, LANE_LEAF_MIN};
use crate::node::Node;
use crate::ray::{Hit, Ray, MISS};
use crate::tree::{Bounds, LeafPrims, TriangleTree, MAX_DEPTH};
use crate::triangle::{ShearedRay, Triangle, TriangleHit};
use core::mem::MaybeUninit;

/// The cell slack relative to the ray's extent through the scene
/// (2^-18 ≈ 3.8e-6, about 32 ulps of the largest `t` in the scene).
pub const SLACK: f32 = 1.0 / 262_144.0;

/// The running closest hit: smallest `t`, then lowest triangle index. The
/// one rule shared by the tree, the packets and brute force.
#[derive(Clone, Copy, Debug)]
pub struct Closest {
    /// The best `t` so far (the ray's `tmax` before any hit): the upper end
    /// of the interval later triangles are tested over.
    pub t: f32,
    /// The best triangle so far, [`MISS`] before any hit.
    pub prim: u32,
    hit: Option<TriangleHit>,
}

impl Closest {
    /// Nothing found yet over `[.., tmax]`.
    #[inline(always)]
    #[must_use]
    pub fn new(tmax: f32) -> Closest {
        Closest {
            t: tmax,
            prim: MISS,
            hit: None,
        }
    }

    /// Tests triangle `prim` and keeps it if it wins.
    #[inline(always)]
    pub fn offer(&mut self, sr: &ShearedRay, tri: &Triangle, prim: u32, tmin: f32) {
        if let Some(h) = sr.intersect(tri, tmin, self.t) {
            self.keep(h, prim);
        }
    }

    /// Keeps hit `h` of triangle `prim` if it wins; `h` was found over
    /// `[tmin, self.t]` (packet lanes call this with their own test's hits).
    #[inline(always)]
    pub(crate) fn keep(&mut self, h: TriangleHit, prim: u32) {
        // h.t <= self.t here, so equal t is the only other case.
        if h.t < self.t || prim < self.prim {
            self.t = h.t;
            self.prim = prim;
            self.hit = Some(h);
        }
    }

    /// The answer.
    #[inline]
    #[must_use]
    pub fn hit(&self) -> Hit {
        match self.hit {
            Some(h) => h.to_hit(self.prim),
            None => Hit::MISS,
        }
    }
}

/// A ray clipped to the scene bounds, ready for the traversal loop.
#[derive(Clone, Copy, Debug)]
pub struct CellRay {
    /// The origin.
    pub org: [f32; 3],
    /// `1/dir`, `±inf` for a zero component (sign kept), NaN for a
    /// component whose inverse overflows (`new`).
    pub inv: [f32; 3],
    /// 1 where the ray enters the above child first (`inv < 0`), else 0.
    pub above_first: [u32; 3],
    /// The same three bits (x in bit 0) repeated in each nibble, the form
    /// `Node::first_child` takes.
    pub(crate) above_first_nibbles: u64,
    /// The widened interval over the root cell.
    pub t0: f32,
    /// End of the widened interval over the root cell.
    pub t1: f32,
    /// The slack `s` (module docs).
    pub slack: f32,
}

impl CellRay {
    /// Clips `ray` to `bounds` (slab test), widening by the slack.
    /// `None` when the ray misses the box or is invalid.
    #[inline(always)]
    #[must_use]
    pub fn new(ray: &Ray, sr: &ShearedRay, bounds: &Bounds) -> Option<CellRay> {
        let org = ray.origin;
        // Whole arrays, not element stores in the loop: those were spilled
        // one lane at a time and reloaded whole, a store-forwarding stall
        // per ray (measured: ~4% of a camera-ray trace).
        let inv = ray.dir.map(|d| 1.0 / d);
        let above_first = inv.map(|i| u32::from(i < 0.0));
        let (mut enter, mut exit) = (f32::NEG_INFINITY, f32::INFINITY);
        let mut nearly_parallel = false;
        for a in 0..3 {
            if inv[a].is_infinite() {
                if ray.dir[a] != 0.0 {
                    // |d| so small that 1/d overflows (< 2^-128) is not
                    // parallel: the ray still crosses this axis's planes,
                    // at t = (p - o) / d, which is any size (t = -1 for an
                    // origin and a direction of the same subnormal size; a
                    // proptest found the ray skipping the cell of its
                    // hit). Its slab clips nothing, and its inverse
                    // becomes NaN below.
                    nearly_parallel = true;
                    continue;
                }
                // Parallel to this slab (d = ±0): inside it for all t, or
                // never. (Taking the slab test here would compute
                // 0 * inf = NaN for an origin on a face.)
                if org[a] < bounds.min[a] || org[a] > bounds.max[a] {
                    return None;
                }
                continue;
            }
            let ta = (bounds.min[a] - org[a]) * inv[a];
            let tb = (bounds.max[a] - org[a]) * inv[a];
            // ta and tb are never NaN (finite inv, finite coordinates):
            // plain selects, not f32::min/max's NaN handling.
            enter = Span::max(enter, Span::min(ta, tb));
            exit = Span::min(exit, Span::max(ta, tb));
        }
        // A NaN inverse makes every split plane on a nearly parallel axis
        // visit both children over the whole interval (NaN t_split),
        // written only on this rare branch (a select per component on
        // every ray, or a store into `inv` in the loop, measured no
        // cheaper: camera rays 1.6-2% slower than before the fix either
        // way).
        let inv = if nearly_parallel {
            core::array::from_fn(|a| {
                let tiny = inv[a].is_infinite() && ray.dir[a] != 0.0;
                if tiny {
                    f32::NAN
                } else {
                    inv[a]
                }
            })
        } else {
            inv
        };
        // Slack from the ray's extent through the scene along its dominant
        // axis, which bounds every t the scene's triangles can produce.
        let kz = sr.k[2];
        let zmax = (bounds.min[kz] - org[kz])
            .abs()
            .max((bounds.max[kz] - org[kz]).abs())
            * inv[kz].abs();
        // No finite extent (the dominant component's inverse overflowed
        // too): an infinite slack, every cell visited over every t.
        let slack = SLACK * zmax;
        let slack = if slack.is_nan() { f32::INFINITY } else { slack };
        let t0 = ray.tmin.max(enter) - slack;
        let t1 = ray.tmax.min(exit) + slack;
        if t0 <= t1 {
            Some(CellRay {
                org,
                inv,
                above_first,
                above_first_nibbles: Node::first_child_mask(above_first),
                t0,
                t1,
                slack,
            })
        } else {
            None
        }
    }
}

impl CellRay {
    /// The root cell's interval as the walk keeps intervals: widened by
    /// the slack once more, `[lo, hi] = [t0 - s, t1 + s]` (the slack rule).
    #[inline(always)]
    #[must_use]
    pub fn start(&self) -> (f32, f32) {
        (self.t0 - self.slack, self.t1 + self.slack)
    }
}

/// The slack rule's interval arithmetic, written once for a single ray
/// (`f32`) and for packet lanes (one `f32` per lane): intervals are kept
/// pre-widened, `[lo, hi] = [t0 - s, t1 + s]`, so the visit tests compare
/// `t_split` as computed (`t_split < lo`: near child skipped,
/// `t_split > hi`: far child skipped) and each new end moves by `2s`.
pub(crate) trait Span:
    Copy + core::ops::Add<Output = Self> + core::ops::Sub<Output = Self>
{
    /// The smaller of the two; a NaN `rhs` keeps `self` (`self` is never NaN).
    fn min(self, rhs: Self) -> Self;
    /// The larger of the two; a NaN `rhs` keeps `self` (`self` is never NaN).
    fn max(self, rhs: Self) -> Self;

    /// The near child's interval end: its cell ends at the plane.
    #[inline(always)]
    fn near_hi(self, t_split: Self, s2: Self) -> Self {
        self.min(t_split + s2)
    }

    /// The far child's interval start: its cell starts at the plane.
    #[inline(always)]
    fn far_lo(self, t_split: Self, s2: Self) -> Self {
        self.max(t_split - s2)
    }

    /// Cells whose `lo` lies beyond this (the best hit `self` plus the
    /// slack, widened by the slack) cannot hold a better hit.
    #[inline(always)]
    fn cutoff(self, s2: Self) -> Self {
        self + s2
    }
}

/// Plain selects: the walk's `lo` and `hi` are never NaN and a NaN `rhs`
/// keeps them, which is all of `f32::min`/`max`'s NaN rule the walk needs
/// (those spend three instructions on the rest).
impl Span for f32 {
    #[inline(always)]
    fn min(self, rhs: f32) -> f32 {
        if rhs < self {
            rhs
        } else {
            self
        }
    }
    #[inline(always)]
    fn max(self, rhs: f32) -> f32 {
        if rhs > self {
            rhs
        } else {
            self
        }
    }
}

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

/// A far child waiting on the stack with its interval.
#[derive(Clone, Copy, Debug)]
struct Pending {
    node: u32,
    /// Start of the cell's interval, less the slack.
    lo: f32,
    /// End of the cell's interval, plus the slack.
    hi: f32,
}

// The traversal stack the docs promise: MAX_DEPTH entries of 12 bytes.
const _: () = assert!(core::mem::size_of::<Pending>() * MAX_DEPTH as usize == 768);

/// What the walk does in a non-empty leaf: the closest-hit or the any-hit
/// search. A trait rather than a closure so that the leaf test is inlined
/// into the loop (as a closure it was an out-of-line call per leaf).
trait Visit<'a, T> {
    /// The end of the ray's current interval: cells starting beyond it
    /// (plus the slack) cannot hold a better hit.
    fn bound(&self) -> f32;
    /// Tests the leaf's triangles; `true` when the answer is known.
    fn leaf(&mut self, tris: &'a [Triangle], prims: LeafIter<'a>, tally: &mut T) -> bool;
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
struct ClosestVisit<'r> {
    sr: &'r ShearedRay,
    tmin: f32,
    best: &'r mut Closest,
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
                self.best.offer(self.sr, tri, p, self.tmin);
            }
        }
        false
    }
}

/// The any-hit search: stops at the first triangle hit in `[tmin, tmax]`.
struct AnyVisit<'r> {
    sr: &'r ShearedRay,
    tmin: f32,
    tmax: f32,
}

impl<'a, T: Tally> Visit<'a, T> for AnyVisit<'_> {
    #[inline(always)]
    fn bound(&self) -> f32 {
        self.tmax
    }

    #[inline(always)]
    fn leaf(&mut self, tris: &'a [Triangle], prims: LeafIter<'a>, tally: &mut T) -> bool {
        if let Some(run) = prims.lane_run() {
            tally.triangles(run.len());
            return leaf_lanes::any_x8(self.sr, tris, run, self.tmin, self.tmax);
        }
        for p in prims {
            if let Some(tri) = tris.get(p as usize) {
                tally.triangles(1);
                if self.sr.intersect(tri, self.tmin, self.tmax).is_some() {
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
    ///     kdray_kernel::include_aligned!("../golden/cube-v1.kdt");
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
        self.closest_hit_tallied(ray, &mut ())
    }

    /// [`TriangleTree::closest_hit`], also counting the nodes visited and
    /// triangles tested (for heatmaps and tuning; a little slower).
    #[must_use]
    pub fn closest_hit_counted(&self, ray: &Ray) -> (Hit, TraversalCounts) {
        let mut counts = TraversalCounts::default();
        let hit = self.closest_hit_tallied(ray, &mut counts);
        (hit, counts)
    }

    // Not inlined: the setup and the walk share one frame and one register
    // allocation, whatever loop the caller has (measured faster than
    // inlining into `closest_hits`, and no wide copies of ray structs).
    #[inline(never)]
    fn closest_hit_tallied<T: Tally>(&self, ray: &Ray, tally: &mut T) -> Hit {
        let Some(sr) = ShearedRay::new(ray) else {
            return Hit::MISS;
        };
        let Some(cr) = CellRay::new(ray, &sr, &self.bounds) else {
            return Hit::MISS;
        };
        let mut best = Closest::new(ray.tmax);
        let (lo, hi) = cr.start();
        let start = (0, lo, hi);
        self.closest_from(&sr, &cr, ray.tmin, &mut best, start, tally);
        best.hit()
    }

    /// The closest-hit search of one ray through the subtree at `start` =
    /// `(node, lo, hi)` (interval widened by the slack), into `best`;
    /// triangles are tested over `[tmin, best.t]`. (Packets finish lone
    /// lanes with it.)
    #[inline(always)]
    pub(crate) fn closest_from<T: Tally>(
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
        self.walk(cr, start, tally, &mut visit);
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
    ///     kdray_kernel::include_aligned!("../golden/cube-v1.kdt");
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
        self.any_hit_tallied(ray, &mut ())
    }

    /// [`TriangleTree::any_hit`], also counting the work done.
    #[must_use]
    pub fn any_hit_counted(&self, ray: &Ray) -> (bool, TraversalCounts) {
        let mut counts = TraversalCounts::default();
        let hit = self.any_hit_tallied(ray, &mut counts);
        (hit, counts)
    }

    // Not inlined: see `closest_hit_tallied`.
    #[inline(never)]
    fn any_hit_tallied<T: Tally>(&self, ray: &Ray, tally: &mut T) -> bool {
        let Some(sr) = ShearedRay::new(ray) else {
            return false;
        };
        let Some(cr) = CellRay::new(ray, &sr, &self.bounds) else {
            return false;
        };
        let (lo, hi) = cr.start();
        let start = (0, lo, hi);
        self.any_from(&sr, &cr, (ray.tmin, ray.tmax), start, tally)
    }

    /// The any-hit search of one ray over `[tmin, tmax]` through the
    /// subtree at `start` = `(node, lo, hi)`.
    #[inline(always)]
    pub(crate) fn any_from<T: Tally>(
        &self,
        sr: &ShearedRay,
        cr: &CellRay,
        (tmin, tmax): (f32, f32),
        start: (u32, f32, f32),
        tally: &mut T,
    ) -> bool {
        let mut visit = AnyVisit { sr, tmin, tmax };
        self.walk(cr, start, tally, &mut visit)
    }

    /// The traversal loop: `visit` sees each non-empty leaf's primitives,
    /// in front-to-back order of cells. `true` when `visit` stopped it.
    #[inline(always)]
    fn walk<T, V>(&self, cr: &CellRay, start: (u32, f32, f32), tally: &mut T, visit: &mut V) -> bool
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
        let mut stack = [MaybeUninit::<Pending>::uninit(); MAX_DEPTH as usize];
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
                // Empty children are skipped here, at their parent (~4.6 of
                // the ~28 steps of a camera ray through the bunny were such
                // cells).
                let Some((near, far, second)) = self.children(node, cr.above_first_nibbles) else {
                    return false;
                };
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
                let (visit_near, visit_far) = (!(t_split < lo), !(t_split > hi));
                let visit_far = visit_far & !far.is_empty_leaf();
                // Push the far child unconditionally; keep it only when both
                // children are visited.
                let Some(slot) = stack.get_mut(sp) else {
                    return false; // deeper than MAX_DEPTH: only an unchecked, invalid blob
                };
                let far_lo = lo.far_lo(t_split, s2);
                slot.write(Pending {
                    node: second as u32,
                    lo: far_lo,
                    hi,
                });
                // Branches, not selects: coherent rays take the same side at
                // the same node, so they predict well. Tried conditional moves
                // (mask selects of node, lo, hi): 25-30% slower on bunny
                // camera rays, the same on random rays.
                if visit_near & !near.is_empty_leaf() {
                    sp += usize::from(visit_far);
                    node = near;
                    hi = hi.near_hi(t_split, s2);
                    continue;
                }
                if visit_far {
                    node = far;
                    lo = far_lo;
                    continue;
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
    //! -p kdray-kernel traverse`.
    use super::*;
    use crate::node::{Axis, Node};
    use crate::triangle::{any_hit_brute, closest_hit_brute};

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
        let nodes = [
            split(0.5, 1),
            split(0.25, 3),
            split(0.75, 5),
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
        let mut seed = 0x9E37_79B9_7F4A_7C15u64;
        let mut f = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 40) as f32 / (1u64 << 24) as f32
        };
        let mut hits = 0;
        for k in 0..200 {
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
            assert_eq!(tree.closest_hit(&ray).bits(), want.bits(), "{ray:?}");
            assert_eq!(tree.any_hit(&ray), any_hit_brute(&tris, &ray), "{ray:?}");
        }
        assert!(
            hits > 20,
            "only {hits} hits: the test would not see a wrong walk"
        );
    }
}
