//! Seven split planes a step: the tree regrouped into complete 3-level
//! treelets, one 64-byte [`Treelet`] each, for rays that share no cells
//! (random rays, bounces).
//!
//! A treelet holds a node and the two levels below it: slot 0 the node,
//! slots `2s + 1` and `2s + 2` the below and above children of slot `s`;
//! its 8 exits are the children of the bottom slots (`2(s - 3)` below,
//! `2(s - 3) + 1` above): another treelet, a leaf or nothing. A leaf or an
//! empty cell inside a treelet falls through planes at `+inf` (the whole
//! cell below, for either sign of the direction) to an exit below it.
//!
//! A step evaluates the 7 planes at once (`t_split` from one permute of
//! the origin and of `1/dir` by the slots' axes), the 8 exits' intervals
//! three levels down in lanes that hold the exits in the order a ray
//! meets them, goes on with the nearest live exit and pushes the others.
//! Each plane is the one-plane walk's (`walk.rs`): the same `t_split`,
//! the same tests (`!(t < lo)` for the near side, `!(t > hi)` for the far,
//! a NaN visiting both), the same intervals widened by the slack and the
//! same cutoff, so the treelet walk visits the leaves the one-plane walk
//! visits, in the same front-to-back order (a treelet's lower planes see
//! the cutoff of when it was entered, not of when a pushed exit is
//! popped, so now and then a cell more), and each answer is the single
//! ray's bit for bit: triangles are tested over the ray's own interval.
//!
//! Why in turns: measured on the walks alone (leaves counted, not tested;
//! the same leaves per ray; bunny, teapot, sponza and the built-in scene,
//! one core), one ray at a time the vector step is a longer chain than
//! three scalar steps whose branches predict (~20 ns a treelet against
//! ~4 ns a step): 0.44-0.9x the one-plane walk on camera rays, 1.0-1.25x
//! on random rays, whose near/far branch is a coin toss. [`TURNS`](walk::TURNS) walks
//! in turns overlap the chains: random rays 1.4-1.9x, camera rays
//! 0.63-1.3x, so coherent batches keep the one-plane walk. AVX-512 (mask
//! registers, compress) ran no faster than AVX2 (compares, blends, a
//! permute table), which is the level taken.
//!
//! Tried: the single-ray walk (camera rays) one plane a step through the
//! lines, each slot's plane read at its fixed place (no child index, no
//! empty-cell check inside a line): bunny and teapot camera rays 0.71x
//! the one-plane walk, the same hits. It took 17% more steps (an empty
//! cell inside a treelet is stepped into, where the one-plane walk skips
//! it at its parent), and a step was no cheaper (~40 instructions: the
//! level test and the third level's exits replace the child reads).
//!
//! The treelets live in the caller's memory ([`TriangleTree::treelets_into`]
//! writes them and returns the [`TreeletTree`](crate::TreeletTree) that uses them); the blob is
//! unchanged.

mod build;
mod walk;

use bytemuck::{Pod, Zeroable};
use core::fmt;

/// Three levels of the tree in one 64-byte line: the 7 slots' split
/// planes and axes and the 8 exits (module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
#[repr(C, align(64))]
pub struct Treelet {
    /// The slots' split positions (`+inf` for a slot a leaf or an empty
    /// cell falls through).
    split: [f32; 7],
    /// The slots' axes, two bits each, slot `s` at bit `2s`.
    axes: u32,
    /// Each exit: a treelet's index, [`LEAF`] and a leaf's node index, or
    /// [`DEAD`].
    exit: [u32; 8],
}

const _: () = assert!(core::mem::size_of::<Treelet>() == 64);

/// [`TriangleTree::treelets_into`](crate::TriangleTree::treelets_into)'s buffer is shorter than the tree's
/// treelets.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TreeletBufferTooSmall {
    /// The tree's treelets ([`TriangleTree::treelet_count`](crate::TriangleTree::treelet_count)).
    pub needed: usize,
    /// The buffer's length.
    pub have: usize,
}

impl fmt::Display for TreeletBufferTooSmall {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "the tree has {} treelets, the buffer room for {}",
            self.needed, self.have
        )
    }
}

impl core::error::Error for TreeletBufferTooSmall {}

/// An exit to nothing: an empty cell, or below a leaf that fell through.
pub(super) const DEAD: u32 = u32::MAX;
/// The tag of an exit to a leaf; the low bits are its node index (node
/// indices are below 2^30).
pub(super) const LEAF: u32 = 1 << 31;
