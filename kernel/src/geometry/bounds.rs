//! Axis-aligned boxes: the scene's root cell, a point-tree node's tight
//! bounds.

use bytemuck::{Pod, Zeroable};

/// An axis-aligned box. `repr(C)`, Pod, 24 bytes (min x y z, max x y z):
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
