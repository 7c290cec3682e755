//! The brute-force oracles: every triangle tested, by the same test and the
//! same tie rule as the tree. What every traversal is held to.

use super::{Closest, ShearedRay, Triangle};
use crate::geometry::{Hit, Ray};

/// The brute-force answer: the closest hit of `ray` over all of
/// `triangles`, by the same test and the same order as the tree.
/// The oracle every traversal is held to.
#[must_use]
pub fn closest_hit_brute(triangles: &[Triangle], ray: &Ray) -> Hit {
    let Some(sr) = ShearedRay::new(ray) else {
        return Hit::MISS;
    };
    let mut best = Closest::new(ray.tmax);
    for (i, tri) in triangles.iter().enumerate() {
        best.offer(&sr, tri, i as u32, ray.tmin);
    }
    best.hit(&sr, triangles)
}

/// The brute-force any-hit answer: does any triangle hit `ray` in
/// `[tmin, tmax]`?
#[must_use]
pub fn any_hit_brute(triangles: &[Triangle], ray: &Ray) -> bool {
    ShearedRay::new(ray).is_some_and(|sr| {
        triangles
            .iter()
            .any(|tri| sr.intersects(tri, ray.tmin, ray.tmax))
    })
}
