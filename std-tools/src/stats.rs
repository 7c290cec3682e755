//! Tree statistics: the numbers that say whether a tree is good
//! (the lecture: "stringy, depth 50-100, ~2 triangle leaves, big empty cells").

use crate::build::Aabb;
use kdray_kernel::{NodeKind, TriangleTree};

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
    /// SAH cost: sum over interior nodes of P(cell) * C_trav plus sum over
    /// leaves of P(cell) * N * C_isect, P = area(cell) / area(root).
    pub sah_cost: f64,
    /// Blob bytes per triangle (header, nodes, indices and the triangles).
    pub bytes_per_triangle: f64,
    /// Blob bytes.
    pub bytes: usize,
}

/// The cost constants [`tree_stats`] weighs nodes with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CostModel {
    /// Cost of a traversal step.
    pub traversal: f64,
    /// Cost of a triangle test.
    pub intersection: f64,
}

impl CostModel {
    /// The builder's defaults.
    #[must_use]
    pub fn from_params(p: &crate::build::BuildParams) -> CostModel {
        CostModel {
            traversal: f64::from(p.traversal_cost),
            intersection: f64::from(p.intersection_cost),
        }
    }
}

/// Walks `tree` and gathers its statistics under `cost`.
#[must_use]
pub fn tree_stats(tree: &TriangleTree<'_>, cost: CostModel) -> TreeStats {
    let b = tree.bounds();
    let root = Aabb {
        min: b.min,
        max: b.max,
    };
    let root_area = root.area();
    let mut s = TreeStats {
        triangles: tree.triangles().len(),
        nodes: tree.nodes().len(),
        leaves: 0,
        empty_leaves: 0,
        max_depth: tree.max_depth(),
        mean_leaf_depth: 0.0,
        refs_per_triangle: 0.0,
        mean_leaf_size: 0.0,
        sah_cost: 0.0,
        bytes: kdray_kernel::wire::HEADER_LEN
            + tree.nodes().len() * 8
            + tree.prim_indices().len() * 4
            + tree.triangles().len() * 36,
        bytes_per_triangle: 0.0,
    };
    let (mut depth_sum, mut refs) = (0u64, 0u64);
    let mut todo = vec![(0u32, root, 0u32)];
    while let Some((i, cell, depth)) = todo.pop() {
        let Some(node) = tree.nodes().get(i as usize) else {
            continue;
        };
        let p = if root_area > 0.0 {
            cell.area() / root_area
        } else {
            1.0
        };
        match node.kind() {
            NodeKind::Interior { axis, split, child } => {
                s.sah_cost += p * cost.traversal;
                let (lo, hi) = cell.split(axis.index(), split);
                todo.push((child, lo, depth + 1));
                todo.push((child + 1, hi, depth + 1));
            }
            NodeKind::Leaf { count, .. } => {
                s.leaves += 1;
                s.empty_leaves += usize::from(count == 0);
                depth_sum += u64::from(depth);
                refs += u64::from(count);
                s.sah_cost += p * f64::from(count) * cost.intersection;
            }
        }
    }
    let full = (s.leaves - s.empty_leaves).max(1) as f64;
    s.mean_leaf_depth = depth_sum as f64 / s.leaves.max(1) as f64;
    s.refs_per_triangle = refs as f64 / s.triangles.max(1) as f64;
    s.mean_leaf_size = refs as f64 / full;
    s.bytes_per_triangle = s.bytes as f64 / s.triangles.max(1) as f64;
    s
}
