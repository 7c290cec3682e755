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
//! This single function defines every answer kdray gives: the tree, the
//! packets and the brute-force oracle all call it (or its lane-wise twin,
//! which performs the same operations in the same order).

mod brute;
mod closest;
pub(crate) mod lanes;

pub use brute::{any_hit_brute, closest_hit_brute};
pub(crate) use closest::Closest;

use crate::geometry::{ray_is_valid, Bounds, Hit, Ray};
use bytemuck::{Pod, Zeroable};

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

    /// Are all nine coordinates finite?
    #[inline]
    #[must_use]
    pub fn is_finite(&self) -> bool {
        self.v.iter().flatten().all(|c| c.is_finite())
    }
}

/// A ray prepared for the watertight test: its origin, the axis permutation
/// that makes z the dominant direction axis, and the shear constants.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ShearedRay {
    /// The ray origin.
    pub(crate) org: [f32; 3],
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
fn dominant_axis(dir: &[f32; 3]) -> usize {
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
            k: [kx, ky, kz],
            s: [d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]],
        })
    }

    /// The watertight test of `tri` against this ray over `[tmin, tmax]`.
    #[inline(always)]
    #[must_use]
    pub(crate) fn intersect(&self, tri: &Triangle, tmin: f32, tmax: f32) -> Option<TriangleHit> {
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
        let t_scaled = u * (sz * az) + v * (sz * bz) + w * (sz * cz);
        let t = t_scaled / det;
        // A hit needs a finite t: with a tiny direction, t can overflow to
        // infinity, a point no cell interval reaches.
        if t >= tmin && t <= tmax && t.is_finite() {
            Some(TriangleHit { t, v, w, det })
        } else {
            None
        }
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
    fn ray_in_the_triangles_plane_misses_and_degenerate_triangles_miss() {
        let t = tri([-1.0, 0.0, -1.0], [1.0, 0.0, -1.0], [0.0, 0.0, 1.0]);
        assert!(!closest_hit_brute(&[t], &ray([0.0, 0.0, -5.0], [0.0, 0.0, 1.0])).is_hit());
        let line = tri([0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [2.0, 2.0, 0.0]);
        assert!(!closest_hit_brute(&[line], &ray([1.0, 1.0, 1.0], [0.0, 0.0, -1.0])).is_hit());
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
    fn equal_t_goes_to_the_lower_index() {
        let t = tri([-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [0.0, 1.0, 0.0]);
        let h = closest_hit_brute(&[t, t, t], &ray([0.0, 0.0, 1.0], [0.0, 0.0, -1.0]));
        assert_eq!(h.prim, 0);
        let far = tri([-1.0, -1.0, -1.0], [1.0, -1.0, -1.0], [0.0, 1.0, -1.0]);
        let h = closest_hit_brute(&[far, t, t], &ray([0.0, 0.0, 1.0], [0.0, 0.0, -1.0]));
        assert_eq!(h.prim, 1);
    }
}
