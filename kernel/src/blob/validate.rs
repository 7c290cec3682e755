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

/// Walks the tree depth-first on a fixed stack ([`walk_layout`]),
/// checking the layout rule of the module docs, every split and every
/// leaf. Returns the max depth.
pub(crate) fn validate_nodes(
    nodes: &[Node],
    prims: &[u32],
    items: usize,
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
    walk_layout(nodes.len(), |i| {
        let Some(&node) = nodes.get(i as usize) else {
            // Unreachable: walk_layout range-checks pairs before it visits them.
            return Err(BlobError::NoNodes);
        };
        match node.kind() {
            NodeKind::Interior { split, child, .. } => {
                if !split.is_finite() {
                    return Err(BlobError::NonFiniteSplit { node: i });
                }
                Ok(Some(child))
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
                Ok(None)
            }
        }
    })
}

/// The layout rule's walk over `total` nodes, for any node type: depth
/// first on a fixed stack, below child first. `node(i)` runs node `i`'s
/// own checks and returns its below child (`None` for a leaf); the walk
/// checks that child against the rule (the next unused pair, in range)
/// before visiting it, so `node` is only called with indices below
/// `total`, each at most once: O(n), and it always terminates. Returns the
/// max depth.
pub(crate) fn walk_layout(
    total: usize,
    mut node: impl FnMut(u32) -> Result<Option<u32>, BlobError>,
) -> Result<u32, BlobError> {
    if total == 0 {
        return Err(BlobError::NoNodes);
    }
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
        let Some(child) = node(i)? else {
            continue;
        };
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
    if next_pair != total {
        return Err(BlobError::UnreachableNodes {
            reached: next_pair as u32,
            total: total as u32,
        });
    }
    Ok(max_depth)
}
