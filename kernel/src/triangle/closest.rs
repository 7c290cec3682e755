//! The tie rule: closest `t` wins, at equal `t` the lower triangle index.

use super::{ShearedRay, Triangle, TriangleHit};
use crate::geometry::{Hit, MISS};

/// The running closest hit: smallest `t`, then lowest triangle index. The
/// one rule shared by the tree, the packets and brute force.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Closest {
    /// The best `t` so far (the ray's `tmax` before any hit): the upper end
    /// of the interval later triangles are tested over.
    pub(crate) t: f32,
    /// The best triangle so far, [`MISS`] before any hit.
    pub(crate) prim: u32,
    hit: Option<TriangleHit>,
}

impl Closest {
    /// Nothing found yet over `[.., tmax]`.
    #[inline(always)]
    #[must_use]
    pub(crate) fn new(tmax: f32) -> Closest {
        Closest {
            t: tmax,
            prim: MISS,
            hit: None,
        }
    }

    /// Tests triangle `prim` and keeps it if it wins.
    #[inline(always)]
    pub(crate) fn offer(&mut self, sr: &ShearedRay, tri: &Triangle, prim: u32, tmin: f32) {
        // The best triangle tested again (it lies in several leaves) gives
        // the same answer, which cannot win: skip its `f64` `t`.
        if prim == self.prim {
            return;
        }
        if let Some(h) = sr.intersect(tri, tmin, self.t) {
            self.keep(h, prim);
        }
    }

    /// Keeps hit `h` of triangle `prim` if it wins; `h` was found over
    /// `[tmin, self.t]` (packet lanes call this with their own test's hits).
    #[inline(always)]
    pub(crate) fn keep(&mut self, h: TriangleHit, prim: u32) {
        // h.t <= self.t here, so equal t is the only other case.
        if h.t < self.t || prim < self.prim {
            self.t = h.t;
            self.prim = prim;
            self.hit = Some(h);
        }
    }

    /// The answer.
    #[inline]
    #[must_use]
    pub(crate) fn hit(&self) -> Hit {
        match self.hit {
            Some(h) => h.to_hit(self.prim),
            None => Hit::MISS,
        }
    }
}
