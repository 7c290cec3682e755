//! An instance: a mesh tree placed in the world by an affine transform,
//! and the one arithmetic that takes a world ray into its space.

use crate::geometry::{next_down, Bounds, Ray};
use bytemuck::{Pod, Zeroable};

/// A placed copy of a mesh: the mesh's index in the scene, its affine
/// transform (3×4, row-major: `world = M[.., 0..3] · local + M[.., 3]`)
/// and the inverse the kernel computed from it once ([`Instance::new`]),
/// a user id and a 32-bit mask. `repr(C)`, Pod, 112 bytes: the scene
/// blob's instance record.
///
/// The fields are private so the stored inverse is always the kernel's
/// inverse of the transform; a scene blob whose inverse differs by one
/// bit is refused.
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
#[repr(C)]
pub struct Instance {
    mesh: u32,
    id: u32,
    mask: u32,
    reserved: u32,
    to_world: [f32; 12],
    to_local: [f32; 12],
}

const _: () = assert!(core::mem::size_of::<Instance>() == 112);

/// The identity transform in [`Instance::new`]'s 3×4 row-major form.
pub const IDENTITY: [f32; 12] = [
    1.0, 0.0, 0.0, 0.0, //
    0.0, 1.0, 0.0, 0.0, //
    0.0, 0.0, 1.0, 0.0,
];

/// The relative padding of an instance's world box ([`Instance::world_bounds`]):
/// 2^-12 of the box's size and distance from the origin, far above the
/// rounding of the ray transform (a few ulps of the same quantities), so
/// a ray that hits the instance in its own space passes through the box.
const BOX_PAD: f64 = 1.0 / 4096.0;

/// How far from a similarity an instance's transform may be and still be
/// taken for one ([`Instance::similarity_scale2`]): `2^-16` relative, far
/// above the `f32` rounding of a rotation's entries.
pub const SIMILAR: f64 = 1.0 / 65_536.0;

impl Instance {
    /// Mesh `mesh` placed by `to_world` (3×4 row-major), with a user `id`
    /// and a `mask` (a ray sees the instance when `ray mask & mask != 0`).
    /// The inverse is computed here, in `f64` and rounded once.
    ///
    /// `None` when `to_world` has a non-finite entry or is singular (its
    /// inverse does not fit `f32`).
    #[must_use]
    pub fn new(mesh: u32, to_world: [f32; 12], id: u32, mask: u32) -> Option<Instance> {
        let to_local = inverse_affine(&to_world)?;
        Some(Instance {
            mesh,
            id,
            mask,
            reserved: 0,
            to_world,
            to_local,
        })
    }

    /// The index of the instance's mesh in its scene.
    #[inline]
    #[must_use]
    pub fn mesh(&self) -> u32 {
        self.mesh
    }

    /// The user id given to [`Instance::new`].
    #[inline]
    #[must_use]
    pub fn id(&self) -> u32 {
        self.id
    }

    /// The instance's mask.
    #[inline]
    #[must_use]
    pub fn mask(&self) -> u32 {
        self.mask
    }

    /// The transform from mesh space to world space (3×4, row-major).
    #[inline]
    #[must_use]
    pub fn to_world(&self) -> [f32; 12] {
        self.to_world
    }

    /// The stored inverse: world space to mesh space (3×4, row-major).
    #[inline]
    #[must_use]
    pub fn to_local(&self) -> [f32; 12] {
        self.to_local
    }

    /// `ray` in the instance's space: origin and direction through the
    /// stored inverse, in `f32`, each row summed left to right
    /// (`((m0 x + m1 y) + m2 z) + m3`, no fused multiply-add); `tmin` and
    /// `tmax` unchanged, since an affine map keeps the ray parameter. The
    /// one arithmetic the scene walk and the brute force share.
    #[inline]
    #[must_use]
    pub fn local_ray(&self, ray: &Ray) -> Ray {
        let m = &self.to_local;
        let d = ray.dir;
        // Rust never contracts these to fused multiply-adds, so every
        // platform rounds them alike.
        let dir = |r: usize| {
            let at = |c: usize| m.get(r * 4 + c).copied().unwrap_or(0.0);
            (at(0) * d[0] + at(1) * d[1]) + at(2) * d[2]
        };
        Ray {
            origin: self.local_point(ray.origin),
            tmin: ray.tmin,
            dir: [dir(0), dir(1), dir(2)],
            tmax: ray.tmax,
        }
    }

    /// The world point `p` in the instance's space, by the arithmetic of
    /// [`Instance::local_ray`]'s origin.
    #[inline]
    #[must_use]
    pub fn local_point(&self, p: [f32; 3]) -> [f32; 3] {
        let m = &self.to_local;
        let row = |r: usize| {
            let at = |c: usize| m.get(r * 4 + c).copied().unwrap_or(0.0);
            ((at(0) * p[0] + at(1) * p[1]) + at(2) * p[2]) + at(3)
        };
        [row(0), row(1), row(2)]
    }

    /// The squared scale of the instance's transform if it is a rotation
    /// (or reflection) times a uniform scale `s` (a similarity), within
    /// [`SIMILAR`] relative: `s^2`, the mean squared length of the linear
    /// part's columns, in `f64`. `None` for a non-uniform scale or a
    /// shear, under which the nearest point in the mesh's space is not
    /// the nearest in the world.
    #[must_use]
    pub fn similarity_scale2(&self) -> Option<f64> {
        let m = self.to_world.map(f64::from);
        let col = |c: usize| [m[c], m[4 + c], m[8 + c]];
        let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        let (c0, c1, c2) = (col(0), col(1), col(2));
        let lens = [dot(c0, c0), dot(c1, c1), dot(c2, c2)];
        let s2 = (lens[0] + lens[1] + lens[2]) / 3.0;
        let tol = s2 * SIMILAR;
        let similar = s2 > 0.0
            && s2.is_finite()
            && lens.iter().all(|l| (l - s2).abs() <= tol)
            && [dot(c0, c1), dot(c1, c2), dot(c2, c0)]
                .iter()
                .all(|d| d.abs() <= tol);
        similar.then_some(s2)
    }

    /// The world point of the instance's point `p`: through the
    /// transform in `f64`, rounded once.
    #[must_use]
    pub fn world_point(&self, p: [f32; 3]) -> [f32; 3] {
        let m = self.to_world.map(f64::from);
        let p = p.map(f64::from);
        core::array::from_fn(|r| {
            let at = |c: usize| m.get(r * 4 + c).copied().unwrap_or(0.0);
            (((at(0) * p[0] + at(1) * p[1]) + at(2) * p[2]) + at(3)) as f32
        })
    }

    /// A box in world space holding the instance of a mesh whose bounds
    /// are `local`: the eight corners through the transform in `f64`,
    /// padded by 2^-12 of the box's size and distance from the
    /// origin and rounded outwards. The top-level tree is built over
    /// these boxes and a scene's bounds must hold them.
    #[must_use]
    pub fn world_bounds(&self, local: &Bounds) -> Bounds {
        // The box's centre through the transform and its half extent
        // through |M| (Arvo 1990): the exact box of the eight corners.
        let m = self.to_world.map(f64::from);
        let c: [f64; 3] =
            core::array::from_fn(|a| (f64::from(local.min[a]) + f64::from(local.max[a])) * 0.5);
        let h: [f64; 3] =
            core::array::from_fn(|a| (f64::from(local.max[a]) - f64::from(local.min[a])) * 0.5);
        let row = |r: usize| {
            let e = |k: usize| m.get(r * 4 + k).copied().unwrap_or(0.0);
            let centre = e(0) * c[0] + e(1) * c[1] + e(2) * c[2] + e(3);
            let half = e(0).abs() * h[0] + e(1).abs() * h[1] + e(2).abs() * h[2];
            (centre - half, centre + half)
        };
        let rows = [row(0), row(1), row(2)];
        // `f64::max` spends compares on NaN, which finite transforms of
        // finite bounds never make; a select is one instruction.
        let max = |a: f64, b: f64| if a > b { a } else { b };
        let size = rows.iter().fold(0.0f64, |s, &(lo, hi)| {
            max(max(max(s, hi - lo), lo.abs()), hi.abs())
        });
        let pad = size * BOX_PAD;
        Bounds {
            min: rows.map(|(lo, _)| down(lo - pad)),
            max: rows.map(|(_, hi)| up(hi + pad)),
        }
    }

    /// The record's own checks: reserved word zero, transform finite and
    /// invertible, stored inverse exactly the kernel's.
    pub(crate) fn check(&self) -> Result<(), InstanceFault> {
        if self.reserved != 0 {
            return Err(InstanceFault::Reserved);
        }
        match inverse_affine(&self.to_world) {
            None => Err(InstanceFault::BadTransform),
            Some(inv) if inv.map(f32::to_bits) != self.to_local.map(f32::to_bits) => {
                Err(InstanceFault::BadInverse)
            }
            Some(_) => Ok(()),
        }
    }
}

/// What is wrong with one instance record.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum InstanceFault {
    Reserved,
    BadTransform,
    BadInverse,
}

/// The largest `f32` at most `x` (`x` finite or infinite).
///
/// Selects, not branches: whether `x` rounded up or down is a coin toss
/// per coordinate, and branching on it cost a mispredict per face (the
/// world boxes of 10,000 instances took 3x as long).
fn down(x: f64) -> f32 {
    let f = x as f32;
    let below = next_down(f);
    if f64::from(f) > x {
        below
    } else {
        f
    }
}

/// The smallest `f32` at least `x`.
fn up(x: f64) -> f32 {
    -down(-x)
}

/// The inverse of an affine 3×4 row-major transform, computed in `f64`
/// (adjugate over determinant) and rounded once to `f32`. `None` for a
/// non-finite entry, a zero determinant or an inverse that overflows `f32`.
#[must_use]
pub fn inverse_affine(m: &[f32; 12]) -> Option<[f32; 12]> {
    if !m.iter().all(|x| x.is_finite()) {
        return None;
    }
    let a = m.map(f64::from);
    let e = |r: usize, c: usize| a.get(r * 4 + c).copied().unwrap_or(0.0);
    let cof = [
        [
            e(1, 1) * e(2, 2) - e(1, 2) * e(2, 1),
            e(0, 2) * e(2, 1) - e(0, 1) * e(2, 2),
            e(0, 1) * e(1, 2) - e(0, 2) * e(1, 1),
        ],
        [
            e(1, 2) * e(2, 0) - e(1, 0) * e(2, 2),
            e(0, 0) * e(2, 2) - e(0, 2) * e(2, 0),
            e(0, 2) * e(1, 0) - e(0, 0) * e(1, 2),
        ],
        [
            e(1, 0) * e(2, 1) - e(1, 1) * e(2, 0),
            e(0, 1) * e(2, 0) - e(0, 0) * e(2, 1),
            e(0, 0) * e(1, 1) - e(0, 1) * e(1, 0),
        ],
    ];
    let det = e(0, 0) * cof[0][0] + e(0, 1) * cof[1][0] + e(0, 2) * cof[2][0];
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let mut out = [0.0f32; 12];
    for (r, c) in cof.iter().enumerate() {
        let inv = c.map(|x| x / det);
        let t = -(inv[0] * e(0, 3) + inv[1] * e(1, 3) + inv[2] * e(2, 3));
        for (c, x) in [inv[0], inv[1], inv[2], t].into_iter().enumerate() {
            let f = x as f32;
            if !f.is_finite() {
                return None;
            }
            if let Some(slot) = out.get_mut(r * 4 + c) {
                *slot = f;
            }
        }
    }
    // A determinant so small that the f32 inverse is all zeros on a row
    // is singular in f32 terms too.
    if (0..3).any(|r| (0..3).all(|c| out.get(r * 4 + c) == Some(&0.0))) {
        return None;
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_inverse_undoes_the_transform_and_the_local_ray_follows() {
        // Rotation by 90 degrees about z, scale 2, mirror in x, then a shift.
        let m = [
            0.0, -2.0, 0.0, 5.0, //
            -2.0, 0.0, 0.0, -1.0, //
            0.0, 0.0, 2.0, 3.0,
        ];
        let inst = Instance::new(0, m, 7, 1).unwrap();
        let ray = Ray {
            origin: [5.0, -1.0, 3.0],
            tmin: 0.0,
            dir: [0.0, -2.0, 0.0],
            tmax: 9.0,
        };
        let local = inst.local_ray(&ray);
        assert_eq!(local.origin, [0.0, 0.0, 0.0]);
        assert_eq!(local.dir, [1.0, 0.0, 0.0]);
        assert_eq!((local.tmin, local.tmax), (0.0, 9.0));
        assert!(inst.check().is_ok());
        assert_eq!(Instance::new(0, [0.0; 12], 0, 0), None);
        let mut nan = IDENTITY;
        nan[3] = f32::NAN;
        assert_eq!(inverse_affine(&nan), None);
    }

    #[test]
    fn the_world_box_holds_every_transformed_corner() {
        let m = [
            0.6, -0.8, 0.0, 100.0, //
            0.8, 0.6, 0.0, 0.0, //
            0.0, 0.0, -3.0, 1.0,
        ];
        let inst = Instance::new(0, m, 0, 1).unwrap();
        let b = Bounds {
            min: [-1.0, -2.0, 0.0],
            max: [1.0, 2.0, 0.5],
        };
        let w = inst.world_bounds(&b);
        for corner in 0..8 {
            let p: [f32; 3] = core::array::from_fn(|a| {
                if corner >> a & 1 == 0 {
                    b.min[a]
                } else {
                    b.max[a]
                }
            });
            let q: [f32; 3] = core::array::from_fn(|r| {
                m[r * 4] * p[0] + m[r * 4 + 1] * p[1] + m[r * 4 + 2] * p[2] + m[r * 4 + 3]
            });
            assert!(w.contains(q), "{q:?} outside {w:?}");
        }
        assert!(w.max[0] < 103.0 && w.min[2] > -0.6, "{w:?}");
    }

    #[test]
    fn outward_rounding_is_the_nearest_f32_on_the_safe_side() {
        let third = 1.0f64 / 3.0;
        for x in [third, -third, 1e30 / 3.0, -1e-40 / 3.0, 2.5e-46, -2.5e-46] {
            let (lo, hi) = (down(x), up(x));
            assert!(f64::from(lo) <= x && x <= f64::from(hi), "{x}: {lo} {hi}");
            assert_eq!(lo.next_up(), hi, "{x}: one step apart");
        }
        // Exact values stay; zero steps outwards only when it must.
        assert_eq!((down(1.5), up(1.5)), (1.5, 1.5));
        assert_eq!((down(0.0), up(0.0)), (0.0, 0.0));
        assert_eq!((down(1e-50), up(-1e-50)), (0.0, -0.0));
        assert_eq!(up(1e-50), f32::from_bits(1));
        assert_eq!(down(-1e-50), -f32::from_bits(1));
        // Beyond f32's range: the infinity on the safe side.
        assert_eq!((down(1e39), up(1e39)), (f32::MAX, f32::INFINITY));
        assert_eq!((down(-1e39), up(-1e39)), (f32::NEG_INFINITY, -f32::MAX));
    }
}
