//! Why a blob was refused: one variant per check, each naming what it read.

use core::fmt;

/// A blob that [`crate::TriangleTree::from_bytes`] (or a point tree's
/// loader) refused, with what was wrong and where.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum BlobError {
    /// The input does not start at a 4-byte aligned address.
    Misaligned {
        /// The address modulo 4.
        offset: usize,
    },
    /// The input ends before the named part does.
    Truncated {
        /// The part being read ("header", "nodes", "triangles", ...).
        what: &'static str,
        /// Bytes that part needs, counted from the start of the blob.
        need: usize,
        /// Bytes there are.
        have: usize,
    },
    /// The input is longer than its sections.
    TrailingBytes {
        /// Bytes the header's counts account for.
        expected: usize,
        /// Bytes there are.
        have: usize,
    },
    /// The first 8 bytes are not `kdray` and three zero bytes.
    BadMagic,
    /// The endianness check word is not `0xFEFF` (a big-endian writer, or
    /// not a kdray blob).
    BadEndianness {
        /// The word read.
        found: u32,
    },
    /// A format version this kernel cannot read.
    UnsupportedVersion {
        /// The version read.
        found: u32,
    },
    /// A blob of an older format version (1: triangle trees in depth-first
    /// node order; 1 and 2: the FNV-1a checksum), which this kernel no
    /// longer reads: rebuild it with `kdray build` (`kdray build-points`
    /// for a point tree).
    OldVersion {
        /// The version read (1 or 2).
        found: u32,
    },
    /// Node 1 of a triangle tree, the padding slot that puts every child
    /// pair in one 16-byte half of a cache line, is not the empty leaf.
    BadPadding {
        /// The node's raw bits.
        found: u64,
    },
    /// The blob holds another kind of tree.
    WrongKind {
        /// The kind this loader reads (1 triangles, 2 points).
        expected: u32,
        /// The kind read.
        found: u32,
    },
    /// A header field that must have a fixed value does not.
    BadHeaderField {
        /// The field's name.
        what: &'static str,
        /// The value read.
        found: u32,
    },
    /// A count times its record size overflows the address space.
    Overflow {
        /// The section whose size overflowed.
        what: &'static str,
    },
    /// The checksum over the sections does not match the header's.
    Checksum {
        /// The checksum stored in the header.
        stored: u32,
        /// The checksum of the bytes.
        computed: u32,
    },
    /// The tree has no nodes (even an empty tree has its root leaf).
    NoNodes,
    /// The scene bounds are non-finite or inverted.
    BadBounds,
    /// An item (triangle vertex or point) lies outside the scene bounds or
    /// is not finite.
    ItemOutsideBounds {
        /// The item's index.
        item: u32,
    },
    /// An interior node's split location is NaN or infinite.
    NonFiniteSplit {
        /// The node's index.
        node: u32,
    },
    /// An interior node's children are not where a depth-first layout puts
    /// them: out of range, not after the parent, or shared with another
    /// parent (which could make cycles or exponential walks).
    BadChild {
        /// The node's index.
        node: u32,
        /// The child index read.
        child: u32,
        /// The child index the layout requires.
        expected: u32,
    },
    /// Nodes the walk from the root never reaches.
    UnreachableNodes {
        /// Nodes reached.
        reached: u32,
        /// Nodes in the blob.
        total: u32,
    },
    /// A leaf's primitive run lies outside the primitive-index array.
    LeafRangeOutOfBounds {
        /// The leaf's index.
        node: u32,
        /// The run's offset.
        offset: u32,
        /// The run's length.
        count: u32,
    },
    /// A primitive index names no item.
    PrimitiveOutOfRange {
        /// Where the index was found: a node index for one-primitive
        /// leaves, otherwise the position in the primitive-index array.
        at: u32,
        /// The index read.
        prim: u32,
    },
    /// Two sections that must have the same length do not (a point tree's
    /// indices and points, or its node bounds and nodes).
    SectionMismatch {
        /// The section whose length is wrong.
        what: &'static str,
        /// The length it must have.
        expected: u32,
        /// The length it has.
        found: u32,
    },
    /// A node's bounds are non-finite or inverted, not inside its parent's
    /// bounds, or on the wrong side of its parent's split plane (point trees).
    BadNodeBounds {
        /// The node's index.
        node: u32,
    },
    /// A point tree's root box reaches beyond `±2^limit_log2`, the range
    /// in which no squared distance overflows
    /// ([`crate::max_point_coord`]).
    PointsOutOfRange {
        /// `log2` of the range's bound for the tree's dimension and type.
        limit_log2: u32,
    },
    /// A leaf's run does not start where the previous leaf's (depth-first,
    /// below child first) ended: the runs must tile the points exactly.
    LeafOutOfOrder {
        /// The leaf's index.
        node: u32,
        /// The run's offset.
        offset: u32,
        /// The offset the tiling requires.
        expected: u32,
    },
    /// A point lies outside the bounds of the leaf holding it, or is not
    /// finite (point trees).
    PointOutsideNode {
        /// The leaf's index.
        node: u32,
        /// The point's position in the blob's point section.
        position: u32,
    },
    /// A leaf's point indices are not strictly increasing (point trees).
    LeafNotSorted {
        /// The leaf's index.
        node: u32,
    },
    /// A point blob holds points of another dimension than the loader's D.
    WrongDimension {
        /// The loader's D.
        expected: u32,
        /// The D the blob records.
        found: u32,
    },
    /// A point blob holds another scalar type than the loader's (codes:
    /// bytes per coordinate, 4 `f32`, 8 `f64`).
    WrongScalar {
        /// The loader's scalar size.
        expected: u32,
        /// The scalar size the blob records.
        found: u32,
    },
    /// The input is not aligned for its scalar type (an `f64` point blob
    /// must start at a multiple of 8).
    MisalignedScalar {
        /// The alignment needed.
        align: usize,
        /// The address modulo `align`.
        offset: usize,
    },
    /// A point tree's interior node splits an axis the points do not have.
    AxisOutOfRange {
        /// The node's index.
        node: u32,
        /// The axis read.
        axis: u32,
        /// The points' dimension.
        dim: u32,
    },
    /// The tree is deeper than the traversal stack (or than the header says).
    TooDeep {
        /// The node found too deep.
        node: u32,
        /// Its depth.
        depth: u32,
        /// The limit.
        max: u32,
    },
    /// The tree is deeper than a [`ShallowTree`](crate::ShallowTree)'s
    /// stack.
    DeeperThanStack {
        /// The tree's depth.
        depth: u32,
        /// The stack's entries (the deepest tree it walks).
        stack: u32,
    },
}

impl fmt::Display for BlobError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use BlobError::*;
        match *self {
            Misaligned { offset } => write!(
                f,
                "blob is not 4-byte aligned (address % 4 = {offset}); load it into aligned memory, e.g. with kdray_kernel::include_aligned!"
            ),
            Truncated { what, need, have } => {
                write!(f, "blob truncated in the {what}: needs {need} bytes, has {have}")
            }
            TrailingBytes { expected, have } => write!(
                f,
                "blob has {} bytes after its last section ({have} bytes, sections end at {expected})",
                // Saturating: a hand-built error may have `have < expected`.
                have.saturating_sub(expected)
            ),
            BadMagic => write!(f, "not a kdray blob: bad magic (expected \"kdray\\0\\0\\0\")"),
            BadEndianness { found } => write!(
                f,
                "blob endianness check word is {found:#x}, expected 0xfeff (big-endian or corrupt)"
            ),
            UnsupportedVersion { found } => write!(
                f,
                "blob format version {found} is not supported (this kernel reads version {})",
                super::wire::VERSION
            ),
            OldVersion { found } => write!(
                f,
                "blob version {found} was written by an older kdray (a weaker checksum), which this kernel no longer reads: rebuild it with `kdray build` (`kdray build-points` for a point tree)"
            ),
            BadPadding { found } => write!(
                f,
                "blob node 1 (the padding slot before the first child pair) is {found:#018x}, expected the empty leaf"
            ),
            WrongKind { expected, found } => write!(
                f,
                "blob holds tree kind {found} ({}), expected kind {expected} ({})",
                kind_name(found),
                kind_name(expected)
            ),
            BadHeaderField { what, found } => {
                write!(f, "blob header field {what} has invalid value {found}")
            }
            Overflow { what } => write!(f, "blob {what} section size overflows"),
            Checksum { stored, computed } => write!(
                f,
                "blob checksum mismatch: header says {stored:#010x}, bytes give {computed:#010x} (corrupt)"
            ),
            NoNodes => write!(f, "blob has no nodes (even an empty tree has a root leaf)"),
            BadBounds => write!(f, "blob scene bounds are not finite or are inverted"),
            ItemOutsideBounds { item } => {
                write!(f, "item {item} is non-finite or lies outside the scene bounds")
            }
            NonFiniteSplit { node } => write!(f, "node {node} has a non-finite split location"),
            BadChild { node, child, expected } => write!(
                f,
                "node {node} names children at {child}, but the depth-first layout puts them at {expected}"
            ),
            UnreachableNodes { reached, total } => write!(
                f,
                "only {reached} of {total} nodes are reachable from the root"
            ),
            LeafRangeOutOfBounds { node, offset, count } => write!(
                f,
                "leaf {node} names primitives {offset}..{offset}+{count}, outside the primitive-index array"
            ),
            PrimitiveOutOfRange { at, prim } => {
                write!(f, "primitive index {prim} at {at} names no item")
            }
            SectionMismatch { what, expected, found } => write!(
                f,
                "blob {what} section has {found} records, expected {expected}"
            ),
            BadNodeBounds { node } => write!(
                f,
                "node {node} has non-finite or inverted bounds, or bounds outside its parent's or across its split plane"
            ),
            PointsOutOfRange { limit_log2 } => write!(
                f,
                "the point tree's bounds reach beyond ±2^{limit_log2}, where squared distances could overflow (`kdray build-points` refuses such points)"
            ),
            LeafOutOfOrder { node, offset, expected } => write!(
                f,
                "leaf {node} starts its run at {offset}, but the previous leaf ended at {expected}"
            ),
            PointOutsideNode { node, position } => write!(
                f,
                "point at position {position} is non-finite or outside the bounds of its leaf {node}"
            ),
            LeafNotSorted { node } => {
                write!(f, "leaf {node} lists its point indices out of increasing order")
            }
            WrongDimension { expected, found } => write!(
                f,
                "blob holds {found}-dimensional points, expected {expected}-dimensional (load it with PointTreeN::<{found}, _>, or rebuild it with --dim {expected})"
            ),
            WrongScalar { expected, found } => write!(
                f,
                "blob holds {} coordinates, expected {}",
                scalar_name(found),
                scalar_name(expected)
            ),
            MisalignedScalar { align, offset } => write!(
                f,
                "blob is not {align}-byte aligned (address % {align} = {offset}), as its coordinates need"
            ),
            AxisOutOfRange { node, axis, dim } => write!(
                f,
                "node {node} splits axis {axis}, but the points have {dim} dimensions"
            ),
            TooDeep { node, depth, max } => write!(
                f,
                "node {node} is at depth {depth}, deeper than the limit {max}"
            ),
            DeeperThanStack { depth, stack } => write!(
                f,
                "the tree is {depth} levels deep, deeper than a stack of {stack} \
                 (rebuild it with `kdray build --max-depth {stack}`)"
            ),
        }
    }
}

fn kind_name(kind: u32) -> &'static str {
    match kind {
        1 => "triangles",
        2 => "3-D points of an older layout: rebuild it",
        3 => "points",
        4 => "scene",
        _ => "unknown",
    }
}

/// A point blob's scalar type by its size in bytes.
fn scalar_name(bytes: u32) -> &'static str {
    match bytes {
        4 => "f32",
        8 => "f64",
        _ => "an unknown scalar type",
    }
}

impl core::error::Error for BlobError {}

/// Why a blob could not be written: a count the header cannot hold, or an
/// output buffer too small for the blob.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum WriteError {
    /// A section has more records than the header's 32-bit count holds.
    TooMany {
        /// The section ("nodes", "triangles", ...).
        what: &'static str,
        /// Its record count.
        count: usize,
    },
    /// The blob's size overflows the address space.
    TooLarge,
    /// The output buffer is smaller than the blob.
    BufferTooSmall {
        /// Bytes the blob needs.
        need: usize,
        /// Bytes the buffer has.
        have: usize,
    },
}

impl fmt::Display for WriteError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            WriteError::TooMany { what, count } => write!(
                f,
                "{count} {what} do not fit a blob (at most {} per section)",
                u32::MAX
            ),
            WriteError::TooLarge => f.write_str("the blob's size overflows the address space"),
            WriteError::BufferTooSmall { need, have } => {
                write!(f, "the blob needs {need} bytes, the buffer has {have}")
            }
        }
    }
}

impl core::error::Error for WriteError {}

#[cfg(test)]
mod tests {
    use super::*;
    use core::fmt::Write;

    /// A sink that keeps nothing: Display only has to run.
    struct Discard;
    impl Write for Discard {
        fn write_str(&mut self, _: &str) -> fmt::Result {
            Ok(())
        }
    }

    #[test]
    fn display_never_overflows_on_hand_built_values() {
        let e = BlobError::TrailingBytes {
            expected: usize::MAX,
            have: 0,
        };
        write!(Discard, "{e}").unwrap();
    }
}
