//! Axis-aligned boxes for building: the cells and the primitives' bounds.

use kdray_kernel::{Bounds, Triangle};

/// An axis-aligned box (min, max corners). May be empty (`min > max`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Minimum corner.
    pub min: [f32; 3],
    /// Maximum corner.
    pub max: [f32; 3],
}

impl Aabb {
    /// The empty box: the identity of [`Aabb::union`].
    pub const EMPTY: Aabb = Aabb {
        min: [f32::INFINITY; 3],
        max: [f32::NEG_INFINITY; 3],
    };

    /// The box holding only the origin (an empty scene's bounds).
    pub const ZERO: Aabb = Aabb {
        min: [0.0; 3],
        max: [0.0; 3],
    };

    /// The bounds of a triangle.
    #[must_use]
    pub fn of_triangle(t: &Triangle) -> Aabb {
        let [p, q, r] = t.v;
        Aabb {
            min: std::array::from_fn(|a| p[a].min(q[a]).min(r[a])),
            max: std::array::from_fn(|a| p[a].max(q[a]).max(r[a])),
        }
    }

    /// The smallest box holding both.
    #[must_use]
    pub fn union(&self, o: &Aabb) -> Aabb {
        Aabb {
            min: std::array::from_fn(|a| self.min[a].min(o.min[a])),
            max: std::array::from_fn(|a| self.max[a].max(o.max[a])),
        }
    }

    /// The intersection of both (empty if they do not overlap).
    #[must_use]
    pub fn intersect(&self, o: &Aabb) -> Aabb {
        Aabb {
            min: std::array::from_fn(|a| self.min[a].max(o.min[a])),
            max: std::array::from_fn(|a| self.max[a].min(o.max[a])),
        }
    }

    /// The surface area (0 for an empty box), in f64 to keep cost sums exact enough.
    #[must_use]
    pub fn area(&self) -> f64 {
        let d: [f64; 3] = std::array::from_fn(|a| f64::from(self.max[a]) - f64::from(self.min[a]));
        if d.iter().any(|&x| x < 0.0) {
            return 0.0;
        }
        2.0 * (d[0] * d[1] + d[1] * d[2] + d[2] * d[0])
    }

    /// The box split at `pos` on `axis`: (below, above).
    #[must_use]
    pub fn split(&self, axis: usize, pos: f32) -> (Aabb, Aabb) {
        let (mut lo, mut hi) = (*self, *self);
        lo.max[axis] = pos;
        hi.min[axis] = pos;
        (lo, hi)
    }

    /// The kernel's bounds type.
    #[must_use]
    pub fn to_bounds(&self) -> Bounds {
        Bounds {
            min: self.min,
            max: self.max,
        }
    }

    /// The box of the kernel's bounds (a tree's scene box).
    #[must_use]
    pub fn from_bounds(b: &Bounds) -> Aabb {
        Aabb {
            min: b.min,
            max: b.max,
        }
    }
}
