//! # kdray-kernel
//!
//! The `no_std`, allocation-free half of kdray: the 8-byte k-d tree node,
//! a validated zero-copy view of a tree blob, and the queries.
//!
//! - [`TriangleTree::from_bytes`] checks a blob (header, sections,
//!   checksum, and the tree's structure) and borrows it; no byte is copied.
//! - [`TriangleTree::closest_hit`] and [`TriangleTree::any_hit`] trace one
//!   ray with the lecture's non-recursive loop on a fixed stack of
//!   [`MAX_DEPTH`] entries; [`TriangleTree::closest_hit_packet`] traces a
//!   [`Packet`] of 4, 8 or 16 rays at once, and
//!   [`TriangleTree::closest_hits`] a batch of any size, the walk chosen per
//!   block ([`Batch`]), with the same answers. [`TriangleTree::counting`]
//!   counts a query's work; [`TreeletTree`] is the tree regrouped for
//!   scattered rays.
//! - [`Scene::from_bytes`] (a scene blob) or [`Scene::from_parts`] (mesh
//!   trees the engine holds, an [`Instance`] table and a top-level tree)
//!   gives a scene of instanced meshes; [`Scene::closest_hit`] and
//!   [`Scene::any_hit`] answer as [`Scene::closest_hit_brute`] does.
//! - [`PointTreeN::from_bytes`] does the same for a point tree over
//!   D-dimensional `f32` or `f64` points ([`PointTree`]: 3-D `f32`), which
//!   answers [`PointTreeN::nearest`], [`PointTreeN::knn`] and
//!   [`PointTreeN::within`] exactly as brute force does.
//!
//! Blobs are written by `kdray build` (or `kdray_tools::blob`) on the host.
//!
//! ## Quick start: a game engine
//!
//! Embed the blob aligned, validate it once, trace with glam vectors:
//!
//! ```
//! use glam::Vec3;
//! use kdray_kernel::{include_aligned, Ray, TriangleTree};
//!
//! // A unit cube with a tilted quad inside (`kdray build cube.obj -o cube-v3.kdt`).
//! static SCENE: &kdray_kernel::Aligned<[u8]> = include_aligned!("../golden/cube-v3.kdt");
//!
//! let tree = TriangleTree::from_bytes(&SCENE.bytes)?; // validated once, zero-copy
//! let ray = Ray::new(Vec3::new(0.3, 0.6, -1.0), Vec3::Z);
//! let hit = tree.closest_hit(&ray);
//! assert!(hit.is_hit());
//! assert_eq!((hit.t, hit.prim), (1.0, 1)); // the cube's z = 0 face, its second triangle
//! let point = ray.at(hit.t);
//! assert_eq!(point, Vec3::new(0.3, 0.6, 0.0));
//! // Shadow rays only need a yes or no.
//! assert!(!tree.any_hit(&Ray::with_range(point, Vec3::NEG_Z, 1e-3, 10.0)));
//! # Ok::<(), kdray_kernel::BlobError>(())
//! ```
//!
//! ## Quick start: firmware
//!
//! No heap and no `std`: the crate builds for `thumbv7em-none-eabihf`.
//! Put the blob in flash with [`include_aligned!`] (or point
//! [`TriangleTree::from_bytes`] at a 4-byte aligned region), validate it
//! once at boot, and keep the `TriangleTree` (it is `Copy`, two words per
//! section). Every query runs on a fixed stack array sized by
//! [`MAX_DEPTH`]; none can panic, so a hostile or corrupt blob costs an
//! `Err` at boot, never a fault. For a smaller stack, build the blob with
//! a depth limit and trace it as a [`ShallowTree`] of that depth (a stack
//! entry per level; the measured bytes per entry point are in
//! `docs/results.md`, "Firmware").
//!
//! ## Guarantees
//! - **No panics** for any blob, ray or query, validated or not (fuzzed:
//!   `fuzz/`; hostile blobs: `tests/hostile_blobs.rs`).
//! - **No allocation**, no `std`, no recursion. Stack: the single-ray walk
//!   keeps [`MAX_DEPTH`] = 64 pending cells of 12 bytes (768 bytes; a
//!   [`ShallowTree`] of depth `D` keeps `D`); a
//!   packet walk 64 entries of a lane-vector interval each (3 KiB for 4
//!   lanes, 6 KiB for 8, 12 KiB for 16, on x86-64); a point query 64
//!   entries of 8 bytes.
//!   Trees deeper than [`MAX_DEPTH`] are refused by validation.
//! - **Exactness**: the closest hit is bit for bit the one
//!   [`closest_hit_brute`] finds over all triangles with the same watertight
//!   test: the smallest `t`, and at equal `t` the lowest triangle index.
//!   Any hit reports a hit exactly when [`any_hit_brute`] does. Every
//!   packet lane answers exactly as its single ray; point queries answer
//!   exactly as [`knn_brute`] (equal distance: lower index first).
//! - **Invalid rays** (non-finite origin, NaN/inf/zero direction, NaN or
//!   inverted `[tmin, tmax]`) miss.
//! - **Accurate `t`**: the watertight edge test decides hit or miss (no
//!   ray slips through a shared edge or vertex of a closed mesh); `t` is
//!   the plane's `n·(v0 - o) / n·d` computed in `f64` and rounded once, so
//!   `|t - t_exact| <= 2^-24 |t| + 2^-47 m·(|v0 - o| + |t| |d|) / |n·d|`
//!   (`e1, e2` the triangle's edges from `v0`, `n = e1 × e2`, `m` its
//!   components' product magnitudes, `m_x = |e1y e2z| + |e1z e2y|` and so
//!   on; `|·|` taken per component): an ulp or two wherever the hit is well
//!   conditioned. A ray whose origin lies on a triangle's plane (within
//!   that formula's `f64` rounding) gets `t = 0` for it, so a ray starting
//!   on a triangle with `tmin <= 0` hits it at `t = 0`.
//! - **Coordinate range**: vertices and ray origins within `±`[`MAX_COORD`]
//!   (2^60). The builders refuse triangles outside it; a ray whose origin
//!   lies outside gets the same answer from tree, packets and brute force
//!   and never a panic, but may miss triangles whose edge functions
//!   overflow `f32`. Triangles whose projected edge products underflow
//!   `f32` (edges below about 2^-63 units) are missed. Points and queries
//!   within `±`[`max_point_coord`] (2^61 for 3-D `f32`, 2^60 up to 16-D:
//!   no squared distance overflows); the point builders refuse points
//!   outside it and a query outside it gets the empty answer, as a NaN
//!   query does.
//! - **Secondary rays need no epsilon**: [`SurfacePoint`] gives a hit's
//!   point with a conservative error bound and spawns rays from it, offset
//!   along the geometric normal past that bound (PBRT-v3's
//!   `OffsetRayOrigin`), that never hit the triangle they leave.
#![no_std]
#![deny(missing_docs)]
#![warn(clippy::std_instead_of_core, clippy::alloc_instead_of_core)]

// The layers, each importing only from those above it in this list
// (docs/architecture.md): geometry -> lanes -> triangle -> blob ->
// triangle_tree, points -> scene.
mod blob;
pub mod cpu;
mod geometry;
mod lanes;
mod points;
mod scene;
#[cfg(test)]
mod test_rng;
mod triangle;
mod triangle_tree;

pub use blob::{BlobError, Node, NodeKind, WriteError, MAX_DEPTH};

/// The blob's layout, for the writers in `kdray-tools` and the tests: the
/// wire format's sections and checksum, the node's fields, and the
/// line order the validation checks. Not a user's API: it follows the
/// format, which changes with its version.
#[doc(hidden)]
pub mod format {
    pub use crate::blob::{node, place_line_groups, wire, FIRST_PAIR, LINE_NODES};
}
pub use blob::wire::Aligned;
pub use cpu::{isa, set_isa, Isa, IsaUnsupported};
pub use geometry::{
    item_index, ray_is_valid, sort_items, Axis, Bounds, Hit, MortonGrid, Ray, RayKey, MISS,
    OCCLUDED,
};
/// The `glam` whose `Vec3` the ray constructors take: use it (or this
/// version of the crate) so the types match.
pub use glam;
pub use points::{
    distance2, knn_brute, max_point_coord, max_point_coord_log2, nearest_brute, within_brute,
    BufferTooSmall, Neighbour, PointNode, PointNodeKind, PointShape, PointTree, PointTreeN, Scalar,
    MAX_POINT_FIELD,
};
pub use scene::{
    inverse_affine, Instance, MeshEntry, NotSimilar, Scene, SceneClosestPoint, SceneError,
    SceneHit, IDENTITY, KIND_SCENE, MESH_ALIGN, SIMILAR,
};
pub use triangle::{
    any_hit_brute, bounds_in_range, closest_hit_brute, closest_point_brute, crossings_brute,
    first_hits_brute, winding_crossings_brute, ClosestPoint, SurfacePoint, Triangle, MAX_COORD,
};
pub use triangle_tree::packet::{Packet, Packet16, Packet4, Packet8, PacketWidth};
#[doc(hidden)]
pub use triangle_tree::Trial;
pub use triangle_tree::{
    Batch, Counting, PacketLanes, ShallowTree, Streams, TraceBatch, TraversalCounts, Treelet,
    TreeletBufferTooSmall, TreeletTree, TriangleTree, INSIDE_RAYS, STREAM_SCRATCH_WORDS,
};
