//! The point blob: its one definition, read by [`PointTreeN::from_bytes`]
//! and written by [`PointTreeN::write_to`], side by side.
//!
//! # Layout (after the 64-byte header, [`crate::blob::wire`])
//! The header's kind is [`KIND_POINTS`]; its index and item counts are the
//! point count n, its node count m; its scene bounds are zero (a point's
//! box has D axes: the root's is the first entry of the node bounds).
//!
//! | section        | records | each                                   |
//! |----------------|---------|----------------------------------------|
//! | point shape    | 1       | `[D, bytes per scalar]` as 2 × u32 (4 = f32, 8 = f64) |
//! | nodes          | m       | [`PointNode`], 8 B, depth-first layout |
//! | splits         | m       | one scalar: an interior node's split location, 0 for a leaf |
//! | points         | n       | D scalars each, in leaf order; within a leaf's run axis by axis (all its axis-0 coordinates, then axis 1, ...: [`PointTreeN::coords`]) |
//! | node bounds    | m       | 2·D scalars: `[min, max]` of the points at or below the node |
//! | point indices  | n       | u32: the input index of the point at each position |
//!
//! Every scalar section starts at a multiple of its scalar's size (the
//! 4-byte sections come first or last), so an `f64` blob in 8-byte
//! aligned memory is read in place, as an `f32` one is in 4-byte aligned
//! memory. A blob read with another D or scalar type than it was built
//! with is refused by its shape record ([`BlobError::WrongDimension`],
//! [`BlobError::WrongScalar`]).

use super::{max_point_coord, max_point_coord_log2};
use super::{replay_depth_first, Sections, WriteError, KIND_POINTS};
use super::{wire, BlobError, Bounds, Header, PointNode, PointNodeKind, PointTreeN, Scalar};

/// A point tree's sections after the header, in blob order: what
/// [`PointTreeN::from_bytes`] reads and [`PointTreeN::write_parts_to`]
/// writes, each named as errors name it.
const SECTIONS: [&str; 6] = [
    "point shape",
    "nodes",
    "splits",
    "points",
    "node bounds",
    "point indices",
];
use bytemuck::Pod;

/// A length for a message (saturated: only ever compared or printed).
fn shown(n: usize) -> u32 {
    u32::try_from(n).unwrap_or(u32::MAX)
}

/// What a point blob holds, read from its shape record: for a caller that
/// learns D and the scalar type at run time (a C program, a tool), to pick
/// the [`PointTreeN`] to load it with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PointShape {
    /// Coordinates per point (D).
    pub dim: u32,
    /// Bytes per coordinate: 4 for `f32`, 8 for `f64`.
    pub scalar_bytes: u32,
}

impl PointShape {
    /// The shape recorded in a point blob, checking only its header
    /// (alignment, magic, endianness, version, kind) and that the shape
    /// record is there: O(1). Loading with [`PointTreeN::from_bytes`] then
    /// validates the rest.
    ///
    /// # Errors
    /// A [`BlobError`] for a bad header or a missing shape record.
    pub fn of_blob(bytes: &[u8]) -> Result<PointShape, BlobError> {
        let (_, mut s) = Sections::open(bytes, KIND_POINTS)?;
        let shape = s.take::<[u32; 2]>(SECTIONS[0], 1)?;
        let [dim, scalar_bytes] = shape.first().copied().unwrap_or([0, 0]);
        Ok(PointShape { dim, scalar_bytes })
    }
}

impl<'a, const D: usize, S: Scalar> PointTreeN<'a, D, S> {
    /// Loads and validates a point blob written by [`PointTreeN::write_to`]
    /// (`kdray_tools::blob::write_point_tree`, `kdray build-points`).
    ///
    /// Checks, in this order: alignment (4 bytes, 8 for `f64`), header
    /// (magic, endianness, version, kind), the shape (D and the scalar
    /// type), section lengths, checksum, then the tree itself (see
    /// [`PointTreeN::from_parts`]). O(size of the blob), no allocation.
    ///
    /// # Errors
    /// A [`BlobError`] naming the first problem found.
    ///
    /// # Panics
    /// Never, for any input.
    ///
    /// # Example
    /// ```
    /// use kdray_kernel::{BlobError, PointTree, PointTreeN};
    /// use kdray_tools::points::{build_points, PointParams};
    /// use kdray_tools::blob::write_point_tree;
    ///
    /// // A 10 x 10 x 10 grid of points; point i is at (i % 10, i / 10 % 10, i / 100).
    /// let points: Vec<[f32; 3]> = (0..1000)
    ///     .map(|i| [(i % 10) as f32, (i / 10 % 10) as f32, (i / 100) as f32])
    ///     .collect();
    /// let blob = write_point_tree(&build_points(&points, &PointParams::default())?)?;
    /// let tree = PointTree::from_bytes(blob.as_bytes())?;
    /// assert_eq!(tree.len(), 1000);
    /// // Point 543 is (3, 4, 5), wherever the build put it.
    /// let at = tree.indices().iter().position(|&i| i == 543).unwrap();
    /// assert_eq!(tree.point(at), Some([3.0, 4.0, 5.0]));
    /// // Read as 2-D or as f64, the blob is refused, naming what differs.
    /// let e = PointTreeN::<2>::from_bytes(blob.as_bytes()).unwrap_err();
    /// assert_eq!(e, BlobError::WrongDimension { expected: 2, found: 3 });
    /// let e = PointTreeN::<3, f64>::from_bytes(blob.as_bytes()).unwrap_err();
    /// assert_eq!(e, BlobError::WrongScalar { expected: 8, found: 4 });
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn from_bytes(bytes: &'a [u8]) -> Result<Self, BlobError> {
        let (header, tree, whole) = Self::sections(bytes)?;
        wire::verify_checksum(header, whole)?;
        let tree = Self::from_parts(
            tree.nodes,
            tree.splits,
            tree.indices,
            tree.coords,
            tree.bounds,
        )?;
        header.expect_depth(tree.max_depth)?;
        Ok(tree)
    }

    /// Loads a blob checking only what O(1) allows: alignment, header,
    /// shape and section lengths. For blobs that passed
    /// [`PointTreeN::from_bytes`] before (e.g. written by this build
    /// pipeline and embedded).
    ///
    /// # Errors
    /// A [`BlobError`] for a bad header or shape, or wrong section lengths.
    ///
    /// A blob that [`PointTreeN::from_bytes`] would refuse gives wrong
    /// answers (and running times), never undefined behaviour: the queries
    /// read every section through bounds-checked accesses.
    pub fn from_bytes_unchecked(bytes: &'a [u8]) -> Result<Self, BlobError> {
        let (header, tree, _) = Self::sections(bytes)?;
        header.depth_fits_stack()?;
        Ok(tree)
    }

    /// The header, the unvalidated view and the whole blob (what the
    /// checksum covers). The order of the reads is the layout's.
    fn sections(bytes: &'a [u8]) -> Result<(&'a Header, Self, &'a [u8]), BlobError> {
        let () = Self::DIMENSION_IS_POSITIVE;
        // The header's length and 4-byte alignment first, then the
        // scalar's wider alignment.
        let (header, mut s) = Sections::open(bytes, KIND_POINTS)?;
        let align = core::mem::align_of::<S>();
        let offset = bytes.as_ptr() as usize % align;
        if align > 4 && offset != 0 {
            return Err(BlobError::MisalignedScalar { align, offset });
        }
        let [shape_name, nodes_name, splits_name, points_name, bounds_name, indices_name] =
            SECTIONS;
        let shape = s.take::<[u32; 2]>(shape_name, 1)?;
        let [dim, scalar] = shape.first().copied().unwrap_or([0, 0]);
        if dim != shown(D) {
            return Err(BlobError::WrongDimension {
                expected: shown(D),
                found: dim,
            });
        }
        if scalar != S::BYTES {
            return Err(BlobError::WrongScalar {
                expected: S::BYTES,
                found: scalar,
            });
        }
        if header.bounds_min != [0.0; 3] || header.bounds_max != [0.0; 3] {
            return Err(BlobError::BadBounds);
        }
        let nodes = s.take(nodes_name, header.node_count)?;
        let splits = s.take(splits_name, header.node_count)?;
        let points: &[[S; D]] = s.take(points_name, header.item_count)?;
        let bounds = s.take(bounds_name, header.node_count)?;
        let indices = s.take(indices_name, header.index_count)?;
        let whole = s.finish()?;
        let tree = PointTreeN {
            nodes,
            splits,
            indices,
            coords: bytemuck::cast_slice(points),
            bounds,
            max_depth: header.max_depth,
        };
        Ok((header, tree, whole))
    }

    /// The size in bytes of the blob [`Self::write_parts_to`] writes for
    /// these parts.
    ///
    /// # Errors
    /// [`WriteError::TooLarge`] when the size overflows.
    pub fn write_parts_len(
        nodes: &[PointNode],
        splits: &[S],
        indices: &[u32],
        coords: &[S],
        bounds: &[[[S; D]; 2]],
    ) -> Result<usize, WriteError> {
        wire::blob_len(&Self::sections_out(
            &Self::SHAPE,
            nodes,
            splits,
            indices,
            coords,
            bounds,
        ))
    }

    /// Writes a point-tree blob into `out` (at least
    /// [`Self::write_parts_len`] bytes, any alignment): the header, then
    /// the sections in the order [`Self::from_bytes`] reads them (module
    /// docs). The parts are written as given, not validated (a loader
    /// validates); `max_depth` is the depth of the deepest node.
    /// Little-endian; the same parts give the same bytes. Returns the
    /// bytes written.
    ///
    /// # Errors
    /// [`WriteError`] for a count the header cannot hold or a short buffer.
    ///
    /// # Panics
    /// Never, for any input.
    pub fn write_parts_to(
        nodes: &[PointNode],
        splits: &[S],
        indices: &[u32],
        coords: &[S],
        bounds: &[[[S; D]; 2]],
        max_depth: u32,
        out: &mut [u8],
    ) -> Result<usize, WriteError> {
        let [_, n, _, p, _, _] = SECTIONS;
        wire::write_blob(
            out,
            KIND_POINTS,
            max_depth,
            Bounds::ZERO,
            [
                (n, nodes.len()),
                ("point indices", indices.len()),
                (p, indices.len()),
            ],
            &Self::sections_out(&Self::SHAPE, nodes, splits, indices, coords, bounds),
        )
    }

    /// This tree's blob size ([`Self::write_parts_len`]).
    ///
    /// # Errors
    /// As [`Self::write_parts_len`].
    pub fn blob_len(&self) -> Result<usize, WriteError> {
        Self::write_parts_len(
            self.nodes,
            self.splits,
            self.indices,
            self.coords,
            self.bounds,
        )
    }

    /// Writes this tree as a blob ([`Self::write_parts_to`]).
    ///
    /// # Errors
    /// As [`Self::write_parts_to`].
    pub fn write_to(&self, out: &mut [u8]) -> Result<usize, WriteError> {
        Self::write_parts_to(
            self.nodes,
            self.splits,
            self.indices,
            self.coords,
            self.bounds,
            self.max_depth,
            out,
        )
    }

    /// The shape record: D and the scalar's size.
    const SHAPE: [u32; 2] = [D as u32, S::BYTES];

    /// The sections as bytes, in blob order ([`SECTIONS`]).
    fn sections_out<'s>(
        shape: &'s [u32; 2],
        nodes: &'s [PointNode],
        splits: &'s [S],
        indices: &'s [u32],
        coords: &'s [S],
        bounds: &'s [[[S; D]; 2]],
    ) -> [&'s [u8]; 6] {
        [
            bytemuck::bytes_of(shape),
            bytes(nodes),
            bytes(splits),
            bytes(coords),
            bytes(bounds),
            bytes(indices),
        ]
    }

    /// A view of a tree held in memory (a builder's output), validated like
    /// a blob: one split, one box per node, D coordinates per index (laid
    /// out as [`Self::coords`] says); the
    /// depth-first layout (each interior node's child pair is the next
    /// unused one, so no cycles, no shared children, nothing unreachable),
    /// axes below D, finite splits and depth at most
    /// [`MAX_DEPTH`](crate::MAX_DEPTH); every box finite, not inverted and
    /// inside its parent's, each child's on its side of the split plane;
    /// leaf runs tiling the points in depth-first order; every point inside
    /// its leaf's box; each leaf's indices strictly increasing and naming a
    /// point.
    ///
    /// Not checked (it would need memory): that no index appears in two
    /// leaves. A blob that repeats one answers with the repeat, no worse.
    ///
    /// # Errors
    /// A [`BlobError`] naming the first problem found.
    ///
    /// # Panics
    /// Never, for any input.
    pub fn from_parts(
        nodes: &'a [PointNode],
        splits: &'a [S],
        indices: &'a [u32],
        coords: &'a [S],
        bounds: &'a [[[S; D]; 2]],
    ) -> Result<Self, BlobError> {
        let () = Self::DIMENSION_IS_POSITIVE;
        for (what, len, expected) in [
            (
                "point coordinates",
                coords.len(),
                indices.len().saturating_mul(D),
            ),
            ("splits", splits.len(), nodes.len()),
            ("node bounds", bounds.len(), nodes.len()),
        ] {
            if len != expected {
                return Err(BlobError::SectionMismatch {
                    what,
                    expected: shown(expected),
                    found: shown(len),
                });
            }
        }
        let tree = PointTreeN {
            nodes,
            splits,
            indices,
            coords,
            bounds,
            max_depth: 0,
        };
        let max_depth = tree.validate()?;
        Ok(PointTreeN { max_depth, ..tree })
    }

    /// The walk of [`Self::from_parts`]: depth-first on a fixed stack,
    /// each node visited at most once (its pair must be the next unused
    /// one before it is pushed), so O(n) and always terminating. Returns
    /// the max depth.
    fn validate(&self) -> Result<u32, BlobError> {
        let total = self.nodes.len();
        match self.bounds.first() {
            None => return Err(BlobError::NoNodes),
            Some(root) if !box_is_valid(root) => return Err(BlobError::BadNodeBounds { node: 0 }),
            // Every box nests in the root's and every point lies in its
            // leaf's box, so this bounds every point.
            Some(root)
                if !root
                    .iter()
                    .flatten()
                    .all(|c| c.abs() <= max_point_coord::<D, S>()) =>
            {
                return Err(BlobError::PointsOutOfRange {
                    limit_log2: max_point_coord_log2::<D, S>(),
                })
            }
            Some(_) => {}
        }
        let mut next_run = 0usize;
        let max_depth = replay_depth_first(total, |i| {
            let (Some(&node), Some(own), Some(&split)) = (
                self.nodes.get(i as usize),
                self.bounds.get(i as usize),
                self.splits.get(i as usize),
            ) else {
                // Unreachable: the walk range-checks pairs before it visits them.
                return Err(BlobError::NoNodes);
            };
            match node.kind() {
                PointNodeKind::Interior { axis, child } => {
                    if axis as usize >= D {
                        return Err(BlobError::AxisOutOfRange {
                            node: i,
                            axis,
                            dim: shown(D),
                        });
                    }
                    if !split.is_finite() {
                        return Err(BlobError::NonFiniteSplit { node: i });
                    }
                    let a = axis as usize;
                    // Below child's points at or below the split plane,
                    // above child's at or above it: the queries' plane
                    // bound relies on it. (The walk checks the pair's
                    // indices after this; a bad one reads no box here.)
                    for (c, below) in [(child, true), (child.wrapping_add(1), false)] {
                        let ok = self.bounds.get(c as usize).is_some_and(|b| {
                            let side = if below {
                                b[1][a] <= split
                            } else {
                                b[0][a] >= split
                            };
                            box_is_valid(b) && nests(b, own) && side
                        });
                        if !ok && (c as usize) < total {
                            return Err(BlobError::BadNodeBounds { node: c });
                        }
                    }
                    Ok(Some(child))
                }
                PointNodeKind::Leaf { offset, count } => {
                    self.check_leaf(i, offset, count, next_run, own)?;
                    next_run += count as usize;
                    Ok(None)
                }
            }
        })?;
        if next_run != self.len() {
            return Err(BlobError::LeafOutOfOrder {
                node: shown(total),
                offset: shown(next_run),
                expected: shown(self.len()),
            });
        }
        Ok(max_depth)
    }

    /// A leaf's own checks: its run starts where the last one ended (an
    /// empty leaf may say any offset), its indices increase and name
    /// points, its points are in its box.
    fn check_leaf(
        &self,
        node: u32,
        offset: u32,
        count: u32,
        expected: usize,
        own: &[[S; D]; 2],
    ) -> Result<(), BlobError> {
        if count == 0 {
            return Ok(());
        }
        if offset as usize != expected {
            return Err(BlobError::LeafOutOfOrder {
                node,
                offset,
                expected: shown(expected),
            });
        }
        let (o, c) = (offset as usize, count as usize);
        let (Some(ids), Some(block)) = (self.indices.get(o..o + c), self.leaf_block(o, c)) else {
            return Err(BlobError::LeafRangeOutOfBounds {
                node,
                offset,
                count,
            });
        };
        if let Some(k) = ids.iter().position(|&p| p as usize >= self.len()) {
            return Err(BlobError::PrimitiveOutOfRange {
                at: offset + shown(k),
                prim: ids[k],
            });
        }
        if ids.windows(2).any(|w| w[0] >= w[1]) {
            return Err(BlobError::LeafNotSorted { node });
        }
        let point = |j: usize| -> [S; D] {
            core::array::from_fn(|a| block.get(a * c + j).copied().unwrap_or(S::INFINITY))
        };
        if let Some(k) = (0..c).position(|j| !contains(own, &point(j))) {
            return Err(BlobError::PointOutsideNode {
                node,
                position: offset + shown(k),
            });
        }
        Ok(())
    }
}

/// The bytes of a Pod slice.
fn bytes<T: Pod>(s: &[T]) -> &[u8] {
    bytemuck::cast_slice(s)
}

/// Is every coordinate finite and `min <= max` on every axis?
fn box_is_valid<const D: usize, S: Scalar>([min, max]: &[[S; D]; 2]) -> bool {
    (0..D).all(|a| min[a].is_finite() && max[a].is_finite() && min[a] <= max[a])
}

/// Is `inner` inside `outer`?
fn nests<const D: usize, S: Scalar>(inner: &[[S; D]; 2], outer: &[[S; D]; 2]) -> bool {
    (0..D).all(|a| inner[0][a] >= outer[0][a] && inner[1][a] <= outer[1][a])
}

/// Does the (valid) box contain `p`? False for a NaN coordinate.
fn contains<const D: usize, S: Scalar>(b: &[[S; D]; 2], p: &[S; D]) -> bool {
    (0..D).all(|a| p[a] >= b[0][a] && p[a] <= b[1][a])
}
