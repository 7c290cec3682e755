//! Rays and hits, laid out exactly as the `.rays` and `.hits` files
//! (`docs/formats.md`) and Embree's `RTCRay`, so a file maps onto a slice
//! with [`bytemuck::cast_slice`] and nothing is converted.

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

/// A ray `origin + t * dir` for `t` in `[tmin, tmax]`. `repr(C)`, Pod, 32 bytes.
///
/// The direction need not be normalised; `t` is measured in its units.
/// A ray with a non-finite origin, a NaN or infinite or all-zero direction,
/// a NaN `tmin`/`tmax` or `tmin > tmax` hits nothing (never a panic), and
/// every hit has a finite `t` (one that overflows to infinity is no hit).
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
#[repr(C)]
pub struct Ray {
    /// Origin x, y, z.
    pub origin: [f32; 3],
    /// Start of the ray's parameter interval.
    pub tmin: f32,
    /// Direction x, y, z.
    pub dir: [f32; 3],
    /// End of the ray's parameter interval (may be `+inf`).
    pub tmax: f32,
}

const _: () = assert!(core::mem::size_of::<Ray>() == 32);

impl Ray {
    /// A ray over `[0, +inf]`.
    #[inline]
    #[must_use]
    pub fn new(origin: Vec3, dir: Vec3) -> Ray {
        Ray::with_range(origin, dir, 0.0, f32::INFINITY)
    }

    /// A ray over `[tmin, tmax]`.
    #[inline]
    #[must_use]
    pub fn with_range(origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> Ray {
        Ray {
            origin: origin.to_array(),
            tmin,
            dir: dir.to_array(),
            tmax,
        }
    }

    /// The point at parameter `t`.
    #[inline]
    #[must_use]
    pub fn at(&self, t: f32) -> Vec3 {
        Vec3::from(self.origin) + t * Vec3::from(self.dir)
    }
}

/// The triangle index that marks a miss.
pub const MISS: u32 = u32::MAX;
/// The triangle index that marks an occluded ray in an any-hit record.
pub const OCCLUDED: u32 = u32::MAX - 1;

/// A closest-hit answer: `repr(C)`, Pod, 16 bytes, the `.hits` record.
///
/// `u` is the barycentric weight of the triangle's vertex 1 and `v` that of
/// vertex 2, so the hit point is `(1 - u - v) * v0 + u * v1 + v * v2`.
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
#[repr(C)]
pub struct Hit {
    /// Ray parameter of the hit; `+inf` for a miss.
    pub t: f32,
    /// Index of the triangle hit; [`MISS`] for a miss.
    pub prim: u32,
    /// Barycentric weight of vertex 1.
    pub u: f32,
    /// Barycentric weight of vertex 2.
    pub v: f32,
}

const _: () = assert!(core::mem::size_of::<Hit>() == 16);

impl Hit {
    /// The miss record: `t = +inf`, triangle [`MISS`], `u = v = 0`.
    pub const MISS: Hit = Hit {
        t: f32::INFINITY,
        prim: MISS,
        u: 0.0,
        v: 0.0,
    };

    /// The any-hit record of an occluded ray: `t = -inf`, triangle
    /// [`OCCLUDED`], `u = v = 0` (Embree's convention).
    pub const OCCLUDED: Hit = Hit {
        t: f32::NEG_INFINITY,
        prim: OCCLUDED,
        u: 0.0,
        v: 0.0,
    };

    /// The any-hit record for `occluded`.
    #[inline]
    #[must_use]
    pub const fn occlusion(occluded: bool) -> Hit {
        if occluded {
            Hit::OCCLUDED
        } else {
            Hit::MISS
        }
    }

    /// Did the ray hit a triangle (closest-hit records)?
    #[inline]
    #[must_use]
    pub const fn is_hit(&self) -> bool {
        self.prim != MISS
    }

    /// Is `self` strictly better than `other` by the contract's order:
    /// smaller `t` wins; at equal `t`, the lower triangle index.
    #[inline(always)]
    #[must_use]
    pub fn beats(&self, other: &Hit) -> bool {
        self.t < other.t || (self.t == other.t && self.prim < other.prim)
    }

    /// Bitwise equality (`-0.0 != 0.0`, NaN equals itself): what the
    /// exactness tests compare.
    #[inline]
    #[must_use]
    pub fn bits(&self) -> [u32; 4] {
        bytemuck::cast(*self)
    }
}

/// Does `ray` describe a non-empty interval along a real direction?
/// Rays that fail this hit nothing (the documented NaN policy).
#[inline]
#[must_use]
pub fn ray_is_valid(ray: &Ray) -> bool {
    ray.origin.iter().all(|c| c.is_finite())
        && ray.dir.iter().all(|c| c.is_finite())
        && ray.dir.iter().any(|&c| c != 0.0)
        && ray.tmin <= ray.tmax
}
