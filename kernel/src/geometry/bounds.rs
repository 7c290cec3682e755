//! Axis-aligned boxes: the scene's root cell, a point-tree node's tight
//! bounds.

use bytemuck::{Pod, Zeroable};

/// An axis-aligned box (may be empty: `min > max`). `repr(C)`, Pod, 24 bytes (min x y z, max x y z):
/// also the record of a point tree's per-node bounds section.
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
#[repr(C)]
pub struct Bounds {
    /// Minimum corner.
    pub min: [f32; 3],
    /// Maximum corner.
    pub max: [f32; 3],
}

impl Bounds {
    /// The empty box: the identity of [`Bounds::union`].
    pub const EMPTY: Bounds = Bounds {
        min: [f32::INFINITY; 3],
        max: [f32::NEG_INFINITY; 3],
    };

    /// The box holding only the origin (an empty scene's bounds).
    pub const ZERO: Bounds = Bounds {
        min: [0.0; 3],
        max: [0.0; 3],
    };

    /// The smallest box holding both.
    #[must_use]
    pub fn union(&self, o: &Bounds) -> Bounds {
        Bounds {
            min: core::array::from_fn(|a| self.min[a].min(o.min[a])),
            max: core::array::from_fn(|a| self.max[a].max(o.max[a])),
        }
    }

    /// The intersection of both (empty if they do not overlap).
    #[must_use]
    pub fn intersect(&self, o: &Bounds) -> Bounds {
        Bounds {
            min: core::array::from_fn(|a| self.min[a].max(o.min[a])),
            max: core::array::from_fn(|a| self.max[a].min(o.max[a])),
        }
    }

    /// The surface area (0 for an empty box), in f64 to keep cost sums exact enough.
    #[must_use]
    pub fn area(&self) -> f64 {
        let d: [f64; 3] = core::array::from_fn(|a| f64::from(self.max[a]) - f64::from(self.min[a]));
        if d.iter().any(|&x| x < 0.0) {
            return 0.0;
        }
        2.0 * (d[0] * d[1] + d[1] * d[2] + d[2] * d[0])
    }

    /// The box split at `pos` on `axis`: (below, above).
    #[must_use]
    pub fn split(&self, axis: usize, pos: f32) -> (Bounds, Bounds) {
        let (mut lo, mut hi) = (*self, *self);
        lo.max[axis] = pos;
        hi.min[axis] = pos;
        (lo, hi)
    }

    /// Does the box contain `p` (closed, and every coordinate finite)?
    #[inline]
    #[must_use]
    pub fn contains(&self, p: [f32; 3]) -> bool {
        (0..3).all(|a| p[a] >= self.min[a] && p[a] <= self.max[a])
    }

    /// Is every coordinate finite and `min <= max` on every axis?
    pub(crate) fn is_valid(&self) -> bool {
        (0..3).all(|a| {
            self.min[a].is_finite() && self.max[a].is_finite() && self.min[a] <= self.max[a]
        })
    }
}
