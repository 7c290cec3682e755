//! The watertight edge test (Woop, Benthin and Wald 2013): the ray
//! sheared once to run along +z, each triangle projected with the same
//! shear and tested by the signs of three 2-D edge functions, recomputed in
//! `f64` when one rounds to zero.

use super::exact_t::{exact_t_hits, plane_t, sure_hit, t_window};
use super::Triangle;
use crate::geometry::{ray_is_valid, Hit, Ray};

/// A ray prepared for the watertight test: its origin, the axis permutation
/// that makes z the dominant direction axis, and the shear constants.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ShearedRay {
    /// The ray origin.
    pub(crate) org: [f32; 3],
    /// The ray direction (for the `f64` `t`, [`plane_t`]).
    pub(crate) dir: [f32; 3],
    /// The permuted axes `[kx, ky, kz]`; `kz` is the dominant axis of the
    /// direction, and `kx, ky` are swapped when `dir[kz] < 0` to keep the
    /// winding of the projected triangle.
    pub(crate) k: [usize; 3],
    /// Shear constants `[dir[kx]/dir[kz], dir[ky]/dir[kz], 1/dir[kz]]`.
    pub(crate) s: [f32; 3],
}

/// A hit of one triangle before the barycentrics are divided out: only the
/// winner of a closest-hit search pays for those two divisions.
#[derive(Clone, Copy, Debug)]
pub(crate) struct TriangleHit {
    /// Ray parameter of the hit.
    pub(crate) t: f32,
    /// Edge function weighting vertex 1.
    pub(crate) v: f32,
    /// Edge function weighting vertex 2.
    pub(crate) w: f32,
    /// Sum of the three edge functions.
    pub(crate) det: f32,
}

impl TriangleHit {
    /// The hit record of triangle `prim`.
    #[inline]
    #[must_use]
    pub(crate) fn to_hit(self, prim: u32) -> Hit {
        Hit {
            t: self.t,
            prim,
            u: self.v / self.det,
            v: self.w / self.det,
        }
    }
}

/// The index of the largest `|dir|` component; ties go to the lower axis.
#[inline]
pub(crate) fn dominant_axis(dir: &[f32; 3]) -> usize {
    let a = [dir[0].abs(), dir[1].abs(), dir[2].abs()];
    if a[0] >= a[1] && a[0] >= a[2] {
        0
    } else if a[1] >= a[2] {
        1
    } else {
        2
    }
}

impl ShearedRay {
    /// Prepares `ray`, or `None` for a ray that hits nothing by
    /// [`ray_is_valid`].
    #[inline]
    #[must_use]
    pub(crate) fn new(ray: &Ray) -> Option<ShearedRay> {
        if !ray_is_valid(ray) {
            return None;
        }
        // Read in place: a local copy indexed by the permuted axes is
        // spilled, and reloading it across the copy's stores stalls
        // store forwarding (measured: ~9% of an 8-wide packet trace).
        let d = &ray.dir;
        let kz = dominant_axis(d);
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if d[kz] < 0.0 {
            core::mem::swap(&mut kx, &mut ky);
        }
        Some(ShearedRay {
            org: ray.origin,
            dir: ray.dir,
            k: [kx, ky, kz],
            s: [d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]],
        })
    }

    /// The watertight test of `tri` against this ray over `[tmin, tmax]`,
    /// with the accurate `t` of the module docs.
    #[inline(always)]
    #[must_use]
    pub(crate) fn intersect(&self, tri: &Triangle, tmin: f32, tmax: f32) -> Option<TriangleHit> {
        let (e, window, _) = self.window(tri, tmin, tmax)?;
        let t = plane_t(&self.org, &self.dir, tri);
        exact_t_hits(t, window, tmin, tmax).then_some(TriangleHit { t, ..e })
    }

    /// Does `tri` hit this ray within `[tmin, tmax]`? The answer
    /// [`ShearedRay::intersect`] gives, without the `f64` `t` when the
    /// estimate's window lies inside the interval.
    #[inline(always)]
    #[must_use]
    pub(crate) fn intersects(&self, tri: &Triangle, tmin: f32, tmax: f32) -> bool {
        let Some((_, window, sure)) = self.window(tri, tmin, tmax) else {
            return false;
        };
        sure || exact_t_hits(plane_t(&self.org, &self.dir, tri), window, tmin, tmax)
    }

    /// The edge test and the `t` window of `tri` over `[tmin, tmax]`: the
    /// edge functions (the estimate in the hit's `t`), the window `(lo,
    /// hi)` and whether it is a hit whatever its `f64` `t` ([`sure_hit`]);
    /// `None` for a miss or a window clearly outside the interval (no
    /// `f64` `t` needed; a NaN window rejects nothing).
    #[inline(always)]
    pub(crate) fn window(
        &self,
        tri: &Triangle,
        tmin: f32,
        tmax: f32,
    ) -> Option<(TriangleHit, (f32, f32), bool)> {
        self.window_by::<false>(tri, tmin, tmax)
    }

    /// The crossing test of `tri` over `[tmin, tmax]`: [`ShearedRay::intersect`]
    /// with the strict fill rule on edges the ray passes exactly through
    /// ([`ShearedRay::edges`]), so a ray through an edge or a vertex of a
    /// closed mesh crosses it once.
    #[inline(always)]
    #[must_use]
    pub(crate) fn crossing(&self, tri: &Triangle, tmin: f32, tmax: f32) -> Option<TriangleHit> {
        let (e, window, _) = self.window_by::<true>(tri, tmin, tmax)?;
        let t = plane_t(&self.org, &self.dir, tri);
        exact_t_hits(t, window, tmin, tmax).then_some(TriangleHit { t, ..e })
    }

    /// `+1` if the ray crosses `tri` at `t >= 0` (by
    /// [`ShearedRay::crossing`]) along the triangle's normal
    /// `(v1 - v0) x (v2 - v0)`, `-1` against it, 0 if it does not cross:
    /// the sign of the crossing's determinant, exact under the strict fill
    /// rule.
    #[must_use]
    pub(crate) fn crossing_sign(&self, tri: &Triangle) -> i32 {
        match self.crossing(tri, 0.0, f32::INFINITY) {
            Some(h) if h.det < 0.0 => 1,
            Some(_) => -1,
            None => 0,
        }
    }

    /// [`ShearedRay::window`], by the crossing rule when `CROSSING`.
    #[inline(always)]
    fn window_by<const CROSSING: bool>(
        &self,
        tri: &Triangle,
        tmin: f32,
        tmax: f32,
    ) -> Option<(TriangleHit, (f32, f32), bool)> {
        let (e, (t_est, slack, shape)) = self.edges::<CROSSING>(tri)?;
        let (lo, hi) = (t_est - slack, t_est + slack);
        if hi < tmin || lo > tmax {
            return None;
        }
        Some((e, (lo, hi), sure_hit((lo, hi), shape, tmin, tmax)))
    }

    /// The watertight decision: the edge functions and determinant of a
    /// ray that passes through `tri` (with its `t` estimate left in the
    /// hit, unused) and the estimate's window, or `None` for a miss.
    ///
    /// With `CROSSING`, an edge function that is exactly zero (the ray
    /// passes through that edge's line) takes the sign it would have were
    /// the ray moved by an infinitesimal `(ε², ε)` in the sheared plane:
    /// the sign of `first.x - second.x`, or if that is zero of
    /// `second.y - first.y`, for the edge's two projected vertices in the
    /// order its edge function names them. Two triangles sharing an edge
    /// see it in opposite orders, so when they lie on either side of it
    /// the moved ray passes through exactly one of them; around a shared
    /// vertex it passes through exactly one triangle of a fan that covers
    /// it; along a silhouette (both on one side) through both or neither.
    /// So a ray crosses a closed mesh an odd number of times exactly when
    /// its origin lies inside (for the inside test: `triangle_tree::inside`).
    #[inline(always)]
    fn edges<const CROSSING: bool>(
        &self,
        tri: &Triangle,
    ) -> Option<(TriangleHit, (f32, f32, f32))> {
        // Clamped as in leaf_lanes: the axes are below 3 by construction,
        // but the optimiser cannot see it through the field, and a bounds
        // check is a panic path (firmware/); the clamps are hoisted out of
        // the leaf loop. Spelled out: at opt-level "s" a `map` closure is
        // not inlined and the clamps are lost.
        let [kx, ky, kz] = [self.k[0].min(2), self.k[1].min(2), self.k[2].min(2)];
        let [sx, sy, sz] = self.s;
        let org = [self.org[kx], self.org[ky], self.org[kz]];
        // Vertices relative to the origin, then sheared so the ray is +z.
        // Read by permuted index straight from the triangle: a local copy
        // indexed by `k` would be spilled and reloaded through store
        // forwarding for every vertex (measured in the leaf loop).
        let rel = |p: &[f32; 3]| {
            let (x, y, z) = (p[kx] - org[0], p[ky] - org[1], p[kz] - org[2]);
            (x - sx * z, y - sy * z, z)
        };
        let (ax, ay, az) = rel(&tri.v[0]);
        let (bx, by, bz) = rel(&tri.v[1]);
        let (cx, cy, cz) = rel(&tri.v[2]);
        // 2-D edge functions: u weighs vertex 0, v vertex 1, w vertex 2.
        let mut u = cx * by - cy * bx;
        let mut v = ax * cy - ay * cx;
        let mut w = bx * ay - by * ax;
        // `|` and `&`: all three signs are tested, no early exit (a NaN
        // edge function passes both tests, then fails on det).
        if (u == 0.0) | (v == 0.0) | (w == 0.0) {
            [u, v, w] = edge_functions_f64([ax, ay, bx, by, cx, cy]);
        }
        let negative = (u < 0.0) | (v < 0.0) | (w < 0.0);
        let positive = (u > 0.0) | (v > 0.0) | (w > 0.0);
        // Tried: every condition below folded into one branch: 12% slower,
        // the early exits pay.
        if negative & positive {
            return None;
        }
        let det = u + v + w;
        // A zero determinant is a ray in the triangle's plane; an infinite
        // one means the edge functions overflowed (coordinates beyond
        // MAX_COORD), and their signs mean nothing.
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        if CROSSING && ((u == 0.0) | (v == 0.0) | (w == 0.0)) {
            let inside = det > 0.0;
            // The moved ray's side of the edge `first -> second` whose
            // edge function is `f` (module docs): coordinate differences
            // of `f32` values have exact signs.
            let owns = |f: f32, first: (f32, f32), second: (f32, f32)| {
                if f != 0.0 {
                    return true;
                }
                let positive = if first.0 != second.0 {
                    first.0 > second.0
                } else if first.1 != second.1 {
                    second.1 > first.1
                } else {
                    return false;
                };
                positive == inside
            };
            let (a, b, c) = ((ax, ay), (bx, by), (cx, cy));
            if !(owns(u, b, c) & owns(v, c, a) & owns(w, a, b)) {
                return None;
            }
        }
        let window = t_window([ax, ay, bx, by, cx, cy], [az, bz, cz], [u, v, w], det, sz);
        Some((
            TriangleHit {
                t: window.0,
                v,
                w,
                det,
            },
            window,
        ))
    }
}

/// The three edge functions in `f64`, rounded back: exact signs where the
/// `f32` products cancelled to zero. Inputs: `[ax, ay, bx, by, cx, cy]`.
#[inline(never)]
#[cold]
#[must_use]
pub(crate) fn edge_functions_f64(p: [f32; 6]) -> [f32; 3] {
    let [ax, ay, bx, by, cx, cy] = p.map(f64::from);
    [
        (cx * by - cy * bx) as f32,
        (ax * cy - ay * cx) as f32,
        (bx * ay - by * ax) as f32,
    ]
}
