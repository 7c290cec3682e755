//! Shading normals: at each triangle's corner, the angle-weighted mean of
//! the normals of the triangles that share the corner's position (Thürmer
//! and Wüthrich 1998), over those within [`CREASE_DEG`] of the triangle's
//! own plane, so a curved mesh shades smooth and a box keeps its edges.
//! A hit's shading normal blends its triangle's three by the hit's
//! barycentrics; the hit itself (its `t`, its triangle) is the tree's.
//!
//! Corners are shared by position, bit for bit (either zero): the loaders give every
//! use of an indexed vertex the same coordinates, and a tree blob keeps
//! only positions, so this works for meshes and blobs alike. A
//! neighbour wound the other way is turned to the triangle's side first.

use glam::Vec3;
use kdray_kernel::{Hit, Triangle};
use std::collections::HashMap;

/// The widest angle, in degrees, between two triangles whose normals are
/// blended at a shared corner: wider is a crease (a box's edge, a step).
pub const CREASE_DEG: f32 = 60.0;

/// Corners sharing one position beyond this many keep their own
/// triangle's normal: the blending costs the square of a corner's
/// triangles, and a fan of thousands (a disc's centre) would stall.
const MAX_SHARED: usize = 256;

/// Each triangle's three corner normals (unit, or zero for a triangle
/// without area).
#[derive(Clone, Debug, Default)]
pub(crate) struct ShadingNormals {
    corners: Vec<[Vec3; 3]>,
}

/// A triangle's unit normal (zero without area) and its three angles.
fn face(t: &Triangle) -> (Vec3, [f32; 3]) {
    let p = t.v.map(Vec3::from);
    let n = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
    let angles = std::array::from_fn(|k| {
        let (a, b) = (p[(k + 1) % 3] - p[k], p[(k + 2) % 3] - p[k]);
        a.normalize_or_zero()
            .dot(b.normalize_or_zero())
            .clamp(-1.0, 1.0)
            .acos()
    });
    (n, angles)
}

impl ShadingNormals {
    /// The corner normals of `tris`. Deterministic: every sum runs in
    /// triangle order.
    pub(crate) fn new(tris: &[Triangle]) -> ShadingNormals {
        let faces: Vec<(Vec3, [f32; 3])> = tris.iter().map(face).collect();
        // Each corner's position, numbered by first use.
        let mut ids: HashMap<[u32; 3], u32> = HashMap::with_capacity(tris.len());
        let corner_ids: Vec<[u32; 3]> = tris
            .iter()
            .map(|t| {
                t.v.map(|p| {
                    let next = ids.len() as u32;
                    // `+ 0.0`: -0.0 and 0.0 are one position.
                    *ids.entry(p.map(|c| (c + 0.0).to_bits())).or_insert(next)
                })
            })
            .collect();
        // The corners at each position, in triangle order (counting sort).
        let mut start = vec![0usize; ids.len() + 1];
        for &id in corner_ids.iter().flatten() {
            start[id as usize + 1] += 1;
        }
        for i in 1..start.len() {
            start[i] += start[i - 1];
        }
        let mut fill = start.clone();
        let mut shared = vec![(0u32, 0u8); start[ids.len()]];
        for (f, c) in corner_ids.iter().enumerate() {
            for (k, &id) in c.iter().enumerate() {
                shared[fill[id as usize]] = (f as u32, k as u8);
                fill[id as usize] += 1;
            }
        }
        let cos_crease = CREASE_DEG.to_radians().cos();
        let corners = corner_ids
            .iter()
            .zip(&faces)
            .map(|(c, &(n, _))| {
                c.map(|id| {
                    let here = &shared[start[id as usize]..start[id as usize + 1]];
                    if n == Vec3::ZERO || here.len() > MAX_SHARED {
                        return n;
                    }
                    let sum = here.iter().fold(Vec3::ZERO, |sum, &(g, k)| {
                        let (m, angles) = faces[g as usize];
                        let m = if m.dot(n) < 0.0 { -m } else { m };
                        if m.dot(n) >= cos_crease {
                            sum + m * angles[k as usize]
                        } else {
                            sum
                        }
                    });
                    sum.try_normalize().unwrap_or(n)
                })
            })
            .collect();
        ShadingNormals { corners }
    }

    /// The shading normal at `hit` (unit; `None` for a triangle without
    /// area or an index past the mesh): the corners' normals blended by
    /// the hit's barycentrics.
    pub(crate) fn at(&self, hit: &Hit) -> Option<Vec3> {
        let [n0, n1, n2] = self.corners.get(hit.prim as usize)?;
        (*n0 * (1.0 - hit.u - hit.v) + *n1 * hit.u + *n2 * hit.v).try_normalize()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f32::consts::{PI, TAU};

    fn hit(prim: u32, u: f32, v: f32) -> Hit {
        Hit { t: 1.0, prim, u, v }
    }

    /// A UV sphere of radius 1: `rings` x `sides` quads, two triangles
    /// each (the pole rows' slivers too, with no area).
    fn sphere(rings: usize, sides: usize) -> Vec<Triangle> {
        let p = |r: usize, s: usize| {
            let (th, ph) = (
                r as f32 / rings as f32 * PI,
                (s % sides) as f32 / sides as f32 * TAU,
            );
            match r {
                // The poles one point each (sin(PI) is not 0 in f32).
                0 => [0.0, 1.0, 0.0],
                _ if r == rings => [0.0, -1.0, 0.0],
                _ => [th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin()],
            }
        };
        let mut tris = Vec::new();
        for r in 0..rings {
            for s in 0..sides {
                let (a, b, c, d) = (p(r, s), p(r, s + 1), p(r + 1, s + 1), p(r + 1, s));
                tris.push(Triangle { v: [a, b, c] });
                // Every other quad wound the other way: turned, not cancelled.
                tris.push(Triangle {
                    v: if s % 2 == 0 { [a, c, d] } else { [a, d, c] },
                });
            }
        }
        tris
    }

    #[test]
    fn a_sphere_gets_near_radial_normals_shared_by_every_corner() {
        let tris = sphere(12, 24);
        let normals = ShadingNormals::new(&tris);
        let mut at_position: HashMap<[u32; 3], Vec3> = HashMap::new();
        for (i, t) in tris.iter().enumerate() {
            let (n, _) = face(t);
            if n == Vec3::ZERO {
                continue;
            }
            for (k, p) in t.v.iter().enumerate() {
                let c = normals.corners[i][k];
                // Radial up to sign, within the facets' spread.
                assert!(c.dot(Vec3::from(*p)).abs() > 0.995, "{i} {k}: {c}");
                // One normal a position (up to the triangle's side).
                let c = if c.dot(Vec3::from(*p)) < 0.0 { -c } else { c };
                let seen = *at_position
                    .entry(p.map(|c| (c + 0.0).to_bits()))
                    .or_insert(c);
                assert!((seen - c).length() < 1e-6, "{i} {k}: {seen} {c}");
            }
        }
        // Inside a triangle the normal turns, where the face normal is flat.
        let (a, b) = (
            normals.at(&hit(241, 0.1, 0.1)),
            normals.at(&hit(241, 0.8, 0.1)),
        );
        assert!(a.unwrap().dot(b.unwrap()) < 0.9999, "{a:?} {b:?}");
    }

    #[test]
    fn a_box_keeps_its_edges() {
        let s = 1.0;
        let quad = |a: [f32; 3], b: [f32; 3], c: [f32; 3], d: [f32; 3]| {
            [Triangle { v: [a, b, c] }, Triangle { v: [a, c, d] }]
        };
        let tris = [
            quad([0.0, 0.0, 0.0], [s, 0.0, 0.0], [s, 0.0, s], [0.0, 0.0, s]),
            quad([0.0, 0.0, 0.0], [0.0, s, 0.0], [s, s, 0.0], [s, 0.0, 0.0]),
            quad([0.0, 0.0, 0.0], [0.0, 0.0, s], [0.0, s, s], [0.0, s, 0.0]),
        ]
        .concat();
        let normals = ShadingNormals::new(&tris);
        for (i, t) in tris.iter().enumerate() {
            let (n, _) = face(t);
            for k in 0..3 {
                assert_eq!(normals.corners[i][k], n, "{i} {k}");
            }
        }
        assert_eq!(normals.at(&hit(6, 0.0, 0.0)), None);
    }

    #[test]
    fn a_triangle_without_area_has_no_normal() {
        let tris = [Triangle {
            v: [[0.0; 3], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]],
        }];
        assert_eq!(ShadingNormals::new(&tris).at(&hit(0, 0.3, 0.3)), None);
    }
}
