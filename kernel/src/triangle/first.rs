//! The first hits along a ray: the closest-hit rule carried past the
//! first hit. Up to `k` hits in `[tmin, tmax]`, sorted by `t` and at equal
//! `t` by the lower key (the triangle index in a mesh; the instance, then
//! the triangle, in a scene), each surface once: for transparency,
//! counting the surfaces a ray crosses (inside/outside tests), or
//! everything along a line of sight. The one rule the tree's and the
//! scene's walks and brute force share, so they answer the same bits.

use super::{ShearedRay, Triangle};
use crate::geometry::Hit;

/// A record [`FirstHits`] keeps: a mesh's [`Hit`] or a scene's hit.
pub(crate) trait Ranked: Copy {
    /// The ray parameter.
    fn t(&self) -> f32;
    /// The surface's key: orders hits at equal `t` and names a surface
    /// once.
    fn key(&self) -> u64;
    /// The key of triangle `prim` of the mesh tagged `tag`.
    fn key_of(prim: u32, tag: u32) -> u64;
    /// The record of `hit` in the mesh tagged `tag`.
    fn from_hit(hit: Hit, tag: u32) -> Self;
}

impl Ranked for Hit {
    #[inline(always)]
    fn t(&self) -> f32 {
        self.t
    }
    #[inline(always)]
    fn key(&self) -> u64 {
        u64::from(self.prim)
    }
    #[inline(always)]
    fn key_of(prim: u32, _: u32) -> u64 {
        u64::from(prim)
    }
    #[inline(always)]
    fn from_hit(hit: Hit, _: u32) -> Hit {
        hit
    }
}

/// The first hits so far, kept sorted in the caller's buffer.
pub(crate) struct FirstHits<'o, R> {
    out: &'o mut [R],
    len: usize,
}

impl<'o, R: Ranked> FirstHits<'o, R> {
    /// None yet; room for `out.len()`.
    #[inline]
    pub(crate) fn new(out: &'o mut [R]) -> FirstHits<'o, R> {
        FirstHits { out, len: 0 }
    }

    /// How many hits are kept.
    #[inline]
    pub(crate) fn len(&self) -> usize {
        self.len
    }

    /// The upper end of the interval later triangles are tested over:
    /// `tmax` until the buffer is full, then its last hit's `t` (a hit at
    /// that `t` still enters with a lower key).
    #[inline]
    pub(crate) fn bound(&self, tmax: f32) -> f32 {
        match self.out.last() {
            Some(last) if self.len == self.out.len() => last.t().min(tmax),
            _ => tmax,
        }
    }

    /// Tests triangle `prim` of the mesh tagged `tag` over `[tmin, tmax]`
    /// and keeps its hit if it is among the first.
    #[inline]
    pub(crate) fn offer(
        &mut self,
        sr: &ShearedRay,
        tri: &Triangle,
        key: (u32, u32),
        tmin: f32,
        tmax: f32,
    ) {
        self.offer_by::<false>(sr, tri, key, tmin, tmax);
    }

    /// [`FirstHits::offer`]; by the crossing test
    /// ([`ShearedRay::crossing`]: an edge or vertex of a closed mesh
    /// crossed once) when `CROSSING`.
    #[inline]
    pub(crate) fn offer_by<const CROSSING: bool>(
        &mut self,
        sr: &ShearedRay,
        tri: &Triangle,
        (prim, tag): (u32, u32),
        tmin: f32,
        tmax: f32,
    ) {
        let key = R::key_of(prim, tag);
        let kept = self.out.get(..self.len).unwrap_or(&[]);
        // A triangle listed in several leaves answers the same each time:
        // kept once. (One pushed out by closer hits is pushed out again.)
        if kept.iter().any(|h| h.key() == key) {
            return;
        }
        let bound = self.bound(tmax);
        let h = if CROSSING {
            sr.crossing(tri, tmin, bound)
        } else {
            sr.intersect(tri, tmin, bound)
        };
        let Some(h) = h else {
            return;
        };
        let at = kept
            .iter()
            .position(|k| h.t < k.t() || (h.t == k.t() && key < k.key()))
            .unwrap_or(self.len);
        // The hits from `at` on move one slot down, the last one off a
        // full buffer; at a full buffer's end the hit is not among the
        // first (an empty range). Swaps, not `rotate_right`: no panic path.
        let end = (self.len + 1).min(self.out.len());
        let Some(moved) = self.out.get_mut(at..end).filter(|m| !m.is_empty()) else {
            return;
        };
        let mut carry = R::from_hit(h.to_hit(prim), tag);
        for slot in moved {
            core::mem::swap(slot, &mut carry);
        }
        self.len = end;
    }
}
