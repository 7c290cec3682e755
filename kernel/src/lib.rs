//! # kdray-kernel
//!
//! The `no_std`, allocation-free half of kdray: the 8-byte k-d tree node,
//! a validated zero-copy view of a tree blob, and the queries.
//!
//! - [`TriangleTree::from_bytes`] checks a blob (header, sections,
//!   checksum, and the tree's structure) and borrows it; no byte is copied.
//! - [`TriangleTree::closest_hit`] and [`TriangleTree::any_hit`] trace one
//!   ray with the lecture's non-recursive loop on a fixed stack of
//!   [`MAX_DEPTH`] entries (768 bytes).
//!
//! ## Guarantees
//! - **No panics** for any blob, ray or query, validated or not.
//! - **No allocation**, no `std`; stack use is bounded by [`MAX_DEPTH`].
//! - **Exactness**: the closest hit is bit for bit the one
//!   [`closest_hit_brute`] finds over all triangles with the same watertight
//!   test: the smallest `t`, and at equal `t` the lowest triangle index.
//!   Any hit reports a hit exactly when [`any_hit_brute`] does.
//! - **Invalid rays** (non-finite origin, NaN/inf/zero direction, NaN or
//!   inverted `[tmin, tmax]`) miss.
#![no_std]
#![deny(missing_docs)]
#![warn(clippy::std_instead_of_core, clippy::alloc_instead_of_core)]

mod error;
pub mod node;
mod ray;
mod traverse;
mod tree;
mod triangle;
pub mod wire;

pub use error::BlobError;
pub use node::{Axis, Node, NodeKind};
pub use ray::{Hit, Ray, MISS, OCCLUDED};
pub use traverse::{CellRay, Closest, SLACK};
pub use tree::{Bounds, TriangleTree, MAX_DEPTH};
pub use triangle::{
    any_hit_brute, closest_hit_brute, edge_functions_f64, ray_is_valid, ShearedRay, Triangle,
    TriangleHit,
};
pub use wire::Aligned;
