//! The top level: a tree over the instances' world boxes, built whole or
//! kept and updated.

use crate::builders::{self, BuildError, BuildParams, BuilderKind, BuiltTree, CostModel};
use kdray_kernel::{Bounds, Instance, Triangle, MAX_DEPTH};

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
