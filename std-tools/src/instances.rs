//! Scenes on the host: the top-level tree over instance world boxes (SAH
//! with binning), the scene blob writer, the flattened scene (every
//! instance's triangles in world space, in instance order) and a
//! generated level.
//!
//! # Updating a scene every frame
//!
//! Static meshes are never rebuilt: their trees (and bounds) are kept and
//! shared by every instance. Per frame an engine
//! 1. gives each moved instance its new transform ([`Instance::new`]
//!    computes the inverse once);
//! 2. recomputes the world boxes from the kept mesh bounds
//!    ([`world_boxes`]) and rebuilds only the top level over them
//!    ([`build_top_level`], [`builders::fast`]), or keeps a [`TopLevel`]
//!    and refills its planes ([`TopLevel::update`]; docs/results.md
//!    `## Scenes` has both times for 10,000 instances);
//! 3. updates the tree of each deforming mesh
//!    ([`crate::deforming::DeformingMesh::update`]: its planes kept, its
//!    moved triangles listed again, rebuilt with [`BuilderKind::Fast`]
//!    when drifted) and takes its view (its bounds change too);
//! 4. assembles the scene from the trees, the instances and the new top
//!    level ([`Scene::from_parts`], which validates them; no copy).
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

use crate::blob::{write_triangle_tree, Blob};
use crate::builders::{self, BuildError, BuildParams, BuilderKind, BuiltTree, CostModel};
use crate::rng::Rng;
use kdray_kernel::format::wire::{
    blob_checksum, Header, CHECKSUM_OFFSET, ENDIAN_CHECK, HEADER_LEN, MAGIC, VERSION,
};
use kdray_kernel::{
    Bounds, Hit, Instance, Ray, Scene, Triangle, TriangleTree, WriteError, KIND_SCENE, MAX_DEPTH,
    MESH_ALIGN,
};

/// The top-level builder's parameters ([`TopParams::DEFAULT`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TopParams {
    /// The SAH's constants: a traversal step against tracing one instance.
    pub cost: CostModel,
    /// Equal-width bins on a cell's longest axis the SAH is evaluated at
    /// (2 to 64).
    pub bins: usize,
    /// Cells of at most this many instances become leaves.
    pub leaf_size: usize,
    /// Depth limit: `extra_depth + log2(n)`, at most `MAX_DEPTH`.
    pub extra_depth: u32,
    /// A kept top level ([`TopLevel::update`]) is rebuilt when its SAH
    /// cost, or its bounds' area, exceeds this factor times what it was
    /// when built.
    pub drift: f64,
}

impl TopParams {
    /// Tracing an instance (a mesh walk of some tens of steps) costs a few
    /// traversal steps; 16 bins; leaves of up to 2 instances.
    pub const DEFAULT: TopParams = TopParams {
        cost: CostModel {
            traversal: 1.0,
            intersection: 4.0,
            empty_factor: 0.8,
        },
        bins: 16,
        leaf_size: 2,
        extra_depth: 6,
        drift: 1.1,
    };
}

/// Each mesh's bounds as its tree's root cell (the default builder's).
///
/// # Errors
/// [`BuildError`] for a mesh the builder refuses.
pub fn mesh_bounds(meshes: &[Vec<Triangle>]) -> Result<Vec<Bounds>, BuildError> {
    meshes
        .iter()
        .map(|m| {
            builders::build(m, BuilderKind::default(), &BuildParams::default()).map(|t| t.bounds)
        })
        .collect()
}

/// The world box of each instance, from its mesh's bounds.
#[must_use]
pub fn world_boxes(mesh_bounds: &[Bounds], instances: &[Instance]) -> Vec<Bounds> {
    instances
        .iter()
        .map(|i| {
            mesh_bounds
                .get(i.mesh() as usize)
                .map_or(Bounds::EMPTY, |b| i.world_bounds(b))
        })
        .collect()
}

/// The top-level tree over instance world boxes with [`TopParams::DEFAULT`]
/// ([`build_top_level_with`]).
#[must_use]
pub fn build_top_level(boxes: &[Bounds]) -> BuiltTree {
    build_top_level_with(boxes, &TopParams::DEFAULT)
}

/// The top-level tree over instance world boxes: SAH at `p.bins` bin
/// boundaries on each cell's longest axis, each box listed in every leaf
/// whose cell it overlaps ([`builders::fast`], the builder of deforming
/// meshes). Boxes that are empty (an instance of a missing mesh) are left
/// out. One thread, no allocation per cell, laid out in the blob's
/// treelet order (docs/results.md, `## Scenes`, has its time for 10,000
/// instances).
#[must_use]
pub fn build_top_level_with(boxes: &[Bounds], p: &TopParams) -> BuiltTree {
    let bounds = boxes
        .iter()
        .filter(|b| b.min[0] <= b.max[0])
        .fold(Bounds::EMPTY, |a, b| a.union(b));
    let (bounds, n) = if bounds.min[0] <= bounds.max[0] {
        (
            bounds,
            boxes.iter().filter(|b| b.min[0] <= b.max[0]).count(),
        )
    } else {
        (Bounds::ZERO, 0)
    };
    let log2 = usize::BITS - n.leading_zeros();
    let fast = builders::fast::FastParams {
        cost: p.cost,
        bins: p.bins,
        leaf_size: p.leaf_size,
        depth: (p.extra_depth + log2).min(MAX_DEPTH),
        shrink_bins: false,
    };
    builders::fast::build(boxes, bounds, &fast)
}

/// A scene's top level kept from frame to frame: [`TopLevel::update`]
/// keeps the split planes it has and sends down them only the world
/// boxes that crossed a plane since the last frame ([`builders::refill`]),
/// and rebuilds only when that tree's SAH cost has drifted past
/// [`TopParams::drift`] times its cost as built.
#[derive(Clone, Debug)]
pub struct TopLevel {
    kept: builders::kept::Kept,
    params: TopParams,
}

impl TopLevel {
    /// The top level over `boxes`, built ([`build_top_level_with`]).
    #[must_use]
    pub fn new(boxes: &[Bounds], params: &TopParams) -> TopLevel {
        let tree = build_top_level_with(boxes, params);
        TopLevel {
            kept: builders::kept::Kept::new(tree, &params.cost, params.drift),
            params: *params,
        }
    }

    /// The tree over this frame's `boxes` (one per instance, as for
    /// [`build_top_level_with`]): the kept planes refilled, or a rebuild
    /// when their cost or the bounds' area drifted past
    /// [`TopParams::drift`] (or no box is left). Returns whether it rebuilt.
    pub fn update(&mut self, boxes: &[Bounds]) -> bool {
        if self.kept.refill(boxes) {
            return false;
        }
        *self = TopLevel::new(boxes, &self.params);
        true
    }

    /// The tree (nodes in the kernel's treelet layout; `prims` with room
    /// after each leaf's run, [`builders::refill::Refill::tree`]).
    #[must_use]
    pub fn tree(&self) -> &BuiltTree {
        self.kept.tree()
    }
}

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

/// `p` through a 3×4 row-major transform, in `f32`, rows summed left to
/// right (the kernel's [`Instance::local_ray`] arithmetic).
#[must_use]
pub fn transform_point(m: &[f32; 12], p: [f32; 3]) -> [f32; 3] {
    core::array::from_fn(|r| {
        ((m[r * 4] * p[0] + m[r * 4 + 1] * p[1]) + m[r * 4 + 2] * p[2]) + m[r * 4 + 3]
    })
}

/// The flattened scene: every instance's triangles through its transform,
/// in instance order, each mesh's triangles in mesh order. Triangle `p` of
/// instance `i` has index `flattened_offsets(..)[i] + p`.
#[must_use]
pub fn flatten_scene<M: AsRef<[Triangle]>>(meshes: &[M], instances: &[Instance]) -> Vec<Triangle> {
    let mut out = Vec::new();
    for inst in instances {
        let m = inst.to_world();
        if let Some(tris) = meshes.get(inst.mesh() as usize) {
            out.extend(tris.as_ref().iter().map(|t| Triangle {
                v: t.v.map(|p| transform_point(&m, p)),
            }));
        }
    }
    out
}

/// Where each instance's triangles start in the flattened order (the
/// prefix sums of their meshes' triangle counts).
#[must_use]
pub fn flattened_offsets(mesh_sizes: &[usize], instances: &[Instance]) -> Vec<u64> {
    let mut at = 0u64;
    instances
        .iter()
        .map(|i| {
            let start = at;
            at += mesh_sizes.get(i.mesh() as usize).copied().unwrap_or(0) as u64;
            start
        })
        .collect()
}

/// A rotation by `angle` about unit `axis`, scaled by `scale` per local
/// axis, then moved by `shift`: a 3×4 row-major transform.
#[must_use]
pub fn placement(axis: [f32; 3], angle: f32, scale: [f32; 3], shift: [f32; 3]) -> [f32; 12] {
    let r = glam::Mat3::from_axis_angle(glam::Vec3::from(axis).normalize_or(glam::Vec3::Y), angle)
        * glam::Mat3::from_diagonal(glam::Vec3::from(scale));
    let c = r.to_cols_array_2d();
    [
        c[0][0], c[1][0], c[2][0], shift[0], //
        c[0][1], c[1][1], c[2][1], shift[1], //
        c[0][2], c[1][2], c[2][2], shift[2],
    ]
}

/// A UV sphere of radius 1 about the origin: `rings` × `segments` quads.
#[must_use]
pub fn sphere(rings: usize, segments: usize) -> Vec<Triangle> {
    let p = |i: usize, j: usize| {
        let th = std::f32::consts::PI * i as f32 / rings as f32;
        let ph = std::f32::consts::TAU * j as f32 / segments as f32;
        [th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin()]
    };
    grid(rings, segments, p)
}

/// A torus of radii 1 and 0.3 about the y axis.
#[must_use]
pub fn torus(rings: usize, segments: usize) -> Vec<Triangle> {
    let p = |i: usize, j: usize| {
        let a = std::f32::consts::TAU * i as f32 / rings as f32;
        let b = std::f32::consts::TAU * j as f32 / segments as f32;
        let r = 1.0 + 0.3 * b.cos();
        [r * a.cos(), 0.3 * b.sin(), r * a.sin()]
    };
    grid(rings, segments, p)
}

fn grid(n: usize, m: usize, p: impl Fn(usize, usize) -> [f32; 3]) -> Vec<Triangle> {
    let mut out = Vec::with_capacity(2 * n * m);
    for i in 0..n {
        for j in 0..m {
            let (a, b, c, d) = (p(i, j), p(i + 1, j), p(i + 1, j + 1), p(i, j + 1));
            out.push(Triangle { v: [a, b, c] });
            out.push(Triangle { v: [a, c, d] });
        }
    }
    out
}

/// A generated level: `copies` transformed copies of a sphere and of a
/// torus (random rotations, scales from 0.3 to 2 per axis, every fifth
/// mirrored) over a `size` × `size` square, plus a floor (mesh 2, one
/// instance). Returns the meshes and the instances.
#[must_use]
pub fn generated_level(copies: usize, size: f32, seed: u64) -> (Vec<Vec<Triangle>>, Vec<Instance>) {
    let floor = vec![
        Triangle {
            v: [[-1.0, 0.0, -1.0], [1.0, 0.0, -1.0], [1.0, 0.0, 1.0]],
        },
        Triangle {
            v: [[-1.0, 0.0, -1.0], [1.0, 0.0, 1.0], [-1.0, 0.0, 1.0]],
        },
    ];
    let meshes = vec![sphere(24, 48), torus(48, 24), floor];
    let mut rng = Rng::new(seed);
    let mut instances = Vec::with_capacity(2 * copies + 1);
    for k in 0..2 * copies {
        let mut scale = [
            rng.range(0.3, 2.0),
            rng.range(0.3, 2.0),
            rng.range(0.3, 2.0),
        ];
        if k % 5 == 4 {
            scale[0] = -scale[0];
        }
        let shift = [
            rng.range(-size, size) * 0.5,
            rng.range(0.0, 2.0),
            rng.range(-size, size) * 0.5,
        ];
        let m = placement(
            rng.unit_vector(),
            rng.range(0.0, std::f32::consts::TAU),
            scale,
            shift,
        );
        if let Some(inst) = Instance::new((k % 2) as u32, m, k as u32, 1 << (k % 4)) {
            instances.push(inst);
        }
    }
    let half = size * 0.5 + 2.0;
    let floor_m = placement([0.0, 1.0, 0.0], 0.0, [half, 1.0, half], [0.0, 0.0, 0.0]);
    instances.extend(Instance::new(2, floor_m, u32::MAX, u32::MAX));
    (meshes, instances)
}

/// `instances` after `frames` frames of motion: each but the last (the
/// generated level's floor) moved by `speed` per frame along its own
/// horizontal direction (from `seed` and its index), nothing else changed.
#[must_use]
pub fn moved_level(instances: &[Instance], frames: u32, speed: f32, seed: u64) -> Vec<Instance> {
    let mut rng = Rng::new(seed);
    let last = instances.len().saturating_sub(1);
    instances
        .iter()
        .enumerate()
        .map(|(k, inst)| {
            let angle = rng.range(0.0, std::f32::consts::TAU);
            if k == last {
                return *inst;
            }
            let step = speed * frames as f32;
            let mut m = inst.to_world();
            m[3] += step * angle.cos();
            m[11] += step * angle.sin();
            Instance::new(inst.mesh(), m, inst.id(), inst.mask()).unwrap_or(*inst)
        })
        .collect()
}

/// Is `bytes` a scene blob (by its header's kind; nothing else checked)?
#[must_use]
pub fn is_scene_blob(bytes: &[u8]) -> bool {
    bytes.get(16..20) == Some(&KIND_SCENE.to_le_bytes()[..])
}

/// Where each instance's triangles start in the flattened order of `scene`.
#[must_use]
pub fn scene_offsets(scene: &Scene<'_>) -> Vec<u64> {
    let sizes: Vec<usize> = (0..scene.mesh_count())
        .map(|m| scene.mesh(m).map_or(0, |t| t.triangles().len()))
        .collect();
    flattened_offsets(&sizes, scene.instances())
}

/// Traces `rays` through `scene` (every instance: mask all ones) on the
/// current rayon pool into `hits`, as hit-file records: `prim` is the
/// triangle's index in the flattened order ([`flatten_scene`]; for a glTF
/// scene, the order `kdray build` without `--instances` uses); `any`
/// writes occlusion records.
pub fn trace_scene(scene: &Scene<'_>, offsets: &[u64], rays: &[Ray], hits: &mut [Hit], any: bool) {
    use rayon::prelude::*;
    hits.par_chunks_mut(1024)
        .zip(rays.par_chunks(1024))
        .for_each(|(hs, rs)| {
            for (h, r) in hs.iter_mut().zip(rs) {
                *h = if any {
                    Hit::occlusion(scene.any_hit(r, u32::MAX))
                } else {
                    flattened_hit(&scene.closest_hit(r, u32::MAX), offsets)
                };
            }
        });
}

/// A scene's hit as a hit-file record, `prim` in the flattened order
/// (`offsets`: [`scene_offsets`]); a miss record for a miss.
fn flattened_hit(s: &kdray_kernel::SceneHit, offsets: &[u64]) -> Hit {
    match offsets.get(s.instance as usize) {
        Some(&at) if s.is_hit() => Hit {
            prim: u32::try_from(at + u64::from(s.prim)).unwrap_or(kdray_kernel::MISS),
            ..s.hit()
        },
        _ => Hit::MISS,
    }
}

/// The first `k` hits of each ray through `scene` (every instance) on the
/// current rayon pool into `hits`, `k` slots a ray, as hit-file records
/// numbered in the flattened order ([`trace_scene`]); unused slots miss
/// records. The scene's order (`t`, then instance, then triangle) is the
/// flattened order's (`t`, then flattened index): instances are flattened
/// in turn. Returns how many hits in all.
pub fn first_hits_scene(
    scene: &Scene<'_>,
    offsets: &[u64],
    rays: &[Ray],
    hits: &mut [Hit],
    k: usize,
) -> usize {
    use kdray_kernel::SceneHit;
    use rayon::prelude::*;
    let k = k.max(1);
    hits.par_chunks_mut(1024 * k)
        .zip(rays.par_chunks(1024))
        .map(|(hs, rs)| {
            let mut found = vec![SceneHit::MISS; k];
            let mut total = 0;
            for (slots, r) in hs.chunks_mut(k).zip(rs) {
                let n = scene.first_hits(r, u32::MAX, &mut found);
                total += n;
                slots.fill(Hit::MISS);
                for (slot, s) in slots.iter_mut().zip(found.iter().take(n)) {
                    *slot = flattened_hit(s, offsets);
                }
            }
            total
        })
        .sum()
}

/// A scene as the renderer's [`Tracer`](crate::render::Tracer): hits
/// numbered in the flattened order, shaded on the flattened triangles.
#[derive(Debug)]
pub struct SceneTracer<'s, 'a> {
    scene: &'s Scene<'a>,
    offsets: Vec<u64>,
    flat: Vec<Triangle>,
}

impl<'s, 'a> SceneTracer<'s, 'a> {
    /// The tracer of `scene` (its flattened triangles are made here).
    #[must_use]
    pub fn new(scene: &'s Scene<'a>) -> SceneTracer<'s, 'a> {
        let meshes: Vec<&[Triangle]> = (0..scene.mesh_count())
            .map(|m| scene.mesh(m).map_or(&[][..], |t| t.triangles()))
            .collect();
        SceneTracer {
            scene,
            offsets: scene_offsets(scene),
            flat: flatten_scene(&meshes, scene.instances()),
        }
    }
}

impl crate::render::Tracer for SceneTracer<'_, '_> {
    fn triangles(&self) -> &[Triangle] {
        &self.flat
    }
    fn packet_width(&self) -> kdray_kernel::PacketWidth {
        kdray_kernel::PacketWidth::One
    }
    fn closest(&self, rays: &[Ray], hits: &mut [Hit]) {
        for (h, r) in hits.iter_mut().zip(rays) {
            *h = flat_hit(&self.offsets, self.scene.closest_hit(r, u32::MAX));
        }
    }
    fn occluded(&self, rays: &[Ray], out: &mut [bool]) {
        for (o, r) in out.iter_mut().zip(rays) {
            *o = self.scene.any_hit(r, u32::MAX);
        }
    }
}

/// A scene hit as a hit-file record: `prim` in the flattened order.
fn flat_hit(offsets: &[u64], s: kdray_kernel::SceneHit) -> Hit {
    match offsets.get(s.instance as usize) {
        Some(&at) if s.is_hit() => Hit {
            prim: u32::try_from(at + u64::from(s.prim)).unwrap_or(kdray_kernel::MISS),
            ..s.hit()
        },
        _ => Hit::MISS,
    }
}
