//! The watertight ray/triangle test of Woop, Benthin and Wald, "Watertight
//! Ray/Triangle Intersection", JCGT 2(1), 2013.
//!
//! The ray is transformed once ([`ShearedRay::new`]) so that it runs along
//! +z from the origin; each triangle is then projected with the same shear
//! and tested by the signs of three 2-D edge functions. Two triangles that
//! share an edge compute that edge's function from the same two projected
//! vertices, bit for bit, so a ray through the edge (or a shared vertex)
//! sees it from both sides and cannot slip between them. When an edge
//! function rounds to exactly zero it is recomputed in `f64`, as the paper
//! prescribes, so its sign is exact.
//!
//! # Where `t` comes from
//! The edge functions decide hit or miss; they do not give an accurate `t`.
//! Interpolating the sheared vertex heights by them cancels badly when the
//! triangle is large beside the distance to its hit (a floor of 1000 units
//! hit 1.5 units from the eye: 1e-4 relative error) or nearly parallel to
//! the ray, and its sign near `t = 0` is noise (a ray leaving a surface
//! misses it as often as not). So `t` is computed twice:
//! 1. an `f32` estimate from the edge functions with a conservative bound
//!    on its error ([`t_window`]): it rejects the triangles that clearly lie
//!    outside `[tmin, tmax]` (behind the origin, beyond the best hit so far)
//!    and accepts, for an any-hit query, those clearly inside;
//! 2. for the others, the plane's `t = n·(v0 - o) / n·d` in `f64`
//!    ([`plane_t`]), rounded once to `f32`: within an ulp or two of the
//!    correctly rounded `t` wherever the hit is well conditioned, and
//!    exactly `0` when the origin lies on the triangle's plane within the
//!    `f64` rounding of that formula, so a ray starting on a triangle with
//!    `tmin <= 0` hits it at `t = 0`.
//!
//! The window is wide enough (16 times the error the analysis bounds) that
//! it holds the `f64` `t` of every hit whose point lies in the triangle's
//! box; a `t` outside it is no hit ([`exact_t_hits`]). So the answer is
//! one function of the window and the `f64` `t`, whatever `[tmin, tmax]`
//! and the order triangles are tested in.
//!
//! # Coordinate range
//! The edge functions are products of coordinate differences in `f32`; they
//! stay finite while every vertex coordinate and the ray origin lie within
//! `±`[`MAX_COORD`] (2^60). The builders refuse triangles outside it. A ray
//! whose origin lies outside it gets a defined answer (tree, packets and
//! brute force agree bit for bit, nothing panics), but a triangle whose
//! edge functions overflow is missed. At the small end, a triangle whose
//! projected edge products underflow `f32` (edges below about 2^-63 units
//! seen from the ray) is missed too.
//!
//! This single function defines every answer kdray gives: the tree, the
//! packets and the brute-force oracle all call it (or its lane-wise twin,
//! which performs the same operations in the same order).

mod brute;
mod closest;
mod first;
pub(crate) mod lanes;
#[cfg(target_arch = "x86_64")]
mod plane_x86;
mod point;
mod spawn;

pub(crate) use brute::offer_every_triangle;
pub use brute::{any_hit_brute, closest_hit_brute, crossings_brute, first_hits_brute};
pub(crate) use closest::Closest;
pub(crate) use first::{FirstHits, Ranked};
pub(crate) use point::{box_distance2, NearestTriangle};
pub use point::{closest_point_brute, ClosestPoint};
pub use spawn::SurfacePoint;

use crate::geometry::{next_down, next_up, ray_is_valid, Bounds, Hit, Ray};
use crate::lanes::{dispatch, Job, Lanes, Level, Real};
use bytemuck::{Pod, Zeroable};

/// The largest vertex coordinate magnitude the watertight test handles:
/// 2^60 (about 1.15e18). With every coordinate of the triangle and of the
/// ray origin within `±MAX_COORD`, a sheared coordinate is below `4 ·
/// MAX_COORD`, an edge function below `32 · MAX_COORD²` and their sum
/// below `96 · MAX_COORD² < f32::MAX`: no product overflows.
pub const MAX_COORD: f32 = 1_152_921_504_606_846_976.0;

/// A triangle: three vertices. `repr(C)`, Pod, 36 bytes; the blob stores
/// triangles in this layout, in mesh order.
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
#[repr(C)]
pub struct Triangle {
    /// Vertices 0, 1, 2.
    pub v: [[f32; 3]; 3],
}

const _: () = assert!(core::mem::size_of::<Triangle>() == 36);

impl Triangle {
    /// The smallest box holding the triangle.
    #[inline]
    #[must_use]
    pub fn bounds(&self) -> Bounds {
        let [p, q, r] = self.v;
        Bounds {
            min: core::array::from_fn(|a| p[a].min(q[a]).min(r[a])),
            max: core::array::from_fn(|a| p[a].max(q[a]).max(r[a])),
        }
    }

    /// The box every hit the triangle test accepts lies in, for a ray
    /// from the origin: [`Triangle::bounds`] with each face moved out by
    /// `2^-18 (|lo| + |hi|)` of its axis (the test's margin for rounding,
    /// which on a huge sliver reaches far past its short end), rounded
    /// outwards. A ray from `o` may hit up to `2^-18 |o|` further out,
    /// which no fixed box holds. A builder that lists a triangle in every
    /// cell this box overlaps lets the walk find the hits brute force
    /// takes where the `f32` edge test passes by rounding far from the
    /// triangle (a huge sliver's short end: `tests/fuzz_regressions.rs`).
    #[must_use]
    pub fn hit_bounds(&self) -> Bounds {
        let b = self.bounds();
        let mut out = b;
        for a in 0..3 {
            let (lo, hi) = widen(f64::from(b.min[a]), f64::from(b.max[a]), 0.0);
            out.min[a] = next_down(lo as f32);
            out.max[a] = next_up(hi as f32);
        }
        out
    }

    /// Are all nine coordinates finite?
    #[inline]
    #[must_use]
    pub fn is_finite(&self) -> bool {
        self.v.iter().flatten().all(|c| c.is_finite())
    }

    /// Are all nine coordinates within `±`[`MAX_COORD`] (and so finite)?
    #[inline]
    #[must_use]
    pub fn in_range(&self) -> bool {
        self.v.iter().flatten().all(|c| c.abs() <= MAX_COORD)
    }

    /// The geometric normal `(v1 - v0) × (v2 - v0)`, not normalised (zero
    /// for a degenerate triangle).
    #[inline]
    #[must_use]
    pub fn normal(&self) -> [f32; 3] {
        let [a, b, c] = self.v;
        let e1 = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let e2 = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
        [
            e1[1] * e2[2] - e1[2] * e2[1],
            e1[2] * e2[0] - e1[0] * e2[2],
            e1[0] * e2[1] - e1[1] * e2[0],
        ]
    }
}

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

/// The verdict on [`plane_t`]'s `t` for a triangle whose edge test passed
/// with the window `(lo, hi)`: finite, within `[tmin, tmax]`, and within
/// the window (a NaN window holds every `t`).
///
/// The window holds every `t` that [`plane_t`] computes before its box
/// clamp; the clamp moves a `t` whose point lies outside the triangle's
/// box (an edge test passed by rounding) into the box, possibly outside
/// the window, and such a `t` is no hit. So the answer is one function of
/// the window and `t`, and the window's early rejection (outside `[tmin,
/// tmax]`) only skips work: without this, a triangle rejected by its
/// window under a tight `tmax` could be hit under a wider one, and the
/// answer would depend on the order triangles are tested in.
#[inline(always)]
pub(crate) fn exact_t_hits(t: f32, (lo, hi): (f32, f32), tmin: f32, tmax: f32) -> bool {
    t >= tmin && t <= tmax && t.is_finite() && !(t < lo || t > hi)
}

/// Is a triangle whose edge test passed with the window `(lo, hi)` and
/// conditioning `shape` ([`t_window`]) a hit over `[tmin, tmax]` whatever
/// its `f64` `t`? When the window lies inside the interval and the
/// triangle is well shaped ([`WELL_SHAPED`]): [`plane_t`]'s `t` then lies
/// in the window, so [`exact_t_hits`] holds (the window finite at both
/// ends: an infinite `t` is no hit). An any-hit test stops there;
/// a closest-hit search defers the `f64` `t` ([`Closest`]).
#[inline(always)]
pub(crate) fn sure_hit((lo, hi): (f32, f32), shape: f32, tmin: f32, tmax: f32) -> bool {
    lo >= tmin && hi <= tmax && -f32::INFINITY < lo && hi < f32::INFINITY && shape < WELL_SHAPED
}

/// The window's scale on the sheared shape's conditioning, `2^-12`: the
/// analysis below bounds the error by `2^-16.2` of that term.
const WINDOW_SHAPE: f32 = 1.0 / 4096.0;
/// The window's scale on the heights, `2^-18`: the rounding of the
/// barycentric sum and of the products bounds it by `2^-20.3`.
const WINDOW_HEIGHT: f32 = 1.0 / 262_144.0;

/// The window's absolute term, `2^-140`, in each of its parts and on `t`
/// itself: the analysis above is relative, and products that fall below
/// `f32`'s normal range (an origin `1e-40` off a triangle's plane, edge
/// functions of a tiny triangle, a height times a tiny `sz` rounding to
/// zero) round with an absolute error of `2^-150` instead; this covers a
/// thousand such roundings.
const WINDOW_UNDERFLOW: f32 = f32::from_bits(1 << 9); // 2^9 times the least subnormal, 2^-149

/// The `f32` estimate of `t` from the sheared vertices (`xy`: `[ax, ay,
/// bx, by, cx, cy]`, `z`: their heights), their edge functions `uvw`
/// (one sign, sum `det`, nonzero) and the shear's `sz = 1/d[kz]`; with a
/// bound on its distance to [`plane_t`]: `(t_est, slack, shape)`, where
/// `shape = 2^-12 · M (M + Z) / |det|` says how well the `f32` determinant
/// stands above its rounding (see [`WELL_SHAPED`]).
///
/// The bound (for each lane alike, the operations in one order): a
/// sheared coordinate is off by at most `2^-22 (M + Z)`, with `M` the
/// largest sheared `|x|, |y|` and `Z` the largest `|z|`; an edge function
/// by `2^-19.8 M (M + Z)`, a barycentric weight by four of those over
/// `|det|`. The weights sum to 1 within `2^-21`, so their errors move `t`
/// by at most `2^-16.2 · M (M + Z) / |det| · (zmax - zmin) |sz|` plus
/// `2^-20.3 · Z |sz|` for the sum's and the heights' rounding and the
/// `f64` `t`'s own. Overflow (huge coordinates, near-parallel rays) makes
/// the window infinite or NaN: it then rejects nothing.
#[inline(always)]
pub(crate) fn t_window<S: Real>(xy: [S; 6], z: [S; 3], uvw: [S; 3], det: S, sz: S) -> (S, S, S) {
    let [ax, ay, bx, by, cx, cy] = xy;
    let [az, bz, cz] = z;
    let [u, v, w] = uvw;
    let rdet = S::splat(1.0) / det;
    let t_est = ((u * rdet) * az + (v * rdet) * bz + (w * rdet) * cz) * sz;
    let m = ax
        .abs()
        .max(ay.abs())
        .max(bx.abs())
        .max(by.abs())
        .max(cx.abs())
        .max(cy.abs());
    let (zmax, zmin) = (az.max(bz).max(cz), az.min(bz).min(cz));
    let zabs = zmax.max(S::splat(0.0) - zmin);
    let asz = sz.abs();
    let shape = (m * (m + zabs) * S::splat(WINDOW_SHAPE) + S::splat(WINDOW_UNDERFLOW)) * rdet.abs();
    let slack = shape * ((zmax - zmin) * asz)
        + (zabs * S::splat(WINDOW_HEIGHT) + S::splat(WINDOW_UNDERFLOW)) * asz
        + S::splat(WINDOW_UNDERFLOW);
    (t_est, slack, shape)
}

/// An any-hit test takes a window inside `[tmin, tmax]` without the `f64`
/// `t` only when `shape` is below this (16): the determinant is then more
/// than `2^-16 M (M + Z)`, many times its own rounding, so the triangle is
/// no sliver of rounding noise and the ray not in its plane, and
/// [`plane_t`] gives a number (a degenerate triangle can pass the `f32`
/// edge test by rounding, and [`plane_t`] rejects it).
pub(crate) const WELL_SHAPED: f32 = 16.0;

/// The ray parameter where `org + t dir` meets the plane of `tri`:
/// `n·(v0 - org) / n·dir` with `n = (v1 - v0) × (v2 - v0)`, in `f64`
/// from the `f32` inputs, rounded once to `f32`.
///
/// Within [`noise_bound`] of zero the numerator is taken as zero: the
/// origin lies on the plane within the formula's `f64` rounding, and `t`
/// is `+0`; so is the denominator: the ray runs in the plane, or the
/// triangle is degenerate (its normal is rounding noise), and `t` is NaN:
/// no hit.
///
/// Out of line: inlined at its several callers it grew the firmware's
/// any-hit stack from 908 to 1,044 B (the budget is 1 KiB) and its `.text`
/// by 1.7 KB; on x86-64 the lanes' levels call their own (`plane_x86`).
#[inline(never)]
#[must_use]
pub(crate) fn plane_t(org: &[f32; 3], dir: &[f32; 3], tri: &Triangle) -> f32 {
    let Some(t) = Plane::of(tri).ray_t(&tri.v[0], org, dir) else {
        return f32::NAN;
    };
    // Kept within the ray's interval through the triangle's bounding box,
    // where every point of the triangle lies: for a well-conditioned hit
    // this changes nothing, but where the `f32` edge test passes a huge
    // sliver by rounding, or the origin is snapped onto its plane, the hit
    // point stays in the triangle's box, so in the scene's, and the tree's
    // walk finds it as brute force does (fuzzed rays from outside the
    // scene hit 1e12-long slivers at t = 0 by brute force alone). The box
    // is widened by [`BOX_MARGIN`] for the rounding of `f32` rays aimed at
    // a vertex or an edge; a ray that misses even that box hits nothing.
    if hit_inside_box(t, tri, org, dir) {
        return t as f32;
    }
    box_clamp(t, tri, org, dir)
}

/// [`plane_t`] at the instruction set level of the lane type `V` (the
/// same bits at every level): in AVX2 registers where `V`'s values imply
/// AVX2.
#[inline(always)]
pub(crate) fn plane_t_at<V: Lanes<N>, const N: usize>(
    org: &[f32; 3],
    dir: &[f32; 3],
    tri: &Triangle,
) -> f32 {
    if V::AVX2 {
        // SAFETY: `V::AVX2` holds only for lane types whose values exist
        // only in code run after AVX2 was detected (`crate::lanes::x86`,
        // x86-64 alone), and this is called from code working on them.
        #[cfg(target_arch = "x86_64")]
        return unsafe { plane_x86::plane_t(org, dir, tri) };
    }
    plane_t(org, dir, tri)
}

/// [`plane_t`] at the instruction set level [`crate::cpu::isa`] chose
/// (the same bits at every level), for code outside a lane job.
#[inline]
#[must_use]
pub(crate) fn plane_t_dispatched(org: &[f32; 3], dir: &[f32; 3], tri: &Triangle) -> f32 {
    dispatch(PlaneT { org, dir, tri })
}

/// [`plane_t_dispatched`]'s arguments.
struct PlaneT<'a> {
    org: &'a [f32; 3],
    dir: &'a [f32; 3],
    tri: &'a Triangle,
}

impl Job for PlaneT<'_> {
    type Out = f32;
    #[inline(always)]
    fn run<L: Level>(self) -> f32 {
        plane_t_at::<L::X8, 8>(self.org, self.dir, self.tri)
    }
}

/// [`plane_t`] of each lane's ray against one triangle `tri`, into `t`
/// for the lanes in `lanes` (bit `l` = lane `l`; the others keep their
/// value): `org[axis][lane]`, `dir` likewise. The triangle's part (normal,
/// threshold, box) is formed once; each lane performs [`plane_t`]'s
/// operations in its order, so its bits are the single ray's. Written over
/// arrays without branches up to the clamp, so that the compiler runs the
/// lanes in vector registers (packets against a triangle that several of
/// their rays hit).
#[inline(always)]
pub(crate) fn plane_t_lanes<V: Lanes<N>, const N: usize>(
    org: &[[f32; N]; 3],
    dir: &[[f32; N]; 3],
    tri: &Triangle,
    lanes: u32,
    t: &mut [f32; N],
) {
    let at = |c: &[[f32; N]; 3], l: usize| [c[0][l], c[1][l], c[2][l]];
    if lanes.count_ones() == 1 {
        // One lane: the scalar call is cheaper than all N. (Tried: the
        // lane arrays for one lane too, once they were written by
        // selects: bunny 8-wide tiles 4% faster, 16-wide and the sponza
        // and teapot 0.4-2.5% slower.)
        let l = lanes.trailing_zeros() as usize;
        if let Some(x) = t.get_mut(l) {
            *x = plane_t_at::<V, N>(&at(org, l), &at(dir, l), tri);
        }
        return;
    }
    let plane = Plane::of(tri);
    // Loops over lane arrays, not `array::from_fn`: that stayed out of
    // line, compiled without the level's vector features.
    let mut t64 = [0.0f64; N];
    for (l, x) in t64.iter_mut().enumerate() {
        let ray_t = plane.ray_t(&tri.v[0], &at(org, l), &at(dir, l));
        *x = ray_t.unwrap_or(f64::NAN);
    }
    let mut inside = [false; N];
    let mut all_inside = true;
    for (l, (inside, &x)) in inside.iter_mut().zip(&t64).enumerate() {
        *inside = hit_inside_box(x, tri, &at(org, l), &at(dir, l));
        all_inside &= *inside | (lanes >> l & 1 == 0);
    }
    if all_inside {
        // Every lane wanted is a plain hit (the common case): its `t`
        // rounded, the others kept, by selects. (A branch per lane on
        // `lanes` and on the box test, as below, was ~60 instructions
        // and mispredicted where the packet's hit lanes vary. Tried: the
        // selects in the box test's loop, the other lanes marked there
        // for the branches: 16-wide tiles 3-5% slower.)
        for (l, (out, &x)) in t.iter_mut().zip(&t64).enumerate() {
            let take = lanes >> l & 1 == 1;
            *out = if take { x as f32 } else { *out };
        }
        return;
    }
    for (l, (out, (&x, &inside))) in t.iter_mut().zip(t64.iter().zip(&inside)).enumerate() {
        if lanes >> l & 1 == 0 {
            continue;
        }
        *out = if inside {
            x as f32
        } else if x.is_nan() {
            // No plane ([`plane_t`]'s early return).
            f32::NAN
        } else {
            box_clamp(x, tri, &at(org, l), &at(dir, l))
        };
    }
}

/// A triangle's plane as [`plane_t`] forms it: the normal `n = (v1 - v0)
/// × (v2 - v0)` in `f64` and its [`normal_magnitudes`] `m`.
#[derive(Clone, Copy)]
struct Plane {
    n: (f64, f64, f64),
    m: (f64, f64, f64),
}

impl Plane {
    /// The plane of `tri`.
    #[inline(always)]
    fn of(tri: &Triangle) -> Plane {
        // Spelled out component by component, each value formed where it
        // is needed: over arrays indexed in loops the compiler kept every
        // `f64` vertex, origin and direction live to the box test,
        // shuffling them through memory (261 instructions a call on
        // x86-64) and, in software floating point, spilling them (a
        // 360-byte frame on thumbv7em).
        let [v0, v1, v2] = &tri.v;
        let f = f64::from;
        let (e1x, e1y, e1z) = (
            f(v1[0]) - f(v0[0]),
            f(v1[1]) - f(v0[1]),
            f(v1[2]) - f(v0[2]),
        );
        let (e2x, e2y, e2z) = (
            f(v2[0]) - f(v0[0]),
            f(v2[1]) - f(v0[1]),
            f(v2[2]) - f(v0[2]),
        );
        Plane {
            n: (
                e1y * e2z - e1z * e2y,
                e1z * e2x - e1x * e2z,
                e1x * e2y - e1y * e2x,
            ),
            m: normal_magnitudes((e1x, e1y, e1z), (e2x, e2y, e2z)),
        }
    }

    /// The unclamped `t` of [`plane_t`] for the ray `org + t dir` (`v0`
    /// the triangle's vertex 0), `None` when there is no plane.
    /// Branch-free but for the result (the division is always made), so
    /// that lanes of it vectorise.
    #[inline(always)]
    fn ray_t(&self, v0: &[f32; 3], org: &[f32; 3], dir: &[f32; 3]) -> Option<f64> {
        let f = f64::from;
        let (nx, ny, nz) = self.n;
        let (dx, dy, dz) = (f(dir[0]), f(dir[1]), f(dir[2]));
        let den = nx * dx + ny * dy + nz * dz;
        // A NaN bound is no plane either.
        let plane = den.abs() > noise_bound(self.m, (dx, dy, dz));
        let (ax, ay, az) = (
            f(v0[0]) - f(org[0]),
            f(v0[1]) - f(org[1]),
            f(v0[2]) - f(org[2]),
        );
        let num = nx * ax + ny * ay + nz * az;
        let on_plane = num.abs() <= noise_bound(self.m, (ax, ay, az));
        let q = num / den;
        let t = if on_plane { 0.0 } else { q };
        plane.then_some(t)
    }
}

/// Each component of the normal `e1 × e2` with its two products' magnitudes
/// summed, `(|e1y e2z| + |e1z e2y|, ...)`: what that component's rounding
/// scales with.
#[inline(always)]
pub(crate) fn normal_magnitudes(
    (e1x, e1y, e1z): (f64, f64, f64),
    (e2x, e2y, e2z): (f64, f64, f64),
) -> (f64, f64, f64) {
    (
        (e1y * e2z).abs() + (e1z * e2y).abs(),
        (e1z * e2x).abs() + (e1x * e2z).abs(),
        (e1x * e2y).abs() + (e1y * e2x).abs(),
    )
}

/// [`plane_t`]'s zero threshold for a dot product `n·a` of the normal with
/// `a`: [`PLANE_NOISE`] `· Σ m_i |a_i|`, `m` the [`normal_magnitudes`].
///
/// Each normal component is off by at most `2^-51 m_i` (two rounded
/// products and their rounded difference, from differences of `f32` that
/// are exact or rounded once), each term `n_i a_i` by `1.5 · 2^-51 m_i
/// |a_i|`, and the two sums add `2^-52` of `Σ m_i |a_i|`: the dot product
/// is off by at most `2^-50 Σ m_i |a_i|`, a quarter of this. Bounded per
/// component, not by `|e1|₁ |e2|₁ |a|₁`: for a sliver whose long edges
/// run along one axis, that product pairs the long edges' product with
/// the long axis's `|a|`, which no term of the dot product does, and a
/// hit 0.875 along the ray was taken for an origin on the plane.
#[inline(always)]
pub(crate) fn noise_bound((mx, my, mz): (f64, f64, f64), (ax, ay, az): (f64, f64, f64)) -> f64 {
    PLANE_NOISE * (mx * ax.abs() + my * ay.abs() + mz * az.abs())
}

/// The triangle's box on axis `a`, `(min, max)` of its vertices'
/// coordinates, in `f32` (exact, as every comparison is).
#[inline(always)]
fn box_axis(tri: &Triangle, a: usize) -> (f32, f32) {
    let [v0, v1, v2] = &tri.v;
    let (x, y, z) = (v0[a], v1[a], v2[a]);
    let min = |a: f32, b: f32| if a < b { a } else { b };
    let max = |a: f32, b: f32| if a > b { a } else { b };
    (min(min(x, y), z), max(max(x, y), z))
}

/// Is the hit point `org + t dir` clearly inside the triangle `tri`'s box
/// widened by [`BOX_MARGIN`]? Then `t` lies inside every axis's interval,
/// and the clamp would keep it: its six divisions are skipped. A
/// sufficient test, in `f32` (hardware where `f64` is software): the point
/// `x = o + (t as f32) d`, off by at most `2^-22 (|x| + |o|)`, strictly
/// inside the box widened by only [`BOX_INSIDE`] of each face's and the
/// origin's magnitude. Where `|x| <= 2|face| + |o|` that leaves the exact
/// point more than `2^-19 (|face| + |o|)` inside the clamp's face, far above
/// the clamp's own `f64` rounding (`2^-51` of it); where `|x|` is larger,
/// `x` lies on the face's inner side by more than `|x| / 2`. A flat box
/// (`lo == hi`) with no margin (`|lo| + |o| = 0`) is left to the clamp, as
/// is a `t` beyond `f32` (an infinite or NaN point fails the comparisons)
/// or below its normal range.
#[inline(always)]
fn hit_inside_box(t: f64, tri: &Triangle, org: &[f32; 3], dir: &[f32; 3]) -> bool {
    let t32 = t as f32;
    // A subnormal `t32` is off by up to half of `2^-149` absolutely, which
    // a direction near `f32::MAX` turns into `2^-22` of a unit: left to the
    // clamp (`t = 0` is exact).
    let mut inside = t.is_finite() & ((t == 0.0) | (t32.abs() >= f32::MIN_POSITIVE));
    // Unrolled by hand: a loop over the axes kept the three axes' values
    // in arrays in memory. The margins are products summed, not a product
    // of a sum, which overflows for an origin near `f32::MAX`.
    let mut axis = |a: usize, o: f32, d: f32| {
        let (lo, hi) = box_axis(tri, a);
        let x = o + t32 * d;
        let mo = BOX_INSIDE * o.abs();
        let (lo, hi) = (
            lo - (BOX_INSIDE * lo.abs() + mo),
            hi + (BOX_INSIDE * hi.abs() + mo),
        );
        inside &= (x > lo) & (x < hi);
    };
    axis(0, org[0], dir[0]);
    axis(1, org[1], dir[1]);
    axis(2, org[2], dir[2]);
    inside
}

/// [`plane_t`]'s `t` kept within the ray's interval through the triangle
/// `tri`'s box widened by [`BOX_MARGIN`] (NaN when the ray misses it).
/// Taken only for hit points near or outside the box: out of line and
/// cold, so that [`plane_t`] keeps nothing live for it.
#[inline(never)]
#[cold]
fn box_clamp(t: f64, tri: &Triangle, org: &[f32; 3], dir: &[f32; 3]) -> f32 {
    let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
    for a in 0..3 {
        // Each axis's values formed where needed: fewer live `f64` values,
        // a smaller frame in software floating point.
        let (bmin, bmax) = box_axis(tri, a);
        let (o, d) = (f64::from(org[a]), f64::from(dir[a]));
        let (bmin, bmax) = widen(f64::from(bmin), f64::from(bmax), o);
        if d == 0.0 {
            if o < bmin || o > bmax {
                return f32::NAN;
            }
            continue;
        }
        let (t1, t2) = ((bmin - o) / d, (bmax - o) / d);
        lo = lo.max(t1.min(t2));
        hi = hi.min(t1.max(t2));
    }
    if lo > hi {
        return f32::NAN;
    }
    // Compared, not `max`/`min`: a `t` in range keeps its bits (and the
    // sign of a zero).
    let t = if t < lo {
        lo
    } else if t > hi {
        hi
    } else {
        t
    };
    // A `t` behind the origin that rounds to `-0` would pass `tmin = 0`:
    // the largest negative `f32` keeps it behind (a ray spawned one ulp off
    // a surface and leaving it). Only here: `hit_inside_box` leaves every
    // `t` below the normal range, zero aside, to this clamp.
    let t32 = t as f32;
    if t < 0.0 && t32 == 0.0 {
        -f32::from_bits(1)
    } else {
        t32
    }
}

/// A triangle box's extent `[lo, hi]` on one axis widened by
/// [`BOX_MARGIN`] of `|lo| + |hi| + |o|` (`o` the origin coordinate) on
/// both faces. Since `x - m|x|` grows with `x` and `|lo|, |hi|` are at most
/// the scene's `|min| + |max|`, a triangle's widened box stays inside the
/// scene's box widened by that margin of the scene's extent, which the
/// walk's root clip covers (the triangle tree's `ROOT_MARGIN`).
#[inline(always)]
pub(crate) fn widen(lo: f64, hi: f64, o: f64) -> (f64, f64) {
    let margin = BOX_MARGIN * (lo.abs() + hi.abs() + o.abs());
    (lo - margin, hi + margin)
}

/// The margin of [`hit_inside_box`]'s box, relative to each face's and the
/// origin's magnitude: `2^-20`, a quarter of [`BOX_MARGIN`], so that the
/// `f32` hit point's rounding (`2^-21` of those magnitudes near the face)
/// cannot carry a point the clamp would move inside it.
const BOX_INSIDE: f32 = 1.0 / 1_048_576.0;

/// How far outside its bounding box [`plane_t`] still takes a triangle's
/// hit point, relative to the coordinates (`2^-18`, 32 `f32` ulps): an
/// `f32` ray aimed at a vertex or an edge passes it by a few ulps, and the
/// watertight test may credit the hit to a neighbour whose box it just
/// misses.
const BOX_MARGIN: f64 = 1.0 / 262_144.0;

/// [`plane_t`]'s zero threshold relative to the operands, `2^-48`.
pub(crate) const PLANE_NOISE: f64 = 1.0 / 281_474_976_710_656.0;

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

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::vec::Vec;

    fn tri(a: [f32; 3], b: [f32; 3], c: [f32; 3]) -> Triangle {
        Triangle { v: [a, b, c] }
    }

    fn ray(o: [f32; 3], d: [f32; 3]) -> Ray {
        Ray {
            origin: o,
            tmin: 0.0,
            dir: d,
            tmax: f32::INFINITY,
        }
    }

    #[test]
    fn hits_with_barycentrics_of_vertices_1_and_2() {
        let t = tri([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]);
        let h = closest_hit_brute(&[t], &ray([0.25, 0.5, 2.0], [0.0, 0.0, -1.0]));
        assert_eq!((h.t, h.prim, h.u, h.v), (2.0, 0, 0.25, 0.5));
        // Seen from below (the other winding) the answer is the same.
        let h = closest_hit_brute(&[t], &ray([0.25, 0.5, -2.0], [0.0, 0.0, 1.0]));
        assert_eq!((h.t, h.prim, h.u, h.v), (2.0, 0, 0.25, 0.5));
    }

    /// The 12 triangles of the cube [0, 1]^3: a closed mesh.
    fn cube() -> [Triangle; 12] {
        let c = |i: usize| [(i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32];
        let quads = [
            [0, 1, 3, 2],
            [4, 6, 7, 5],
            [0, 4, 5, 1],
            [2, 3, 7, 6],
            [0, 2, 6, 4],
            [1, 5, 7, 3],
        ];
        let mut out = [tri(c(0), c(0), c(0)); 12];
        for (q, quad) in quads.iter().enumerate() {
            out[2 * q] = tri(c(quad[0]), c(quad[1]), c(quad[2]));
            out[2 * q + 1] = tri(c(quad[0]), c(quad[2]), c(quad[3]));
        }
        out
    }

    #[test]
    fn closed_mesh_is_watertight_at_shared_edges_and_vertices() {
        // From points inside the cube, aim at every vertex, at points along
        // every edge (shared by two faces, and the face diagonals shared by
        // two triangles): a ray escaping would be a leak.
        let mesh = cube();
        let inside = [[0.5, 0.5, 0.5], [0.3, 0.6, 0.45], [0.123, 0.877, 0.5]];
        let mut aims = Vec::new();
        for i in 0..=16 {
            let s = i as f32 / 16.0;
            for a in 0..3 {
                for (p, q) in [(0.0, 0.0), (0.0, 1.0), (1.0, 0.0), (1.0, 1.0)] {
                    let mut e = [p, q, q];
                    e[a] = s;
                    e[(a + 1) % 3] = p;
                    e[(a + 2) % 3] = q;
                    aims.push(e);
                }
                // Face diagonals.
                let mut d = [s, s, 0.0];
                d[2] = if a == 0 { 0.0 } else { 1.0 };
                aims.push([d[(3 - a) % 3], d[(4 - a) % 3], d[(5 - a) % 3]]);
            }
        }
        for o in inside {
            for aim in &aims {
                let d = [aim[0] - o[0], aim[1] - o[1], aim[2] - o[2]];
                let h = closest_hit_brute(&mesh, &ray(o, d));
                assert!(h.is_hit(), "leaked from {o:?} towards {aim:?}");
            }
        }
    }

    #[test]
    fn invalid_rays_miss() {
        let t = [tri([-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [0.0, 1.0, 0.0])];
        let bad = [
            ray([f32::NAN, 0.0, 1.0], [0.0, 0.0, -1.0]),
            ray([0.0, 0.0, 1.0], [0.0, f32::NAN, -1.0]),
            ray([0.0, 0.0, 1.0], [0.0, 0.0, f32::NEG_INFINITY]),
            ray([0.0, 0.0, 1.0], [0.0, -0.0, 0.0]),
            Ray {
                tmin: 2.0,
                tmax: 1.0,
                ..ray([0.0, 0.0, 1.0], [0.0, 0.0, -1.0])
            },
            Ray {
                tmin: f32::NAN,
                ..ray([0.0, 0.0, 1.0], [0.0, 0.0, -1.0])
            },
        ];
        for r in bad {
            assert_eq!(closest_hit_brute(&t, &r), Hit::MISS, "{r:?}");
            assert!(!any_hit_brute(&t, &r));
        }
    }

    #[test]
    fn hit_at_a_subnormal_t_is_a_hit() {
        // The origin 1e-40 off the triangle's plane (x = 0): the heights
        // and `t` are subnormal and round by an absolute 2^-150, which the
        // relative window alone did not hold: the `f64` `t` fell outside
        // it, and the hit was refused.
        let t = tri([0.0, 0.0, 0.0], [0.0, 0.0, 0.75], [0.0, 0.75, 0.5]);
        let r = ray(
            [-1e-40, 0.205_905_56, 0.371_435_88],
            [0.75, -0.614_305, 0.562_131_4],
        );
        let h = closest_hit_brute(&[t], &r);
        assert!(h.is_hit());
        let want = 1e-40 / 0.75;
        assert!((f64::from(h.t) - want).abs() <= want * 1e-4, "{h:?}");
        assert!(any_hit_brute(&[t], &r));
    }

    #[test]
    fn a_window_infinite_at_either_end_is_never_sure() {
        // `t` may then be infinite, which is no hit.
        let shape = 1.0;
        assert!(sure_hit((0.5, 1.0), shape, 0.0, 2.0));
        assert!(!sure_hit(
            (f32::NEG_INFINITY, 1.0),
            shape,
            f32::NEG_INFINITY,
            2.0
        ));
        assert!(!sure_hit((0.5, f32::INFINITY), shape, 0.0, f32::INFINITY));
        assert!(!sure_hit((0.5, 1.0), WELL_SHAPED, 0.0, 2.0));
    }

    #[test]
    fn ray_in_the_triangles_plane_misses_and_degenerate_triangles_miss() {
        let t = tri([-1.0, 0.0, -1.0], [1.0, 0.0, -1.0], [0.0, 0.0, 1.0]);
        assert!(!closest_hit_brute(&[t], &ray([0.0, 0.0, -5.0], [0.0, 0.0, 1.0])).is_hit());
        let line = tri([0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [2.0, 2.0, 0.0]);
        assert!(!closest_hit_brute(&[line], &ray([1.0, 1.0, 1.0], [0.0, 0.0, -1.0])).is_hit());
    }

    #[test]
    fn exact_t_outside_its_window_is_no_hit() {
        // A t that the box clamp moved out of the window is no hit, in
        // any [tmin, tmax]: the window's early rejection agrees with it.
        let w = (0.874, 0.876);
        assert!(exact_t_hits(0.875, w, 0.0, f32::INFINITY));
        assert!(!exact_t_hits(0.325, w, 0.0, f32::INFINITY));
        assert!(!exact_t_hits(0.325, w, 0.0, 0.5));
        assert!(!exact_t_hits(0.875, w, 0.0, 0.5));
        // An overflowed window (NaN or infinite) holds every t.
        assert!(exact_t_hits(0.325, (f32::NAN, f32::NAN), 0.0, 1.0));
        assert!(exact_t_hits(
            0.325,
            (f32::NEG_INFINITY, f32::INFINITY),
            0.0,
            1.0
        ));
        assert!(!exact_t_hits(f32::NAN, (f32::NAN, f32::NAN), 0.0, 1.0));
    }

    #[test]
    fn overflowing_t_is_no_hit() {
        // Found by proptest: a subnormal direction makes t overflow to +inf,
        // which [inf, inf] would accept but no cell interval reaches.
        let t = tri([0.0, -1.0, 1.0], [1.0, 1.0, 1.0], [-1.0, 1.0, 1.0]);
        let r = Ray {
            origin: [0.0; 3],
            tmin: f32::INFINITY,
            dir: [-0.0, -0.0, 2.938_736e-39],
            tmax: f32::INFINITY,
        };
        assert_eq!(closest_hit_brute(&[t], &r), Hit::MISS);
        assert!(!any_hit_brute(&[t], &r));
    }

    #[test]
    fn overflowing_edge_functions_are_no_hit() {
        // Found by the tree_vs_brute fuzzer: a vertex at z = 4.26e37 made
        // the edge products overflow, and the test reported a hit at
        // t = -0 at the ray origin, far from the triangle (no tree cell
        // around the origin holds it, so tree and brute force disagreed).
        let t = tri(
            [0.0, 0.0, 0.0],
            [0.0, 0.0, 4.255_651_6e37],
            [-8.0, -4.0, -4.0],
        );
        let r = Ray {
            origin: [-3.75, 3.75, 9.0],
            tmin: 0.0,
            dir: [-1.75, 9.0, 6.75],
            tmax: f32::INFINITY,
        };
        assert_eq!(closest_hit_brute(&[t], &r), Hit::MISS);
    }

    #[test]
    fn box_shortcut_keeps_only_what_the_clamp_keeps() {
        // Hit points placed on and around the faces of the widened box, a
        // relative 2^-14 to 2^-60 inside or outside, at scales from 1e-30
        // to 1e12: wherever the shortcut skips the clamp, the clamp would
        // have kept `t` bit for bit.
        let mut rng = crate::test_rng::Rng(0x9E37_79B9_7F4A_7C15);
        let (mut skipped, mut clamped) = (0, 0);
        for _ in 0..200_000 {
            let scale = f64::from(rng.pick(&[1e-30f32, 1e-6, 1.0, 3e3, 1e12]));
            let mut c = || (f64::from(rng.f()) * 2.0 - 1.0) * scale;
            let p = [[c(), c(), c()], [c(), c(), c()], [c(), c(), c()]];
            let o = [c(), c(), c()].map(|x| f64::from(x as f32));
            let p = p.map(|v| v.map(|x| f64::from(x as f32)));
            let d = [c(), c(), c()].map(|x| f64::from(x as f32));
            let a = rng.pick(&[0usize, 1, 2]);
            if d[a] == 0.0 {
                continue;
            }
            let (lo, hi) = (
                p[0][a].min(p[1][a]).min(p[2][a]),
                p[0][a].max(p[1][a]).max(p[2][a]),
            );
            let (lo, hi) = widen(lo, hi, o[a]);
            let face = if rng.f() < 0.5 { lo } else { hi };
            let k = 14 + (rng.f() * 47.0) as i32;
            let off = (f64::from(rng.f()) * 2.0 - 1.0) * face.abs().max(scale) * 2f64.powi(-k);
            let t = (face + off - o[a]) / d[a];
            let tri = Triangle {
                v: p.map(|v| v.map(|x| x as f32)),
            };
            let (o, d) = (o.map(|x| x as f32), d.map(|x| x as f32));
            if hit_inside_box(t, &tri, &o, &d) {
                skipped += 1;
                assert_eq!(box_clamp(t, &tri, &o, &d).to_bits(), (t as f32).to_bits());
            } else {
                clamped += 1;
            }
        }
        assert!(skipped > 500 && clamped > 1000, "{skipped} {clamped}");
    }

    #[test]
    fn plane_t_lanes_equal_the_scalar_plane_t_bitwise() {
        // Rays through, beside and in the plane of grid-snapped, sliver and
        // degenerate triangles (the clamp's and the no-plane paths), for
        // every lane mask from one lane to all eight; the AVX2 `plane_t`
        // on each lane's ray where the CPU has it.
        let mut rng = crate::test_rng::Rng(0x2545_F491_4F6C_DD1D);
        let c = |rng: &mut crate::test_rng::Rng| {
            let x = rng.f() * 4.0 - 2.0;
            if rng.f() < 0.5 {
                (x * 4.0).floor() / 4.0
            } else {
                x
            }
        };
        let (mut clamped, mut nan) = (0, 0);
        // Rounds of two or more lanes all plain hits (the selects) and
        // with some lane not (the branches).
        let (mut all_plain, mut some_not) = (0, 0);
        for round in 0..20_000u32 {
            let mut v: [[f32; 3]; 3] = core::array::from_fn(|_| [c(&mut rng), c(&mut rng), 0.0]);
            for p in &mut v {
                p[2] = if round % 4 == 0 { 0.0 } else { c(&mut rng) };
            }
            if round % 7 == 0 {
                v[2] = v[1]; // degenerate: no plane
            }
            let tri = Triangle { v };
            let org: [[f32; 8]; 3] = core::array::from_fn(|a| {
                core::array::from_fn(|_| {
                    if round % 4 == 0 && a == 2 {
                        0.0
                    } else {
                        c(&mut rng)
                    }
                })
            });
            let mut dir: [[f32; 8]; 3] =
                core::array::from_fn(|_| core::array::from_fn(|_| c(&mut rng)));
            if round % 3 == 1 {
                // Every lane aimed at a point of the triangle: plain hits.
                for l in 0..8 {
                    let (a, b) = (rng.f(), rng.f());
                    let (a, b) = if a + b > 1.0 {
                        (1.0 - a, 1.0 - b)
                    } else {
                        (a, b)
                    };
                    for (k, d) in dir.iter_mut().enumerate() {
                        let p = v[0][k] + a * (v[1][k] - v[0][k]) + b * (v[2][k] - v[0][k]);
                        d[l] = p - org[k][l];
                    }
                }
            }
            let lanes = (round.wrapping_mul(0x9E37_79B9) >> 24) | 1 << (round % 8);
            let mut t = [7.0f32; 8];
            plane_t_lanes::<wide::f32x8, 8>(&org, &dir, &tri, lanes, &mut t);
            let mut plain = 0u32;
            for l in 0..8 {
                let want = if lanes >> l & 1 == 1 {
                    let at = |c: &[[f32; 8]; 3]| [c[0][l], c[1][l], c[2][l]];
                    let want = plane_t(&at(&org), &at(&dir), &tri);
                    let t = Plane::of(&tri).ray_t(&tri.v[0], &at(&org), &at(&dir));
                    #[cfg(target_arch = "x86_64")]
                    if std::is_x86_feature_detected!("avx2") {
                        // SAFETY: AVX2 was detected.
                        let avx = unsafe { plane_x86::plane_t(&at(&org), &at(&dir), &tri) };
                        assert_eq!(avx.to_bits(), want.to_bits(), "AVX2, round {round}");
                    }
                    nan += usize::from(want.is_nan());
                    clamped += usize::from(t.is_some_and(|t| t as f32 != want));
                    let inside = |t| hit_inside_box(t, &tri, &at(&org), &at(&dir));
                    plain |= u32::from(t.is_some_and(inside)) << l;
                    want
                } else {
                    7.0
                };
                assert_eq!(t[l].to_bits(), want.to_bits(), "round {round} lane {l}");
            }
            if lanes.count_ones() > 1 {
                all_plain += usize::from(plain == lanes);
                some_not += usize::from(plain != lanes);
            }
        }
        assert!(clamped > 100 && nan > 100, "{clamped} {nan}");
        assert!(all_plain > 100 && some_not > 100, "{all_plain} {some_not}");
    }

    #[test]
    fn equal_t_goes_to_the_lower_index() {
        let t = tri([-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [0.0, 1.0, 0.0]);
        let h = closest_hit_brute(&[t, t, t], &ray([0.0, 0.0, 1.0], [0.0, 0.0, -1.0]));
        assert_eq!(h.prim, 0);
        let far = tri([-1.0, -1.0, -1.0], [1.0, -1.0, -1.0], [0.0, 1.0, -1.0]);
        let h = closest_hit_brute(&[far, t, t], &ray([0.0, 0.0, 1.0], [0.0, 0.0, -1.0]));
        assert_eq!(h.prim, 1);
    }
}
