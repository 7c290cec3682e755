//! The first hits along a ray: the closest-hit rule carried past the
//! first hit. Up to `k` hits in `[tmin, tmax]`, sorted by `t` and at equal
//! `t` by the lower triangle index, each triangle once: for transparency,
//! counting the surfaces a ray crosses (inside/outside tests), or
//! everything along a line of sight. The one rule the tree's walk and
//! brute force share, so the two answer the same bits.

use super::{ShearedRay, Triangle};
use crate::geometry::Hit;

/// The first hits so far, kept sorted in the caller's buffer.
pub(crate) struct FirstHits<'o> {
    out: &'o mut [Hit],
    len: usize,
}

impl<'o> FirstHits<'o> {
    /// None yet; room for `out.len()`.
    #[inline]
    pub(crate) fn new(out: &'o mut [Hit]) -> FirstHits<'o> {
        FirstHits { out, len: 0 }
    }

    /// How many hits are kept.
    #[inline]
    pub(crate) fn len(&self) -> usize {
        self.len
    }

    /// The upper end of the interval later triangles are tested over:
    /// `tmax` until the buffer is full, then its last hit's `t` (a hit at
    /// that `t` still enters with a lower triangle index).
    #[inline]
    pub(crate) fn bound(&self, tmax: f32) -> f32 {
        match self.out.last() {
            Some(last) if self.len == self.out.len() => last.t,
            _ => tmax,
        }
    }

    /// Tests triangle `prim` over `[tmin, tmax]` and keeps its hit if it is
    /// among the first.
    #[inline]
    pub(crate) fn offer(
        &mut self,
        sr: &ShearedRay,
        tri: &Triangle,
        prim: u32,
        tmin: f32,
        tmax: f32,
    ) {
        let kept = self.out.get(..self.len).unwrap_or(&[]);
        // A triangle listed in several leaves answers the same each time:
        // kept once. (One pushed out by closer hits is pushed out again.)
        if kept.iter().any(|h| h.prim == prim) {
            return;
        }
        let Some(h) = sr.intersect(tri, tmin, self.bound(tmax)) else {
            return;
        };
        let at = kept
            .iter()
            .position(|k| h.t < k.t || (h.t == k.t && prim < k.prim))
            .unwrap_or(self.len);
        // The hits from `at` on move one slot down, the last one off a
        // full buffer; at a full buffer's end the hit is not among the
        // first (an empty range). Swaps, not `rotate_right`: no panic path.
        let end = (self.len + 1).min(self.out.len());
        let Some(moved) = self.out.get_mut(at..end).filter(|m| !m.is_empty()) else {
            return;
        };
        let mut carry = h.to_hit(prim);
        for slot in moved {
            core::mem::swap(slot, &mut carry);
        }
        self.len = end;
    }
}
