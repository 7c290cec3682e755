//! The scene's oracles: every instance the mask selects, each tested by
//! brute force over its mesh's triangles with the ray in its space by the
//! same arithmetic ([`Instance::local_ray`](super::Instance::local_ray)).

use super::closest_point::{NearestInstance, NotSimilar, SceneClosestPoint};
use super::{Scene, SceneHit};
use crate::geometry::{ray_is_valid, Ray};
use crate::triangle::{any_hit_brute, closest_hit_brute, offer_every_triangle, FirstHits};

impl Scene<'_> {
    /// The brute-force closest hit: every selected instance, every
    /// triangle; smallest `t`, then lower instance, then lower triangle.
    /// What [`Scene::closest_hit`] is held to.
    #[must_use]
    pub fn closest_hit_brute(&self, ray: &Ray, mask: u32) -> SceneHit {
        let mut best = SceneHit::MISS;
        if !ray_is_valid(ray) {
            return best;
        }
        for i in 0..self.instances.len() as u32 {
            if let Some((inst, mesh)) = self.selected(i, mask) {
                best.keep(closest_hit_brute(mesh.triangles(), &inst.local_ray(ray)), i);
            }
        }
        best
    }

    /// The brute-force any hit: does any triangle of any selected instance
    /// hit `ray` in `[tmin, tmax]`?
    #[must_use]
    pub fn any_hit_brute(&self, ray: &Ray, mask: u32) -> bool {
        ray_is_valid(ray)
            && (0..self.instances.len() as u32).any(|i| {
                self.selected(i, mask).is_some_and(|(inst, mesh)| {
                    any_hit_brute(mesh.triangles(), &inst.local_ray(ray))
                })
            })
    }

    /// The brute-force first hits: every selected instance, every
    /// triangle; the first `out.len()` by `t`, then instance, then
    /// triangle, written to the front of `out`; returns how many. What
    /// [`Scene::first_hits`] is held to.
    #[must_use]
    pub fn first_hits_brute(&self, ray: &Ray, mask: u32, out: &mut [SceneHit]) -> usize {
        let mut first = FirstHits::new(out);
        if ray_is_valid(ray) {
            for i in 0..self.instances.len() as u32 {
                if let Some((inst, mesh)) = self.selected(i, mask) {
                    offer_every_triangle(&mut first, mesh.triangles(), &inst.local_ray(ray), i);
                }
            }
        }
        first.len()
    }

    /// The brute-force closest point: every selected instance, every
    /// triangle ([`closest_point_brute`](crate::closest_point_brute) with
    /// the query in the instance's space), by the rule of
    /// [`Scene::closest_point`]. What it is held to.
    ///
    /// # Errors
    /// [`NotSimilar`] as [`Scene::closest_point`].
    pub fn closest_point_brute(
        &self,
        q: [f32; 3],
        mask: u32,
    ) -> Result<Option<SceneClosestPoint>, NotSimilar> {
        let mut near = NearestInstance { best: None };
        if !q.iter().all(|c| c.is_finite()) {
            return Ok(None);
        }
        self.check_similar(mask)?;
        for i in 0..self.instances.len() as u32 {
            let Some((inst, mesh)) = self.selected(i, mask) else {
                continue;
            };
            if let Some(s2) = inst.similarity_scale2() {
                let local = inst.local_point(q);
                if let Some(c) = crate::closest_point_brute(mesh.triangles(), local, f32::INFINITY)
                {
                    near.keep(i, inst, s2, c);
                }
            }
        }
        Ok(near.best)
    }
}
