//! Where `t` comes from (the module docs of `triangle`): the `f32`
//! estimate's window from the edge functions, and the plane's `t` in `f64`
//! rounded once, with its zero threshold and the box clamp.

use super::Triangle;
use crate::lanes::{dispatch, Job, Lanes, Level, Real};

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
        return unsafe { super::plane_x86::plane_t(org, dir, tri) };
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
pub(super) struct Plane {
    n: (f64, f64, f64),
    m: (f64, f64, f64),
}

impl Plane {
    /// The plane of `tri`.
    #[inline(always)]
    pub(super) fn of(tri: &Triangle) -> Plane {
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
    pub(super) fn ray_t(&self, v0: &[f32; 3], org: &[f32; 3], dir: &[f32; 3]) -> Option<f64> {
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
pub(super) fn hit_inside_box(t: f64, tri: &Triangle, org: &[f32; 3], dir: &[f32; 3]) -> bool {
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
pub(super) fn box_clamp(t: f64, tri: &Triangle, org: &[f32; 3], dir: &[f32; 3]) -> f32 {
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
pub(super) const BOX_INSIDE: f32 = 1.0 / 1_048_576.0;

/// How far outside its bounding box [`plane_t`] still takes a triangle's
/// hit point, relative to the coordinates (`2^-18`, 32 `f32` ulps): an
/// `f32` ray aimed at a vertex or an edge passes it by a few ulps, and the
/// watertight test may credit the hit to a neighbour whose box it just
/// misses.
const BOX_MARGIN: f64 = 1.0 / 262_144.0;

/// [`plane_t`]'s zero threshold relative to the operands, `2^-48`.
pub(crate) const PLANE_NOISE: f64 = 1.0 / 281_474_976_710_656.0;
