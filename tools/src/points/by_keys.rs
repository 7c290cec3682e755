//! Points of all other sizes (2-D `f32`, and from 4-D `f32` and 2-D `f64`
//! on), moved once a level: a node's median is found among its
//! coordinates on the split axis (the keys, [`key_of_rank`]), then one
//! pass writes each point to its side of the other buffer, where the
//! children's points then are. No point moves twice a level, and no
//! branch depends on the side, a coin toss around a median.
//!
//! Points and indices lie in separate arrays ([`Columns`]), so that the
//! array that ends in leaf order is the kernel's coordinate array once
//! each leaf's run is turned axis by axis ([`ByKeys::leaf`]), in place:
//! no third copy of the points is made. The root reads the caller's
//! points where they lie ([`FromInput`]), so neither buffer is filled
//! before the first partition writes it (16-D builds 2-4% faster than
//! with the input copied first).
//!
//! Against selecting the points themselves (`select_nth_unstable`, which
//! moves each several times), one thread pinned, best of 7 interleaved
//! `kdray build-points`: 300k points at 8-D 35.7 -> 29.9 ms, 16-D 70.8 ->
//! 45.6 ms, 1M `f64` points at 3-D 94.1 -> 88.7 ms. Tried: Hoare's two
//! cursors swapping in place (8-D 18% fewer instructions, slower on the
//! clock: its loops mispredicted); (coordinate, position) pairs selected
//! and the points gathered by position (12% more instructions at 16-D:
//! the gather reads out of order); a `u32` index array selected with ties
//! broken by index (1.2-1.5x the build time, the extra compare
//! mispredicted); both children's boxes taken in the moving pass,
//! branch-free (1.8x the time at 8-D and 16-D: four masked
//! compare-selects per coordinate instead of two) or over each block of
//! 16 points just written (1.2x: the short loops' exits mispredict); a
//! child's keys gathered in its box pass on the axis guessed from the
//! parent's box (no change); a quickselect of its
//! own on the keys (median-of-three pivots, branch-free partitions, a
//! branch-free count among the last 16 keys, to drop `std`'s final
//! insertion sort): 8-D `kdray build-points` of 100k points 108.9M ->
//! 129.5M instructions for 158k -> 140k mispredicts (callgrind); the keys
//! counted into 1,024 buckets over the node's extent and selected among
//! the median's bucket only (counting alone costs more than `std`'s
//! selection: 3.2 against 1.9 ns a key); below 1,024 or 8,192 `f32`
//! points, no point moved at all (each node selecting packed `(key,
//! position)` words, which break ties by themselves, its box and keys
//! read through the positions, only leaves writing their runs): the knn
//! bench's builds 8-D duplicates 0.92x -> 0.83-0.88x kiddo, 16-D
//! 0.89-0.96x -> 0.81-0.99x, 2-D 1.02x -> 0.79x (gathers by position
//! cost more than the moves they save); every node split at its median
//! exactly (ties past the median broken by index as below, not only when
//! the median is the largest coordinate): 8-D duplicates 0.88-0.91x ->
//! 0.62x kiddo, 16-D 0.92x -> 0.69-0.70x, 2-D 1.96-2.10x -> 0.90x (the
//! ties' passes cost more than the levels the balance saves); where ties
//! run past the median, the split moved down to the largest coordinate
//! below it when that balances the node better (one scan of the keys, no
//! index tie-break): 8-D duplicates 0.87-0.93x -> 0.88-0.89x, the rest
//! level or slower by the scan.

use super::median::{key_of_rank, MedianScratch};
use super::store::{bounds_of, leaf_node, put_leaf_major, Store};
use kdray_kernel::{PointNode, Scalar};

/// Points and their input indices, side by side.
pub(super) struct Columns<'a, const D: usize, S> {
    /// The points.
    pub(super) p: &'a mut [[S; D]],
    /// The input index of each.
    pub(super) index: &'a mut [u32],
}

impl<'a, const D: usize, S> Columns<'a, D, S> {
    /// The columns split at `mid`.
    fn split_at(self, mid: usize) -> [Columns<'a, D, S>; 2] {
        let (p0, p1) = self.p.split_at_mut(mid);
        let (i0, i1) = self.index.split_at_mut(mid);
        [Columns { p: p0, index: i0 }, Columns { p: p1, index: i1 }]
    }
}

/// A node's points: in `now`, with `spare` (the same places of the other
/// buffer) for the partition to write into. `now_is_final` when `now`
/// lies in the buffer the leaves' runs are read from.
pub(super) struct ByKeys<'a, const D: usize, S> {
    /// Where the node's points are.
    pub(super) now: Columns<'a, D, S>,
    /// The other buffer's places for them.
    pub(super) spare: Columns<'a, D, S>,
    /// Whether `now` is in the final buffer.
    pub(super) now_is_final: bool,
}

/// Buffers a thread reuses: the median's, the indices of the ties at a
/// median, a leaf's order and a copy of its points.
#[derive(Default)]
pub(super) struct KeyScratch<const D: usize, S> {
    median: MedianScratch<S>,
    ties: Vec<u32>,
    order: Vec<u64>,
    block: Vec<[S; D]>,
}

/// Writes the points of `from` (each with its index) for which `below`
/// holds to the front of `to`, in order, and the others to its back;
/// returns how many are below.
#[inline(always)]
fn split_into<'p, const D: usize, S: Scalar + 'p>(
    from: impl Iterator<Item = (&'p [S; D], u32)>,
    to: &mut Columns<'_, D, S>,
    below: impl Fn(&[S; D], u32) -> bool,
) -> usize {
    let (mut lo, mut hi) = (0, to.p.len());
    for (p, i) in from {
        let b = below(p, i);
        // `lo < hi` until the last point: each step fills one slot.
        let at = if b { lo } else { hi - 1 };
        to.p[at] = *p;
        to.index[at] = i;
        lo += usize::from(b);
        hi -= usize::from(!b);
    }
    lo
}

/// Splits `points` (each with its index from `indices()`) at the median
/// of axis `a` ([`Store::partition`]), writing the below side to the
/// front of `to` and the above side to its back.
fn partition_into<'p, const D: usize, S: Scalar + 'p, J>(
    points: &'p [[S; D]],
    indices: impl Fn() -> J,
    a: usize,
    to: &mut Columns<'_, D, S>,
    scratch: &mut KeyScratch<D, S>,
) -> (usize, S)
where
    J: Iterator<Item = u32>,
{
    let from = || points.iter().zip(indices());
    let n = points.len();
    let mid = n / 2;
    let split = key_of_rank(points, a, mid, &mut scratch.median);
    let mut below = split_into(from(), to, |p, _| p[a] <= split);
    if below == n {
        // The median is the largest coordinate: the points below it,
        // then the `take` ties of lowest index, those below the index of
        // rank `take` among the ties (indices are distinct). Ties are
        // gathered and the points split without a branch on a point's
        // test, as ties and others interleave at random: the knn bench's
        // duplicates 0.87-0.89x -> 0.91-0.93x kiddo at 8-D, 1.94-2.05x ->
        // 2.37-2.44x at 2-D (three interleaved rounds).
        let ties = &mut scratch.ties;
        if ties.len() <= n {
            ties.resize(n + 1, 0);
        }
        let mut count = 0;
        for (p, i) in from() {
            ties[count] = i;
            count += usize::from(p[a] == split);
        }
        let ties = &mut ties[..count];
        // At most `mid` points lie below the median, so `take < ties`.
        let take = mid - (n - count);
        let limit = *ties.select_nth_unstable(take).1;
        below = split_into(from(), to, |p, i| {
            (p[a] < split) | ((p[a] == split) & (i < limit))
        });
    }
    (below, split)
}

impl<const D: usize, S: Scalar> Store<D, S> for ByKeys<'_, D, S> {
    type Scratch = KeyScratch<D, S>;
    type Child = Self;

    fn len(&self) -> usize {
        self.now.p.len()
    }

    fn bounds(&self) -> [[S; D]; 2] {
        bounds_of(self.now.p)
    }

    fn partition(&mut self, a: usize, scratch: &mut KeyScratch<D, S>) -> (usize, S) {
        let now = &self.now;
        let indices = || now.index.iter().copied();
        let split = partition_into(now.p, indices, a, &mut self.spare, scratch);
        std::mem::swap(&mut self.now, &mut self.spare);
        self.now_is_final = !self.now_is_final;
        split
    }

    fn children(self, mid: usize) -> [Self; 2] {
        let [now_below, now_above] = self.now.split_at(mid);
        let [spare_below, spare_above] = self.spare.split_at(mid);
        let now_is_final = self.now_is_final;
        [
            ByKeys {
                now: now_below,
                spare: spare_below,
                now_is_final,
            },
            ByKeys {
                now: now_above,
                spare: spare_above,
                now_is_final,
            },
        ]
    }

    /// Writes the leaf's run to its places in the final buffer, sorted by
    /// index, in the kernel's leaf-major layout ([`put_leaf_major`]).
    ///
    /// Tried: leaves of up to 32 placed by rank, the count of lower
    /// indices, as the in-place store sorts them: 2-D builds 1.01-1.04x ->
    /// 0.98-1.02x kiddo (three interleaved rounds): the ranks' compares
    /// cost more than the sort's mispredicts (4.5 a leaf, callgrind).
    fn leaf(self, offset: usize, scratch: &mut KeyScratch<D, S>) -> PointNode {
        let count = self.len();
        let order = &mut scratch.order;
        order.clear();
        order.extend(
            (self.now.index.iter().enumerate()).map(|(j, &i)| (u64::from(i) << 32) | j as u64),
        );
        order.sort_unstable();
        let (from, to): (&[[S; D]], Columns<'_, D, S>) = if self.now_is_final {
            scratch.block.clear();
            scratch.block.extend_from_slice(self.now.p);
            (&scratch.block, self.now)
        } else {
            (self.now.p, self.spare)
        };
        let coords = to.p.as_flattened_mut();
        for (j, (&o, index)) in order.iter().zip(to.index.iter_mut()).enumerate() {
            *index = (o >> 32) as u32;
            put_leaf_major(coords, count, j, &from[o as u32 as usize]);
        }
        leaf_node(offset, count)
    }
}

/// The root's points: the caller's, read where they lie (their indices
/// their places), with the two buffers the levels below move them
/// between; `first`, which the root writes, is the final one. Saves
/// copying the input into a buffer before the first partition.
pub(super) struct FromInput<'a, const D: usize, S> {
    /// The caller's points.
    pub(super) points: &'a [[S; D]],
    /// The final buffer, as long.
    pub(super) first: Columns<'a, D, S>,
    /// The other buffer, as long.
    pub(super) second: Columns<'a, D, S>,
}

impl<'a, const D: usize, S: Scalar> FromInput<'a, D, S> {
    /// The points as a [`ByKeys`] run: copied into the final buffer.
    fn held(self) -> ByKeys<'a, D, S> {
        self.first.p.copy_from_slice(self.points);
        for (i, index) in self.first.index.iter_mut().enumerate() {
            *index = i as u32;
        }
        ByKeys {
            now: self.first,
            spare: self.second,
            now_is_final: true,
        }
    }
}

impl<'a, const D: usize, S: Scalar> Store<D, S> for FromInput<'a, D, S> {
    type Scratch = KeyScratch<D, S>;
    type Child = ByKeys<'a, D, S>;

    fn len(&self) -> usize {
        self.points.len()
    }

    fn bounds(&self) -> [[S; D]; 2] {
        bounds_of(self.points)
    }

    fn partition(&mut self, a: usize, scratch: &mut KeyScratch<D, S>) -> (usize, S) {
        // Indices fit `u32`: the point count was checked against MAX_POINTS.
        partition_into(self.points, || 0.., a, &mut self.first, scratch)
    }

    fn children(self, mid: usize) -> [ByKeys<'a, D, S>; 2] {
        ByKeys {
            now: self.first,
            spare: self.second,
            now_is_final: true,
        }
        .children(mid)
    }

    fn leaf(self, offset: usize, scratch: &mut KeyScratch<D, S>) -> PointNode {
        self.held().leaf(offset, scratch)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A leaf of `n` points in shuffled index order, ended from either
    /// buffer: the final buffer holds the run sorted by index, axis by
    /// axis, whichever buffer the points were in.
    #[test]
    fn a_leaf_lands_sorted_and_axis_by_axis_in_the_final_buffer() {
        let mut r = crate::rng::Rng::new(9);
        for n in [1, 2, 5, 32, 77] {
            let mut ids: Vec<u32> = (0..n as u32).map(|i| i * 3 + 1).collect();
            for i in (1..n).rev() {
                ids.swap(i, r.below(i + 1));
            }
            let point = |i: u32| [i as f32, -(i as f32), 0.5 * i as f32];
            for now_is_final in [true, false] {
                let mut held: Vec<[f32; 3]> = ids.iter().map(|&i| point(i)).collect();
                let mut held_index = ids.clone();
                let mut other = vec![[0.0; 3]; n];
                let mut other_index = vec![0; n];
                let (now, spare) = (
                    Columns {
                        p: &mut held,
                        index: &mut held_index,
                    },
                    Columns {
                        p: &mut other,
                        index: &mut other_index,
                    },
                );
                let run = ByKeys {
                    now,
                    spare,
                    now_is_final,
                };
                let node = run.leaf(4, &mut KeyScratch::default());
                assert_eq!(node, leaf_node(4, n));
                let (coords, index) = if now_is_final {
                    (held.as_flattened(), &held_index)
                } else {
                    (other.as_flattened(), &other_index)
                };
                let want: Vec<u32> = (0..n as u32).map(|i| i * 3 + 1).collect();
                assert_eq!(index, &want);
                for (j, &i) in want.iter().enumerate() {
                    for a in 0..3 {
                        assert_eq!(coords[a * n + j], point(i)[a], "n {n} j {j} axis {a}");
                    }
                }
            }
        }
    }
}
