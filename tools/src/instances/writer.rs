//! A scene's mesh trees, instances and top level built, and written as
//! one scene blob.

use super::top_level::{build_top_level, world_boxes};
use crate::blob::{write_triangle_tree, Blob};
use crate::builders::{self, BuildError, BuildParams, BuilderKind, BuiltTree};
use kdray_kernel::format::wire::{
    blob_checksum, Header, CHECKSUM_OFFSET, ENDIAN_CHECK, HEADER_LEN, MAGIC, VERSION,
};
use kdray_kernel::{
    Bounds, Instance, Scene, Triangle, TriangleTree, WriteError, KIND_SCENE, MESH_ALIGN,
};

/// A scene built on the host: the mesh tree blobs, the instances, the top level.
#[derive(Clone, Debug)]
pub struct SceneParts {
    /// Each mesh's triangle-tree blob.
    pub meshes: Vec<Blob>,
    /// The instances.
    pub instances: Vec<Instance>,
    /// The top level over the instances' world boxes.
    pub top: BuiltTree,
}

/// Why a scene could not be built.
#[derive(Debug)]
pub enum SceneBuildError {
    /// A mesh's tree could not be built.
    Build {
        /// The mesh.
        mesh: usize,
        /// Why.
        error: BuildError,
    },
    /// An instance's world box reaches beyond `±`[`kdray_kernel::MAX_COORD`],
    /// the range the flat build holds vertices to.
    OutOfRange {
        /// The instance's index.
        instance: usize,
        /// Its world box.
        world: Bounds,
    },
    /// A blob could not be written.
    Write(WriteError),
}

impl std::fmt::Display for SceneBuildError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SceneBuildError::Build { mesh, error } => write!(f, "mesh {mesh}: {error}"),
            SceneBuildError::OutOfRange { instance, world } => write!(
                f,
                "instance {instance}'s world box {:?}..{:?} reaches beyond the kernel's range of ±{:e} (kdray_kernel::MAX_COORD), which a flat build of the same triangles refuses",
                world.min,
                world.max,
                kdray_kernel::MAX_COORD
            ),
            SceneBuildError::Write(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for SceneBuildError {}

/// Builds a tree per mesh (with `kind` and `params`) and the top level
/// over `instances`.
///
/// # Errors
/// [`SceneBuildError`] naming the mesh whose build failed, or the first
/// instance whose world box is out of range.
pub fn build_scene(
    meshes: &[Vec<Triangle>],
    instances: Vec<Instance>,
    kind: BuilderKind,
    params: &BuildParams,
) -> Result<SceneParts, SceneBuildError> {
    let mut blobs = Vec::with_capacity(meshes.len());
    let mut bounds = Vec::with_capacity(meshes.len());
    for (mesh, tris) in meshes.iter().enumerate() {
        let tree = builders::build(tris, kind, params)
            .map_err(|error| SceneBuildError::Build { mesh, error })?;
        bounds.push(tree.bounds);
        blobs.push(write_triangle_tree(&tree, tris).map_err(SceneBuildError::Write)?);
    }
    let boxes = world_boxes(&bounds, &instances);
    // An empty box is an instance of a missing mesh, which the scene's
    // validation names.
    if let Some(instance) = boxes
        .iter()
        .position(|b| *b != Bounds::EMPTY && !kdray_kernel::bounds_in_range(b))
    {
        return Err(SceneBuildError::OutOfRange {
            instance,
            world: boxes[instance],
        });
    }
    let top = build_top_level(&boxes);
    Ok(SceneParts {
        meshes: blobs,
        instances,
        top,
    })
}

impl SceneParts {
    /// The validated mesh trees, for [`kdray_kernel::Scene::from_parts`].
    ///
    /// # Errors
    /// The kernel's error for a mesh blob (never for one this module wrote).
    pub fn trees(&self) -> Result<Vec<TriangleTree<'_>>, kdray_kernel::BlobError> {
        self.meshes.iter().map(Blob::tree).collect()
    }

    /// The scene over these parts and `trees` (from [`SceneParts::trees`]),
    /// validated ([`Scene::from_parts`]).
    ///
    /// # Errors
    /// The kernel's [`SceneError`](kdray_kernel::SceneError) (never for parts this module built).
    pub fn scene<'s>(
        &'s self,
        trees: &'s [TriangleTree<'s>],
    ) -> Result<Scene<'s>, kdray_kernel::SceneError> {
        Scene::from_parts(
            trees,
            &self.instances,
            &self.top.nodes,
            &self.top.prims,
            self.top.bounds,
        )
    }

    /// The scene blob.
    ///
    /// # Errors
    /// [`WriteError`] when a count or offset does not fit 32 bits.
    pub fn write(&self) -> Result<Blob, WriteError> {
        let meshes: Vec<&[u8]> = self.meshes.iter().map(Blob::as_bytes).collect();
        write_scene(&meshes, &self.instances, &self.top)
    }
}

/// Writes a scene blob (layout: the kernel's `scene` module docs): the
/// header, the top level, the instances, the mesh table, then each mesh
/// blob at the next multiple of [`MESH_ALIGN`]. The same input gives the
/// same bytes.
///
/// # Errors
/// [`WriteError::TooMany`] for a count or offset beyond 32 bits.
pub fn write_scene(
    meshes: &[&[u8]],
    instances: &[Instance],
    top: &BuiltTree,
) -> Result<Blob, WriteError> {
    let count = |what: &'static str, count: usize| {
        u32::try_from(count).map_err(|_| WriteError::TooMany { what, count })
    };
    let header = Header {
        magic: MAGIC,
        endian: ENDIAN_CHECK,
        version: VERSION,
        kind: KIND_SCENE,
        max_depth: top.max_depth,
        node_count: count("top-level nodes", top.nodes.len())?,
        index_count: count("instance indices", top.prims.len())?,
        item_count: count("instances", instances.len())?,
        checksum: 0,
        bounds_min: top.bounds.min,
        bounds_max: top.bounds.max,
    };
    let mut out =
        Vec::with_capacity(HEADER_LEN + meshes.iter().map(|m| m.len() + MESH_ALIGN).sum::<usize>());
    out.extend_from_slice(bytemuck::bytes_of(&header));
    out.extend_from_slice(bytemuck::cast_slice(&top.nodes));
    out.extend_from_slice(bytemuck::cast_slice(&top.prims));
    out.extend_from_slice(bytemuck::cast_slice(instances));
    out.extend_from_slice(&count("meshes", meshes.len())?.to_le_bytes());
    let table_at = out.len();
    out.resize(table_at + 8 * meshes.len(), 0);
    for (i, m) in meshes.iter().enumerate() {
        out.resize(out.len().next_multiple_of(MESH_ALIGN), 0);
        let entry = [
            count("mesh offset", out.len())?,
            count("mesh length", m.len())?,
        ];
        out[table_at + 8 * i..table_at + 8 * i + 8].copy_from_slice(bytemuck::cast_slice(&entry));
        out.extend_from_slice(m);
    }
    let sum = blob_checksum(&out);
    out[CHECKSUM_OFFSET..CHECKSUM_OFFSET + 4].copy_from_slice(&sum.to_le_bytes());
    Ok(Blob::from_bytes(&out))
}
