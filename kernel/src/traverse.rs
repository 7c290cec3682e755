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

use crate::ray::{Hit, Ray, MISS};
use crate::tree::{Bounds, LeafPrims, TriangleTree, MAX_DEPTH};
use crate::triangle::{ShearedRay, Triangle, TriangleHit};

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
    /// `1/dir`, `±inf` for a zero component (sign kept).
    pub inv: [f32; 3],
    /// 1 where the ray enters the above child first (`inv < 0`), else 0.
    pub above_first: [u32; 3],
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
    #[inline]
    #[must_use]
    pub fn new(ray: &Ray, sr: &ShearedRay, bounds: &Bounds) -> Option<CellRay> {
        let org = ray.origin;
        let mut inv = [0.0; 3];
        let mut above_first = [0; 3];
        let (mut enter, mut exit) = (f32::NEG_INFINITY, f32::INFINITY);
        for a in 0..3 {
            inv[a] = 1.0 / ray.dir[a];
            above_first[a] = u32::from(inv[a] < 0.0);
            if ray.dir[a] == 0.0 {
                // Parallel to this slab: inside it for all t, or never.
                if org[a] < bounds.min[a] || org[a] > bounds.max[a] {
                    return None;
                }
                continue;
            }
            let ta = (bounds.min[a] - org[a]) * inv[a];
            let tb = (bounds.max[a] - org[a]) * inv[a];
            enter = enter.max(ta.min(tb));
            exit = exit.min(ta.max(tb));
        }
        // Slack from the ray's extent through the scene along its dominant
        // axis, which bounds every t the scene's triangles can produce.
        let kz = sr.k[2];
        let zmax = (bounds.min[kz] - org[kz])
            .abs()
            .max((bounds.max[kz] - org[kz]).abs())
            * inv[kz].abs();
        let slack = SLACK * zmax;
        let t0 = ray.tmin.max(enter) - slack;
        let t1 = ray.tmax.min(exit) + slack;
        if t0 <= t1 {
            Some(CellRay {
                org,
                inv,
                above_first,
                t0,
                t1,
                slack,
            })
        } else {
            None
        }
    }
}

/// A far child waiting on the stack with its interval.
#[derive(Clone, Copy, Debug, Default)]
struct Pending {
    node: u32,
    t0: f32,
    t1: f32,
}

/// What a leaf visitor tells the walk.
enum Step {
    /// Keep going; skip cells starting after this `t` (the best hit plus slack).
    Continue(f32),
    /// The answer is known.
    Stop,
}

impl<'a> TriangleTree<'a> {
    /// The closest hit of `ray` in `[tmin, tmax]`: the smallest `t`, and at
    /// equal `t` the lowest triangle index, exactly as
    /// [`closest_hit_brute`](crate::closest_hit_brute) over all triangles.
    /// [`Hit::MISS`] for a miss or an invalid ray.
    ///
    /// # Panics
    /// Never. No allocation; the stack is [`MAX_DEPTH`] entries.
    #[inline]
    #[must_use]
    pub fn closest_hit(&self, ray: &Ray) -> Hit {
        let Some(sr) = ShearedRay::new(ray) else {
            return Hit::MISS;
        };
        let Some(cr) = CellRay::new(ray, &sr, &self.bounds) else {
            return Hit::MISS;
        };
        let mut best = Closest::new(ray.tmax);
        self.closest_from(&sr, &cr, ray.tmin, &mut best, (0, cr.t0, cr.t1));
        best.hit()
    }

    /// Does any triangle hit `ray` in `[tmin, tmax]`? Exactly when
    /// [`any_hit_brute`](crate::any_hit_brute) says so.
    ///
    /// # Panics
    /// Never. No allocation; the stack is [`MAX_DEPTH`] entries.
    #[inline]
    #[must_use]
    pub fn any_hit(&self, ray: &Ray) -> bool {
        let Some(sr) = ShearedRay::new(ray) else {
            return false;
        };
        let Some(cr) = CellRay::new(ray, &sr, &self.bounds) else {
            return false;
        };
        self.any_from(&sr, &cr, (ray.tmin, ray.tmax), (0, cr.t0, cr.t1))
    }

    /// The closest-hit search of one ray through the subtree at `start`
    /// `(node, t0, t1)`, into `best`; triangles are tested over
    /// `[tmin, best.t]`. (Packets finish lone lanes with it.)
    #[inline(always)]
    pub(crate) fn closest_from(
        &self,
        sr: &ShearedRay,
        cr: &CellRay,
        tmin: f32,
        best: &mut Closest,
        start: (u32, f32, f32),
    ) {
        self.walk(cr, start, |tris, prims| {
            for p in prims {
                if let Some(tri) = tris.get(p as usize) {
                    best.offer(sr, tri, p, tmin);
                }
            }
            Step::Continue(best.t)
        });
    }

    /// The any-hit search of one ray over `[tmin, tmax]` through the
    /// subtree at `start` `(node, t0, t1)`.
    #[inline(always)]
    pub(crate) fn any_from(
        &self,
        sr: &ShearedRay,
        cr: &CellRay,
        (tmin, tmax): (f32, f32),
        start: (u32, f32, f32),
    ) -> bool {
        let mut found = false;
        self.walk(cr, start, |tris, prims| {
            for p in prims {
                if tris
                    .get(p as usize)
                    .is_some_and(|tri| sr.intersect(tri, tmin, tmax).is_some())
                {
                    found = true;
                    return Step::Stop;
                }
            }
            Step::Continue(tmax)
        });
        found
    }

    /// The traversal loop from `start` = (node, t0, t1). `leaf` is called
    /// with the triangles and each leaf's primitives, in front-to-back
    /// order of cells.
    #[inline(always)]
    fn walk<F>(&self, cr: &CellRay, start: (u32, f32, f32), mut leaf: F)
    where
        F: FnMut(&'a [Triangle], LeafIter<'a>) -> Step,
    {
        let s = cr.slack;
        let mut stack = [Pending::default(); MAX_DEPTH as usize];
        let mut sp = 0usize;
        let (mut node_idx, mut t0, mut t1) = start;
        loop {
            let Some(&node) = self.nodes.get(node_idx as usize) else {
                return;
            };
            let axis = node.axis_bits();
            if axis < 3 {
                // Compute parametric distance along ray to split plane.
                let t_split = (node.split() - cr.org[axis]) * cr.inv[axis];
                let first = node.upper() + cr.above_first[axis];
                let second = node.upper() + 1 - cr.above_first[axis];
                if t_split - s > t1 {
                    // Plane beyond the interval: near child only.
                    node_idx = first;
                } else if t_split + s < t0 {
                    // Plane before the interval: far child only.
                    node_idx = second;
                } else {
                    // Both: push the far child, continue with the near one.
                    let Some(slot) = stack.get_mut(sp) else {
                        return; // deeper than MAX_DEPTH: only an unchecked, invalid blob
                    };
                    *slot = Pending {
                        node: second,
                        t0: t0.max(t_split - s),
                        t1,
                    };
                    sp += 1;
                    node_idx = first;
                    t1 = t1.min(t_split + s);
                }
                continue;
            }
            // A leaf: test its triangles against the ray's own interval.
            // Cells starting after `cutoff` are behind the best hit.
            let cutoff = match leaf(self.triangles, LeafIter::new(self.leaf_prims(node))) {
                Step::Stop => return,
                Step::Continue(best_t) => best_t + s,
            };
            // Advance to the next far cell that can still hold a better hit.
            loop {
                if sp == 0 {
                    return;
                }
                sp -= 1;
                let p = stack[sp];
                if p.t0 <= cutoff {
                    (node_idx, t0, t1) = (p.node, p.t0, p.t1.min(cutoff));
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
