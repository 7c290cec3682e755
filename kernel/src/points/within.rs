//! All points within a radius: by callback, or into a caller's buffer.

use super::scalar::query_is_valid;
use super::search::Accumulator;
use super::{distance2, Neighbour, PointTreeN, Scalar};
use core::fmt;

/// [`PointTreeN::within`]'s buffer could not hold every point in range.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BufferTooSmall {
    /// How many points are in range: the buffer length that suffices.
    pub needed: usize,
}

impl fmt::Display for BufferTooSmall {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} points are in range; the buffer is smaller",
            self.needed
        )
    }
}

impl core::error::Error for BufferTooSmall {}

/// Hands every point at squared distance `<= r2` to a callback.
struct Within<S, F> {
    r2: S,
    found: F,
}

impl<S: Scalar, F: FnMut(Neighbour<S>)> Accumulator<S> for Within<S, F> {
    #[inline(always)]
    fn bound(&self) -> S {
        self.r2
    }

    #[inline(always)]
    fn offer(&mut self, d2: S, index: u32) -> bool {
        let inside = d2 <= self.r2;
        if inside {
            (self.found)(Neighbour { index, d2 });
        }
        inside
    }
}

impl<const D: usize, S: Scalar> PointTreeN<'_, D, S> {
    /// Calls `found` once for every point at squared distance `<= r2` from
    /// `q` (the radius is given squared, so "within" is decided by the same
    /// distance as everywhere else), in tree order. Nothing for a query
    /// with a coordinate that is NaN or beyond
    /// [`max_point_coord`](crate::max_point_coord), or a NaN `r2`.
    ///
    /// # Panics
    /// Never (unless `found` does). No allocation.
    pub fn for_each_within(&self, q: [S; D], r2: S, found: impl FnMut(Neighbour<S>)) {
        if !query_is_valid(&q) || r2.is_nan() {
            return;
        }
        self.search(&q, &mut Within { r2, found });
    }

    /// Every point at squared distance `<= r2` from `q`, written to the
    /// front of `out` sorted by (squared distance, index); returns how many.
    ///
    /// # Errors
    /// [`BufferTooSmall`] with the number of points in range when `out`
    /// cannot hold them all; `out` then holds `out.len()` of them, in no
    /// particular order.
    ///
    /// # Panics
    /// Never. No allocation.
    ///
    /// # Example
    /// ```
    /// use kdray_kernel::{Neighbour, PointTree};
    /// use kdray_tools::points::{build_points, PointParams};
    /// use kdray_tools::blob::write_point_tree;
    ///
    /// // A 10 x 10 x 10 grid of points; point i is at (i % 10, i / 10 % 10, i / 100).
    /// let points: Vec<[f32; 3]> = (0..1000)
    ///     .map(|i| [(i % 10) as f32, (i / 10 % 10) as f32, (i / 100) as f32])
    ///     .collect();
    /// let blob = write_point_tree(&build_points(&points, &PointParams::default())?)?;
    /// let tree = PointTree::from_bytes(blob.as_bytes())?;
    /// let mut out = [Neighbour::NONE; 8];
    /// // Radius 1 (squared: 1) around a grid point: itself and its 6 neighbours.
    /// assert_eq!(tree.within([5.0, 5.0, 5.0], 1.0, &mut out), Ok(7));
    /// assert_eq!(out[0].index, 555);
    /// // Too small a buffer says how many it would have needed.
    /// let err = tree.within([5.0, 5.0, 5.0], 1.0, &mut out[..3]).unwrap_err();
    /// assert_eq!(err.needed, 7);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn within(
        &self,
        q: [S; D],
        r2: S,
        out: &mut [Neighbour<S>],
    ) -> Result<usize, BufferTooSmall> {
        let mut needed = 0;
        self.for_each_within(q, r2, |n| {
            if let Some(slot) = out.get_mut(needed) {
                *slot = n;
            }
            needed += 1;
        });
        finish(out, needed)
    }
}

/// Sorts the found points, or reports that they did not fit.
fn finish<S: Scalar>(out: &mut [Neighbour<S>], needed: usize) -> Result<usize, BufferTooSmall> {
    let Some(found) = out.get_mut(..needed) else {
        return Err(BufferTooSmall { needed });
    };
    found.sort_unstable_by(|a, b| a.d2.total_cmp(&b.d2).then(a.index.cmp(&b.index)));
    Ok(needed)
}

/// The oracle for [`PointTreeN::within`]: every point in order, with the
/// same distance expression (index = position).
///
/// # Errors
/// As [`PointTreeN::within`].
pub fn within_brute<const D: usize, S: Scalar>(
    points: &[[S; D]],
    q: [S; D],
    r2: S,
    out: &mut [Neighbour<S>],
) -> Result<usize, BufferTooSmall> {
    let mut needed = 0;
    if query_is_valid(&q) && !r2.is_nan() {
        let mut acc = Within {
            r2,
            found: |n| {
                if let Some(slot) = out.get_mut(needed) {
                    *slot = n;
                }
                needed += 1;
            },
        };
        for (i, p) in points.iter().enumerate() {
            acc.offer(distance2(p, &q), i as u32);
        }
    }
    finish(out, needed)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::points::tests_support::{hand_tree, HAND_POINTS};

    #[test]
    fn hand_built_tree_finds_the_ball() {
        let parts = hand_tree();
        let tree = parts.view();
        let mut out = [Neighbour::NONE; 7];
        // Within d2 <= 9 of (0,0,0): 0 (0), 1 (1), 2 (9), 3 (9): the boundary counts.
        assert_eq!(tree.within([0.0; 3], 9.0, &mut out), Ok(4));
        assert_eq!(
            [out[0], out[1], out[2], out[3]].map(|n| n.index),
            [0, 1, 2, 3]
        );
        // A buffer of 2 for 4 points: the count needed.
        assert_eq!(
            tree.within([0.0; 3], 9.0, &mut out[..2]),
            Err(BufferTooSmall { needed: 4 })
        );
        // The pile, from on top of it.
        assert_eq!(tree.within([5.0, 5.0, 0.0], 0.0, &mut out), Ok(2));
        assert_eq!((out[0].index, out[1].index), (4, 5));
        let mut calls = 0;
        tree.for_each_within([f32::NAN; 3], 100.0, |_| calls += 1);
        tree.for_each_within([0.0; 3], f32::NAN, |_| calls += 1);
        assert_eq!(calls, 0);
    }

    #[test]
    fn random_queries_match_brute_force() {
        let parts = hand_tree();
        let tree = parts.view();
        let mut s = 5u32;
        for _ in 0..1000 {
            let mut next = || {
                s = s.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                ((s >> 8) % 10) as f32 - 1.0
            };
            let q = [next(), next(), next()];
            let r2 = next() * 4.0;
            let (mut a, mut b) = ([Neighbour::NONE; 7], [Neighbour::NONE; 7]);
            assert_eq!(
                tree.within(q, r2, &mut a),
                within_brute(&HAND_POINTS, q, r2, &mut b)
            );
            assert_eq!(a.map(Neighbour::bits), b.map(Neighbour::bits), "{q:?} {r2}");
        }
    }
}
