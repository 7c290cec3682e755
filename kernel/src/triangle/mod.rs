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
mod exact_t;
mod first;
pub(crate) mod lanes;
#[cfg(target_arch = "x86_64")]
mod plane_x86;
mod point;
mod spawn;
mod watertight;

pub(crate) use brute::offer_every_triangle;
pub use brute::{
    any_hit_brute, closest_hit_brute, crossings_brute, first_hits_brute, winding_crossings_brute,
};
pub(crate) use closest::Closest;
pub(crate) use first::{FirstHits, Ranked};
pub(crate) use point::{box_distance2, box_gaps2, NearestTriangle};
pub use point::{closest_point_brute, ClosestPoint};
pub use spawn::SurfacePoint;

pub(crate) use exact_t::*;
pub(crate) use watertight::*;

use crate::geometry::{next_down, next_up, Bounds};
use bytemuck::{Pod, Zeroable};

/// The largest vertex coordinate magnitude the watertight test handles:
/// 2^60 (about 1.15e18). With every coordinate of the triangle and of the
/// ray origin within `±MAX_COORD`, a sheared coordinate is below `4 ·
/// MAX_COORD`, an edge function below `32 · MAX_COORD²` and their sum
/// below `96 · MAX_COORD² < f32::MAX`: no product overflows.
pub const MAX_COORD: f32 = 1_152_921_504_606_846_976.0;

/// Is every coordinate of the box within `±`[`MAX_COORD`] (false for NaN)?
/// The rule for an instance's world box too, so an instanced scene holds
/// no coordinate a flat build of its triangles would refuse.
#[inline]
#[must_use]
pub fn bounds_in_range(b: &Bounds) -> bool {
    b.min.iter().chain(&b.max).all(|c| c.abs() <= MAX_COORD)
}

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

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::geometry::{Hit, Ray};
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
