//! A tree kept from frame to frame over moving boxes: its split planes
//! stay and its leaves are refilled ([`super::refill`]) while its SAH cost
//! and its bounds' area stay within a drift factor of what they were when
//! built; past it, its owner rebuilds. The rule the scene's top level
//! ([`crate::instances::TopLevel`]) and deforming meshes
//! ([`crate::deforming::DeformingMesh`]) share.

use super::refill::Refill;
use super::{BuiltTree, CostModel};
use kdray_kernel::Bounds;

/// A built tree, its planes kept (module docs).
#[derive(Clone, Debug)]
pub struct Kept {
    refill: Refill,
    drift: f64,
    /// The SAH cost and the root cell's area when built.
    built: (f64, f64),
}

impl Kept {
    /// Keeps `tree`, its SAH weights from its cells under `cost`; a refill
    /// whose cost or bounds' area passes `drift` times the built tree's
    /// asks for a rebuild.
    #[must_use]
    pub fn new(tree: BuiltTree, cost: &CostModel, drift: f64) -> Kept {
        let area = tree.bounds.area();
        let refill = Refill::new(tree, cost);
        let built = (refill.cost(), area);
        Kept {
            refill,
            drift,
            built,
        }
    }

    /// Lists `boxes` in the kept planes' leaves ([`Refill::refill`]).
    /// `true` when the tree is fit to keep; `false` when its cost or area
    /// drifted past the factor, or no box is left: the caller rebuilds
    /// (the tree still lists every box, unless none was left).
    pub fn refill(&mut self, boxes: &[Bounds]) -> bool {
        let (cost, area) = self.built;
        match self.refill.refill(boxes) {
            Some(c) => c <= self.drift * cost && self.tree().bounds.area() <= self.drift * area,
            None => false,
        }
    }

    /// The drift factor past which a refill asks for a rebuild.
    #[must_use]
    pub fn drift(&self) -> f64 {
        self.drift
    }

    /// The tree as last refilled (or as built); its `prims` hold each
    /// leaf's run with room after it ([`Refill::tree`]).
    #[must_use]
    pub fn tree(&self) -> &BuiltTree {
        self.refill.tree()
    }
}
