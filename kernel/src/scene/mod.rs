//! Scenes: instances of shared triangle trees under a top-level k-d tree
//! (Wald, Benthin & Slusallek 2003). Static meshes keep their trees; an
//! instance places one by an affine transform, and the ray, not the mesh,
//! is transformed ([`Instance::local_ray`]).
//!
//! The top level is a k-d tree of the same 8-byte [`Node`]s, in the same
//! layout and checked by the same validation as a mesh tree; its leaves
//! list instance indices, each instance in every leaf whose cell its
//! padded world box ([`Instance::world_bounds`]) overlaps. Its walk is the
//! lecture's loop with the same slack rule as the mesh walk, and in a leaf
//! each instance the ray's mask selects is traced with the mesh tree's own
//! [`TriangleTree::closest_hit`] or [`TriangleTree::any_hit`], so the
//! answers are the brute force's ([`Scene::closest_hit_brute`]): closest
//! `t`, then lower instance, then lower triangle.
//!
//! A scene blob (kind [`KIND_SCENE`]) holds the top level, the instance
//! table and the mesh tree blobs it references, under one header and one
//! checksum:
//!
//! ```text
//! header      the blob header: node count, primitive-index count and item
//!             count are the top level's nodes, its instance indices and
//!             the instances; bounds hold every instance's world box
//! nodes       top-level nodes (8 B each)
//! indices     instance indices of the top level's leaves (4 B each)
//! instances   Instance records (112 B each)
//! mesh count  one u32
//! mesh table  per mesh: byte offset from the blob's start, byte length
//! meshes      each mesh's own triangle-tree blob, starting at the first
//!             multiple of 64 at or after the previous one's end (zero
//!             padding), the last ending the blob
//! ```

mod brute;
mod closest_point;
mod instance;
mod walk;

pub use closest_point::{NotSimilar, SceneClosestPoint};
pub use instance::{inverse_affine, Instance, IDENTITY, SIMILAR};
pub use walk::SceneHit;

use crate::blob::wire::{self, Sections, HEADER_LEN};
use crate::blob::{validate_nodes, BlobError, Node};
use crate::geometry::Bounds;
use crate::triangle_tree::TriangleTree;
use core::fmt;
use instance::InstanceFault;

/// The kind of a scene blob.
pub const KIND_SCENE: u32 = 4;

/// Where each mesh blob starts in a scene blob: a multiple of this many
/// bytes from the blob's start, so a 64-byte aligned scene blob holds
/// cache-line aligned mesh trees.
pub const MESH_ALIGN: usize = 64;

/// A mesh's place in a scene blob: `repr(C)`, Pod, 8 bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub struct MeshEntry {
    /// Byte offset of the mesh blob from the scene blob's start.
    pub offset: u32,
    /// The mesh blob's length in bytes.
    pub len: u32,
}

/// Why a scene could not be loaded or assembled.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub enum SceneError {
    /// The blob's header, sections or checksum, or the top-level tree.
    Blob(BlobError),
    /// A mesh tree inside the scene blob is invalid.
    Mesh {
        /// The mesh's index.
        mesh: u32,
        /// What is wrong with it.
        error: BlobError,
    },
    /// A mesh blob is not where the layout puts it.
    MeshPlacement {
        /// The mesh's index.
        mesh: u32,
        /// The offset its entry records.
        offset: u32,
        /// The offset the layout gives it.
        expected: u32,
    },
    /// The padding before a mesh blob is not zero.
    MeshPadding {
        /// The mesh's index.
        mesh: u32,
    },
    /// The last mesh blob does not end the scene blob.
    MeshesEnd {
        /// Where the mesh table says the meshes end.
        end: u64,
        /// The blob's length.
        len: usize,
    },
    /// An instance names a mesh the scene does not have.
    MeshOutOfRange {
        /// The instance's index.
        instance: u32,
        /// The mesh it names.
        mesh: u32,
        /// How many meshes the scene has.
        meshes: u32,
    },
    /// An instance's reserved word is not zero.
    Reserved {
        /// The instance's index.
        instance: u32,
    },
    /// An instance's transform is not finite or not invertible.
    BadTransform {
        /// The instance's index.
        instance: u32,
    },
    /// An instance's stored inverse is not the kernel's inverse of its transform.
    BadInverse {
        /// The instance's index.
        instance: u32,
    },
    /// An instance's world box is not inside the scene's bounds.
    InstanceOutsideBounds {
        /// The instance's index.
        instance: u32,
    },
    /// An instance's world box reaches beyond `±`[`MAX_COORD`](crate::MAX_COORD),
    /// the range a flat build of the same triangles is held to.
    InstanceOutOfRange {
        /// The instance's index.
        instance: u32,
    },
}

impl From<BlobError> for SceneError {
    fn from(e: BlobError) -> SceneError {
        SceneError::Blob(e)
    }
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use SceneError::*;
        match *self {
            Blob(e) => write!(f, "{e}"),
            Mesh { mesh, error } => write!(f, "mesh {mesh} of the scene: {error}"),
            MeshPlacement {
                mesh,
                offset,
                expected,
            } => write!(
                f,
                "mesh {mesh} starts at byte {offset}, but the layout puts it at {expected}"
            ),
            MeshPadding { mesh } => write!(f, "the padding before mesh {mesh} is not zero"),
            MeshesEnd { end, len } => write!(
                f,
                "the mesh table ends the meshes at byte {end}, but the blob has {len} bytes"
            ),
            MeshOutOfRange {
                instance,
                mesh,
                meshes,
            } => write!(
                f,
                "instance {instance} names mesh {mesh}, but the scene has {meshes} meshes"
            ),
            Reserved { instance } => write!(f, "instance {instance} has a non-zero reserved word"),
            BadTransform { instance } => write!(
                f,
                "instance {instance} has a non-finite or singular transform"
            ),
            BadInverse { instance } => write!(
                f,
                "instance {instance}'s stored inverse is not the inverse of its transform"
            ),
            InstanceOutsideBounds { instance } => write!(
                f,
                "instance {instance}'s world box is not inside the scene bounds"
            ),
            InstanceOutOfRange { instance } => write!(
                f,
                "instance {instance}'s world box reaches beyond the kernel's range of ±{:e} (kdray_kernel::MAX_COORD)",
                crate::MAX_COORD
            ),
        }
    }
}

impl core::error::Error for SceneError {}

/// Where a scene's mesh trees live.
#[derive(Clone, Copy, Debug)]
enum Meshes<'a> {
    /// Trees the engine validated and holds.
    Trees(&'a [TriangleTree<'a>]),
    /// Inside a validated scene blob: each mesh's blob by its table entry.
    Blob {
        table: &'a [MeshEntry],
        bytes: &'a [u8],
    },
}

/// A scene, borrowed: instances of mesh trees under a top-level tree.
/// Cheap to copy; share it across threads.
#[derive(Clone, Copy, Debug)]
pub struct Scene<'a> {
    meshes: Meshes<'a>,
    instances: &'a [Instance],
    nodes: &'a [Node],
    prims: &'a [u32],
    bounds: Bounds,
    max_depth: u32,
    /// The masks of the instances whose transform is not a similarity,
    /// merged: a query whose mask shares no bit with it selects none
    /// (`closest_point`'s refusal).
    unsimilar_masks: u32,
    /// The largest `s^2` times squared mesh-box magnitude of the
    /// similarity instances: the closest-point walk's cell cut.
    reach2: f64,
}

impl<'a> Scene<'a> {
    /// A scene over parts the engine owns: mesh trees it validated, the
    /// instance table, and a top-level tree over the instances (built by
    /// `kdray_tools::instances`, or an engine's own builder). Checks every
    /// instance (mesh in range, transform invertible, stored inverse the
    /// kernel's, world box inside `bounds`) and the top level as a mesh
    /// tree is checked. O(instances + nodes), no allocation.
    ///
    /// # Errors
    /// A [`SceneError`] naming the first problem found.
    ///
    /// # Panics
    /// Never, for any input.
    pub fn from_parts(
        meshes: &'a [TriangleTree<'a>],
        instances: &'a [Instance],
        nodes: &'a [Node],
        prims: &'a [u32],
        bounds: Bounds,
    ) -> Result<Scene<'a>, SceneError> {
        let scene = Scene {
            meshes: Meshes::Trees(meshes),
            instances,
            nodes,
            prims,
            bounds,
            max_depth: 0,
            unsimilar_masks: 0,
            reach2: 0.0,
        };
        scene.validate()
    }

    /// Loads and validates a scene blob (module docs): alignment, header,
    /// section lengths and the checksum, then the mesh table and every
    /// mesh tree ([`TriangleTree::from_bytes`]), every instance and the
    /// top level ([`Scene::from_parts`]'s checks). O(size of the blob),
    /// no allocation; nothing is copied.
    ///
    /// # Errors
    /// A [`SceneError`] naming the first problem found.
    ///
    /// # Panics
    /// Never, for any input.
    pub fn from_bytes(bytes: &'a [u8]) -> Result<Scene<'a>, SceneError> {
        let (header, mut s) = Sections::open(bytes, KIND_SCENE)?;
        let nodes: &[Node] = s.take("top-level nodes", header.node_count)?;
        let prims: &[u32] = s.take("instance indices", header.index_count)?;
        let instances: &[Instance] = s.take("instances", header.item_count)?;
        let count: &[u32] = s.take("mesh count", 1)?;
        let count = count.first().copied().unwrap_or(0);
        let table: &[MeshEntry] = s.take("mesh table", count)?;
        // Where the meshes start: the header and the sections so far.
        let start = [
            core::mem::size_of_val(nodes),
            core::mem::size_of_val(prims),
            core::mem::size_of_val(instances),
            4,
            core::mem::size_of_val(table),
        ]
        .iter()
        .try_fold(HEADER_LEN, |n, &b| n.checked_add(b))
        .ok_or(BlobError::Overflow { what: "mesh table" })?;
        let mut end = start as u64;
        for (i, e) in table.iter().enumerate() {
            let expected = end.div_ceil(MESH_ALIGN as u64) * MESH_ALIGN as u64;
            if u64::from(e.offset) != expected {
                return Err(SceneError::MeshPlacement {
                    mesh: i as u32,
                    offset: e.offset,
                    expected: expected.min(u64::from(u32::MAX)) as u32,
                });
            }
            let padding = bytes.get(end as usize..expected as usize).unwrap_or(&[1]);
            if padding.iter().any(|&b| b != 0) {
                return Err(SceneError::MeshPadding { mesh: i as u32 });
            }
            end = expected + u64::from(e.len);
        }
        if end < start as u64 || end - start as u64 > u32::MAX as u64 {
            return Err(SceneError::MeshesEnd {
                end,
                len: bytes.len(),
            });
        }
        let _meshes: &[u8] = s.take("meshes", (end - start as u64) as u32)?;
        let whole = s.finish()?;
        wire::verify_checksum(header, whole)?;
        for (i, e) in table.iter().enumerate() {
            let mesh = e.offset as usize..(e.offset as usize).saturating_add(e.len as usize);
            let blob = bytes.get(mesh).unwrap_or(&[]);
            TriangleTree::from_bytes(blob).map_err(|error| SceneError::Mesh {
                mesh: i as u32,
                error,
            })?;
        }
        let scene = Scene {
            meshes: Meshes::Blob { table, bytes },
            instances,
            nodes,
            prims,
            bounds: Bounds {
                min: header.bounds_min,
                max: header.bounds_max,
            },
            max_depth: 0,
            unsimilar_masks: 0,
            reach2: 0.0,
        }
        .validate()?;
        header.expect_depth(scene.max_depth)?;
        Ok(scene)
    }

    /// The checks [`Scene::from_parts`] lists; returns the scene with its
    /// measured depth and what the closest-point walk needs of its
    /// instances.
    fn validate(mut self) -> Result<Scene<'a>, SceneError> {
        if !self.bounds.is_valid() {
            return Err(BlobError::BadBounds.into());
        }
        let meshes = self.mesh_count();
        for (i, inst) in self.instances.iter().enumerate() {
            let instance = i as u32;
            inst.check().map_err(|f| match f {
                InstanceFault::Reserved => SceneError::Reserved { instance },
                InstanceFault::BadTransform => SceneError::BadTransform { instance },
                InstanceFault::BadInverse => SceneError::BadInverse { instance },
            })?;
            let Some(mesh) = self.mesh(inst.mesh()) else {
                return Err(SceneError::MeshOutOfRange {
                    instance,
                    mesh: inst.mesh(),
                    meshes,
                });
            };
            let w = inst.world_bounds(&mesh.bounds());
            if !crate::triangle::bounds_in_range(&w) {
                return Err(SceneError::InstanceOutOfRange { instance });
            }
            if !(self.bounds.contains(w.min) && self.bounds.contains(w.max)) {
                return Err(SceneError::InstanceOutsideBounds { instance });
            }
            match inst.similarity_scale2() {
                Some(s2) => {
                    self.reach2 = self.reach2.max(closest_point::reach2(s2, &mesh.bounds()))
                }
                None => self.unsimilar_masks |= inst.mask(),
            }
        }
        self.max_depth = validate_nodes(self.nodes, self.prims, self.instances.len())?;
        Ok(self)
    }

    /// How many meshes the scene holds.
    #[must_use]
    pub fn mesh_count(&self) -> u32 {
        match self.meshes {
            Meshes::Trees(t) => t.len() as u32,
            Meshes::Blob { table, .. } => table.len() as u32,
        }
    }

    /// Mesh `i`'s tree; `None` past the end. For a scene blob this reads
    /// the mesh's header (O(1): it was validated when the scene was).
    #[inline]
    #[must_use]
    pub fn mesh(&self, i: u32) -> Option<TriangleTree<'a>> {
        match self.meshes {
            Meshes::Trees(t) => t.get(i as usize).copied(),
            Meshes::Blob { table, bytes } => {
                let e = table.get(i as usize)?;
                let start = e.offset as usize;
                let blob = bytes.get(start..start.checked_add(e.len as usize)?)?;
                TriangleTree::from_bytes_unchecked(blob).ok()
            }
        }
    }

    /// The instances, in index order.
    #[must_use]
    pub fn instances(&self) -> &'a [Instance] {
        self.instances
    }

    /// The top-level nodes, root first.
    #[must_use]
    pub fn nodes(&self) -> &'a [Node] {
        self.nodes
    }

    /// The top level's instance-index array.
    #[must_use]
    pub fn prim_indices(&self) -> &'a [u32] {
        self.prims
    }

    /// The scene bounds: the top level's root cell.
    #[must_use]
    pub fn bounds(&self) -> Bounds {
        self.bounds
    }

    /// The depth of the top level's deepest node.
    #[must_use]
    pub fn max_depth(&self) -> u32 {
        self.max_depth
    }
}
