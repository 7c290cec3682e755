//! Deforming meshes: a triangle tree kept from frame to frame while its
//! triangles move (a skinned character, cloth, a wave), the k-d tree's
//! counterpart of refitting a BVH.
//!
//! A k-d tree cannot be refitted: its cells are fixed by the split planes,
//! and a triangle that moved may now overlap other cells. So the planes
//! of the last build stay and the triangles are listed again: each frame
//! sends down them only the triangles whose box crossed a plane since the
//! last frame ([`crate::builders::refill`]), each listed by its
//! [`Triangle::hit_bounds`] in every leaf whose closed cell it overlaps,
//! the rule of [`BuilderKind::Fast`], so the tree finds every hit brute
//! force does, whatever the planes. When the tree's SAH cost has drifted
//! past a factor of its cost as built, the frame rebuilds with `fast`
//! ([`crate::builders::kept`]).
//!
//! ```
//! use kdray_kernel::{glam::Vec3, Ray, Triangle};
//! use kdray_tools::builders::BuildParams;
//! use kdray_tools::deforming::DeformingMesh;
//! use kdray_tools::instances::sphere;
//!
//! let rest = sphere(16, 32);
//! let mut mesh = DeformingMesh::new(&rest, &BuildParams::default(), DeformingMesh::DRIFT)?;
//! let mut tris = rest.clone();
//! for frame in 1..4 {
//!     // Each frame, the engine's new vertex positions (here a squash).
//!     let s = 1.0 - 0.02 * frame as f32;
//!     for (t, r) in tris.iter_mut().zip(&rest) {
//!         *t = Triangle { v: r.v.map(|v| [v[0], v[1] * s, v[2]]) };
//!     }
//!     let _rebuilt = mesh.update(&tris)?;
//!     let tree = mesh.view(&tris)?; // validated, no copy
//!     let hit = tree.closest_hit(&Ray::new(Vec3::new(0.0, 0.0, -5.0), Vec3::Z));
//!     assert!(hit.is_hit());
//! }
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use crate::builders::kept::Kept;
use crate::builders::{self, BuildError, BuildParams, BuilderKind, BuiltTree, CostModel};
use kdray_kernel::{BlobError, Bounds, Triangle, TriangleTree};

/// A deforming mesh's tree, kept from frame to frame (module docs).
#[derive(Clone, Debug)]
pub struct DeformingMesh {
    kept: Kept,
    params: BuildParams,
    /// How many triangles the tree was built or last refilled over.
    count: usize,
    /// This frame's boxes (scratch kept for the next frame).
    boxes: Vec<Bounds>,
}

impl DeformingMesh {
    /// The default drift factor: a frame rebuilds once the refilled tree's
    /// SAH cost is 10% above the built tree's (as the scene's top level).
    pub const DRIFT: f64 = 1.1;

    /// The tree over `triangles`, built with [`BuilderKind::Fast`] under
    /// `params`; later frames rebuild when its SAH cost has drifted past
    /// `drift` times its cost as built.
    ///
    /// # Errors
    /// The builder's [`BuildError`] (a non-finite or out-of-range triangle,
    /// too many triangles).
    pub fn new(
        triangles: &[Triangle],
        params: &BuildParams,
        drift: f64,
    ) -> Result<DeformingMesh, BuildError> {
        let tree = builders::build(triangles, BuilderKind::Fast, params)?;
        Ok(DeformingMesh {
            kept: Kept::new(tree, &CostModel::from_params(params), drift),
            params: params.clone(),
            count: triangles.len(),
            boxes: Vec::new(),
        })
    }

    /// The tree over this frame's `triangles` (the same mesh, moved): the
    /// kept planes refilled, or a rebuild when their cost drifted (or the
    /// triangle count changed). Returns whether it rebuilt.
    ///
    /// # Errors
    /// [`BuildError`] for a non-finite or out-of-range triangle; the tree
    /// is then as it was.
    pub fn update(&mut self, triangles: &[Triangle]) -> Result<bool, BuildError> {
        builders::check_triangles(triangles)?;
        if triangles.len() == self.count {
            self.boxes.clear();
            self.boxes
                .extend(triangles.iter().map(Triangle::hit_bounds));
            if self.kept.refill(&self.boxes) {
                return Ok(false);
            }
        }
        let boxes = std::mem::take(&mut self.boxes);
        let params = self.params.clone();
        *self = DeformingMesh::new(triangles, &params, self.kept.drift())?;
        self.boxes = boxes;
        Ok(true)
    }

    /// The tree: nodes in the kernel's layout, `prims` with room after
    /// each leaf's run ([`crate::builders::refill::Refill::tree`]).
    #[must_use]
    pub fn tree(&self) -> &BuiltTree {
        self.kept.tree()
    }

    /// The kernel's view of the tree over `triangles` (this frame's, as
    /// given to [`DeformingMesh::update`]), validated, without a copy.
    ///
    /// # Errors
    /// [`BlobError`] when `triangles` are not the ones the tree was last
    /// filled with: another count ([`BlobError::SectionMismatch`]), a
    /// triangle outside its bounds.
    pub fn view<'a>(&'a self, triangles: &'a [Triangle]) -> Result<TriangleTree<'a>, BlobError> {
        if triangles.len() != self.count {
            return Err(BlobError::SectionMismatch {
                what: "triangles",
                expected: u32::try_from(self.count).unwrap_or(u32::MAX),
                found: u32::try_from(triangles.len()).unwrap_or(u32::MAX),
            });
        }
        let t = self.tree();
        TriangleTree::from_parts(&t.nodes, &t.prims, triangles, t.bounds)
    }
}
