//! Where a node's points lie while the builder splits them ([`Store`]),
//! the tight bounds of a run of points ([`bounds_of`]), the leaf node
//! over a run ([`leaf_node`]) and the run's layout in the kernel's
//! coordinate array ([`put_leaf_major`]).

use kdray_kernel::{PointNode, Scalar};

/// A node's points, in the layout the builder moves them in: what the
/// builder asks of them, from the root to the leaves.
///
/// Two layouts exist, chosen by the points' size: points of 8 or 16
/// bytes with their index are selected where they lie
/// (`in_place::InPlace`); the others are moved once a level by a
/// selection among their coordinates (`by_keys::ByKeys`).
pub(super) trait Store<const D: usize, S: Scalar>: Sized + Send {
    /// Buffers a thread reuses from node to node.
    type Scratch: Default;

    /// How many points the node holds.
    fn len(&self) -> usize;

    /// The tight bounds of the node's points.
    fn bounds(&self) -> [[S; D]; 2];

    /// Splits the node's points at the median of axis `a`: below `..mid`,
    /// above `mid..`; returns `mid` and the split location.
    ///
    /// Points equal to the median all go below when some point is left
    /// above: the above child's box then starts strictly past the split
    /// plane, so a query sitting on a pile or plane of equal coordinates
    /// (where ties make every subtree at distance 0 worth a visit) prunes
    /// the above side by the plane's gap. Measured on the `dupes` anchor
    /// set (one core): k = 1 0.8-0.9M -> 1.3-2.0M queries/s; no change on
    /// uniform points.
    ///
    /// Which points go below depends only on their coordinates and
    /// indices, never on the order the node holds them in: all those at
    /// or below the median, or, when the median is the largest
    /// coordinate, those below it and then the ties of lowest index up to
    /// `mid`.
    fn partition(&mut self, a: usize, scratch: &mut Self::Scratch) -> (usize, S);

    /// The store the children's points are in.
    type Child: Store<D, S, Scratch = Self::Scratch>;

    /// The children's points after [`Store::partition`] returned `mid`.
    fn children(self, mid: usize) -> [Self::Child; 2];

    /// Ends the node as a leaf at `offset` (its first point's place in
    /// leaf order): its points sorted by index, as the kernel's tie rule
    /// needs.
    fn leaf(self, offset: usize, scratch: &mut Self::Scratch) -> PointNode;
}

/// A leaf of `count` points at `offset` (the point count was checked
/// against `MAX_POINTS`, so both fit).
pub(super) fn leaf_node(offset: usize, count: usize) -> PointNode {
    PointNode::leaf(offset as u32, count as u32).unwrap_or(PointNode::EMPTY_LEAF)
}

/// Writes `p`, the `j`-th point of a leaf's run of `count`, into the
/// run's block of the kernel's coordinate array: `count * D` values axis
/// by axis (`block[a * count + j]`, the leaf-major layout of
/// `kdray_kernel::PointTreeN::coords`).
#[inline(always)]
pub(super) fn put_leaf_major<const D: usize, S: Copy>(
    block: &mut [S],
    count: usize,
    j: usize,
    p: &[S; D],
) {
    for (a, &x) in p.iter().enumerate() {
        block[a * count + j] = x;
    }
}

/// A record that carries a point.
pub(super) trait Located<const D: usize, S> {
    /// The point's coordinates.
    fn point(&self) -> &[S; D];
}

impl<const D: usize, S> Located<D, S> for [S; D] {
    #[inline(always)]
    fn point(&self) -> &[S; D] {
        self
    }
}

/// The tight bounds of `items` (the zero box for none).
///
/// Compares, not `f32::min`: the points are finite (checked), and a plain
/// compare-and-select is one vector min per lane group where the NaN-aware
/// `min` is three instructions per coordinate (a fifth of a 16-D build's
/// instructions, callgrind).
pub(super) fn bounds_of<const D: usize, S: Scalar, T: Located<D, S>>(items: &[T]) -> [[S; D]; 2] {
    // Up to 2-D a box's four compare-selects a point wait on the last
    // point's: four boxes over every fourth point, merged at the end, cut
    // the knn bench's 100k-point 2-D builds from 7.0-7.1 to 5.5 ms. From
    // 3-D on a point already gives the processor six or more independent
    // compare-selects, and four boxes no longer fit in its registers
    // (3-D 4.9-5.0 -> 5.1-5.3 ms); two boxes at 8-D `f32` read the same
    // as one (7.1-7.2 against 7.2-7.3 ms on the duplicates).
    if D <= 2 {
        bounds_in::<4, D, S, T>(items)
    } else {
        bounds_in::<1, D, S, T>(items)
    }
}

/// [`bounds_of`] through `B` boxes, each over every `B`-th point.
fn bounds_in<const B: usize, const D: usize, S: Scalar, T: Located<D, S>>(
    items: &[T],
) -> [[S; D]; 2] {
    let Some(first) = items.first() else {
        return [[S::ZERO; D]; 2];
    };
    let mut boxes = [[*first.point(); 2]; B];
    let mut groups = items.chunks_exact(B);
    for group in &mut groups {
        for (b, it) in boxes.iter_mut().zip(group) {
            grow_box(b, it.point());
        }
    }
    let mut b = boxes[0];
    for it in groups.remainder() {
        grow_box(&mut b, it.point());
    }
    for other in &boxes[1..] {
        grow_box(&mut b, &other[0]);
        grow_box(&mut b, &other[1]);
    }
    b
}

/// Widens the box `b` to hold `p`.
#[inline(always)]
fn grow_box<const D: usize, S: Scalar>(b: &mut [[S; D]; 2], p: &[S; D]) {
    for a in 0..D {
        let x = p[a];
        b[0][a] = if x < b[0][a] { x } else { b[0][a] };
        b[1][a] = if x > b[1][a] { x } else { b[1][a] };
    }
}

/// The order the selections compare coordinates in: the points are
/// finite, so `<` orders them (-0 and +0 as equals, which the partition
/// rule puts on one side): 93M -> 78M instructions for a 100k-point 3-D
/// build against `total_cmp`'s bit twiddling.
#[inline(always)]
pub(super) fn coordinate_order<S: Scalar>(x: &S, y: &S) -> std::cmp::Ordering {
    x.partial_cmp(y).unwrap_or(std::cmp::Ordering::Equal)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `bounds_of` against one fold over every point, at each length
    /// around its four boxes' groups.
    fn bounds_match_a_fold<const D: usize>(r: &mut crate::rng::Rng) {
        for n in 1..20 {
            let items: Vec<[f32; D]> = (0..n)
                .map(|_| std::array::from_fn(|_| r.range(-5.0, 5.0)))
                .collect();
            let want = items.iter().fold([items[0]; 2], |[lo, hi], p| {
                [
                    std::array::from_fn(|a| lo[a].min(p[a])),
                    std::array::from_fn(|a| hi[a].max(p[a])),
                ]
            });
            assert_eq!(bounds_of(&items), want, "D {D} n {n}");
        }
    }

    #[test]
    fn node_bounds_are_tight() {
        let mut r = crate::rng::Rng::new(4);
        bounds_match_a_fold::<1>(&mut r);
        bounds_match_a_fold::<2>(&mut r);
        bounds_match_a_fold::<3>(&mut r);
        bounds_match_a_fold::<8>(&mut r);
        assert_eq!(bounds_of::<2, f32, [f32; 2]>(&[]), [[0.0; 2]; 2]);
    }
}
