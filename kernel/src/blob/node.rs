//! The 8-byte k-d tree node of the lecture ("Compact (8-byte) nodes").
//!
//! `repr(C)`, [`bytemuck::Pod`], 8 bytes, two little-endian `u32` words:
//!
//! ```text
//!            word 0 (bits 31..0)            word 1 (bits 31..2)        bits 1..0
//! interior   split location (f32 bits)      index of the first child   axis: 0 x, 1 y, 2 z
//! leaf       primitive offset, or the one   primitive count            3
//!            primitive of a 1-prim leaf
//! ```
//!
//! The two children of an interior node sit side by side: the *below* child
//! (coordinates `<= split`) at `child`, the *above* child at `child + 1`, so
//! one 30-bit index reaches both.
//!
//! Worked example: an interior node splitting at `z = 1.5` whose children are
//! nodes 6 and 7 is `word0 = 1.5f32.to_bits() = 0x3FC0_0000` and
//! `word1 = 6 << 2 | 2 = 0b1_1010 = 0x1A`. A leaf holding the three
//! primitives `prims[40..43]` is `word0 = 40`, `word1 = 3 << 2 | 3 = 0xF`; a
//! leaf holding only triangle 9 is `word0 = 9`, `word1 = 1 << 2 | 3 = 0x7`;
//! an empty leaf is `word0 = 0`, `word1 = 0x3`.
//!
//! Only the accessors below apply masks and only [`Node::interior`] and
//! [`Node::leaf`] write fields, so a node is never half-built.

use crate::geometry::Axis;
use bytemuck::{Pod, Zeroable};

/// The largest child index or primitive count a node can hold (30 bits).
pub const MAX_NODE_FIELD: u32 = (1 << 30) - 1;

const LEAF_TAG: u32 = 3;

/// One node of a k-d tree: an interior split or a leaf (see the module docs).
#[derive(Clone, Copy, PartialEq, Eq, Hash, Pod, Zeroable)]
#[repr(C)]
pub struct Node {
    word0: u32,
    word1: u32,
}

const _: () = assert!(core::mem::size_of::<Node>() == 8);
const _: () = assert!(core::mem::align_of::<Node>() == 4);

/// What a node is, decoded.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum NodeKind {
    /// An interior node: split plane `axis = split`, children at `child`
    /// (below) and `child + 1` (above).
    Interior {
        /// The split axis.
        axis: Axis,
        /// The split location (the raw bits; may be non-finite in an
        /// unvalidated node).
        split: f32,
        /// The index of the below child; the above child follows it.
        child: u32,
    },
    /// A leaf with `count` primitives.
    Leaf {
        /// How many primitives the leaf holds.
        count: u32,
        /// For `count == 1` the primitive itself, otherwise the offset of the
        /// leaf's run in the primitive-index array (0 for an empty leaf).
        word: u32,
    },
}

impl Node {
    /// An interior node, or `None` if `child` does not fit in 30 bits.
    #[inline]
    #[must_use]
    pub const fn interior(axis: Axis, split: f32, child: u32) -> Option<Node> {
        if child > MAX_NODE_FIELD {
            return None;
        }
        Some(Node {
            word0: split.to_bits(),
            word1: (child << 2) | axis as u32,
        })
    }

    /// A leaf of `count` primitives; `word` is the primitive itself when
    /// `count == 1`, otherwise the offset into the primitive-index array.
    /// `None` if `count` does not fit in 30 bits.
    #[inline]
    #[must_use]
    pub const fn leaf(count: u32, word: u32) -> Option<Node> {
        if count > MAX_NODE_FIELD {
            return None;
        }
        Some(Node {
            word0: word,
            word1: (count << 2) | LEAF_TAG,
        })
    }

    /// An empty leaf (an empty cell of the lecture: nothing to test).
    pub const EMPTY_LEAF: Node = Node {
        word0: 0,
        word1: LEAF_TAG,
    };

    /// Is this a leaf?
    #[inline(always)]
    #[must_use]
    pub const fn is_leaf(self) -> bool {
        self.word1 & 3 == LEAF_TAG
    }

    /// Is this a leaf with no primitives (an empty cell)?
    #[inline(always)]
    #[must_use]
    pub const fn is_empty_leaf(self) -> bool {
        self.word1 == LEAF_TAG
    }

    /// The split axis index 0..=2 (3 for a leaf).
    #[inline(always)]
    #[must_use]
    pub const fn axis_bits(self) -> usize {
        (self.word1 & 3) as usize
    }

    /// The split location of an interior node (meaningless for a leaf).
    #[inline(always)]
    #[must_use]
    pub const fn split(self) -> f32 {
        f32::from_bits(self.word0)
    }

    /// The index of the below child of an interior node; the above child
    /// is the next node. (For a leaf: the primitive count.)
    #[inline(always)]
    #[must_use]
    pub const fn upper(self) -> u32 {
        self.word1 >> 2
    }

    /// The `above_first` mask [`Node::first_child`] takes, from a ray's
    /// per-axis flags (1 where it enters the above child first): the three
    /// bits, x in bit 0, repeated in every nibble of a 64-bit word.
    #[inline(always)]
    #[must_use]
    pub(crate) const fn first_child_mask(above_first: [u32; 3]) -> u64 {
        let bits = (above_first[0] & 1) | (above_first[1] & 1) << 1 | (above_first[2] & 1) << 2;
        bits as u64 * 0x1111_1111_1111_1111
    }

    /// The child of an interior node that a ray enters first: the below
    /// child (`upper()`), or the above one when the ray's bit for this
    /// node's axis is set in `above_first`. `above_first` holds the three
    /// per-axis bits (x in bit 0, y in 1, z in 2) repeated in every nibble,
    /// so one shift by the whole second word (the hardware takes its low
    /// six bits: `4 * (child % 16) + axis`) finds the bit: the walk's
    /// node-to-node latency chain has no table load in it. In 64 bits, as
    /// an index: on x86-64 that is one `bt` and one `adc` after the node's
    /// load, with no masking of the shift nor widening of the index
    /// (measured: ~2% of a camera-ray trace).
    #[inline(always)]
    #[must_use]
    pub(crate) const fn first_child(self, above_first: u64) -> usize {
        (self.upper() as usize) + (above_first.wrapping_shr(self.word1) & 1) as usize
    }

    /// The child of the pair that is not `first` (one of the two).
    #[inline(always)]
    #[must_use]
    pub(crate) const fn other_child(self, first: usize) -> usize {
        (self.upper() as usize * 2 + 1).wrapping_sub(first)
    }

    /// The low word: a leaf's offset or single primitive (the split bits
    /// for an interior node).
    #[inline(always)]
    #[must_use]
    pub const fn word0(self) -> u32 {
        self.word0
    }

    /// The node decoded.
    #[inline]
    #[must_use]
    pub const fn kind(self) -> NodeKind {
        match Axis::from_index(self.axis_bits()) {
            Some(axis) => NodeKind::Interior {
                axis,
                split: self.split(),
                child: self.upper(),
            },
            None => NodeKind::Leaf {
                count: self.upper(),
                word: self.word0,
            },
        }
    }
}

impl core::fmt::Debug for Node {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        self.kind().fmt(f)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn worked_examples_match_the_docs() {
        let n = Node::interior(Axis::Z, 1.5, 6).unwrap();
        assert_eq!(bytemuck::cast::<Node, [u32; 2]>(n), [0x3FC0_0000, 0x1A]);
        let l = Node::leaf(3, 40).unwrap();
        assert_eq!(bytemuck::cast::<Node, [u32; 2]>(l), [40, 0xF]);
        assert_eq!(
            bytemuck::cast::<Node, [u32; 2]>(Node::leaf(1, 9).unwrap()),
            [9, 7]
        );
        assert_eq!(bytemuck::cast::<Node, [u32; 2]>(Node::EMPTY_LEAF), [0, 3]);
    }

    #[test]
    fn fields_round_trip_and_overflow_is_refused() {
        let n = Node::interior(Axis::Y, -0.0, MAX_NODE_FIELD).unwrap();
        assert_eq!(
            n.kind(),
            NodeKind::Interior {
                axis: Axis::Y,
                split: -0.0,
                child: MAX_NODE_FIELD
            }
        );
        assert!(Node::interior(Axis::X, 0.0, MAX_NODE_FIELD + 1).is_none());
        assert!(Node::leaf(MAX_NODE_FIELD + 1, 0).is_none());
        assert!(Node::leaf(0, 0).unwrap().is_leaf());
    }

    #[test]
    fn first_child_reads_the_axis_bit_for_every_child_index() {
        for bits in 0..8u32 {
            let above_first = [bits & 1, bits >> 1 & 1, bits >> 2 & 1];
            let mask = Node::first_child_mask(above_first);
            for axis in Axis::ALL {
                let above = above_first[axis.index()];
                for child in (1..40).chain(MAX_NODE_FIELD - 8..MAX_NODE_FIELD) {
                    let n = Node::interior(axis, 0.0, child).unwrap();
                    let first = n.first_child(mask);
                    assert_eq!(first, (child + above) as usize);
                    assert_eq!(n.other_child(first), (child + 1 - above) as usize);
                }
            }
        }
    }
}
