//! From a builder's tree to the kernel's layout: nodes depth-first, below
//! child before above, the `k`-th interior node met with its children at
//! `2k + 1` and `2k + 2` (the rule `TriangleTree::from_parts` checks).

use kdray_kernel::{Axis, Bounds, Node};

use super::BuiltTree;

/// A builder's tree node.
#[derive(Clone, Debug, PartialEq)]
pub enum BuildNode {
    /// A leaf and its primitives (sorted, no duplicates).
    Leaf(Vec<u32>),
    /// A split plane and the two cells it makes.
    Interior {
        /// The split axis.
        axis: Axis,
        /// The split location.
        split: f32,
        /// The cell below the plane (`<= split`).
        below: Box<BuildNode>,
        /// The cell above the plane (`>= split`).
        above: Box<BuildNode>,
    },
}

impl BuildNode {
    /// Is this a leaf without primitives (an empty cell)?
    #[must_use]
    pub fn is_empty_leaf(&self) -> bool {
        matches!(self, BuildNode::Leaf(p) if p.is_empty())
    }

    /// Appends the primitives of every leaf below to `out` (with repeats).
    pub fn collect_prims(&self, out: &mut Vec<u32>) {
        let mut todo = vec![self];
        while let Some(n) = todo.pop() {
            match n {
                BuildNode::Leaf(p) => out.extend_from_slice(p),
                BuildNode::Interior { below, above, .. } => {
                    todo.push(above);
                    todo.push(below);
                }
            }
        }
    }
}

/// Frees the tree under `node`, its two halves in parallel down to
/// `depth` levels (the nodes are boxes freed one by one: 100 ms for the
/// 2.3M nodes of the 1M-triangle bunny on one thread).
pub(super) fn drop_in_parallel(node: BuildNode, depth: u32) {
    match node {
        BuildNode::Interior { below, above, .. } if depth > 0 => {
            rayon::join(
                || drop_in_parallel(*below, depth - 1),
                || drop_in_parallel(*above, depth - 1),
            );
        }
        leaf_or_deep => drop(leaf_or_deep),
    }
}

/// Lays `root` out for the kernel. Node fields cannot overflow: the caller
/// checked the triangle count, and a tree over n < 2^30 primitives with
/// depth <= 64 that the builders make has far fewer than 2^30 nodes... or
/// the leaf/child is clamped to an empty leaf, which `from_parts` would flag.
#[must_use]
pub fn flatten(root: &BuildNode, bounds: Bounds) -> BuiltTree {
    let mut nodes = vec![Node::EMPTY_LEAF];
    let mut prims = Vec::new();
    let mut max_depth = 0;
    // (node to lay out, its slot, its depth); pop order = depth-first, below first.
    let mut todo = vec![(root, 0usize, 0u32)];
    while let Some((n, slot, depth)) = todo.pop() {
        max_depth = max_depth.max(depth);
        nodes[slot] = match n {
            BuildNode::Leaf(p) => match p.len() {
                0 => Node::EMPTY_LEAF,
                1 => Node::leaf(1, p[0]).unwrap_or(Node::EMPTY_LEAF),
                len => {
                    let off = prims.len() as u32;
                    prims.extend_from_slice(p);
                    Node::leaf(len as u32, off).unwrap_or(Node::EMPTY_LEAF)
                }
            },
            BuildNode::Interior {
                axis,
                split,
                below,
                above,
            } => {
                let child = nodes.len();
                nodes.push(Node::EMPTY_LEAF);
                nodes.push(Node::EMPTY_LEAF);
                todo.push((above, child + 1, depth + 1));
                todo.push((below, child, depth + 1));
                Node::interior(*axis, *split, child as u32).unwrap_or(Node::EMPTY_LEAF)
            }
        };
    }
    BuiltTree {
        nodes,
        prims,
        bounds,
        max_depth,
    }
}
