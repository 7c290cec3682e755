//! Tree statistics: the numbers that say whether a tree is good
//! (the lecture: "stringy, depth 50-100, ~2 triangle leaves, big empty cells").

pub use crate::builders::CostModel;
use kdray_kernel::Bounds;
use kdray_kernel::{Node, NodeKind, TriangleTree};

/// Statistics of a triangle tree.
#[derive(Clone, Debug, PartialEq)]
pub struct TreeStats {
    /// Triangles in the scene.
    pub triangles: usize,
    /// Nodes, interior and leaf.
    pub nodes: usize,
    /// Leaves.
    pub leaves: usize,
    /// Leaves with no triangle (empty cells).
    pub empty_leaves: usize,
    /// The deepest leaf's depth (root = 0).
    pub max_depth: u32,
    /// Mean leaf depth.
    pub mean_leaf_depth: f64,
    /// Triangle references in leaves per triangle.
    pub refs_per_triangle: f64,
    /// Mean triangles per non-empty leaf.
    pub mean_leaf_size: f64,
    /// SAH cost per ray entering the root, the builders' recursion applied to
    /// the finished tree: a leaf costs `N * C_isect`, an interior node
    /// `lambda * (C_trav + P(below) cost(below) + P(above) cost(above))`,
    /// P = area(child) / area(node), lambda the empty factor when a child is
    /// an empty leaf. With no empty factor (1.0) this is the classic sum of
    /// area(cell) / area(root) times C_trav per interior node and N * C_isect
    /// per leaf.
    pub sah_cost: f64,
    /// Cache lines a walk reads from the root to a leaf (each child pair
    /// read whole, the blob 64-byte aligned), mean over leaves: what the
    /// treelet layout of blob version 2 cuts.
    pub mean_leaf_lines: f64,
    /// Blob bytes per triangle (header, nodes, indices and the triangles).
    pub bytes_per_triangle: f64,
    /// Blob bytes.
    pub bytes: usize,
}

/// Walks `tree` and gathers its statistics under `cost`.
#[must_use]
pub fn tree_stats(tree: &TriangleTree<'_>, cost: CostModel) -> TreeStats {
    let b = tree.bounds();
    let root = Bounds {
        min: b.min,
        max: b.max,
    };
    let mut s = TreeStats {
        triangles: tree.triangles().len(),
        nodes: tree.nodes().len(),
        leaves: 0,
        empty_leaves: 0,
        max_depth: tree.max_depth(),
        mean_leaf_depth: 0.0,
        mean_leaf_lines: 0.0,
        refs_per_triangle: 0.0,
        mean_leaf_size: 0.0,
        sah_cost: 0.0,
        bytes: kdray_kernel::format::wire::HEADER_LEN
            + tree.nodes().len() * 8
            + tree.prim_indices().len() * 4
            + tree.triangles().len() * 36,
        bytes_per_triangle: 0.0,
    };
    let (mut depth_sum, mut refs, mut lines_sum) = (0u64, 0u64, 0u64);
    // The line of node `i`: the 64-byte header is line 0.
    let line = |i: u32| (kdray_kernel::format::wire::HEADER_LEN as u64 + 8 * u64::from(i)) / 64;
    let nodes = tree.nodes();
    // (node, cell, depth, lines read so far, the last of them): children
    // come after their parent, so the lines on a path only increase.
    let mut todo = vec![(0u32, root, 0u32, 1u64, line(0))];
    while let Some((i, cell, depth, lines, last)) = todo.pop() {
        let Some(node) = nodes.get(i as usize) else {
            continue;
        };
        match node.kind() {
            NodeKind::Interior { axis, split, child } => {
                let (lo, hi) = cell.split(axis.index(), split);
                let (a, b) = (line(child), line(child + 1));
                let lines = lines + u64::from(a > last) + u64::from(b > a);
                todo.push((child, lo, depth + 1, lines, b));
                todo.push((child + 1, hi, depth + 1, lines, b));
            }
            NodeKind::Leaf { count, .. } => {
                s.leaves += 1;
                s.empty_leaves += usize::from(count == 0);
                depth_sum += u64::from(depth);
                lines_sum += lines;
                refs += u64::from(count);
            }
        }
    }
    s.sah_cost = sah_cost(nodes, &root, cost);
    let full = (s.leaves - s.empty_leaves).max(1) as f64;
    s.mean_leaf_depth = depth_sum as f64 / s.leaves.max(1) as f64;
    s.mean_leaf_lines = lines_sum as f64 / s.leaves.max(1) as f64;
    s.refs_per_triangle = refs as f64 / s.triangles.max(1) as f64;
    s.mean_leaf_size = refs as f64 / full;
    s.bytes_per_triangle = s.bytes as f64 / s.triangles.max(1) as f64;
    s
}

/// The SAH cost per ray entering the root of the tree of `nodes` over the
/// root cell `root` ([`TreeStats::sah_cost`]); for any tree in the blob's
/// layout, a scene's top level included (its leaves' counts are instances).
#[must_use]
pub fn sah_cost(nodes: &[Node], root: &Bounds, cost: CostModel) -> f64 {
    // Pre-order: cell areas. Children always come after their parent, so
    // one backward pass then costs every subtree.
    let mut area = vec![0.0f64; nodes.len()];
    let mut todo = vec![(0u32, *root)];
    while let Some((i, cell)) = todo.pop() {
        let Some(node) = nodes.get(i as usize) else {
            continue;
        };
        area[i as usize] = cell.area();
        if let NodeKind::Interior { axis, split, child } = node.kind() {
            let (lo, hi) = cell.split(axis.index(), split);
            todo.push((child, lo));
            todo.push((child + 1, hi));
        }
    }
    let mut sub = vec![0.0f64; nodes.len()];
    for i in (0..nodes.len()).rev() {
        sub[i] = match nodes[i].kind() {
            NodeKind::Leaf { count, .. } => cost.leaf(count as usize),
            NodeKind::Interior { child, .. } => {
                let (b, a) = (child as usize, child as usize + 1);
                let (Some(&cb), Some(&ca)) = (sub.get(b), sub.get(a)) else {
                    continue;
                };
                let ratio = |c: usize| {
                    if area[i] > 0.0 {
                        area[c] / area[i]
                    } else {
                        0.5
                    }
                };
                let empty_leaf =
                    |c: usize| matches!(nodes[c].kind(), NodeKind::Leaf { count: 0, .. });
                cost.interior(ratio(b), cb, ratio(a), ca, empty_leaf(b) || empty_leaf(a))
            }
        };
    }
    sub.first().copied().unwrap_or(0.0)
}
