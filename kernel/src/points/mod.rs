//! The point k-d tree of the lecture's nearest-neighbour search: a
//! validated, zero-copy view of a kind-2 blob, and its queries (one file
//! each: [`nearest`](PointTree::nearest), [`knn`](PointTree::knn),
//! [`within`](PointTree::within)).
//!
//! # Blob sections (after the 64-byte header, `wire`)
//! 1. nodes (8 B each), the triangle tree's [`Node`] and depth-first layout;
//!    a leaf's word is always the *offset* of its run, also for one point;
//! 2. point indices (4 B each, `index_count == item_count`): the original
//!    index of the point stored at each position;
//! 3. points (12 B each), stored in leaf order, so a leaf's points are one
//!    contiguous run (no indirection on the query's hot path);
//! 4. node bounds (24 B each, one per node): the tight bounds of the points
//!    at or below the node. The header's scene bounds are the root's.
//!
//! # How a query prunes
//! The child on the query's side of the split plane (the near child) is
//! searched first; the far child is pushed with a lower bound on its
//! points' squared distances: the squared gap from the query to the split
//! plane (every far point lies beyond it: the validator checks each child's
//! box against the plane). When it is popped, its tight box gives a better
//! bound. A subtree is skipped when its bound is *greater* than the current
//! k-th best. Both bounds are computed with the same f32 operations as a
//! point's distance ([`distance2`]), and f32 subtraction, multiplication
//! and addition are monotone, so neither exceeds the computed distance of
//! any point it covers: no point that brute force would report is ever
//! pruned, and pruning only on *greater* keeps equal-distance points with
//! lower indices reachable. Hence exactness.
//!
//! # Ties and degenerate sets
//! Results are ordered by (squared distance, point index). A leaf's
//! indices are strictly increasing, so in a leaf whose points all sit at
//! one location (a pile of duplicates, which no split can divide) the scan
//! stops at the first point the query rejects: every later one is at the
//! same distance with a higher index.
//!
//! # Dimension
//! Points are 3-D. 2-D data is stored with `z = 0`: the squared distances
//! are then bit for bit those of the 2-D expression `dx*dx + dy*dy`.

mod knn;
mod nearest;
mod search;
mod within;

pub use knn::knn_brute;
pub use nearest::nearest_brute;
pub use within::{within_brute, BufferTooSmall};

use crate::blob::wire::{self, Header, Sections, KIND_POINTS};
use crate::blob::{validate_nodes_with, BlobError, Node, NodeKind};
use crate::geometry::Bounds;
use bytemuck::{Pod, Zeroable};

/// One neighbour: the point's index and its squared distance to the query.
/// `repr(C)`, Pod, 8 bytes: the record of a `.knn` file.
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
#[repr(C)]
pub struct Neighbour {
    /// The point's index in the builder's input.
    pub index: u32,
    /// The squared Euclidean distance, [`distance2`].
    pub d2: f32,
}

impl Neighbour {
    /// The filler for a missing neighbour in a `.knn` file (fewer than k
    /// points): index `0xFFFF_FFFF`, distance `+inf`.
    pub const NONE: Neighbour = Neighbour {
        index: u32::MAX,
        d2: f32::INFINITY,
    };

    /// Does `self` come before `(d2, index)` in the result order: smaller
    /// squared distance, then lower index?
    #[inline(always)]
    #[must_use]
    pub fn precedes(d2: f32, index: u32, other: Neighbour) -> bool {
        d2 < other.d2 || (d2 == other.d2 && index < other.index)
    }

    /// The bits of both fields, for bitwise comparisons in tests.
    #[must_use]
    pub fn bits(self) -> (u32, u32) {
        (self.index, self.d2.to_bits())
    }
}

/// The squared distance between `p` and `q`: `dx*dx + dy*dy + dz*dz` with
/// `d = p - q`, summed left to right in f32. The one expression the tree
/// and brute force share, so their answers agree bit for bit.
#[inline(always)]
#[must_use]
pub fn distance2(p: &[f32; 3], q: &[f32; 3]) -> f32 {
    let dx = p[0] - q[0];
    let dy = p[1] - q[1];
    let dz = p[2] - q[2];
    dx * dx + dy * dy + dz * dz
}

/// The squared distance from `q` to the nearest point of box `b`, by the
/// expression of [`distance2`] on per-axis gaps, so it is never above the
/// computed distance of a point inside the box (module docs).
#[inline(always)]
pub(crate) fn box_distance2(b: &Bounds, q: &[f32; 3]) -> f32 {
    let gap = |a: usize| (b.min[a] - q[a]).max(q[a] - b.max[a]).max(0.0);
    let (dx, dy, dz) = (gap(0), gap(1), gap(2));
    dx * dx + dy * dy + dz * dz
}

/// Is `q` a query the trees answer? NaN coordinates get an empty answer.
#[inline(always)]
pub(crate) fn query_is_valid(q: &[f32; 3]) -> bool {
    !q.iter().any(|c| c.is_nan())
}

/// A point k-d tree, borrowed. Cheap to copy; share it across threads.
#[derive(Clone, Copy, Debug)]
pub struct PointTree<'a> {
    pub(crate) nodes: &'a [Node],
    pub(crate) indices: &'a [u32],
    pub(crate) points: &'a [[f32; 3]],
    pub(crate) bounds: &'a [Bounds],
    pub(crate) max_depth: u32,
}

impl<'a> PointTree<'a> {
    /// Loads and validates a kind-2 blob written by `kdray-tools` (or
    /// `kdray build-points`).
    ///
    /// Checks, in this order: alignment, header (magic, endianness,
    /// version, kind), section lengths, checksum, the header's scene bounds
    /// against the root's, then the tree itself (see
    /// [`PointTree::from_parts`]). O(size of the blob), no allocation.
    ///
    /// # Errors
    /// A [`BlobError`] naming the first problem found.
    ///
    /// # Panics
    /// Never, for any input.
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
    /// let blob = write_point_tree(&build_points(&points, &PointParams::default())?);
    /// let tree = PointTree::from_bytes(blob.as_bytes())?;
    /// assert_eq!(tree.points().len(), 1000);
    /// // A triangle blob is not a point blob.
    /// assert!(PointTree::from_bytes(&blob.as_bytes()[..64]).is_err());
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn from_bytes(bytes: &'a [u8]) -> Result<Self, BlobError> {
        let (header, tree, whole) = Self::sections(bytes)?;
        wire::verify_checksum(header, whole)?;
        let tree = Self::from_parts(tree.nodes, tree.indices, tree.points, tree.bounds)?;
        let root = tree.bounds.first().copied();
        if root.map(|b| (b.min, b.max)) != Some((header.bounds_min, header.bounds_max)) {
            return Err(BlobError::BadBounds);
        }
        header.expect_depth(tree.max_depth)?;
        Ok(tree)
    }

    /// Loads a blob checking only what O(1) allows: alignment, header and
    /// section lengths. For blobs that passed [`PointTree::from_bytes`]
    /// before (e.g. written by this build pipeline and embedded).
    ///
    /// # Errors
    /// A [`BlobError`] for a bad header or wrong section lengths.
    ///
    /// # Safety
    /// `bytes` must be accepted by [`PointTree::from_bytes`]. The queries
    /// never read out of bounds either way, but their answers (and their
    /// running time) rely on the validated invariants.
    pub unsafe fn from_bytes_unchecked(bytes: &'a [u8]) -> Result<Self, BlobError> {
        let (header, tree, _) = Self::sections(bytes)?;
        header.depth_fits_stack()?;
        Ok(tree)
    }

    /// The header, the unvalidated view and the whole blob (what the
    /// checksum covers).
    fn sections(bytes: &'a [u8]) -> Result<(&'a Header, Self, &'a [u8]), BlobError> {
        let (header, mut s) = Sections::open(bytes, KIND_POINTS)?;
        let nodes = s.take("nodes", header.node_count)?;
        let indices = s.take("point indices", header.index_count)?;
        let points = s.take("points", header.item_count)?;
        let bounds = s.take("node bounds", header.node_count)?;
        let whole = s.finish()?;
        let tree = PointTree {
            nodes,
            indices,
            points,
            bounds,
            max_depth: header.max_depth,
        };
        Ok((header, tree, whole))
    }

    /// A view of a tree held in memory (a builder's output), validated like
    /// a blob: one index per point and one box per node; the depth-first
    /// node layout, finite splits and depth at most [`MAX_DEPTH`](crate::MAX_DEPTH) (as for
    /// triangle trees); every box finite, not inverted and inside its
    /// parent's; leaf runs tiling the points in depth-first order; every
    /// point inside its leaf's box; each leaf's indices strictly increasing
    /// and naming a point.
    ///
    /// Not checked (it would need memory): that no index appears in two
    /// leaves. A blob that repeats one answers with the repeat, no worse.
    ///
    /// # Errors
    /// A [`BlobError`] naming the first problem found.
    ///
    /// # Panics
    /// Never, for any input.
    pub fn from_parts(
        nodes: &'a [Node],
        indices: &'a [u32],
        points: &'a [[f32; 3]],
        bounds: &'a [Bounds],
    ) -> Result<Self, BlobError> {
        if indices.len() != points.len() {
            return Err(BlobError::SectionMismatch {
                what: "point indices",
                expected: points.len() as u32,
                found: indices.len() as u32,
            });
        }
        if bounds.len() != nodes.len() {
            return Err(BlobError::SectionMismatch {
                what: "node bounds",
                expected: nodes.len() as u32,
                found: bounds.len() as u32,
            });
        }
        if let Some(root) = bounds.first() {
            if !root.is_valid() {
                return Err(BlobError::BadNodeBounds { node: 0 });
            }
        }
        let mut next_run = 0u32;
        let max_depth = validate_nodes_with(nodes, indices, points.len(), |i, node| {
            let own = bounds
                .get(i as usize)
                .ok_or(BlobError::BadNodeBounds { node: i })?;
            match node.kind() {
                NodeKind::Interior { child, axis, split } => {
                    let a = axis.index();
                    // Below child's points at or below the split plane,
                    // above child's at or above it: the queries' plane
                    // bound relies on it. (A direct test, not a table of
                    // function pointers: an indirect call has no static
                    // stack bound, and `get` because through one `a < 3`
                    // is not seen and an index is a panic path; firmware/.)
                    let on_side = |b: &Bounds, above: bool| {
                        if above {
                            b.min.get(a).is_some_and(|&m| m >= split)
                        } else {
                            b.max.get(a).is_some_and(|&m| m <= split)
                        }
                    };
                    for (c, above) in [(child, false), (child + 1, true)] {
                        let inner = bounds.get(c as usize);
                        if !inner
                            .is_some_and(|b| b.is_valid() && nests(b, own) && on_side(b, above))
                        {
                            return Err(BlobError::BadNodeBounds { node: c });
                        }
                    }
                    Ok(())
                }
                NodeKind::Leaf { count, word } => {
                    check_leaf(i, count, word, next_run, indices, points, own)?;
                    next_run += count;
                    Ok(())
                }
            }
        })?;
        if next_run as usize != points.len() {
            return Err(BlobError::LeafOutOfOrder {
                node: nodes.len() as u32,
                offset: next_run,
                expected: points.len() as u32,
            });
        }
        Ok(PointTree {
            nodes,
            indices,
            points,
            bounds,
            max_depth,
        })
    }

    /// The nodes, root first.
    #[must_use]
    pub fn nodes(&self) -> &'a [Node] {
        self.nodes
    }

    /// The original index of the point at each position of [`Self::points`].
    #[must_use]
    pub fn indices(&self) -> &'a [u32] {
        self.indices
    }

    /// The points in leaf order (see [`Self::indices`] for their indices).
    #[must_use]
    pub fn points(&self) -> &'a [[f32; 3]] {
        self.points
    }

    /// The tight bounds of the points at or below each node.
    #[must_use]
    pub fn node_bounds(&self) -> &'a [Bounds] {
        self.bounds
    }

    /// The depth of the deepest node.
    #[must_use]
    pub fn max_depth(&self) -> u32 {
        self.max_depth
    }
}

/// Is `inner` inside `outer`?
fn nests(inner: &Bounds, outer: &Bounds) -> bool {
    (0..3).all(|a| inner.min[a] >= outer.min[a] && inner.max[a] <= outer.max[a])
}

/// A leaf's own checks: its run starts where the last one ended (an empty
/// leaf may say offset 0), its indices increase, its points are in its box.
fn check_leaf(
    node: u32,
    count: u32,
    offset: u32,
    expected: u32,
    indices: &[u32],
    points: &[[f32; 3]],
    own: &Bounds,
) -> Result<(), BlobError> {
    if count == 0 {
        return Ok(());
    }
    if offset != expected {
        return Err(BlobError::LeafOutOfOrder {
            node,
            offset,
            expected,
        });
    }
    let run = offset as usize..offset as usize + count as usize;
    // validate_nodes checked the run against the index section, whose
    // length is the point count: both gets succeed.
    let (Some(ids), Some(pts)) = (indices.get(run.clone()), points.get(run)) else {
        return Err(BlobError::LeafRangeOutOfBounds {
            node,
            offset,
            count,
        });
    };
    if ids.windows(2).any(|w| w[0] >= w[1]) {
        return Err(BlobError::LeafNotSorted { node });
    }
    if let Some(k) = pts.iter().position(|p| !own.contains(*p)) {
        return Err(BlobError::PointOutsideNode {
            node,
            position: offset + k as u32,
        });
    }
    Ok(())
}

#[cfg(test)]
pub(crate) mod tests_support {
    //! A hand-built tree the query tests share.
    use super::PointTree;
    use crate::blob::Node;
    use crate::geometry::{Axis, Bounds};

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
        pub(crate) nodes: [Node; 5],
        pub(crate) indices: [u32; 7],
        pub(crate) points: [[f32; 3]; 7],
        pub(crate) bounds: [Bounds; 5],
    }

    impl HandParts {
        pub(crate) fn view(&self) -> PointTree<'_> {
            PointTree::from_parts(&self.nodes, &self.indices, &self.points, &self.bounds).unwrap()
        }
    }

    fn b(min: [f32; 3], max: [f32; 3]) -> Bounds {
        Bounds { min, max }
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
                Node::interior(Axis::X, 2.0, 1).unwrap(),
                Node::leaf(3, 0).unwrap(),
                Node::interior(Axis::Y, 1.0, 3).unwrap(),
                Node::leaf(2, 3).unwrap(),
                Node::leaf(2, 5).unwrap(),
            ],
            indices: [0, 1, 2, 3, 6, 4, 5],
            points: [p[0], p[1], p[2], p[3], p[6], p[4], p[5]],
            bounds: [
                b([0.0; 3], [8.0, 5.0, 0.0]),
                b([0.0; 3], [1.0, 3.0, 0.0]),
                b([3.0, 0.0, 0.0], [8.0, 5.0, 0.0]),
                b([3.0, 0.0, 0.0], [8.0, 1.0, 0.0]),
                b([5.0, 5.0, 0.0], [5.0, 5.0, 0.0]),
            ],
        }
    }
}
