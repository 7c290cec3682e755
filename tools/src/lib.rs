//! # kdray-tools
//!
//! The std half of kdray: mesh loaders, tree builders, the blob writer,
//! tree statistics, and the `kdray` command-line tool built on them.
//!
//! ```text
//! mesh file -> mesh::load -> triangles -> builders::build -> BuiltTree
//!           -> blob::write_triangle_tree -> Blob -> Blob::tree() -> kernel queries
//! .pts file -> io::read_records -> points::build_points -> BuiltPoints
//!           -> blob::write_point_tree -> Blob -> Blob::point_tree() -> kernel queries
//! ```
#![forbid(unsafe_code)]
#![deny(missing_docs)]

pub mod blob;
pub mod builders;
pub mod camera;
pub mod deforming;
pub mod demo_scene;
pub mod distance;
pub mod instances;
pub mod io;
pub mod memory;
pub mod mesh;
pub mod morton;
pub mod points;
pub mod render;
pub mod rng;
pub mod stats;
pub mod teapot;
pub mod threads;
pub mod trace;
pub mod winding;
