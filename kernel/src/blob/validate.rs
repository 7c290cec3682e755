//! The node-layout rule every tree blob obeys, and its O(n) check.
//!
//! Nodes are in depth-first order with side-by-side child pairs: the root
//! is node 0, and walking the tree depth-first, below child before above
//! child, the `k`-th interior node met has its children at `2k + 1` and
//! `2k + 2`. That one rule, checked with a counter during an O(n) walk on a
//! fixed stack, proves that every node has exactly one parent, that every
//! child comes after its parent (no cycles), that no node is unreachable, and
//! bounds the depth, all without allocating. It is also a good layout: the
//! below child's subtree follows its pair directly in memory.

use super::error::BlobError;
use super::node::{Node, NodeKind};
use super::MAX_DEPTH;

/// [`validate_nodes_with`] with no kind-specific checks.
pub(crate) fn validate_nodes(
    nodes: &[Node],
    prims: &[u32],
    items: usize,
) -> Result<u32, BlobError> {
    validate_nodes_with(nodes, prims, items, |_, _| Ok(()))
}

/// Walks the tree depth-first on a fixed stack, checking the layout rule
/// of the module docs, every split and every leaf. Returns the max depth.
///
/// Nodes must also be in bounds: each child pair is checked against the
/// node count before it is pushed, so the walk never indexes out of range,
/// and since each pair must be the next unused one, it visits each node
/// at most once: O(n), and it always terminates.
///
/// `visit(index, node)` is called for every node in depth-first order,
/// below child first, after the node's own checks passed (so an interior
/// node's children are in range): the hook for a tree kind's own checks.
pub(crate) fn validate_nodes_with(
    nodes: &[Node],
    prims: &[u32],
    items: usize,
    mut visit: impl FnMut(u32, Node) -> Result<(), BlobError>,
) -> Result<u32, BlobError> {
    if nodes.is_empty() {
        return Err(BlobError::NoNodes);
    }
    if let Some(at) = prims.iter().position(|&p| p as usize >= items) {
        return Err(BlobError::PrimitiveOutOfRange {
            at: at as u32,
            prim: prims[at],
        });
    }
    let total = nodes.len();
    // (node, depth); a pending above child per level, plus the one popped.
    let mut stack = [(0u32, 0u32); MAX_DEPTH as usize + 2];
    let mut len = 1;
    let mut next_pair = 1usize;
    let mut max_depth = 0;
    while len > 0 {
        len -= 1;
        // `get`: `len` is in range (pushes are checked below), but the
        // optimiser cannot see it, and an index would leave a panic path
        // (firmware/ links only without one).
        let Some(&(i, depth)) = stack.get(len) else {
            return Err(BlobError::TooDeep {
                node: 0,
                depth: len as u32,
                max: MAX_DEPTH,
            });
        };
        if depth > MAX_DEPTH {
            return Err(BlobError::TooDeep {
                node: i,
                depth,
                max: MAX_DEPTH,
            });
        }
        max_depth = max_depth.max(depth);
        let Some(&node) = nodes.get(i as usize) else {
            // Unreachable: pairs are range-checked before they are pushed.
            return Err(BlobError::UnreachableNodes {
                reached: next_pair as u32,
                total: total as u32,
            });
        };
        match node.kind() {
            NodeKind::Interior { split, child, .. } => {
                if !split.is_finite() {
                    return Err(BlobError::NonFiniteSplit { node: i });
                }
                if child as usize != next_pair || next_pair + 1 >= total {
                    return Err(BlobError::BadChild {
                        node: i,
                        child,
                        expected: next_pair as u32,
                    });
                }
                next_pair += 2;
                // depth <= MAX_DEPTH, so len <= depth + 1 <= MAX_DEPTH + 1 before
                // these two pushes... one pending above child per level.
                if len + 2 > stack.len() {
                    return Err(BlobError::TooDeep {
                        node: i,
                        depth: depth + 1,
                        max: MAX_DEPTH,
                    });
                }
                stack[len] = (child + 1, depth + 1);
                stack[len + 1] = (child, depth + 1);
                len += 2;
            }
            NodeKind::Leaf { count, word } => {
                if count == 1 {
                    if word as usize >= items {
                        return Err(BlobError::PrimitiveOutOfRange { at: i, prim: word });
                    }
                } else if (word as usize).saturating_add(count as usize) > prims.len() {
                    return Err(BlobError::LeafRangeOutOfBounds {
                        node: i,
                        offset: word,
                        count,
                    });
                }
            }
        }
        visit(i, node)?;
    }
    if next_pair != total {
        return Err(BlobError::UnreachableNodes {
            reached: next_pair as u32,
            total: total as u32,
        });
    }
    Ok(max_depth)
}
