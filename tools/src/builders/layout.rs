//! From a builder's tree to the kernel's layout: first depth-first, below
//! child before above, the `k`-th interior node met with its children at
//! `2k + 1` and `2k + 2` (both halves laid out at once, in parallel), then
//! reordered into the cache-line groups of blob version 2
//! ([`kdray_kernel::format::place_line_groups`], the rule `TriangleTree::from_parts`
//! checks).

use kdray_kernel::format::place_line_groups;
use kdray_kernel::{Axis, Bounds, Node, NodeKind};

use super::BuiltTree;

/// A builder's tree node.
#[derive(Clone, Debug, PartialEq)]
pub enum BuildNode {
    /// A leaf and its primitives (sorted, no duplicates).
    Leaf(Vec<u32>),
    /// A split plane and the two cells it makes ([`BuildNode::interior`]).
    Interior(Split),
}

/// An interior node: a split plane, its two cells and the subtree's size.
/// Opaque: only [`BuildNode::interior`] makes one, so the size [`flatten`]
/// lays the subtree out by is always the one it computed.
#[derive(Clone, Debug, PartialEq)]
pub struct Split {
    axis: Axis,
    split: f32,
    below: Box<BuildNode>,
    above: Box<BuildNode>,
    size: Size,
}

/// A subtree's size in the kernel's layout: where its parts go is known
/// before they are laid out, so both halves of a tree are laid out at once.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
struct Size {
    /// Interior nodes, this one included.
    interiors: usize,
    /// Primitive indices listed by its leaves (a leaf of one primitive
    /// holds it in the node).
    listed: usize,
}

impl BuildNode {
    /// The interior node splitting its cell at `split` on `axis`.
    #[must_use]
    pub fn interior(axis: Axis, split: f32, below: BuildNode, above: BuildNode) -> BuildNode {
        let (b, a) = (below.size(), above.size());
        BuildNode::Interior(Split {
            axis,
            split,
            below: Box::new(below),
            above: Box::new(above),
            size: Size {
                interiors: 1 + b.interiors + a.interiors,
                listed: b.listed + a.listed,
            },
        })
    }

    /// The subtree's size in the kernel's layout.
    fn size(&self) -> Size {
        match self {
            BuildNode::Leaf(p) if p.len() < 2 => Size::default(),
            BuildNode::Leaf(p) => Size {
                interiors: 0,
                listed: p.len(),
            },
            BuildNode::Interior(s) => s.size,
        }
    }

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
                BuildNode::Interior(s) => {
                    todo.push(&s.above);
                    todo.push(&s.below);
                }
            }
        }
    }
}

/// Subtrees of at least this many interior nodes lay out their two halves
/// in parallel (and free them there).
const PARALLEL_INTERIORS: usize = 2048;

/// Lays `root` out for the kernel, freeing it on the way. Node fields
/// cannot overflow: the caller checked the triangle count, and a tree over
/// n < 2^30 primitives with depth <= 64 that the builders make has far
/// fewer than 2^30 nodes... or the leaf/child is clamped to an empty leaf,
/// which `from_parts` would flag.
#[must_use]
pub fn flatten(root: BuildNode, bounds: Bounds) -> BuiltTree {
    let Size { interiors, listed } = root.size();
    let mut nodes = vec![Node::EMPTY_LEAF; 1 + 2 * interiors];
    let mut prims = vec![0; listed];
    let (slot, below_root) = nodes.split_at_mut(1);
    let place = Place {
        interior: 0,
        prims_at: 0,
        depth: 0,
    };
    let max_depth = lay_out(root, place, &mut slot[0], below_root, &mut prims);
    BuiltTree {
        nodes: into_line_groups(&nodes),
        prims,
        bounds,
        max_depth,
    }
}

/// The depth-first `nodes` in the kernel's line order: the root, the
/// padding node, then every pair where [`place_line_groups`] places it, each
/// interior node's child index renumbered (the scene's top level uses it
/// too).
#[must_use]
pub fn into_line_groups(nodes: &[Node]) -> Vec<Node> {
    // Where each depth-first node goes.
    let mut to = vec![0u32; nodes.len()];
    let below = |i: u32| match nodes.get(i as usize).map(|n| n.kind()) {
        Some(NodeKind::Interior { child, .. }) => Ok(Some(child)),
        _ => Ok(None),
    };
    let placed = place_line_groups(nodes.len() + 1, below, |_, child, slot| {
        to[child as usize] = slot;
        to[child as usize + 1] = slot + 1;
        Ok(())
    });
    debug_assert!(placed.is_ok(), "the depth-first layout is a tree");
    let mut out = vec![Node::EMPTY_LEAF; nodes.len() + 1];
    for (n, &at) in nodes.iter().zip(&to) {
        out[at as usize] = match n.kind() {
            NodeKind::Interior { axis, split, child } => {
                Node::interior(axis, split, to[child as usize]).unwrap_or(Node::EMPTY_LEAF)
            }
            NodeKind::Leaf { .. } => *n,
        };
    }
    out
}

/// Where a subtree goes: the index its root takes among the interior nodes
/// met depth-first (its children then sit at `2k + 1`, `2k + 2`), where
/// its listed primitives start, and its root's depth.
#[derive(Clone, Copy)]
struct Place {
    interior: usize,
    prims_at: usize,
    depth: u32,
}

/// Writes `n` to `slot`, its descendants to `below` (the slots after its
/// children's: exactly its subtree's, as the depth-first numbering keeps
/// each subtree's slots together) and its listed primitives to `prims`;
/// returns the deepest depth.
fn lay_out(n: BuildNode, at: Place, slot: &mut Node, below: &mut [Node], prims: &mut [u32]) -> u32 {
    match n {
        BuildNode::Leaf(p) => {
            *slot = match p.len() {
                0 => Node::EMPTY_LEAF,
                1 => Node::leaf(1, p[0]).unwrap_or(Node::EMPTY_LEAF),
                len => {
                    prims.copy_from_slice(&p);
                    Node::leaf(len as u32, at.prims_at as u32).unwrap_or(Node::EMPTY_LEAF)
                }
            };
            at.depth
        }
        BuildNode::Interior(Split {
            axis,
            split,
            below: b,
            above: a,
            size,
        }) => {
            let child = 2 * at.interior + 1;
            *slot = Node::interior(axis, split, child as u32).unwrap_or(Node::EMPTY_LEAF);
            let (sb, sa) = (b.size(), a.size());
            let [slot_b, slot_a, rest @ ..] = below else {
                unreachable!("an interior node's subtree has its children's two slots")
            };
            let (rest_b, rest_a) = rest.split_at_mut(2 * sb.interiors);
            let (prims_b, prims_a) = prims.split_at_mut(sb.listed);
            let place_b = Place {
                interior: at.interior + 1,
                prims_at: at.prims_at,
                depth: at.depth + 1,
            };
            let place_a = Place {
                interior: at.interior + 1 + sb.interiors,
                prims_at: at.prims_at + sb.listed,
                depth: at.depth + 1,
            };
            debug_assert_eq!(rest_a.len(), 2 * sa.interiors);
            let go_b = || lay_out(*b, place_b, slot_b, rest_b, prims_b);
            let go_a = || lay_out(*a, place_a, slot_a, rest_a, prims_a);
            let (db, da) = if size.interiors >= PARALLEL_INTERIORS {
                rayon::join(go_b, go_a)
            } else {
                (go_b(), go_a())
            };
            db.max(da)
        }
    }
}
