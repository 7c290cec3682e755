//! The nearest point: the lecture's query, k = 1.

use super::scalar::query_is_valid;
use super::search::Accumulator;
use super::{distance2, Neighbour, PointTreeN, Scalar};

/// The best point so far: smaller squared distance, then lower index.
pub(crate) struct Nearest<S: Scalar> {
    best: Neighbour<S>,
}

impl<S: Scalar> Nearest<S> {
    /// Nothing found yet; points farther than `max_d2` are never taken
    /// (the sentinel index `u32::MAX` loses every tie at `max_d2`).
    #[inline(always)]
    pub(crate) fn new(max_d2: S) -> Nearest<S> {
        Nearest {
            best: Neighbour {
                index: u32::MAX,
                d2: max_d2,
            },
        }
    }

    pub(crate) fn answer(&self) -> Option<Neighbour<S>> {
        (self.best.index != u32::MAX).then_some(self.best)
    }
}

impl<S: Scalar> Accumulator<S> for Nearest<S> {
    #[inline(always)]
    fn bound(&self) -> S {
        self.best.d2
    }

    #[inline(always)]
    fn offer(&mut self, d2: S, index: u32) -> bool {
        let better = Neighbour::precedes(d2, index, self.best);
        if better {
            self.best = Neighbour { index, d2 };
        }
        better
    }
}

impl<const D: usize, S: Scalar> PointTreeN<'_, D, S> {
    /// The nearest point to `q`: smallest squared distance, at equal
    /// distance the lowest index. `None` for an empty tree or a query with
    /// a coordinate that is NaN or beyond
    /// [`max_point_coord`](crate::max_point_coord).
    ///
    /// # Panics
    /// Never. No allocation; the stack is [`MAX_DEPTH`](crate::MAX_DEPTH) entries.
    ///
    /// # Example
    /// ```
    /// use kdray_kernel::PointTree;
    /// use kdray_tools::points::{build_points, PointParams};
    /// use kdray_tools::blob::write_point_tree;
    ///
    /// // A 10 x 10 x 10 grid of points; point i is at (i % 10, i / 10 % 10, i / 100).
    /// let points: Vec<[f32; 3]> = (0..1000)
    ///     .map(|i| [(i % 10) as f32, (i / 10 % 10) as f32, (i / 100) as f32])
    ///     .collect();
    /// let blob = write_point_tree(&build_points(&points, &PointParams::default())?)?;
    /// let tree = PointTree::from_bytes(blob.as_bytes())?;
    /// let n = tree.nearest([3.2, 4.1, 5.4]).unwrap();
    /// assert_eq!(n.index, 543); // the grid point (3, 4, 5)
    /// assert!(tree.nearest([f32::NAN, 0.0, 0.0]).is_none());
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    #[must_use]
    pub fn nearest(&self, q: [S; D]) -> Option<Neighbour<S>> {
        self.nearest_within(q, S::INFINITY)
    }

    /// [`Self::nearest`] among the points at squared distance `<= max_d2`
    /// (`None` if there is none, or `max_d2` is NaN).
    #[must_use]
    pub fn nearest_within(&self, q: [S; D], max_d2: S) -> Option<Neighbour<S>> {
        if !query_is_valid(&q) || max_d2.is_nan() {
            return None;
        }
        let mut acc = Nearest::new(max_d2);
        self.search(&q, &mut acc);
        acc.answer()
    }
}

/// The oracle for [`PointTreeN::nearest_within`]: every point in order,
/// with the same distance expression and tie rule (index = position).
#[must_use]
pub fn nearest_brute<const D: usize, S: Scalar>(
    points: &[[S; D]],
    q: [S; D],
    max_d2: S,
) -> Option<Neighbour<S>> {
    if !query_is_valid(&q) || max_d2.is_nan() {
        return None;
    }
    let mut acc = Nearest::new(max_d2);
    for (i, p) in points.iter().enumerate() {
        acc.offer(distance2(p, &q), i as u32);
    }
    acc.answer()
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::points::tests_support::{hand_tree, HAND_POINTS};

    #[test]
    fn hand_built_tree_answers_by_distance_then_index() {
        let parts = hand_tree();
        let tree = parts.view();
        // (0.9,0,0): point 1 at (1,0,0) is 0.1 away: d2 = 0.1^2 in f32.
        let n = tree.nearest([0.9, 0.0, 0.0]).unwrap();
        assert_eq!(n.index, 1);
        assert_eq!(n.d2, distance2(&[1.0, 0.0, 0.0], &[0.9, 0.0, 0.0]));
        // (2,0,0): points 1 (1,0,0) and 3 (3,0,0) both at d2 = 1: lower index wins.
        assert_eq!(
            tree.nearest([2.0, 0.0, 0.0]).unwrap().bits(),
            (1, u64::from(1.0f32.to_bits()))
        );
        // (5,5,0) is on the pile of points 4 and 5: d2 = 0, index 4.
        assert_eq!(tree.nearest([5.0, 5.0, 0.0]).unwrap().bits(), (4, 0));
        // max distance: nothing within 0.5 of (10,10,10).
        assert_eq!(tree.nearest_within([10.0, 10.0, 10.0], 0.5), None);
        // Exactly at the max distance counts: point 2 (0,3,0) is at d2 = 1
        // from (0,2,0); nothing is nearer.
        assert_eq!(tree.nearest_within([0.0, 2.0, 0.0], 1.0).unwrap().index, 2);
        assert_eq!(tree.nearest_within([0.0, 2.0, 0.0], 0.99), None);
        assert_eq!(tree.nearest([f32::NAN, 0.0, 0.0]), None);
        assert_eq!(tree.nearest_within([0.0; 3], f32::NAN), None);
    }

    #[test]
    fn random_queries_match_brute_force() {
        let parts = hand_tree();
        let tree = parts.view();
        let mut s = 7u32;
        for _ in 0..1000 {
            let q = core::array::from_fn(|_| {
                s = s.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                (s >> 8) as f32 / (1 << 24) as f32 * 12.0 - 3.0
            });
            let a = tree.nearest(q).map(Neighbour::bits);
            let b = nearest_brute(&HAND_POINTS, q, f32::INFINITY).map(Neighbour::bits);
            assert_eq!(a, b, "{q:?}");
        }
    }
}
