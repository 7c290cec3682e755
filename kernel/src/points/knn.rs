//! The k nearest points, into a caller's buffer, sorted.
//!
//! Up to [`SORTED_MAX`] neighbours the buffer is kept sorted by insertion
//! (a new point usually lands near the end, and k is small); past it, the
//! buffer is a binary max-heap on (squared distance, index), sorted in
//! place when the search ends: O(log k) per accepted point and
//! O(k log k) for the final sort, where insertion would cost O(k) per
//! point (O(k²) per query). The order is total (indices are distinct), so
//! both keep exactly the k first points in it: the same answer, bit for bit.

use super::nearest::Nearest;
use super::scalar::query_is_valid;
use super::search::Accumulator;
use super::{distance2, Neighbour, PointTreeN, Scalar};

/// The largest k kept by sorted insertion; larger ones use the heap.
/// (Not tuned by measurement: insertion is the cheaper loop for the small
/// k most queries ask; the heap bounds the cost for large k.)
pub(crate) const SORTED_MAX: usize = 32;

/// The best `out.len()` points so far, in the caller's buffer.
struct Knn<'o, S: Scalar> {
    out: &'o mut [Neighbour<S>],
    len: usize,
    /// The k-th best distance once the buffer is full, else the max distance.
    bound: S,
    /// Is `out[..len]` a max-heap (k > [`SORTED_MAX`]) rather than sorted?
    heap: bool,
}

/// Does `a` come after `b` in the result order?
#[inline(always)]
fn after<S: Scalar>(a: Neighbour<S>, b: Neighbour<S>) -> bool {
    Neighbour::precedes(b.d2, b.index, a)
}

impl<'o, S: Scalar> Knn<'o, S> {
    #[inline(always)]
    fn new(out: &'o mut [Neighbour<S>], max_d2: S) -> Knn<'o, S> {
        let heap = out.len() > SORTED_MAX;
        Knn {
            out,
            len: 0,
            bound: max_d2,
            heap,
        }
    }

    /// The answer's length, `out[..len]` sorted.
    fn finish(self) -> usize {
        let Knn { out, len, heap, .. } = self;
        if heap {
            // Heapsort: move the worst to the end, restore the heap before it.
            let mut end = len;
            while end > 1 {
                end -= 1;
                // Swapped through split_last_mut: `swap(0, end)` left a
                // bounds check the optimiser could not remove (a panic path).
                if let Some((last, rest)) = out.get_mut(..=end).and_then(|h| h.split_last_mut()) {
                    if let Some(first) = rest.first_mut() {
                        core::mem::swap(first, last);
                    }
                }
                if let Some(h) = out.get_mut(..end) {
                    sift_down(h, 0);
                }
            }
        }
        len
    }

    /// Sorted insertion of a point known to belong in the answer.
    /// (Tried: every kept slot rewritten by selects, a loop of fixed
    /// length without the mispredicted exit: k = 10 at 2-D and 3-D
    /// 0.88-0.90x -> 0.68-0.75x kiddo.)
    #[inline(always)]
    fn insert_sorted(&mut self, n: Neighbour<S>) {
        let k = self.out.len();
        let mut j = if self.len == k {
            k - 1
        } else {
            self.len += 1;
            self.len - 1
        };
        // Shift the worse ones up one slot; j < k throughout. Read and
        // written through `get`: the optimiser cannot see j < k, and an
        // index would leave a panic path (firmware/ links only without one).
        while j > 0 {
            let Some(&prev) = self.out.get(j - 1) else {
                break;
            };
            if !after(prev, n) {
                break;
            }
            put(self.out, j, prev);
            j -= 1;
        }
        put(self.out, j, n);
    }

    /// Heap insertion of a point known to belong in the answer.
    fn insert_heap(&mut self, n: Neighbour<S>) {
        let k = self.out.len();
        if self.len == k {
            // Replace the worst (the root) and sift it down.
            put(self.out, 0, n);
            sift_down(self.out, 0);
        } else {
            let mut j = self.len;
            self.len += 1;
            // Sift up.
            while j > 0 {
                let parent = (j - 1) / 2;
                let Some(&p) = self.out.get(parent) else {
                    break;
                };
                if !after(n, p) {
                    break;
                }
                put(self.out, j, p);
                j = parent;
            }
            put(self.out, j, n);
        }
    }
}

/// Restores the max-heap property below `j` in `h`.
fn sift_down<S: Scalar>(h: &mut [Neighbour<S>], mut j: usize) {
    let Some(&n) = h.get(j) else { return };
    loop {
        let l = 2 * j + 1;
        let Some(&left) = h.get(l) else { break };
        let (c, child) = match h.get(l + 1) {
            Some(&right) if after(right, left) => (l + 1, right),
            _ => (l, left),
        };
        if !after(child, n) {
            break;
        }
        put(h, j, child);
        j = c;
    }
    put(h, j, n);
}

/// `h[j] = n` without a panic path (`j` is in range at every caller; the
/// optimiser cannot always see it).
#[inline(always)]
fn put<S: Scalar>(h: &mut [Neighbour<S>], j: usize, n: Neighbour<S>) {
    if let Some(slot) = h.get_mut(j) {
        *slot = n;
    }
}

impl<S: Scalar> Accumulator<S> for Knn<'_, S> {
    #[inline(always)]
    fn bound(&self) -> S {
        self.bound
    }

    #[inline(always)]
    fn offer(&mut self, d2: S, index: u32) -> bool {
        let k = self.out.len();
        if d2 > self.bound {
            return false;
        }
        // Full: must precede the k-th best (the last, or the heap's root);
        // otherwise within the max distance.
        if self.len == k {
            let worst = if self.heap {
                self.out.first()
            } else {
                self.out.last()
            };
            match worst {
                Some(&w) if Neighbour::precedes(d2, index, w) => {}
                _ => return false,
            }
        }
        let n = Neighbour { index, d2 };
        if self.heap {
            self.insert_heap(n);
        } else {
            self.insert_sorted(n);
        }
        if self.len == k {
            let worst = if self.heap {
                self.out.first()
            } else {
                self.out.last()
            };
            if let Some(w) = worst {
                self.bound = w.d2;
            }
        }
        true
    }
}

impl<const D: usize, S: Scalar> PointTreeN<'_, D, S> {
    /// The `out.len()` nearest points to `q`, written to the front of `out`
    /// sorted by squared distance, at equal distance by lower index;
    /// returns how many were found (fewer than `out.len()` only when the
    /// tree has fewer points). 0 for an empty `out` or a NaN query.
    /// O(k log k) per query at most, for any k.
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
    /// let blob = write_point_tree(&build_points(&points, &PointParams::default())?)?;
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
    pub fn knn(&self, q: [S; D], out: &mut [Neighbour<S>]) -> usize {
        self.knn_within(q, S::INFINITY, out)
    }

    /// [`Self::knn`] among the points at squared distance `<= max_d2`
    /// (none if `max_d2` is NaN).
    pub fn knn_within(&self, q: [S; D], max_d2: S, out: &mut [Neighbour<S>]) -> usize {
        if out.is_empty() || !query_is_valid(&q) || max_d2.is_nan() {
            return 0;
        }
        if let [one] = out {
            // k = 1 is the nearest point: its accumulator keeps one
            // neighbour in registers, where the buffer's is in memory.
            let mut acc = Nearest::new(max_d2);
            self.search(&q, &mut acc);
            let best = acc.answer();
            if let Some(n) = best {
                *one = n;
            }
            return usize::from(best.is_some());
        }
        let mut acc = Knn::new(out, max_d2);
        self.search(&q, &mut acc);
        acc.finish()
    }
}

/// The oracle for [`PointTreeN::knn_within`]: every point in order, with
/// the same distance expression and tie rule (index = position).
pub fn knn_brute<const D: usize, S: Scalar>(
    points: &[[S; D]],
    q: [S; D],
    max_d2: S,
    out: &mut [Neighbour<S>],
) -> usize {
    if out.is_empty() || !query_is_valid(&q) || max_d2.is_nan() {
        return 0;
    }
    let mut acc = Knn::new(out, max_d2);
    for (i, p) in points.iter().enumerate() {
        acc.offer(distance2(p, &q), i as u32);
    }
    acc.finish()
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
        // k = 1 (the nearest point's path): a point exactly at the max
        // distance counts, none within leaves the buffer as it was.
        let mut one = [Neighbour::NONE];
        assert_eq!(tree.knn_within([0.0, 2.0, 0.0], 1.0, &mut one), 1);
        assert_eq!(one[0].bits(), (2, u64::from(1.0f32.to_bits())));
        let mut one = [Neighbour::NONE];
        assert_eq!(tree.knn_within([0.0, 2.0, 0.0], 0.99, &mut one), 0);
        assert_eq!(one[0], Neighbour::NONE);
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
