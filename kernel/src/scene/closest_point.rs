//! The closest point of a scene: over every instance the mask selects,
//! the query taken into the instance's space ([`Instance::local_point`])
//! and answered by its mesh tree ([`TriangleTree::closest_point`]).
//!
//! Distances are measured in world space. For a transform that is a
//! rotation (or reflection) times a uniform scale `s` (a similarity,
//! [`Instance::similarity_scale2`]) the nearest point in the mesh's space
//! is the nearest in the world, at `s` times the distance: the instance's
//! world squared distance is `s^2` times the mesh tree's. Under a
//! non-uniform scale or a shear it is not (a nearer point in the mesh's
//! metric can be a farther one in the world's), so a selected instance
//! with such a transform makes the query refuse ([`NotSimilar`]) instead
//! of answering wrongly.
//!
//! The winner is the smallest world squared distance, then the lower
//! instance, then (within an instance) the lower triangle: bit for bit
//! [`Scene::closest_point_brute`]. An instance whose world box
//! ([`Instance::world_bounds`]) lies well beyond the best so far is
//! skipped: by twice the best squared distance plus `2^-28` of the squared
//! coordinate magnitudes, far above the rounding of the query's transform
//! and the `2^-16` a similarity may be off.

use super::{Instance, Scene};
use crate::geometry::Bounds;
use crate::triangle::{box_distance2, ClosestPoint};
use crate::triangle_tree::TriangleTree;
use core::fmt;

/// A scene's closest point to a query.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SceneClosestPoint {
    /// The closest point in world space (the mesh's point through the
    /// instance's transform in `f64`, rounded once).
    pub point: [f32; 3],
    /// The instance's index in the scene.
    pub instance: u32,
    /// The triangle's index in its mesh.
    pub prim: u32,
    /// Barycentric weight of the triangle's vertex 1.
    pub u: f32,
    /// Barycentric weight of the triangle's vertex 2.
    pub v: f32,
    /// The world squared distance: the instance's `s^2` times the mesh
    /// tree's `distance2`.
    pub distance2: f64,
}

impl SceneClosestPoint {
    /// The fields' bits, for bitwise comparisons in tests.
    #[must_use]
    pub fn bits(&self) -> [u64; 8] {
        let [x, y, z] = self.point.map(|c| u64::from(c.to_bits()));
        [
            x,
            y,
            z,
            u64::from(self.instance),
            u64::from(self.prim),
            u64::from(self.u.to_bits()),
            u64::from(self.v.to_bits()),
            self.distance2.to_bits(),
        ]
    }
}

/// A selected instance whose transform is not a similarity (a non-uniform
/// scale or a shear): the scene's closest point is refused (module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct NotSimilar {
    /// The instance's index in the scene.
    pub instance: u32,
}

impl fmt::Display for NotSimilar {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "instance {} is scaled unevenly or sheared: the closest point in its mesh's space is not the closest in the world",
            self.instance
        )
    }
}

/// The running best over instances: smallest world squared distance, then
/// lower instance. Shared by the walk and the brute force.
pub(super) struct NearestInstance {
    pub(super) best: Option<SceneClosestPoint>,
}

impl NearestInstance {
    /// Keeps instance `i`'s answer `c` (in its space, scale `s2`) if it
    /// wins.
    pub(super) fn keep(&mut self, i: u32, inst: &Instance, s2: f64, c: ClosestPoint) {
        let d2 = s2 * c.distance2;
        if self
            .best
            .is_none_or(|b| d2 < b.distance2 || (d2 == b.distance2 && i < b.instance))
        {
            self.best = Some(SceneClosestPoint {
                point: inst.world_point(c.point),
                instance: i,
                prim: c.prim,
                u: c.u,
                v: c.v,
                distance2: d2,
            });
        }
    }
}

/// The largest squared coordinate magnitude of `p` and `b`, in `f64`.
fn magnitude2(p: &[f32; 3], b: &Bounds) -> f64 {
    let m = p
        .iter()
        .chain(&b.min)
        .chain(&b.max)
        .fold(0.0f64, |m, c| m.max(f64::from(c.abs())));
    m * m
}

impl<'a> Scene<'a> {
    /// Every instance `mask` selects, with its mesh and squared scale, in
    /// index order; the first one that is not a similarity refuses.
    pub(super) fn similar_instances(
        &self,
        mask: u32,
        mut each: impl FnMut(u32, &Instance, TriangleTree<'a>, f64),
    ) -> Result<(), NotSimilar> {
        for i in 0..self.instances.len() as u32 {
            if let Some((inst, _)) = self.selected(i, mask) {
                if inst.similarity_scale2().is_none() {
                    return Err(NotSimilar { instance: i });
                }
            }
        }
        for i in 0..self.instances.len() as u32 {
            if let Some((inst, mesh)) = self.selected(i, mask) {
                if let Some(s2) = inst.similarity_scale2() {
                    each(i, inst, mesh, s2);
                }
            }
        }
        Ok(())
    }

    /// The closest point to `q` (world space) over the instances `mask`
    /// selects (`instance mask & mask != 0`), measured in world space
    /// (module docs): bit for bit [`Scene::closest_point_brute`].
    /// `Ok(None)` when no instance is selected or `q` has a NaN or
    /// infinite coordinate.
    ///
    /// # Errors
    /// [`NotSimilar`] when a selected instance is scaled unevenly or
    /// sheared.
    ///
    /// # Panics
    /// Never. No allocation.
    pub fn closest_point(
        &self,
        q: [f32; 3],
        mask: u32,
    ) -> Result<Option<SceneClosestPoint>, NotSimilar> {
        let mut near = NearestInstance { best: None };
        if !q.iter().all(|c| c.is_finite()) {
            return Ok(None);
        }
        self.similar_instances(mask, |i, inst, mesh, s2| {
            let local = mesh.bounds();
            if let Some(best) = near.best {
                let slack = (magnitude2(&q, &self.bounds)
                    + s2 * magnitude2(&inst.local_point(q), &local))
                    / 268_435_456.0;
                if box_distance2(&inst.world_bounds(&local), &q.map(f64::from))
                    > 2.0 * best.distance2 + slack
                {
                    return;
                }
            }
            if let Some(c) = mesh.closest_point(inst.local_point(q)) {
                near.keep(i, inst, s2, c);
            }
        })?;
        Ok(near.best)
    }
}
