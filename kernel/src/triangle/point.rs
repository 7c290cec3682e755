//! The closest point of a triangle to a query point, the tie rule of the
//! closest-point search, and its brute-force oracle.
//!
//! # The arithmetic
//! [`closest_on_triangle`] is Ericson's region test ("Real-Time Collision
//! Detection", 5.1.5): the query is classified against the Voronoi
//! regions of the three vertices, the three edges and the face by six dot
//! products, and projected onto the one it lies in. It runs in `f64` on
//! the `f32` inputs, and it is a pure function of the point and the
//! triangle: the tree and brute force call it and get the same bits. A
//! degenerate triangle (a segment or a point) whose face region the
//! rounding lets through is answered by its nearest edge, so the point is
//! always on the triangle: barycentrics `u, v >= 0`, `u + v <= 1` (up to
//! one rounding).
//!
//! The distance is reported squared (`distance2`, `f64`): the squared
//! length of `q - p` for the reported point `p`, the key the search
//! compares. The kernel has no square root (`no_std`, no `libm`); the
//! tools take it.
//!
//! # Error against an exact oracle
//! Every operation rounds once in `f64` (`2^-53`); `p` lies within
//! `2^-47 M` of the exact closest point of the region the test picked and
//! the squared distance within `2^-50` relative of `|q - p|^2`, with `M`
//! the largest coordinate magnitude of the query and the triangle. Near a
//! region boundary the test may pick the neighbouring region, whose
//! closest point is then equally close (to that bound). So
//! `|sqrt(distance2) - d_exact| <= 2^-40 (d_exact + M)` (tested with a
//! separate `f64` oracle in `tests/distance.rs`).
//!
//! # Pruning stays exact
//! A cell (or a triangle's box) is skipped only when its squared box
//! distance exceeds [`NearestTriangle::cut`]: the best squared distance
//! times `1 + 2^-20`, plus `2^-58 M^2`. Any triangle whose computed
//! distance is at most the best has its computed point within the bound
//! above of a point of the triangle, which lies in a leaf listing it (every
//! kdray builder lists a triangle in every leaf whose closed cell it
//! touches); that leaf's box distance is at most the cut. So no skipped
//! cell holds a triangle that could win or tie, and the tree's answer is
//! brute force's, bit for bit.

use super::Triangle;
use crate::geometry::Bounds;

/// The closest point of a mesh to a query point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClosestPoint {
    /// The closest point (rounded to `f32` from the `f64` computation).
    pub point: [f32; 3],
    /// The triangle it lies on (the lowest index among equally near ones).
    pub prim: u32,
    /// Barycentric weight of vertex 1: `point = (1 - u - v) v0 + u v1 + v v2`.
    pub u: f32,
    /// Barycentric weight of vertex 2.
    pub v: f32,
    /// The squared distance from the query to the point (computed in
    /// `f64`; the key the search compares, module docs).
    pub distance2: f64,
}

impl ClosestPoint {
    /// The fields' bits, for bitwise comparisons in tests.
    #[must_use]
    pub fn bits(&self) -> [u64; 7] {
        let [x, y, z] = self.point.map(|c| u64::from(c.to_bits()));
        [
            x,
            y,
            z,
            u64::from(self.prim),
            u64::from(self.u.to_bits()),
            u64::from(self.v.to_bits()),
            self.distance2.to_bits(),
        ]
    }
}

/// A triangle's closest point to `q`, before it is rounded to `f32`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct OnTriangle {
    p: [f64; 3],
    u: f64,
    v: f64,
    d2: f64,
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// `n / d` within `[0, 1]`; 0 when `d` is not positive or the ratio NaN.
fn ratio(n: f64, d: f64) -> f64 {
    let s = n / d;
    if !(d > 0.0 && s > 0.0) {
        0.0
    } else if s > 1.0 {
        1.0
    } else {
        s
    }
}

/// The point `p` with weights `(u, v)` and its squared distance to `q`.
fn on(q: &[f64; 3], p: [f64; 3], u: f64, v: f64) -> OnTriangle {
    let d = sub(*q, p);
    OnTriangle {
        p,
        u,
        v,
        d2: dot(d, d),
    }
}

/// `a + u ab + v ac`.
fn at(a: [f64; 3], ab: [f64; 3], ac: [f64; 3], u: f64, v: f64) -> [f64; 3] {
    core::array::from_fn(|i| a[i] + u * ab[i] + v * ac[i])
}

/// The closest point of `tri` to `q` (module docs): Ericson's regions in
/// `f64`. Vertices are returned as they are, edges and the face by their
/// weights from vertex 0.
#[must_use]
pub(crate) fn closest_on_triangle(q: &[f64; 3], tri: &Triangle) -> OnTriangle {
    let [a, b, c] = tri.v.map(|p| p.map(f64::from));
    let (ab, ac) = (sub(b, a), sub(c, a));
    let ap = sub(*q, a);
    let (d1, d2) = (dot(ab, ap), dot(ac, ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return on(q, a, 0.0, 0.0);
    }
    let bp = sub(*q, b);
    let (d3, d4) = (dot(ab, bp), dot(ac, bp));
    if d3 >= 0.0 && d4 <= d3 {
        return on(q, b, 1.0, 0.0);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let s = ratio(d1, d1 - d3);
        return on(q, at(a, ab, ac, s, 0.0), s, 0.0);
    }
    let cp = sub(*q, c);
    let (d5, d6) = (dot(ab, cp), dot(ac, cp));
    if d6 >= 0.0 && d5 <= d6 {
        return on(q, c, 0.0, 1.0);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let s = ratio(d2, d2 - d6);
        return on(q, at(a, ab, ac, 0.0, s), 0.0, s);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 >= d3 && d5 >= d6 {
        let s = ratio(d4 - d3, (d4 - d3) + (d5 - d6));
        let bc = sub(c, b);
        let p = core::array::from_fn(|i| b[i] + s * bc[i]);
        return on(q, p, 1.0 - s, s);
    }
    let sum = va + vb + vc;
    if va >= 0.0 && vb >= 0.0 && vc >= 0.0 && sum > 0.0 && sum.is_finite() {
        let (u, v) = (vb / sum, vc / sum);
        return on(q, at(a, ab, ac, u, v), u, v);
    }
    // The rounding sent a degenerate triangle (or one whose products
    // overflow) to the face region: its nearest edge, the first of equals.
    let edges = [(a, ab, 0), (a, ac, 1), (b, sub(c, b), 2)];
    let mut best: Option<OnTriangle> = None;
    for (p0, e, which) in edges {
        let s = ratio(dot(sub(*q, p0), e), dot(e, e));
        let p = core::array::from_fn(|i| p0[i] + s * e[i]);
        let (u, v) = match which {
            0 => (s, 0.0),
            1 => (0.0, s),
            _ => (1.0 - s, s),
        };
        let cand = on(q, p, u, v);
        if best.is_none_or(|b| cand.d2 < b.d2) {
            best = Some(cand);
        }
    }
    best.unwrap_or(on(q, a, 0.0, 0.0))
}

/// The squared gaps from `q` to the box `b` along x, y and z (0 where
/// `q` lies within the box's extent), in `f64`.
#[inline]
#[must_use]
pub(crate) fn box_gaps2(b: &Bounds, q: &[f64; 3]) -> [f64; 3] {
    core::array::from_fn(|a| {
        let (lo, hi) = (f64::from(b.min[a]), f64::from(b.max[a]));
        let g = if q[a] < lo {
            lo - q[a]
        } else if q[a] > hi {
            q[a] - hi
        } else {
            0.0
        };
        g * g
    })
}

/// The squared distance from `q` to the box `b` (0 inside), in `f64`: the
/// sum of [`box_gaps2`] in axis order.
#[inline]
#[must_use]
pub(crate) fn box_distance2(b: &Bounds, q: &[f64; 3]) -> f64 {
    let g = box_gaps2(b, q);
    g[0] + g[1] + g[2]
}

/// The smaller of `a` and `b` for numbers that are not NaN: one `minsd`
/// (`f64::min` also handles NaN, with a compare and a blend more).
#[inline(always)]
fn lesser(a: f64, b: f64) -> f64 {
    if a < b {
        a
    } else {
        b
    }
}

/// The larger of `a` and `b` for numbers that are not NaN: one `maxsd`.
#[inline(always)]
fn greater(a: f64, b: f64) -> f64 {
    if a > b {
        a
    } else {
        b
    }
}

/// [`box_distance2`] of the triangle's box, bit for bit, for a triangle
/// with finite vertices (a validated tree's), without making the box:
/// rounding `x - q` is monotone in `x`, so the nearest face's offset
/// `lo - q` is the least of the vertices' offsets `v - q` and `q - hi` is
/// minus the greatest. About a third of the instructions of the box
/// (no `f32::min`/`max` NaN handling, no branches).
#[inline(always)]
#[must_use]
pub(crate) fn triangle_box_distance2(tri: &Triangle, q: &[f64; 3]) -> f64 {
    let [a, b, c] = &tri.v;
    let g = |i: usize| {
        let (da, db, dc) = (
            f64::from(a[i]) - q[i],
            f64::from(b[i]) - q[i],
            f64::from(c[i]) - q[i],
        );
        let below = lesser(lesser(da, db), dc);
        let above = -greater(greater(da, db), dc);
        let g = greater(greater(below, above), 0.0);
        g * g
    };
    g(0) + g(1) + g(2)
}

/// The running closest point: smallest squared distance, then lowest
/// triangle index. The one rule shared by the tree and brute force.
#[derive(Clone, Copy, Debug)]
pub(crate) struct NearestTriangle {
    /// The query, widened.
    pub(crate) q: [f64; 3],
    best: OnTriangle,
    prim: u32,
    /// `2^-58 M^2` (module docs, "Pruning stays exact").
    slack: f64,
    cut: f64,
}

/// The relative part of the cut: `2^-20`.
const CUT_RELATIVE: f64 = 1.0 / 1_048_576.0;
/// The scale of the cut's absolute part: `2^-58`.
const CUT_ABSOLUTE: f64 = 1.0 / 288_230_376_151_711_744.0;

impl NearestTriangle {
    /// Nothing found yet within `max_distance` of `q`; `scale` is the
    /// largest coordinate magnitude of every triangle whose box will be
    /// tested by [`NearestTriangle::may_take`]. `None` for a
    /// query with a NaN or infinite coordinate, or a NaN or negative
    /// `max_distance` (an infinite one takes every triangle).
    #[must_use]
    pub(crate) fn new(q: [f32; 3], max_distance: f32, scale: f32) -> Option<NearestTriangle> {
        if !q.iter().all(|c| c.is_finite()) || max_distance.is_nan() || max_distance < 0.0 {
            return None;
        }
        let m = q
            .iter()
            .fold(f64::from(scale.abs()), |m, c| m.max(f64::from(c.abs())));
        let max = f64::from(max_distance);
        let mut n = NearestTriangle {
            q: q.map(f64::from),
            best: OnTriangle {
                p: [0.0; 3],
                u: 0.0,
                v: 0.0,
                d2: max * max,
            },
            prim: u32::MAX,
            slack: m * m * CUT_ABSOLUTE,
            cut: 0.0,
        };
        n.cut = n.cut_of(n.best.d2);
        Some(n)
    }

    fn cut_of(&self, d2: f64) -> f64 {
        d2 + d2 * CUT_RELATIVE + self.slack
    }

    /// Cells (and triangle boxes) at a squared distance above this hold
    /// nothing that could win or tie (module docs).
    #[inline(always)]
    #[must_use]
    pub(crate) fn cut(&self) -> f64 {
        self.cut
    }

    /// Tests triangle `prim` and keeps it if it wins: brute force's rule.
    ///
    /// Tried a prefilter on the squared distance to the triangle's plane
    /// (a lower bound, with slack): 4.6% more instructions on 20k points
    /// within 1% of the bunny, because near a smooth surface the
    /// neighbouring triangles' planes pass within the cut too (rejects
    /// were rare, the cross product paid on every offer).
    #[inline(never)]
    pub(crate) fn offer(&mut self, tri: &Triangle, prim: u32) {
        let c = closest_on_triangle(&self.q, tri);
        if c.d2 < self.best.d2 || (c.d2 == self.best.d2 && prim < self.prim) {
            self.best = c;
            self.prim = prim;
            self.cut = self.cut_of(c.d2);
        }
    }

    /// May triangle `prim` still win: its box lies within the cut, and it
    /// is not the best one already (a triangle listed in several leaves
    /// answers the same each time)? When not, [`NearestTriangle::offer`]
    /// would keep the best as it is.
    #[inline(always)]
    #[must_use]
    pub(crate) fn may_take(&self, tri: &Triangle, prim: u32) -> bool {
        prim != self.prim && triangle_box_distance2(tri, &self.q) <= self.cut
    }

    /// The answer, `None` when no triangle lies within the maximum distance.
    #[must_use]
    pub(crate) fn answer(&self) -> Option<ClosestPoint> {
        (self.prim != u32::MAX).then(|| ClosestPoint {
            point: self.best.p.map(|c| c as f32),
            prim: self.prim,
            u: self.best.u as f32,
            v: self.best.v as f32,
            distance2: self.best.d2,
        })
    }
}

/// The brute-force closest point: every triangle by the same arithmetic
/// and tie rule as [`TriangleTree::closest_point_within`](crate::TriangleTree::closest_point_within)
/// (smallest squared distance, then lowest index), within `max_distance`
/// (`f32::INFINITY` for no limit). `None` for an empty mesh, nothing within
/// `max_distance`, a query with a NaN or infinite coordinate, or a NaN or
/// negative `max_distance`. The oracle the tree is held to.
#[must_use]
pub fn closest_point_brute(
    triangles: &[Triangle],
    q: [f32; 3],
    max_distance: f32,
) -> Option<ClosestPoint> {
    let mut best = NearestTriangle::new(q, max_distance, 0.0)?;
    for (i, tri) in triangles.iter().enumerate() {
        best.offer(tri, i as u32);
    }
    best.answer()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tri(a: [f32; 3], b: [f32; 3], c: [f32; 3]) -> Triangle {
        Triangle { v: [a, b, c] }
    }

    #[test]
    fn every_region_of_a_right_triangle() {
        let t = tri([0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]);
        let c = |q: [f64; 3]| {
            let r = closest_on_triangle(&q, &t);
            (r.p, r.u, r.v, r.d2)
        };
        // Vertex regions.
        assert_eq!(c([-1.0, -1.0, 0.0]), ([0.0; 3], 0.0, 0.0, 2.0));
        assert_eq!(c([3.0, -1.0, 0.0]), ([2.0, 0.0, 0.0], 1.0, 0.0, 2.0));
        assert_eq!(c([-1.0, 3.0, 1.0]), ([0.0, 2.0, 0.0], 0.0, 1.0, 3.0));
        // Edge regions.
        assert_eq!(c([1.0, -1.0, 0.0]), ([1.0, 0.0, 0.0], 0.5, 0.0, 1.0));
        assert_eq!(c([-2.0, 1.5, 0.0]), ([0.0, 1.5, 0.0], 0.0, 0.75, 4.0));
        assert_eq!(c([2.0, 2.0, 0.0]), ([1.0, 1.0, 0.0], 0.5, 0.5, 2.0));
        // The face: straight below.
        assert_eq!(c([0.5, 0.5, -3.0]), ([0.5, 0.5, 0.0], 0.25, 0.25, 9.0));
        // On a vertex, an edge, the face: distance 0.
        assert_eq!(c([2.0, 0.0, 0.0]).3, 0.0);
        assert_eq!(c([1.0, 0.0, 0.0]).3, 0.0);
        assert_eq!(c([0.25, 0.5, 0.0]).3, 0.0);
    }

    #[test]
    fn triangle_box_distance_is_the_box_distance_bit_for_bit() {
        let mut r = crate::test_rng::Rng(0x2545_f491_4f6c_dd1d);
        for i in 0..20_000 {
            let mut v = || -> [f32; 3] { core::array::from_fn(|_| r.f() * 4.0 - 2.0) };
            let t = tri(v(), v(), v());
            // Queries below, above and within each axis's extent, and on a
            // vertex (every gap 0).
            let q: [f64; 3] = if i % 7 == 0 {
                t.v[i % 3].map(f64::from)
            } else {
                v().map(|c| f64::from(c) * 1.5)
            };
            let want = box_distance2(&t.bounds(), &q);
            let got = triangle_box_distance2(&t, &q);
            assert_eq!(got.to_bits(), want.to_bits(), "{t:?} {q:?}");
        }
    }

    #[test]
    fn degenerate_triangles_answer_a_point_on_them() {
        // A segment (collinear) and a point.
        let seg = tri([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]);
        for q in [[0.5, 1.0, 0.0], [1.5, 0.0, -1.0], [3.0, 0.0, 0.0]] {
            let r = closest_on_triangle(&q, &seg);
            let want = (q[0].clamp(0.0, 2.0) - q[0]).powi(2) + q[1] * q[1] + q[2] * q[2];
            assert_eq!(r.d2, want, "{q:?}");
            assert!(r.u >= 0.0 && r.v >= 0.0 && r.u + r.v <= 1.0);
        }
        let pt = tri([1.0; 3], [1.0; 3], [1.0; 3]);
        assert_eq!(closest_on_triangle(&[1.0, 1.0, 3.0], &pt).d2, 4.0);
    }

    #[test]
    fn ties_go_to_the_lower_index_and_bad_queries_miss() {
        // Two triangles mirrored about z = 0: (0.2, 0.2, 0) is 1 from both.
        let up = tri([0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 1.0, 1.0]);
        let down = tri([0.0, 0.0, -1.0], [1.0, 0.0, -1.0], [0.0, 1.0, -1.0]);
        let q = [0.2, 0.2, 0.0];
        assert_eq!(
            closest_point_brute(&[up, down], q, f32::INFINITY)
                .unwrap()
                .prim,
            0
        );
        assert_eq!(
            closest_point_brute(&[down, up], q, f32::INFINITY)
                .unwrap()
                .prim,
            0
        );
        // Exactly at the maximum distance counts; below it, nothing.
        assert_eq!(closest_point_brute(&[up], q, 1.0).unwrap().distance2, 1.0);
        assert_eq!(closest_point_brute(&[up], q, 0.99), None);
        assert_eq!(closest_point_brute(&[], q, f32::INFINITY), None);
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            assert_eq!(closest_point_brute(&[up], [bad, 0.0, 0.0], 1e9), None);
        }
        assert_eq!(closest_point_brute(&[up], q, f32::NAN), None);
        assert_eq!(closest_point_brute(&[up], q, -1.0), None);
    }
}
