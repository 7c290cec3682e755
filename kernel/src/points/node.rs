//! The point tree's node: `repr(C)`, Pod, 8 bytes, two little-endian
//! `u32` words. The split location is not in the node (it is an `f32` or
//! an `f64`): it sits at the same index in the blob's split section.
//!
//! ```text
//!            word 0                      word 1 (bit 31)   word 1 (bits 30..0)
//! interior   index of the below child    0                 split axis, 0..D
//! leaf       offset of its point run     1                 point count
//! ```
//!
//! The two children of an interior node sit side by side: the *below*
//! child (coordinates `<= split`) at `child`, the *above* child at
//! `child + 1`.
//!
//! Worked example: an interior node splitting axis 7 whose children are
//! nodes 6 and 7 is `[6, 7]`; a leaf of the 20 points at positions
//! `40..60` is `[40, 0x8000_0014]`; an empty leaf is `[0, 0x8000_0000]`.

use bytemuck::{Pod, Zeroable};

const LEAF_BIT: u32 = 1 << 31;

/// The largest point count or axis a [`PointNode`] holds (31 bits).
pub const MAX_POINT_FIELD: u32 = LEAF_BIT - 1;

/// One node of a point tree (module docs).
#[derive(Clone, Copy, PartialEq, Eq, Hash, Pod, Zeroable)]
#[repr(C)]
pub struct PointNode {
    word0: u32,
    word1: u32,
}

const _: () = assert!(core::mem::size_of::<PointNode>() == 8);

/// What a point node is, decoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PointNodeKind {
    /// Split on `axis`; children at `child` (below) and `child + 1`.
    Interior {
        /// The split axis (below D in a valid tree).
        axis: u32,
        /// The index of the below child; the above child follows it.
        child: u32,
    },
    /// A run of `count` points starting at position `offset`.
    Leaf {
        /// Where the run starts in the point section.
        offset: u32,
        /// How many points.
        count: u32,
    },
}

impl PointNode {
    /// An empty leaf.
    pub const EMPTY_LEAF: PointNode = PointNode {
        word0: 0,
        word1: LEAF_BIT,
    };

    /// An interior node splitting `axis`, its children at `child` and
    /// `child + 1`; `None` if `axis` does not fit in 31 bits.
    #[inline]
    #[must_use]
    pub const fn interior(axis: u32, child: u32) -> Option<PointNode> {
        if axis > MAX_POINT_FIELD {
            return None;
        }
        Some(PointNode {
            word0: child,
            word1: axis,
        })
    }

    /// A leaf of the `count` points at `offset..offset + count`; `None` if
    /// `count` does not fit in 31 bits.
    #[inline]
    #[must_use]
    pub const fn leaf(offset: u32, count: u32) -> Option<PointNode> {
        if count > MAX_POINT_FIELD {
            return None;
        }
        Some(PointNode {
            word0: offset,
            word1: LEAF_BIT | count,
        })
    }

    /// Is this a leaf?
    #[inline(always)]
    #[must_use]
    pub const fn is_leaf(self) -> bool {
        self.word1 & LEAF_BIT != 0
    }

    /// Word 0: the below child, or the leaf's offset.
    #[inline(always)]
    #[must_use]
    pub(crate) const fn word0(self) -> u32 {
        self.word0
    }

    /// Word 1 without the leaf bit: the axis, or the leaf's count.
    #[inline(always)]
    #[must_use]
    pub(crate) const fn field(self) -> u32 {
        self.word1 & MAX_POINT_FIELD
    }

    /// The node decoded.
    #[inline]
    #[must_use]
    pub const fn kind(self) -> PointNodeKind {
        if self.is_leaf() {
            PointNodeKind::Leaf {
                offset: self.word0,
                count: self.field(),
            }
        } else {
            PointNodeKind::Interior {
                axis: self.word1,
                child: self.word0,
            }
        }
    }
}

impl core::fmt::Debug for PointNode {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        self.kind().fmt(f)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn worked_examples_match_the_docs() {
        let words = |n: PointNode| bytemuck::cast::<PointNode, [u32; 2]>(n);
        assert_eq!(words(PointNode::interior(7, 6).unwrap()), [6, 7]);
        assert_eq!(words(PointNode::leaf(40, 20).unwrap()), [40, 0x8000_0014]);
        assert_eq!(words(PointNode::EMPTY_LEAF), [0, 0x8000_0000]);
        assert_eq!(
            PointNode::leaf(40, 20).unwrap().kind(),
            PointNodeKind::Leaf {
                offset: 40,
                count: 20
            }
        );
        assert!(PointNode::leaf(0, MAX_POINT_FIELD + 1).is_none());
        assert!(PointNode::interior(MAX_POINT_FIELD + 1, 0).is_none());
    }
}
