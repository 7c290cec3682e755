//! The point k-d tree of the lecture's nearest-neighbour search, over
//! D-dimensional points (D a compile-time constant, any D >= 1) of `f32` or
//! `f64`: a validated, zero-copy view of a point blob (`blob.rs`, whose
//! layout `docs/points.md` repeats), and its
//! queries (one file each: [`nearest`](PointTreeN::nearest),
//! [`knn`](PointTreeN::knn), [`within`](PointTreeN::within)).
//! [`PointTree`] is the 3-D `f32` tree.
//!
//! # How a query prunes
//! The child on the query's side of the split plane (the near child) is
//! searched first; the far child is pushed with a lower bound on its
//! points' squared distances: the squared gap from the query to the split
//! plane (every far point lies beyond it: the validator checks each child's
//! box against the plane). When it is popped, its tight box gives a better
//! bound. A subtree is skipped when its bound is *greater* than the current
//! k-th best. Both bounds are computed with the same operations as a
//! point's distance ([`distance2`]), and IEEE subtraction, multiplication
//! and addition are monotone, so neither exceeds the computed distance of
//! any point it covers: no point that brute force would report is ever
//! pruned, and pruning only on *greater* keeps equal-distance points with
//! lower indices reachable. Hence exactness, in every dimension and for
//! both scalar types.
//!
//! # Ties and degenerate sets
//! Results are ordered by (squared distance, point index). A leaf's
//! indices are strictly increasing, so in a leaf whose points all sit at
//! one location (a pile of duplicates, which no split can divide) the scan
//! stops at the first point the query rejects: every later one is at the
//! same distance with a higher index.

mod blob;
mod knn;
mod nearest;
mod node;
mod scalar;
mod search;
mod within;

pub use blob::PointShape;
pub use knn::knn_brute;
pub use nearest::nearest_brute;
pub use node::{PointNode, PointNodeKind, MAX_POINT_FIELD};
pub use scalar::{distance2, max_point_coord, max_point_coord_log2, Scalar};
pub use within::{within_brute, BufferTooSmall};

// Everything the point tree takes from the rest of the kernel: the blob's
// header and section reader, its errors, and the depth limit.
use crate::blob::wire::{self, Header, Sections, KIND_POINTS};
use crate::blob::{replay_depth_first, BlobError, WriteError, MAX_DEPTH};
use crate::geometry::Bounds;

/// One neighbour: the point's index and its squared distance to the query.
/// `repr(C)`; for `f32` 8 bytes, the record of a `.knn` file.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct Neighbour<S: Scalar = f32> {
    /// The point's index in the builder's input.
    pub index: u32,
    /// The squared Euclidean distance, [`distance2`].
    pub d2: S,
}

impl<S: Scalar> Neighbour<S> {
    /// The filler for a missing neighbour in a `.knn` file (fewer than k
    /// points): index `0xFFFF_FFFF`, distance `+inf`.
    pub const NONE: Neighbour<S> = Neighbour {
        index: u32::MAX,
        d2: S::INFINITY,
    };

    /// Does `(d2, index)` come before `other` in the result order: smaller
    /// squared distance, then lower index?
    #[inline(always)]
    #[must_use]
    pub fn precedes(d2: S, index: u32, other: Neighbour<S>) -> bool {
        // Tried: `|` and `&` for one branch less (no second branch on
        // equal distances): k = 10 at 2-D 0.86-0.88x -> 0.82x kiddo.
        d2 < other.d2 || (d2 == other.d2 && index < other.index)
    }

    /// The bits of both fields, for bitwise comparisons in tests.
    #[must_use]
    pub fn bits(self) -> (u32, u64) {
        (self.index, self.d2.bits())
    }
}

/// A point k-d tree over `D`-dimensional points of `S`, borrowed. Cheap to
/// copy; share it across threads. Load one with [`PointTreeN::from_bytes`].
#[derive(Clone, Copy, Debug)]
pub struct PointTreeN<'a, const D: usize, S: Scalar = f32> {
    pub(crate) nodes: &'a [PointNode],
    /// One per node: the split location of an interior node (0 for leaves).
    pub(crate) splits: &'a [S],
    pub(crate) indices: &'a [u32],
    /// The points' coordinates, `D` per point, leaf by leaf; within a
    /// leaf's run axis by axis ([`Self::coords`]).
    pub(crate) coords: &'a [S],
    /// One per node: `[min, max]` of the points at or below it.
    pub(crate) bounds: &'a [[[S; D]; 2]],
    pub(crate) max_depth: u32,
}

/// The 3-D `f32` point tree.
pub type PointTree<'a> = PointTreeN<'a, 3, f32>;

impl<'a, const D: usize, S: Scalar> PointTreeN<'a, D, S> {
    /// No tree has zero dimensions (checked at compile time).
    const DIMENSION_IS_POSITIVE: () = assert!(D >= 1, "a point tree needs D >= 1");

    /// The nodes, root first.
    #[must_use]
    pub fn nodes(&self) -> &'a [PointNode] {
        self.nodes
    }

    /// The split location of each interior node (0 for a leaf).
    #[must_use]
    pub fn splits(&self) -> &'a [S] {
        self.splits
    }

    /// The original index of the point at each position ([`Self::point`]).
    #[must_use]
    pub fn indices(&self) -> &'a [u32] {
        self.indices
    }

    /// How many points the tree holds.
    #[must_use]
    pub fn len(&self) -> usize {
        self.indices.len()
    }

    /// Does the tree hold no point?
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.indices.is_empty()
    }

    /// The coordinates of every point, `D` per point, in leaf order: a
    /// leaf of `c` points at positions `o..o + c` owns `coords[o * D..(o + c) * D]`,
    /// and holds there its points' axis-0 coordinates, then their axis-1
    /// coordinates, and so on (`c` of each), so the leaf scan reads each
    /// axis as one contiguous vector ([`Self::point`] undoes it).
    #[must_use]
    pub fn coords(&self) -> &'a [S] {
        self.coords
    }

    /// The point at `position` (original index: `indices()[position]`),
    /// or `None` past the end. O(nodes): it looks for the leaf holding the
    /// position (for inspection; the queries never need it).
    #[must_use]
    pub fn point(&self, position: usize) -> Option<[S; D]> {
        let (offset, count) = self.nodes.iter().find_map(|n| match n.kind() {
            PointNodeKind::Leaf { offset, count } => {
                let (o, c) = (offset as usize, count as usize);
                (position >= o && position - o < c).then_some((o, c))
            }
            PointNodeKind::Interior { .. } => None,
        })?;
        let block = self.leaf_block(offset, count)?;
        let j = position - offset;
        let mut p = [S::ZERO; D];
        for (a, c) in p.iter_mut().enumerate() {
            *c = *block.get(a * count + j)?;
        }
        Some(p)
    }

    /// A leaf's coordinates: `count` of each axis, axis by axis.
    #[inline(always)]
    pub(crate) fn leaf_block(&self, offset: usize, count: usize) -> Option<&'a [S]> {
        let start = offset.checked_mul(D)?;
        let end = offset.checked_add(count)?.checked_mul(D)?;
        self.coords.get(start..end)
    }

    /// The tight bounds `[min, max]` of the points at or below each node.
    #[must_use]
    pub fn node_bounds(&self) -> &'a [[[S; D]; 2]] {
        self.bounds
    }

    /// The depth of the deepest node.
    #[must_use]
    pub fn max_depth(&self) -> u32 {
        self.max_depth
    }
}

#[cfg(test)]
pub(crate) mod tests_support {
    //! A hand-built 3-D tree the query tests share.
    use super::{PointNode, PointTree};

    /// The points by index; 4 and 5 are a pile of two.
    pub(crate) const HAND_POINTS: [[f32; 3]; 7] = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 3.0, 0.0],
        [3.0, 0.0, 0.0],
        [5.0, 5.0, 0.0],
        [5.0, 5.0, 0.0],
        [8.0, 1.0, 0.0],
    ];

    pub(crate) struct HandParts {
        pub(crate) nodes: [PointNode; 5],
        pub(crate) splits: [f32; 5],
        pub(crate) indices: [u32; 7],
        pub(crate) coords: [f32; 21],
        pub(crate) bounds: [[[f32; 3]; 2]; 5],
    }

    impl HandParts {
        pub(crate) fn view(&self) -> PointTree<'_> {
            PointTree::from_parts(
                &self.nodes,
                &self.splits,
                &self.indices,
                &self.coords,
                &self.bounds,
            )
            .unwrap()
        }
    }

    /// ```text
    /// 0: x <= 2 ? 1 : 2                 bounds (0,0,0)-(8,5,0)
    /// 1: leaf, positions 0..3 = {0,1,2}  (0,0,0)-(1,3,0)
    /// 2: y <= 1 ? 3 : 4                 (3,0,0)-(8,5,0)
    /// 3: leaf, positions 3..5 = {3,6}    (3,0,0)-(8,1,0)
    /// 4: leaf, positions 5..7 = {4,5}    (5,5,0)-(5,5,0): a pile
    /// ```
    pub(crate) fn hand_tree() -> HandParts {
        let p = HAND_POINTS;
        HandParts {
            nodes: [
                PointNode::interior(0, 1).unwrap(),
                PointNode::leaf(0, 3).unwrap(),
                PointNode::interior(1, 3).unwrap(),
                PointNode::leaf(3, 2).unwrap(),
                PointNode::leaf(5, 2).unwrap(),
            ],
            splits: [2.0, 0.0, 1.0, 0.0, 0.0],
            indices: [0, 1, 2, 3, 6, 4, 5],
            // Each leaf's run axis by axis: its x coordinates, its y, its z.
            coords: [
                p[0][0], p[1][0], p[2][0], p[0][1], p[1][1], p[2][1], 0.0, 0.0, 0.0, // leaf 1
                p[3][0], p[6][0], p[3][1], p[6][1], 0.0, 0.0, // leaf 3
                p[4][0], p[5][0], p[4][1], p[5][1], 0.0, 0.0, // leaf 4
            ],
            bounds: [
                [[0.0; 3], [8.0, 5.0, 0.0]],
                [[0.0; 3], [1.0, 3.0, 0.0]],
                [[3.0, 0.0, 0.0], [8.0, 5.0, 0.0]],
                [[3.0, 0.0, 0.0], [8.0, 1.0, 0.0]],
                [[5.0, 5.0, 0.0], [5.0, 5.0, 0.0]],
            ],
        }
    }
}
