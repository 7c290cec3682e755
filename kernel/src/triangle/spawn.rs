//! Secondary rays without an epsilon: a hit's point with a conservative
//! bound on its rounding error, and rays spawned from it offset along the
//! geometric normal just past that bound (PBRT-v3's `OffsetRayOrigin`,
//! Pharr, Jakob and Humphreys, "Physically Based Rendering", 3rd ed.,
//! section 3.9).
//!
//! The point is interpolated from the vertices by the hit's barycentrics,
//! `b0 v0 + b1 v1 + b2 v2`, not computed as `origin + t dir`: for any
//! weights that sum to 1 that point lies on the triangle's plane, so its
//! error is a few roundings of the vertices' own magnitudes (`γ7 Σ |bi vi|`
//! per axis), however far the ray travelled. The spawned origin is moved
//! along the unit normal by the extent of that error box in the normal's
//! direction, then each moved coordinate one more `f32` step outwards:
//! the origin lies strictly on the side of the plane it leaves towards.
//! A ray from it meets the plane only at a negative `t`, and the triangle
//! test's `t` (the triangle test (`ShearedRay::intersect`)) gets that sign right
//! outside the small distance where it takes a point as lying on the plane
//! (and reports `t = 0`); the error bound includes that distance, so a
//! spawned ray over `[0, tmax]` never hits the triangle it leaves.

use super::{noise_bound, normal_magnitudes, Triangle};
use crate::geometry::{next_down, next_up, Hit, Ray};

/// `γ7 = 7u / (1 - 7u)` for `f32` (`u = 2^-24`): the bound on seven
/// roundings, PBRT's `gamma(7)`.
const GAMMA7: f32 = 7.0 * (f32::EPSILON * 0.5) / (1.0 - 7.0 * (f32::EPSILON * 0.5));

/// A point on a triangle, as a hit found it, ready to spawn rays from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePoint {
    /// The point, `(1 - u - v) v0 + u v1 + v v2`.
    pub p: [f32; 3],
    /// A conservative bound on each coordinate's distance to the exact
    /// point of the triangle's plane that the barycentrics name, plus the
    /// distance within which the triangle test takes a point as lying on
    /// the plane (a ray from there would hit it at `t = 0`).
    pub err: [f32; 3],
    /// The triangle's unit geometric normal (`(v1 - v0) × (v2 - v0)`,
    /// the cross product in `f64`); zero for a degenerate triangle.
    pub normal: [f32; 3],
}

impl SurfacePoint {
    /// The point of `hit` on `tri` (the triangle `hit.prim` names).
    #[must_use]
    pub fn new(tri: &Triangle, hit: &Hit) -> SurfacePoint {
        let (b1, b2) = (hit.u, hit.v);
        let b0 = 1.0 - b1 - b2;
        let [v0, v1, v2] = tri.v;
        let p: [f32; 3] = core::array::from_fn(|i| b0 * v0[i] + b1 * v1[i] + b2 * v2[i]);
        let (normal, snap) = plane_of(tri, &p);
        let err = core::array::from_fn(|i| {
            let rounding = (b0 * v0[i]).abs() + (b1 * v1[i]).abs() + (b2 * v2[i]).abs();
            GAMMA7 * rounding + snap
        });
        SurfacePoint { p, err, normal }
    }

    /// The origin for a ray leaving towards `dir`: `p` moved along the
    /// normal (to the side `dir` points to) past the error box, then each
    /// coordinate the normal moves one `f32` step further out (to the
    /// normal's side for a `dir` in the plane; a step even where the error
    /// is zero). `p` itself for a degenerate triangle.
    #[must_use]
    pub fn offset_origin(&self, dir: [f32; 3]) -> [f32; 3] {
        let d: f32 = (0..3).map(|i| self.normal[i].abs() * self.err[i]).sum();
        let facing: f32 = (0..3).map(|i| self.normal[i] * dir[i]).sum();
        let n = if facing < 0.0 {
            self.normal.map(|c| -c)
        } else {
            self.normal
        };
        core::array::from_fn(|i| {
            let o = self.p[i] + d * n[i];
            if n[i] > 0.0 {
                next_up(o)
            } else if n[i] < 0.0 {
                next_down(o)
            } else {
                o
            }
        })
    }

    /// A ray from the surface along `dir` over `[0, tmax]`.
    #[must_use]
    pub fn spawn(&self, dir: [f32; 3], tmax: f32) -> Ray {
        Ray {
            origin: self.offset_origin(dir),
            tmin: 0.0,
            dir,
            tmax,
        }
    }

    /// A ray from the surface to `target` (a light): direction `target -
    /// origin`, over `[0, 1]`, so `t = 1` is the target.
    #[must_use]
    pub fn spawn_to(&self, target: [f32; 3]) -> Ray {
        let towards = core::array::from_fn(|i| target[i] - self.p[i]);
        let origin = self.offset_origin(towards);
        Ray {
            origin,
            tmin: 0.0,
            dir: core::array::from_fn(|i| target[i] - origin[i]),
            tmax: 1.0,
        }
    }
}

/// `tri`'s unit normal, and the distance from its plane within which
/// the triangle test takes a point near `p` as lying on it (`plane_t`'s
/// zero numerator), four times over. The cross product is taken in `f64`
/// (an `f32` one of a sliver can be off by more than its own length),
/// normalised in `f32`; a degenerate triangle gets a zero normal.
fn plane_of(tri: &Triangle, p: &[f32; 3]) -> ([f32; 3], f32) {
    let v = tri.v.map(|c| c.map(f64::from));
    let e1 = [v[1][0] - v[0][0], v[1][1] - v[0][1], v[1][2] - v[0][2]];
    let e2 = [v[2][0] - v[0][0], v[2][1] - v[0][1], v[2][2] - v[0][2]];
    let n = [
        e1[1] * e2[2] - e1[2] * e2[1],
        e1[2] * e2[0] - e1[0] * e2[2],
        e1[0] * e2[1] - e1[1] * e2[0],
    ];
    // Scaled by the largest component first, so the squares neither
    // overflow nor underflow.
    let big = n[0].abs().max(n[1].abs()).max(n[2].abs());
    if big == 0.0 || !big.is_finite() {
        return ([0.0; 3], 0.0);
    }
    let unit = glam::Vec3::from_array(n.map(|c| (c / big) as f32)).normalize();
    let m = normal_magnitudes((e1[0], e1[1], e1[2]), (e2[0], e2[1], e2[2]));
    let a = (
        v[0][0] - f64::from(p[0]),
        v[0][1] - f64::from(p[1]),
        v[0][2] - f64::from(p[2]),
    );
    // |n| >= the largest component.
    let snap = 4.0 * noise_bound(m, a) / big;
    (unit.to_array(), snap as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offset_moves_to_the_side_of_the_direction() {
        let tri = Triangle {
            v: [[0.0, 0.0, 5.0], [1.0, 0.0, 5.0], [0.0, 1.0, 5.0]],
        };
        let hit = Hit {
            t: 1.0,
            prim: 0,
            u: 0.25,
            v: 0.25,
        };
        let sp = SurfacePoint::new(&tri, &hit);
        assert_eq!(sp.p, [0.25, 0.25, 5.0]);
        assert_eq!(sp.normal, [0.0, 0.0, 1.0]);
        assert!(sp.offset_origin([0.0, 0.0, 1.0])[2] > 5.0);
        assert!(sp.offset_origin([0.3, 0.0, -1.0])[2] < 5.0);
        let degenerate = Triangle { v: [[1.0; 3]; 3] };
        let sp = SurfacePoint::new(&degenerate, &hit);
        assert_eq!(sp.offset_origin([1.0, 0.0, 0.0]), sp.p);
    }
}
