//! The validated, zero-copy view of a triangle tree: nodes, primitive
//! indices and the triangles themselves, borrowed from a blob or from a
//! builder's vectors.
//!
//! # Layout the validator requires
//!
//! Nodes are in depth-first order with side-by-side child pairs: the root
//! is node 0, and walking the tree depth-first, below child before above
//! child, the `k`-th interior node met has its children at `2k + 1` and
//! `2k + 2`. That one rule, checked with a counter during an O(n) walk on a
//! fixed stack, proves that every node has exactly one parent, that every
//! child comes after its parent (no cycles), that no node is unreachable, and
//! bounds the depth, all without allocating. It is also a good layout: the
//! below child's subtree follows its pair directly in memory.

use crate::error::BlobError;
use crate::node::{Node, NodeKind};
use crate::triangle::Triangle;
use crate::wire::{self, Header, Sections, KIND_TRIANGLES};
use bytemuck::{Pod, Zeroable};

/// The deepest a node may be (the root is at depth 0). The traversal stack
/// holds one entry per level, so this is also its capacity; builders cap
/// their depth at it and loaders refuse deeper trees.
pub const MAX_DEPTH: u32 = 64;

/// An axis-aligned box. `repr(C)`, Pod, 24 bytes (min x y z, max x y z):
/// also the record of a point tree's per-node bounds section.
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
#[repr(C)]
pub struct Bounds {
    /// Minimum corner.
    pub min: [f32; 3],
    /// Maximum corner.
    pub max: [f32; 3],
}

impl Bounds {
    /// Does the box contain `p` (closed, and every coordinate finite)?
    #[inline]
    #[must_use]
    pub fn contains(&self, p: [f32; 3]) -> bool {
        (0..3).all(|a| p[a] >= self.min[a] && p[a] <= self.max[a])
    }

    /// Is every coordinate finite and `min <= max` on every axis?
    pub(crate) fn is_valid(&self) -> bool {
        (0..3).all(|a| {
            self.min[a].is_finite() && self.max[a].is_finite() && self.min[a] <= self.max[a]
        })
    }
}

/// A triangle k-d tree, borrowed. Cheap to copy; share it across threads.
#[derive(Clone, Copy, Debug)]
pub struct TriangleTree<'a> {
    pub(crate) nodes: &'a [Node],
    pub(crate) prims: &'a [u32],
    pub(crate) triangles: &'a [Triangle],
    pub(crate) bounds: Bounds,
    pub(crate) max_depth: u32,
}

impl<'a> TriangleTree<'a> {
    /// Loads and validates a blob written by `kdray-tools` (or `kdray build`).
    ///
    /// Checks, in this order: alignment, header (magic, endianness,
    /// version, kind), section lengths, checksum, then the tree itself (see
    /// [`TriangleTree::from_parts`]). O(size of the blob), no allocation.
    ///
    /// # Errors
    /// A [`BlobError`] naming the first problem found.
    ///
    /// # Panics
    /// Never, for any input.
    ///
    /// # Example
    /// ```
    /// use kdray_kernel::TriangleTree;
    /// static CUBE: &kdray_kernel::Aligned<[u8]> =
    ///     kdray_kernel::include_aligned!("../golden/cube-v1.kdt");
    /// let tree = TriangleTree::from_bytes(&CUBE.bytes)?;
    /// assert_eq!(tree.triangles().len(), 14); // six square faces and a quad
    ///
    /// // Any damage is refused with the place it was found.
    /// let mut bad = CUBE.bytes.to_vec();
    /// bad[100] ^= 1;
    /// let err = TriangleTree::from_bytes(&bad).unwrap_err();
    /// assert!(err.to_string().contains("checksum"), "{err}");
    /// # Ok::<(), kdray_kernel::BlobError>(())
    /// ```
    pub fn from_bytes(bytes: &'a [u8]) -> Result<Self, BlobError> {
        let (header, nodes, prims, triangles, whole) = Self::sections(bytes)?;
        wire::verify_checksum(header, whole)?;
        let bounds = Bounds {
            min: header.bounds_min,
            max: header.bounds_max,
        };
        let tree = Self::from_parts(nodes, prims, triangles, bounds)?;
        header.expect_depth(tree.max_depth)?;
        Ok(tree)
    }

    /// Loads a blob checking only what O(1) allows: alignment, header and
    /// section lengths. For blobs that passed [`TriangleTree::from_bytes`]
    /// before (e.g. written by this build pipeline and embedded).
    ///
    /// # Errors
    /// A [`BlobError`] for a bad header or wrong section lengths.
    ///
    /// # Safety
    /// `bytes` must be accepted by [`TriangleTree::from_bytes`]. The
    /// traversal relies on the validated invariants (child and primitive
    /// indices in range, depth within [`MAX_DEPTH`]) to find its way.
    pub unsafe fn from_bytes_unchecked(bytes: &'a [u8]) -> Result<Self, BlobError> {
        let (header, nodes, prims, triangles, _) = Self::sections(bytes)?;
        header.depth_fits_stack()?;
        Ok(TriangleTree {
            nodes,
            prims,
            triangles,
            bounds: Bounds {
                min: header.bounds_min,
                max: header.bounds_max,
            },
            max_depth: header.max_depth,
        })
    }

    #[allow(clippy::type_complexity)]
    fn sections(
        bytes: &'a [u8],
    ) -> Result<(&'a Header, &'a [Node], &'a [u32], &'a [Triangle], &'a [u8]), BlobError> {
        let (header, mut s) = Sections::open(bytes, KIND_TRIANGLES)?;
        let nodes = s.take("nodes", header.node_count)?;
        let prims = s.take("primitive indices", header.index_count)?;
        let triangles = s.take("triangles", header.item_count)?;
        let whole = s.finish()?;
        Ok((header, nodes, prims, triangles, whole))
    }

    /// A view of a tree held in memory (a builder's output), validated like
    /// a blob: bounds finite and containing every triangle, children in the
    /// depth-first layout (module docs), splits finite, leaf runs and
    /// primitive indices in range, depth at most [`MAX_DEPTH`].
    ///
    /// # Errors
    /// A [`BlobError`] naming the first problem found.
    ///
    /// # Panics
    /// Never, for any input.
    pub fn from_parts(
        nodes: &'a [Node],
        prims: &'a [u32],
        triangles: &'a [Triangle],
        bounds: Bounds,
    ) -> Result<Self, BlobError> {
        if !bounds.is_valid() {
            return Err(BlobError::BadBounds);
        }
        for (i, tri) in triangles.iter().enumerate() {
            if !tri.v.iter().all(|&p| bounds.contains(p)) {
                return Err(BlobError::ItemOutsideBounds { item: i as u32 });
            }
        }
        let max_depth = validate_nodes(nodes, prims, triangles.len())?;
        Ok(TriangleTree {
            nodes,
            prims,
            triangles,
            bounds,
            max_depth,
        })
    }

    /// The nodes, root first.
    #[must_use]
    pub fn nodes(&self) -> &'a [Node] {
        self.nodes
    }

    /// The primitive-index array that leaves of several primitives point into.
    #[must_use]
    pub fn prim_indices(&self) -> &'a [u32] {
        self.prims
    }

    /// The triangles, in mesh order.
    #[must_use]
    pub fn triangles(&self) -> &'a [Triangle] {
        self.triangles
    }

    /// The scene bounds: the root cell.
    #[must_use]
    pub fn bounds(&self) -> Bounds {
        self.bounds
    }

    /// The depth of the deepest node.
    #[must_use]
    pub fn max_depth(&self) -> u32 {
        self.max_depth
    }

    /// The children of interior node `node` for a ray whose per-axis
    /// above-first bits are `above_first` (`Node::first_child`'s form): the
    /// near child, the far child and the far child's index; `None` when
    /// they lie outside the node array (only an unchecked, invalid blob).
    /// The walks step into one of them next, and an empty cell has nothing
    /// to test, so they skip it at its parent instead of stepping into it
    /// and popping back out. Each child is read by its own index: reading
    /// the pair in one go and ordering it by conditional moves made 8-wide
    /// packets 2.5% slower (bunny camera tiles, 19.13 -> 19.61 Mrays/s).
    #[inline(always)]
    pub(crate) fn children(&self, node: Node, above_first: u64) -> Option<(Node, Node, usize)> {
        let first = node.first_child(above_first);
        let second = node.other_child(first);
        Some((*self.nodes.get(first)?, *self.nodes.get(second)?, second))
    }

    /// The primitives of a leaf: its one primitive, or its run of the
    /// primitive-index array (empty for an empty leaf or a bad run).
    #[inline(always)]
    pub(crate) fn leaf_prims(&self, node: Node) -> LeafPrims<'a> {
        let count = node.upper();
        if count == 1 {
            LeafPrims::One(node.word0())
        } else {
            let start = node.word0() as usize;
            LeafPrims::Run(
                self.prims
                    .get(start..start.saturating_add(count as usize))
                    .unwrap_or(&[]),
            )
        }
    }
}

/// The primitives of one leaf.
pub(crate) enum LeafPrims<'a> {
    One(u32),
    Run(&'a [u32]),
}

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
