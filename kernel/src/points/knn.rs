//! The k nearest points, into a caller's buffer, sorted.
//!
//! The buffer is kept one of two ways, by k ([`Keep`]): sorted, a new
//! point's slot found walking down from the end with each later point
//! moved up as it is passed (k <= [`SORTED_MAX`]); past that, a binary
//! max-heap on (squared distance, index), filled unsorted and built once
//! full by Floyd's method, sorted in place when the search ends. The order
//! is total (indices are distinct), so both keep exactly the k first
//! points in it: the same answer, bit for bit.

// Tried and lost (the knn bench's uniform sets, kdray / kiddo):
// - the heap from k = 256 down: 3-D 0.87x -> 0.79x, 8-D 1.28x -> 1.15x; sorted past 512: every D loses;
// - each heap point sifted up as it arrives: k = 256-2000 0.80-0.91x -> 0.77-0.89x (a mispredicted exit a point);
// - the slot found first, the later points moved in one `ptr::copy`: 2-D k = 64-128 0.89-0.95x -> 0.81-0.84x;
// - the slot by a branch-free binary search: 3-D k = 64 0.63x, each step waits on the last one's load;
// - filled unsorted, sorted once full (heapsort, Shell's gaps, our quicksort): 0.60-0.91x, their exits mispredict;
// - a leaf chunk's accepted points sorted and merged: k = 64-128 0.57-0.65x (1.3x the instructions);
// - the later points moved by a fixed-length select loop: 0.84x -> 0.30x;
// - `core`'s `sort_unstable_by`: k = 128 0.95-0.98x, but it keeps a panic path the firmware image refuses.

use super::nearest::Nearest;
use super::scalar::query_is_valid;
use super::search::Accumulator;
use super::{distance2, Neighbour, PointTreeN, Scalar};

/// The largest k kept sorted; larger ones use the heap (module docs).
pub(crate) const SORTED_MAX: usize = 128;

/// How the buffer is kept, by k.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Keep {
    /// Sorted; each later point moved up on its own, as the walk down
    /// from the end compares it (k <= [`SORTED_MAX`]).
    Sorted,
    /// A max-heap, sorted when the search ends.
    Heap,
}

/// The best `out.len()` points so far, in the caller's buffer.
struct Knn<'o, S: Scalar> {
    out: &'o mut [Neighbour<S>],
    len: usize,
    /// The k-th best distance once the buffer is full, else the max distance.
    bound: S,
    /// How `out[..len]` is kept.
    keep: Keep,
}

/// Does `a` come after `b` in the result order?
///
/// Tried: both compared as one integer each (the distance's bits above
/// the index: one compare where this takes two and a branch): 2-D k = 10
/// 1.03-1.10x -> 0.96-0.99x kiddo, 3-D 1.03-1.05x -> 1.02-1.03x (three
/// interleaved rounds of the knn bench); the branch on equal distances
/// is never taken on most sets, so it predicts.
#[inline(always)]
fn after<S: Scalar>(a: Neighbour<S>, b: Neighbour<S>) -> bool {
    Neighbour::precedes(b.d2, b.index, a)
}

/// [`after`] as one expression of non-short-circuit `|` and `&`: a value
/// for arithmetic, with no branch on equal distances.
#[inline(always)]
fn after_unbranched<S: Scalar>(a: Neighbour<S>, b: Neighbour<S>) -> bool {
    (b.d2 < a.d2) | ((b.d2 == a.d2) & (b.index < a.index))
}

impl<'o, S: Scalar> Knn<'o, S> {
    #[inline(always)]
    fn new(out: &'o mut [Neighbour<S>], max_d2: S) -> Knn<'o, S> {
        let keep = match out.len() {
            ..=SORTED_MAX => Keep::Sorted,
            _ => Keep::Heap,
        };
        Knn {
            out,
            len: 0,
            bound: max_d2,
            keep,
        }
    }

    /// The answer's length, `out[..len]` sorted.
    fn finish(self) -> usize {
        let Knn { out, len, keep, .. } = self;
        if keep == Keep::Heap {
            // Never filled: still unsorted, not yet a heap.
            if len < out.len() {
                if let Some(h) = out.get_mut(..len) {
                    heapify(h);
                }
            }
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

    /// The k-th best point of a full buffer: the heap's root, or the
    /// sorted buffer's last.
    #[inline(always)]
    fn worst(&self) -> Option<&Neighbour<S>> {
        if self.keep == Keep::Heap {
            self.out.first()
        } else {
            self.out.last()
        }
    }

    /// Counts one more point, unless full (then the worst is dropped);
    /// returns how many of the points held stay: the new one's slot is
    /// among `out[..=kept]`.
    #[inline(always)]
    fn make_room(&mut self) -> usize {
        if self.len == self.out.len() {
            self.len.saturating_sub(1)
        } else {
            self.len += 1;
            self.len - 1
        }
    }

    /// Sorted insertion of a point known to belong in the answer.
    /// (Tried: every kept slot rewritten by selects, a loop of fixed
    /// length without the mispredicted exit: k = 10 at 2-D and 3-D
    /// 0.88-0.90x -> 0.68-0.75x kiddo.)
    #[inline(always)]
    fn insert_sorted(&mut self, n: Neighbour<S>) {
        let kept = self.make_room();
        let Some(run) = self.out.get_mut(..=kept) else {
            return;
        };
        // Shift the worse ones up one slot, walking down from the end.
        let mut j = kept;
        while let Some(&prev) = j.checked_sub(1).and_then(|i| run.get(i)) {
            if !after(prev, n) {
                break;
            }
            put(run, j, prev);
            j -= 1;
        }
        put(run, j, n);
    }

    /// Heap insertion of a point known to belong in the answer.
    fn insert_heap(&mut self, n: Neighbour<S>) {
        let k = self.out.len();
        if self.len == k {
            // Replace the worst (the root) and sift it down.
            put(self.out, 0, n);
            sift_down(self.out, 0);
        } else {
            put(self.out, self.len, n);
            self.len += 1;
            if self.len == k {
                heapify(self.out);
            }
        }
    }
}

/// Floyd's heap construction: every inner node sifted down, the last
/// first.
fn heapify<S: Scalar>(h: &mut [Neighbour<S>]) {
    for j in (0..h.len() / 2).rev() {
        sift_down(h, j);
    }
}

/// Restores the max-heap property below `j` in `h`.
fn sift_down<S: Scalar>(h: &mut [Neighbour<S>], mut j: usize) {
    let Some(&n) = h.get(j) else { return };
    let len = h.len();
    let mut c = 2 * j + 1;
    while c + 1 < len {
        let (Some(&l), Some(&r)) = (h.get(c), h.get(c + 1)) else {
            break;
        };
        // The later child, by arithmetic on its index (which one it is
        // is a coin toss: a branch mispredicted every other level; 2-D
        // and 3-D k = 512 to 2,000 0.59-0.65x -> 0.75-0.82x kiddo). Tried:
        // the child's value picked by a select instead: 0.50-0.66x; a
        // 4-ary heap (half the levels, the latest of four children by
        // two pairs): k = 256 to 2,000 at 2-D, 3-D and 8-D 2-8% slower.
        c += usize::from(after_unbranched(r, l));
        let Some(&child) = h.get(c) else { break };
        if !after(child, n) {
            put(h, j, n);
            return;
        }
        put(h, j, child);
        j = c;
        c = 2 * j + 1;
    }
    // A last child without a sibling. (`c + 1 == len` follows from the
    // `get`; tried without it: the search this is inlined into ran 3-D
    // k = 10 and 64 4-5% slower, interleaved: its registers moved.)
    if let Some(&child) = h.get(c) {
        if c + 1 == len && after(child, n) {
            put(h, j, child);
            j = c;
        }
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
            match self.worst() {
                Some(&w) if Neighbour::precedes(d2, index, w) => {}
                _ => return false,
            }
        }
        let n = Neighbour { index, d2 };
        match self.keep {
            Keep::Sorted => self.insert_sorted(n),
            Keep::Heap => self.insert_heap(n),
        }
        if self.len == k {
            if let Some(w) = self.worst() {
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
    /// tree has fewer points). 0 for an empty `out` or a query with a coordinate that is NaN or beyond
    /// [`max_point_coord`](crate::max_point_coord).
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

    /// Each way the buffer is kept (sorted, the heap), filled or not,
    /// through the scan that offers every point: the k first of all points
    /// sorted by (distance, index). Points on a lattice of 5 values per
    /// axis, so distances tie.
    #[test]
    fn every_way_of_keeping_matches_a_sort() {
        const N: usize = 160;
        let mut s = 5u32;
        let points: [[f32; 3]; N] = core::array::from_fn(|_| {
            core::array::from_fn(|_| {
                s = s.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                ((s >> 8) % 5) as f32
            })
        });
        let q = [2.0, 1.5, 3.0];
        // Every point, sorted by insertion (the oracle shares no code
        // with the buffer's two ways).
        let mut all: [Neighbour; N] = core::array::from_fn(|i| Neighbour {
            index: i as u32,
            d2: distance2(&points[i], &q),
        });
        for i in 1..N {
            let mut j = i;
            while j > 0 && Neighbour::precedes(all[j].d2, all[j].index, all[j - 1]) {
                all.swap(j, j - 1);
                j -= 1;
            }
        }
        for max_d2 in [f32::INFINITY, 3.0] {
            let within = all.iter().filter(|n| n.d2 <= max_d2).count();
            for k in [5, SORTED_MAX, SORTED_MAX + 1, N + 3] {
                let mut out = [Neighbour::NONE; N + 3];
                let found = knn_brute(&points, q, max_d2, &mut out[..k]);
                assert_eq!(found, k.min(within), "k {k} max {max_d2}");
                for (slot, (got, want)) in out.iter().zip(&all).take(found).enumerate() {
                    assert_eq!(got.bits(), want.bits(), "k {k} max {max_d2} slot {slot}");
                }
            }
        }
    }
}
