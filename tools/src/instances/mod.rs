//! Scenes on the host, a file each: the top-level tree over instance world
//! boxes (`top_level.rs`: SAH with binning), the scene blob writer
//! (`writer.rs`), the flattened scene (`flatten.rs`: every instance's
//! triangles in world space, in instance order), a scene traced as its
//! flattened mesh for the CLI and the renderer (`tracing.rs`) and a
//! generated level (`generated.rs`).
//!
//! # Updating a scene every frame
//!
//! Static meshes are never rebuilt: their trees (and bounds) are kept and
//! shared by every instance. Per frame an engine
//! 1. gives each moved instance its new transform ([`Instance::new`](kdray_kernel::Instance::new)
//!    computes the inverse once);
//! 2. recomputes the world boxes from the kept mesh bounds
//!    ([`world_boxes`]) and rebuilds only the top level over them
//!    ([`build_top_level`], [`builders::fast`](crate::builders::fast)), or keeps a [`TopLevel`]
//!    and refills its planes ([`TopLevel::update`]; docs/results.md
//!    `## Scenes` has both times for 10,000 instances);
//! 3. updates the tree of each deforming mesh
//!    ([`crate::deforming::DeformingMesh::update`]: its planes kept, its
//!    moved triangles listed again, rebuilt with [`BuilderKind::Fast`](crate::builders::BuilderKind::Fast)
//!    when drifted) and takes its view (its bounds change too);
//! 4. assembles the scene from the trees, the instances and the new top
//!    level ([`Scene::from_parts`](kdray_kernel::Scene::from_parts), which validates them; no copy).
//!
//! ```
//! use kdray_tools::blob::Blob;
//! use kdray_tools::builders::{BuildParams, BuilderKind};
//! use kdray_tools::instances::{build_scene, build_top_level, generated_level, placement, world_boxes};
//! use kdray_kernel::{glam::Vec3, Instance, Ray, Scene};
//!
//! let (meshes, instances) = generated_level(20, 10.0, 1);
//! let parts = build_scene(&meshes, instances, BuilderKind::Sah, &BuildParams::default())?;
//! // The mesh trees, validated once and kept.
//! let trees = parts.meshes.iter().map(Blob::tree).collect::<Result<Vec<_>, _>>()?;
//! let bounds: Vec<_> = trees.iter().map(|t| t.bounds()).collect();
//! let mut instances = parts.instances.clone();
//! for frame in 0..3 {
//!     // Instance 0 moves; no mesh tree is touched.
//!     let m = placement([0.0, 1.0, 0.0], frame as f32 * 0.1, [1.0; 3], [frame as f32, 0.0, 0.0]);
//!     instances[0] = Instance::new(0, m, 0, u32::MAX).expect("invertible");
//!     let top = build_top_level(&world_boxes(&bounds, &instances));
//!     let scene = Scene::from_parts(&trees, &instances, &top.nodes, &top.prims, top.bounds)?;
//!     let ray = Ray::new(Vec3::new(frame as f32, 0.5, -20.0), Vec3::Z);
//!     let _hit = scene.closest_hit(&ray, u32::MAX);
//! }
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod flatten;
mod generated;
mod top_level;
mod tracing;
mod writer;

pub use flatten::*;
pub use generated::*;
pub use top_level::*;
pub use tracing::*;
pub use writer::*;
