//! The k nearest points, into a caller's buffer, sorted.

use super::search::Accumulator;
use super::{distance2, query_is_valid, Neighbour, PointTree};

/// The best `out.len()` points so far, kept sorted by (squared distance,
/// index) in the caller's buffer by insertion: k is small, and a new point
/// usually lands near the end.
struct Knn<'o> {
    out: &'o mut [Neighbour],
    len: usize,
    /// The k-th best distance once the buffer is full, else the max distance.
    bound: f32,
}

impl<'o> Knn<'o> {
    #[inline(always)]
    fn new(out: &'o mut [Neighbour], max_d2: f32) -> Knn<'o> {
        Knn {
            out,
            len: 0,
            bound: max_d2,
        }
    }
}

impl Accumulator for Knn<'_> {
    #[inline(always)]
    fn bound(&self) -> f32 {
        self.bound
    }

    #[inline(always)]
    fn offer(&mut self, d2: f32, index: u32) -> bool {
        let k = self.out.len();
        if d2 > self.bound {
            return false;
        }
        // Full: must precede the k-th best; otherwise within the max distance.
        let mut j = if self.len == k {
            match self.out.last() {
                Some(&last) if Neighbour::precedes(d2, index, last) => k - 1,
                _ => return false,
            }
        } else {
            self.len += 1;
            self.len - 1
        };
        // Shift the worse ones up one slot; j < k throughout. `get` and
        // `get_mut`, not indices: the optimiser cannot see j < k, and an
        // index would leave a panic path (firmware/).
        while j > 0 {
            let Some(&prev) = self.out.get(j - 1) else {
                break;
            };
            if !Neighbour::precedes(d2, index, prev) {
                break;
            }
            if let Some(slot) = self.out.get_mut(j) {
                *slot = prev;
            }
            j -= 1;
        }
        if let Some(slot) = self.out.get_mut(j) {
            *slot = Neighbour { index, d2 };
        }
        if self.len == k {
            if let Some(last) = self.out.last() {
                self.bound = last.d2;
            }
        }
        true
    }
}

impl PointTree<'_> {
    /// The `out.len()` nearest points to `q`, written to the front of `out`
    /// sorted by squared distance, at equal distance by lower index;
    /// returns how many were found (fewer than `out.len()` only when the
    /// tree has fewer points). 0 for an empty `out` or a NaN query.
    ///
    /// # Panics
    /// Never. No allocation; the stack is [`MAX_DEPTH`](crate::MAX_DEPTH) entries.
    ///
    /// # Example
    /// ```
    /// use kdray_kernel::{knn_brute, Neighbour, PointTree};
    /// use kdray_tools::points::{build_points, PointParams};
    /// use kdray_tools::blob::write_point_tree;
    ///
    /// // A 10 x 10 x 10 grid of points; point i is at (i % 10, i / 10 % 10, i / 100).
    /// let points: Vec<[f32; 3]> = (0..1000)
    ///     .map(|i| [(i % 10) as f32, (i / 10 % 10) as f32, (i / 100) as f32])
    ///     .collect();
    /// let blob = write_point_tree(&build_points(&points, &PointParams::default())?);
    /// let tree = PointTree::from_bytes(blob.as_bytes())?;
    /// let q = [0.0, 0.0, 0.0];
    /// let mut out = [Neighbour::NONE; 4];
    /// assert_eq!(tree.knn(q, &mut out), 4);
    /// // The corner, then its three neighbours at distance 1, lowest index first.
    /// assert_eq!(out.map(|n| (n.index, n.d2)), [(0, 0.0), (1, 1.0), (10, 1.0), (100, 1.0)]);
    /// let mut brute = [Neighbour::NONE; 4];
    /// knn_brute(&points, q, f32::INFINITY, &mut brute);
    /// assert_eq!(out.map(Neighbour::bits), brute.map(Neighbour::bits));
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn knn(&self, q: [f32; 3], out: &mut [Neighbour]) -> usize {
        self.knn_within(q, f32::INFINITY, out)
    }

    /// [`Self::knn`] among the points at squared distance `<= max_d2`
    /// (none if `max_d2` is NaN).
    pub fn knn_within(&self, q: [f32; 3], max_d2: f32, out: &mut [Neighbour]) -> usize {
        if out.is_empty() || !query_is_valid(&q) || max_d2.is_nan() {
            return 0;
        }
        let mut acc = Knn::new(out, max_d2);
        self.search(&q, &mut acc);
        acc.len
    }
}

/// The oracle for [`PointTree::knn_within`]: every point in order, with
/// the same distance expression and tie rule (index = position).
pub fn knn_brute(points: &[[f32; 3]], q: [f32; 3], max_d2: f32, out: &mut [Neighbour]) -> usize {
    if out.is_empty() || !query_is_valid(&q) || max_d2.is_nan() {
        return 0;
    }
    let mut acc = Knn::new(out, max_d2);
    for (i, p) in points.iter().enumerate() {
        acc.offer(distance2(p, &q), i as u32);
    }
    acc.len
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::points::tests_support::{hand_tree, HAND_POINTS};

    #[test]
    fn hand_built_tree_sorts_by_distance_then_index() {
        let parts = hand_tree();
        let tree = parts.view();
        let mut out = [Neighbour::NONE; 4];
        // From (5,5,0): the pile 4, 5 (d2 0), then 6 at (8,1,0): 9+16 = 25,
        // then 2 at (0,3,0): 25+4 = 29 ties 3 at (3,0,0): 4+25 = 29.
        assert_eq!(tree.knn([5.0, 5.0, 0.0], &mut out), 4);
        let got: [(u32, f32); 4] = out.map(|n| (n.index, n.d2));
        assert_eq!(got, [(4, 0.0), (5, 0.0), (6, 25.0), (2, 29.0)]);
        // From (2,0,0): 1 and 3 tie at 1, then 0 at 4.
        let mut out3 = [Neighbour::NONE; 3];
        assert_eq!(tree.knn([2.0, 0.0, 0.0], &mut out3), 3);
        assert_eq!(out3.map(|n| n.index), [1, 3, 0]);
        // More than there are: all 7, the rest untouched.
        let mut all = [Neighbour::NONE; 9];
        assert_eq!(tree.knn([0.0; 3], &mut all), 7);
        assert_eq!(all[7], Neighbour::NONE);
        // max distance 1 from (0,0,0): points 0 (d2 0) and 1 (d2 1).
        assert_eq!(tree.knn_within([0.0; 3], 1.0, &mut all), 2);
        assert_eq!(tree.knn([f32::NAN; 3], &mut all), 0);
        assert_eq!(tree.knn([0.0; 3], &mut []), 0);
    }

    #[test]
    fn random_queries_match_brute_force() {
        let parts = hand_tree();
        let tree = parts.view();
        let mut s = 11u32;
        for k in 1..=8 {
            for _ in 0..300 {
                let q = core::array::from_fn(|_| {
                    s = s.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                    ((s >> 8) % 10) as f32 - 1.0
                });
                let (mut a, mut b) = ([Neighbour::NONE; 8], [Neighbour::NONE; 8]);
                let na = tree.knn(q, &mut a[..k]);
                let nb = knn_brute(&HAND_POINTS, q, f32::INFINITY, &mut b[..k]);
                assert_eq!(na, nb);
                assert_eq!(
                    a.map(Neighbour::bits),
                    b.map(Neighbour::bits),
                    "{q:?} k={k}"
                );
            }
        }
    }
}
