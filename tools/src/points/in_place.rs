//! Small points (8 or 16 bytes with their index: 1-D and 3-D `f32`, 1-D
//! `f64`), selected where they lie: each point travels with its index as
//! one [`Item`], and a node's median is found by `select_nth_unstable` on
//! the items themselves.
//!
//! Tried for these sizes, all slower: moving them through their keys
//! ([`in_place`] has the figures); a radix selection on integer
//! keys of the coordinates (a byte histogram per pass, no compares: 1.33x
//! the instructions at 3-D, its filter passes cost more than the compares
//! they save); no selection at all (branch `issue-20-presort`: each axis's
//! order radix sorted once, split stably per level by each point's ranks;
//! the knn bench's 2-D builds 7.4 -> 8.8 ms, 3-D 6.4 -> 9.0 ms: a level
//! moves `D` orders of `D` ranks a point); Floyd and Rivest's sampling
//! select (the knn bench's 2-D builds 7.8 -> 8.7 ms, 3-D 5.9 -> 6.5 ms: it
//! moves a point fewer times only in the top levels, and each move of a
//! 12-byte item costs more than quickselect's); the median found among
//! the keys as `by_keys` finds it (`median::key_of_rank`), then one pass
//! swapping each item to its side: the knn bench's 3-D uniform and
//! clustered builds 1.14-1.20x -> 1.04-1.08x kiddo, whether every node
//! or only those of 1,024 points or more took that path (interleaved
//! rounds; the trees byte for byte the same).

use super::store::{bounds_of, coordinate_order, leaf_node, put_leaf_major, Located, Store};
use kdray_kernel::{PointNode, PointNodeKind, Scalar};

/// A point and its input index, moved together by the selection.
#[derive(Clone, Copy)]
pub(super) struct Item<const D: usize, S> {
    /// The point.
    pub(super) p: [S; D],
    /// Its input index.
    pub(super) index: u32,
}

impl<const D: usize, S> Located<D, S> for Item<D, S> {
    #[inline(always)]
    fn point(&self) -> &[S; D] {
        &self.p
    }
}

/// Are points of this shape selected where they lie? Those of 8 or 16
/// bytes with their index, which the selection moves as one register.
/// A 12-byte item (2-D `f32`) moves as two: through its keys its builds
/// are 1.03-1.08x kiddo's, in place 0.89-0.91x (the knn bench, three
/// interleaved rounds); at 3-D `f32` in place wins, 1.14-1.16x against
/// 0.95-0.99x, and at 1-D (`kdray build-points`, 1M points, best of 5)
/// 48 against 60 ms in `f32`, 50 against 60 ms in `f64`.
pub(super) const fn in_place<const D: usize, S>() -> bool {
    matches!(size_of::<Item<D, S>>(), 8 | 16)
}

/// A node's items, partitioned where they lie; when the build ends they
/// are in leaf order ([`leaf_major`] lays them out for the kernel).
pub(super) struct InPlace<'a, const D: usize, S>(pub(super) &'a mut [Item<D, S>]);

impl<const D: usize, S: Scalar> Store<D, S> for InPlace<'_, D, S> {
    type Scratch = ();
    type Child = Self;

    fn len(&self) -> usize {
        self.0.len()
    }

    fn bounds(&self) -> [[S; D]; 2] {
        bounds_of(self.0)
    }

    fn partition(&mut self, a: usize, (): &mut ()) -> (usize, S) {
        let items = &mut *self.0;
        let mid = items.len() / 2;
        items.select_nth_unstable_by(mid, |x, y| coordinate_order(&x.p[a], &y.p[a]));
        let split = items[mid].p[a];
        // Move the ties after the median to the front of the above part.
        let above = &mut items[mid + 1..];
        let mut ties = 0;
        for j in 0..above.len() {
            if above[j].p[a] == split {
                above.swap(ties, j);
                ties += 1;
            }
        }
        let end = mid + 1 + ties;
        if end < items.len() {
            return (end, split);
        }
        // The median is the largest coordinate: the points below it
        // first, then the ties of lowest index.
        let mut below = 0;
        for j in 0..items.len() {
            // Swapped whichever side the point is on, without a branch
            // (near a median the side is a coin toss): `items[below..j]`
            // are all not below, so the swap moves one of them (or the
            // point itself) to `j`.
            let b = items[j].p[a] < split;
            items.swap(below, j);
            below += usize::from(b);
        }
        let take = mid - below; // the median is not below itself
        let ties = &mut items[below..];
        if take > 0 && take < ties.len() {
            ties.select_nth_unstable_by_key(take, |it| it.index);
        }
        (mid, split)
    }

    fn children(self, mid: usize) -> [Self; 2] {
        let (below, above) = self.0.split_at_mut(mid);
        [InPlace(below), InPlace(above)]
    }

    fn leaf(self, offset: usize, (): &mut ()) -> PointNode {
        sort_by_index(self.0);
        leaf_node(offset, self.0.len())
    }
}

/// Sorts a leaf's items by index (all distinct).
///
/// Leaves of up to [`RANKED_MAX`] go to their rank, the count of lower
/// indices: every index compared with every other, a vector compare and
/// sum without a branch, then one move per point. A comparison sort
/// mispredicts on about every other compare of indices in random order (a
/// quarter of the build's mispredicts at 2-D, callgrind): the knn bench's
/// 100k-point builds 2-D 7.4 -> 7.0 ms, 3-D 5.5 -> 4.9 ms (best of 15,
/// pinned, interleaved).
fn sort_by_index<const D: usize, S: Copy>(items: &mut [Item<D, S>]) {
    let n = items.len();
    let Some(&first) = items.first() else {
        return;
    };
    if n > RANKED_MAX {
        items.sort_unstable_by_key(|it| it.index);
        return;
    }
    let mut keys = [u32::MAX; RANKED_MAX];
    for (k, it) in keys.iter_mut().zip(items.iter()) {
        *k = it.index;
    }
    let mut sorted = [first; RANKED_MAX];
    for it in items.iter() {
        let rank: u32 = keys.iter().map(|&k| u32::from(k < it.index)).sum();
        sorted[rank as usize] = *it;
    }
    items.copy_from_slice(&sorted[..n]);
}

/// The largest leaf [`sort_by_index`] sorts by ranks: the default leaf
/// size of the dimensions built in place (below 8-D).
const RANKED_MAX: usize = 32;

/// The coordinates of `items` (in leaf order) as the kernel stores them:
/// each leaf's run axis by axis.
pub(super) fn leaf_major<const D: usize, S: Scalar>(
    nodes: &[PointNode],
    items: &[Item<D, S>],
) -> Vec<S> {
    let mut coords = vec![S::ZERO; items.len() * D];
    for n in nodes {
        if let PointNodeKind::Leaf { offset, count } = n.kind() {
            let (o, c) = (offset as usize, count as usize);
            let block = &mut coords[o * D..(o + c) * D];
            for (j, it) in items[o..o + c].iter().enumerate() {
                put_leaf_major(block, c, j, &it.p);
            }
        }
    }
    coords
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn leaves_are_sorted_by_index_with_their_points() {
        let mut r = crate::rng::Rng::new(11);
        for n in 0..=(RANKED_MAX + 3) {
            // Distinct indices in random order, each point tagged by its index.
            let mut ids: Vec<u32> = (0..n as u32).map(|i| i * 7 + 3).collect();
            for i in (1..n).rev() {
                ids.swap(i, r.below(i + 1));
            }
            let mut items: Vec<Item<2, f32>> = ids
                .iter()
                .map(|&i| Item {
                    p: [i as f32, -(i as f32)],
                    index: i,
                })
                .collect();
            sort_by_index(&mut items);
            let want: Vec<u32> = (0..n as u32).map(|i| i * 7 + 3).collect();
            assert_eq!(items.iter().map(|it| it.index).collect::<Vec<_>>(), want);
            assert!(items
                .iter()
                .all(|it| it.p == [it.index as f32, -(it.index as f32)]));
        }
    }
}
