//! The lecture's point k-d tree builder: split the widest dimension at the
//! median (an O(n) selection per level, so O(n log n) in all), keep the
//! tight bounds of the points under every node, stop at `leaf_size` points
//! or when the widest extent is at most `min_width`.
//!
//! The points are carried along with their indices and partitioned in
//! place, so when the recursion ends they are in leaf order: each leaf's
//! run is a slice of that one array, as the kernel's blob stores them.
//! Subtrees of at least `parallel_min` points are built on rayon tasks and
//! spliced into the depth-first layout afterwards; the output is the same
//! for any thread count.

use kdray_kernel::node::MAX_NODE_FIELD;
use kdray_kernel::{Axis, BlobError, Bounds, Node, PointTree, MAX_DEPTH};
use std::fmt;

/// The builder's parameters, defaults documented per field.
#[derive(Clone, Debug, PartialEq)]
pub struct PointParams {
    /// A node with at most this many points is a leaf (the lecture's m;
    /// median splits make leaves of m/2 to m points). Default 32: measured
    /// on the 1M-point anchor sets (uniform, clustered, bunny), one core,
    /// k = 1 and 10: m = 6 and 8 were 10-40% slower than 16 and 32, which
    /// were within noise of each other (32 ahead on the bunny), and 32
    /// builds ~10% faster.
    pub leaf_size: usize,
    /// A node whose widest extent is at most this is a leaf, however many
    /// points it holds. Default 0: only piles of equal points stop early
    /// (they cannot be split; the query scans such a pile in O(k)).
    pub min_width: f32,
    /// Subtrees of at least this many points are built in parallel.
    /// Default 65536.
    pub parallel_min: usize,
}

impl Default for PointParams {
    fn default() -> Self {
        PointParams {
            leaf_size: 32,
            min_width: 0.0,
            parallel_min: 1 << 16,
        }
    }
}

/// Why a point build failed.
#[derive(Debug, Clone, PartialEq)]
pub enum PointBuildError {
    /// A point with a NaN or infinite coordinate.
    NonFinite {
        /// The point's index.
        point: usize,
        /// Its coordinates.
        coords: [f32; 3],
    },
    /// More points than a node's 30-bit fields can count.
    TooManyPoints {
        /// How many there are.
        count: usize,
    },
}

impl fmt::Display for PointBuildError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PointBuildError::NonFinite { point, coords } => {
                write!(f, "point {point} has a non-finite coordinate {coords:?}")
            }
            PointBuildError::TooManyPoints { count } => write!(
                f,
                "{count} points is more than a tree can index ({MAX_NODE_FIELD})"
            ),
        }
    }
}

impl std::error::Error for PointBuildError {}

/// A built point tree, in the kernel's layout (see `kdray_kernel::PointTree`).
#[derive(Clone, Debug, PartialEq)]
pub struct BuiltPoints {
    /// Nodes in the depth-first layout; leaves hold runs of the arrays below.
    pub nodes: Vec<Node>,
    /// The input index of each point of `points`.
    pub indices: Vec<u32>,
    /// The points in leaf order.
    pub points: Vec<[f32; 3]>,
    /// The tight bounds of the points at or below each node.
    pub bounds: Vec<Bounds>,
    /// The depth of the deepest node.
    pub max_depth: u32,
}

impl BuiltPoints {
    /// The validated kernel view ([`PointTree::from_parts`]).
    ///
    /// # Errors
    /// The kernel's [`BlobError`] (never, for a tree [`build_points`] made).
    pub fn view(&self) -> Result<PointTree<'_>, BlobError> {
        PointTree::from_parts(&self.nodes, &self.indices, &self.points, &self.bounds)
    }
}

/// A point and its input index, moved together by the partitioning.
#[derive(Clone, Copy)]
struct Item {
    p: [f32; 3],
    index: u32,
}

/// Builds the tree over `points` (index = position).
///
/// # Errors
/// [`PointBuildError::NonFinite`] naming the first NaN or infinite point;
/// [`PointBuildError::TooManyPoints`] past 2^30 - 1 points.
pub fn build_points(
    points: &[[f32; 3]],
    params: &PointParams,
) -> Result<BuiltPoints, PointBuildError> {
    if let Some(point) = points.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
        return Err(PointBuildError::NonFinite {
            point,
            coords: points[point],
        });
    }
    if points.len() > MAX_NODE_FIELD as usize {
        return Err(PointBuildError::TooManyPoints {
            count: points.len(),
        });
    }
    let mut items: Vec<Item> = points
        .iter()
        .enumerate()
        .map(|(i, &p)| Item { p, index: i as u32 })
        .collect();
    let params = PointParams {
        leaf_size: params.leaf_size.max(1),
        ..params.clone()
    };
    let tree = grow_parallel(&mut items, 0, 0, &params);
    Ok(BuiltPoints {
        nodes: tree.nodes,
        indices: items.iter().map(|it| it.index).collect(),
        points: items.iter().map(|it| it.p).collect(),
        bounds: tree.bounds,
        max_depth: tree.max_depth,
    })
}

/// A subtree in the depth-first layout with its root at 0; leaf offsets
/// are already absolute.
struct Subtree {
    nodes: Vec<Node>,
    bounds: Vec<Bounds>,
    max_depth: u32,
}

/// The tight bounds of `items` (the zero box for none).
fn bounds_of(items: &[Item]) -> Bounds {
    let Some(first) = items.first() else {
        return Bounds {
            min: [0.0; 3],
            max: [0.0; 3],
        };
    };
    let mut b = Bounds {
        min: first.p,
        max: first.p,
    };
    for it in items {
        for a in 0..3 {
            b.min[a] = b.min[a].min(it.p[a]);
            b.max[a] = b.max[a].max(it.p[a]);
        }
    }
    b
}

/// The split axis for a node, or `None` for a leaf: few points, too
/// narrow (a pile of equal points always is), or at the depth limit.
fn split_axis(len: usize, b: &Bounds, depth: u32, params: &PointParams) -> Option<Axis> {
    if len <= params.leaf_size || depth >= MAX_DEPTH {
        return None;
    }
    let extent = |a: usize| b.max[a] - b.min[a];
    let widest = Axis::ALL.into_iter().max_by(|&a, &b| {
        extent(a.index())
            .total_cmp(&extent(b.index()))
            .then(b.cmp(&a))
    })?;
    (extent(widest.index()) > params.min_width).then_some(widest)
}

/// Partitions `items` at the median of `axis`: below `..mid`, above
/// `mid..`; returns `mid` and the split location (the median coordinate).
///
/// Points equal to the median all go below when some point is left above:
/// the above child's box then starts strictly past the split plane, so a
/// query sitting on a pile or plane of equal coordinates (where ties make
/// every subtree at distance 0 worth a visit) prunes the above side by the
/// plane's gap. Measured on the `dupes` anchor set (one core): k = 1
/// 0.8-0.9M -> 1.3-2.0M queries/s; no change on uniform points.
fn partition(items: &mut [Item], axis: Axis) -> (usize, f32) {
    let a = axis.index();
    let mid = items.len() / 2;
    items.select_nth_unstable_by(mid, |x, y| x.p[a].total_cmp(&y.p[a]));
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
        (end, split)
    } else {
        (mid, split)
    }
}

/// A leaf over `items` at `offset`: its indices sorted (the kernel's tie
/// rule relies on it) with their points.
fn leaf(items: &mut [Item], offset: usize) -> Node {
    items.sort_unstable_by_key(|it| it.index);
    // Counts and offsets fit: the point count was checked against 2^30.
    Node::leaf(items.len() as u32, offset as u32).unwrap_or(Node::EMPTY_LEAF)
}

/// Builds the subtree over `items` into `t`, its root at `slot`.
fn grow(
    items: &mut [Item],
    offset: usize,
    depth: u32,
    slot: usize,
    t: &mut Subtree,
    params: &PointParams,
) {
    let b = bounds_of(items);
    t.bounds[slot] = b;
    t.max_depth = t.max_depth.max(depth);
    let Some(axis) = split_axis(items.len(), &b, depth, params) else {
        t.nodes[slot] = leaf(items, offset);
        return;
    };
    let (mid, split) = partition(items, axis);
    let child = t.nodes.len();
    t.nodes[slot] = Node::interior(axis, split, child as u32).unwrap_or(Node::EMPTY_LEAF);
    t.nodes.extend([Node::EMPTY_LEAF; 2]);
    t.bounds.extend([b; 2]);
    let (below, above) = items.split_at_mut(mid);
    grow(below, offset, depth + 1, child, t, params);
    grow(above, offset + mid, depth + 1, child + 1, t, params);
}

/// [`grow`] for a subtree rooted at 0, forking the two halves of large
/// nodes onto rayon tasks.
fn grow_parallel(items: &mut [Item], offset: usize, depth: u32, params: &PointParams) -> Subtree {
    let b = bounds_of(items);
    let axis = split_axis(items.len(), &b, depth, params);
    let (Some(axis), true) = (axis, items.len() >= params.parallel_min) else {
        let mut t = Subtree {
            nodes: vec![Node::EMPTY_LEAF],
            bounds: vec![b],
            max_depth: 0,
        };
        grow(items, offset, depth, 0, &mut t, params);
        return t;
    };
    let (mid, split) = partition(items, axis);
    let (below, above) = items.split_at_mut(mid);
    let (below, above) = rayon::join(
        || grow_parallel(below, offset, depth + 1, params),
        || grow_parallel(above, offset + mid, depth + 1, params),
    );
    splice(
        Node::interior(axis, split, 1).unwrap_or(Node::EMPTY_LEAF),
        b,
        depth,
        below,
        above,
    )
}

/// Joins two subtrees under a new root. Depth-first, the below subtree's
/// child pairs come first (right after the root's pair at 1, 2), then the
/// above subtree's: a child at local `c >= 1` moves to `c - 1 + base`.
fn splice(root: Node, b: Bounds, depth: u32, below: Subtree, above: Subtree) -> Subtree {
    let below_base = 3;
    let above_base = below_base + below.nodes.len() - 1;
    let moved = |n: Node, base: usize| match n.kind() {
        kdray_kernel::NodeKind::Interior { axis, split, child } => {
            Node::interior(axis, split, child - 1 + base as u32).unwrap_or(Node::EMPTY_LEAF)
        }
        kdray_kernel::NodeKind::Leaf { .. } => n,
    };
    let mut nodes = Vec::with_capacity(below.nodes.len() + above.nodes.len() + 1);
    nodes.push(root);
    nodes.push(moved(below.nodes[0], below_base));
    nodes.push(moved(above.nodes[0], above_base));
    nodes.extend(below.nodes[1..].iter().map(|&n| moved(n, below_base)));
    nodes.extend(above.nodes[1..].iter().map(|&n| moved(n, above_base)));
    let mut bounds = Vec::with_capacity(nodes.len());
    bounds.extend([b, below.bounds[0], above.bounds[0]]);
    bounds.extend_from_slice(&below.bounds[1..]);
    bounds.extend_from_slice(&above.bounds[1..]);
    Subtree {
        nodes,
        bounds,
        max_depth: depth.max(below.max_depth).max(above.max_depth),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lcg_points(n: usize, seed: u64) -> Vec<[f32; 3]> {
        let mut rng = crate::rng::Rng::new(seed);
        (0..n).map(|_| std::array::from_fn(|_| rng.f32())).collect()
    }

    #[test]
    fn parallel_and_serial_builds_are_identical_and_valid() {
        let pts = lcg_points(5000, 3);
        let serial = build_points(
            &pts,
            &PointParams {
                parallel_min: usize::MAX,
                ..Default::default()
            },
        )
        .unwrap();
        let parallel = build_points(
            &pts,
            &PointParams {
                parallel_min: 100,
                ..Default::default()
            },
        )
        .unwrap();
        assert_eq!(serial, parallel);
        let tree = serial.view().unwrap();
        assert_eq!(tree.points().len(), 5000);
    }

    #[test]
    fn nan_points_are_rejected_by_index() {
        let mut pts = lcg_points(10, 1);
        pts[7][1] = f32::NAN;
        let e = build_points(&pts, &PointParams::default()).unwrap_err();
        assert!(matches!(e, PointBuildError::NonFinite { point: 7, .. }));
        assert!(e.to_string().contains("point 7"));
    }

    #[test]
    fn a_pile_is_one_leaf_and_empty_sets_build() {
        let pile = vec![[1.0, 2.0, 3.0]; 1000];
        let t = build_points(&pile, &PointParams::default()).unwrap();
        assert_eq!(t.nodes.len(), 1);
        assert!(t.view().is_ok());
        let empty = build_points(&[], &PointParams::default()).unwrap();
        assert!(empty.view().is_ok());
    }
}
