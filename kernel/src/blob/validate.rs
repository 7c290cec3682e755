//! The node-layout rules, and their O(n) checks.
//!
//! **Triangle trees (blob version 2): cache-line groups.** The root is
//! node 0, node 1 is padding (the empty leaf), and the child pairs follow
//! from node 2, so every pair fills one 16-byte quarter of a 64-byte line
//! (a blob in 64-byte aligned memory; its 64-byte header is one line, so
//! node `i` lies in line `i / 8`). Pairs are placed in the order of
//! [`place_line_groups`]: a group starts at a node, takes the next free pair
//! for it and, breadth-first below it, for its descendants until the line
//! of its first pair is full; the nodes that did not fit start later
//! groups, depth-first (last left, first taken). A walk from the root
//! steps through two to three levels in one line before it needs another.
//!
//! The check replays that placement with a counter: the `k`-th pair
//! placed must be the pair at `2 + 2k`. As in the depth-first rule, that
//! proves every node has exactly one parent, that every child comes after
//! its parent (no cycles), that no node is unreachable (the counter ends
//! at the node count), and bounds the depth, on a fixed stack, without
//! allocating.
//!
//! **Point trees: depth first** ([`replay_depth_first`]): the `k`-th interior node
//! met depth-first, below child first, has its children at `2k + 1` and
//! `2k + 2`.

use super::error::BlobError;
use super::node::{Node, NodeKind};
use super::MAX_DEPTH;

/// Replays a triangle tree's line groups on a fixed stack ([`place_line_groups`]),
/// checking the padding node, the layout rule of the module docs, every
/// split and every leaf. Returns the max depth.
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
    if let Some(&pad) = nodes.get(1) {
        if pad != Node::EMPTY_LEAF {
            return Err(BlobError::BadPadding {
                found: bytemuck::cast(pad),
            });
        }
    }
    let mut node = |i: u32| {
        let Some(&node) = nodes.get(i as usize) else {
            // Unreachable: replay_depth_first range-checks pairs before it visits them.
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
    };
    place_line_groups(nodes.len(), &mut node, |i, child, slot| {
        if child == slot {
            Ok(())
        } else {
            Err(BlobError::BadChild {
                node: i,
                child,
                expected: slot,
            })
        }
    })
}

/// Nodes per 64-byte cache line.
pub const LINE_NODES: usize = 8;
/// The first child pair's node index (node 1 is padding).
pub const FIRST_PAIR: usize = 2;
/// Nodes a group may leave in its queue: its root, plus two children
/// for each of the at most `LINE_NODES / 2` pairs it places.
const QUEUE: usize = 1 + LINE_NODES;
/// Pending group roots: each group leaves at most `LINE_NODES / 2 + 1`
/// of its queue for later, the pending ones all belong to groups on the
/// current chain, and a chain's root depths strictly increase up to
/// `MAX_DEPTH + 1`.
const PENDING: usize = (LINE_NODES / 2 + 1) * (MAX_DEPTH as usize + 2) + 1;

/// The group placement of the module docs over `total` nodes of any
/// representation. `node(i)` runs node `i`'s own checks and returns its
/// below child (`None` for a leaf), in whatever numbering the caller
/// uses; `place(i, child, slot)` is told that the rule puts the pair of
/// node `i` (at `child` in that numbering) at node `slot`; the validator
/// checks `child == slot`, a builder records it. The replay range-checks
/// `child` before visiting it, so `node` is only called with indices below
/// `total`; on a valid layout each once: O(n). Returns the max depth.
///
/// # Errors
/// [`BlobError::NoNodes`] for `total < 2`, [`BlobError::BadChild`] for a
/// pair out of range, [`BlobError::TooDeep`], [`BlobError::UnreachableNodes`]
/// when the placed pairs do not end at `total`, and whatever `node` or
/// `place` return.
pub fn place_line_groups(
    total: usize,
    mut node: impl FnMut(u32) -> Result<Option<u32>, BlobError>,
    mut place: impl FnMut(u32, u32, u32) -> Result<(), BlobError>,
) -> Result<u32, BlobError> {
    if total < FIRST_PAIR {
        return Err(BlobError::NoNodes);
    }
    let too_deep = |node, depth| BlobError::TooDeep {
        node,
        depth,
        max: MAX_DEPTH,
    };
    // The group roots left for later: nodes and depths side by side,
    // the depths in bytes (at most `MAX_DEPTH + 1`), which halves the
    // replay's stack (2,984 bytes with `(u32, u32)` pairs on thumbv7em).
    let mut pending_node = [0u32; PENDING];
    let mut pending_depth = [0u8; PENDING];
    let mut len = 1;
    let mut next = FIRST_PAIR;
    let mut max_depth = 0;
    while len > 0 {
        len -= 1;
        let (Some(&i), Some(&depth)) = (pending_node.get(len), pending_depth.get(len)) else {
            return Err(too_deep(0, len as u32));
        };
        let root = (i, u32::from(depth));
        let line = next / LINE_NODES;
        let mut queue = [(0u32, 0u32); QUEUE];
        queue[0] = root;
        let (mut head, mut tail) = (0, 1);
        // Breadth first while the line of the group's first pair has room.
        while head < tail && next / LINE_NODES == line {
            let Some(&(i, depth)) = queue.get(head) else {
                break;
            };
            head += 1;
            if depth > MAX_DEPTH {
                return Err(too_deep(i, depth));
            }
            max_depth = max_depth.max(depth);
            let Some(child) = node(i)? else {
                continue;
            };
            if child as usize + 1 >= total {
                return Err(BlobError::BadChild {
                    node: i,
                    child,
                    expected: next as u32,
                });
            }
            place(i, child, next as u32)?;
            next += 2;
            let Some(two) = queue.get_mut(tail..tail + 2) else {
                // Unreachable: a line holds LINE_NODES / 2 pairs.
                return Err(too_deep(i, depth + 1));
            };
            two[0] = (child, depth + 1);
            two[1] = (child + 1, depth + 1);
            tail += 2;
        }
        // The rest start groups of their own, the first of them next.
        for k in (head..tail).rev() {
            let (Some(&(i, depth)), Some(slot_node), Some(slot_depth)) = (
                queue.get(k),
                pending_node.get_mut(len),
                pending_depth.get_mut(len),
            ) else {
                return Err(too_deep(root.0, root.1));
            };
            // A queued node's depth is at most MAX_DEPTH + 1; a larger one
            // (never) is kept too deep.
            *slot_node = i;
            *slot_depth = u8::try_from(depth).unwrap_or(u8::MAX);
            len += 1;
        }
    }
    all_reached(next, total, max_depth)
}

/// The layout rule's replay over `total` nodes, for any node type: depth
/// first on a fixed stack, below child first. `node(i)` runs node `i`'s
/// own checks and returns its below child (`None` for a leaf); the replay
/// checks that child against the rule (the next unused pair, in range)
/// before visiting it, so `node` is only called with indices below
/// `total`, each at most once: O(n), and it always terminates. Returns the
/// max depth.
pub(crate) fn replay_depth_first(
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
    all_reached(next_pair, total, max_depth)
}

/// The end of a layout replay: the pairs placed must end at the node count
/// (else some nodes are unreachable); then `max_depth` is the answer.
fn all_reached(next: usize, total: usize, max_depth: u32) -> Result<u32, BlobError> {
    if next != total {
        return Err(BlobError::UnreachableNodes {
            reached: next as u32,
            total: total as u32,
        });
    }
    Ok(max_depth)
}
