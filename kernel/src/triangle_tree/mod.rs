//! The validated, zero-copy view of a triangle tree: nodes, primitive
//! indices and the triangles themselves, borrowed from a blob or from a
//! builder's vectors; and the walks over it (single rays in `walk`, packets
//! in `packet`).

mod batch;
pub(crate) mod cell_ray;
mod closest_point;
mod counting;
mod counts;
mod first_hits;
mod inside;
mod leaf_lanes;
pub(crate) mod packet;
mod shallow;
mod streams;
mod treelet_tree;
mod treelets;
mod turns;
mod walk;
mod walk_choice;

pub use batch::{Batch, Streams};
pub use packet::PacketLanes;
pub use streams::STREAM_SCRATCH_WORDS;
pub use treelet_tree::{TraceBatch, TreeletTree};
pub use treelets::{Treelet, TreeletBufferTooSmall};
#[doc(hidden)]
pub use walk_choice::Trial;

pub use counting::Counting;
pub use counts::TraversalCounts;
pub use inside::INSIDE_RAYS;
pub use shallow::ShallowTree;

use crate::blob::wire::{self, Header, Sections, KIND_TRIANGLES};
use crate::blob::{validate_nodes, BlobError, Node, WriteError};
use crate::geometry::Bounds;
use crate::triangle::Triangle;

/// A triangle tree's sections after the header, in blob order: what
/// [`TriangleTree::from_bytes`] reads and [`TriangleTree::write_parts_to`]
/// writes, each named as errors name it.
const SECTIONS: [&str; 3] = ["nodes", "primitive indices", "triangles"];

/// A triangle k-d tree, borrowed. Cheap to copy; share it across threads.
#[derive(Clone, Copy, Debug)]
pub struct TriangleTree<'a> {
    pub(crate) nodes: &'a [Node],
    pub(crate) prims: &'a [u32],
    pub(crate) triangles: &'a [Triangle],
    pub(crate) bounds: Bounds,
    pub(crate) max_depth: u32,
    /// The treelets scattered rays walk, if any: set only inside a
    /// [`TreeletTree`], empty for a tree as loaded. Read only by the
    /// treelet walk, which needs AVX2 (x86-64).
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    pub(crate) lines: &'a [Treelet],
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
    ///     kdray_kernel::include_aligned!("../../golden/cube-v3.kdt");
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
    /// Safe for any bytes: every node, primitive and triangle read is
    /// bounds-checked and the traversal stack never overflows, so a blob
    /// that [`TriangleTree::from_bytes`] would refuse gives defined but
    /// wrong answers, never undefined behaviour. It can give no answer at
    /// all: a node array with a cycle (which only validation rules out)
    /// makes a query walk forever. Use it only on bytes that passed
    /// `from_bytes` before.
    ///
    /// # Errors
    /// A [`BlobError`] for a bad header or wrong section lengths, or a
    /// header depth beyond [`MAX_DEPTH`](crate::MAX_DEPTH).
    pub fn from_bytes_unchecked(bytes: &'a [u8]) -> Result<Self, BlobError> {
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
            lines: &[],
        })
    }

    #[allow(clippy::type_complexity)]
    fn sections(
        bytes: &'a [u8],
    ) -> Result<(&'a Header, &'a [Node], &'a [u32], &'a [Triangle], &'a [u8]), BlobError> {
        let (header, mut s) = Sections::open(bytes, KIND_TRIANGLES)?;
        let [nodes_name, prims_name, tris_name] = SECTIONS;
        let nodes = s.take(nodes_name, header.node_count)?;
        let prims = s.take(prims_name, header.index_count)?;
        let triangles = s.take(tris_name, header.item_count)?;
        let whole = s.finish()?;
        Ok((header, nodes, prims, triangles, whole))
    }

    /// The size in bytes of the blob [`TriangleTree::write_parts_to`]
    /// writes for these parts.
    ///
    /// # Errors
    /// [`WriteError::TooLarge`] when the size overflows.
    pub fn write_parts_len(
        nodes: &[Node],
        prims: &[u32],
        triangles: &[Triangle],
    ) -> Result<usize, WriteError> {
        wire::blob_len(&[
            bytemuck::cast_slice(nodes),
            bytemuck::cast_slice(prims),
            bytemuck::cast_slice(triangles),
        ])
    }

    /// Writes a triangle-tree blob into `out` (at least
    /// [`TriangleTree::write_parts_len`] bytes): the header, then the
    /// sections in the order [`TriangleTree::from_bytes`] reads them. The
    /// parts are written as given, not validated (a loader validates);
    /// `max_depth` is the depth of the deepest node. Little-endian, as
    /// every platform kdray supports; the same parts give the same bytes.
    /// Returns the bytes written.
    ///
    /// # Errors
    /// [`WriteError`] for a count the header cannot hold or a short buffer.
    ///
    /// # Panics
    /// Never, for any input.
    pub fn write_parts_to(
        nodes: &[Node],
        prims: &[u32],
        triangles: &[Triangle],
        bounds: Bounds,
        max_depth: u32,
        out: &mut [u8],
    ) -> Result<usize, WriteError> {
        let [n, p, t] = SECTIONS;
        wire::write_blob(
            out,
            KIND_TRIANGLES,
            max_depth,
            bounds,
            [(n, nodes.len()), (p, prims.len()), (t, triangles.len())],
            &[
                bytemuck::cast_slice(nodes),
                bytemuck::cast_slice(prims),
                bytemuck::cast_slice(triangles),
            ],
        )
    }

    /// A view of a tree held in memory (a builder's output), validated like
    /// a blob: bounds finite and containing every triangle, children in the
    /// depth-first layout (module docs), splits finite, leaf runs and
    /// primitive indices in range, depth at most [`MAX_DEPTH`](crate::MAX_DEPTH).
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
            lines: &[],
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
    /// and popping back out (~4.6 of a camera ray's ~28 steps were such
    /// cells). Each child is read by its own index. Tried: the pair read in
    /// one go and ordered by conditional moves: 8-wide packets 2.5% slower,
    /// single rays 1-2% slower.
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
