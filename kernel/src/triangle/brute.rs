//! The brute-force oracles: every triangle tested, by the same test and the
//! same tie rule as the tree. What every traversal is held to.

use super::{Closest, FirstHits, Ranked, ShearedRay, Triangle};
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

/// The brute-force crossings: how many of `triangles` the ray from `q`
/// along `dir` crosses at `t >= 0` by the crossing test (a shared edge or
/// vertex of a closed mesh once). The oracle
/// [`TriangleTree::crossings`](crate::TriangleTree::crossings) is held to.
#[must_use]
pub fn crossings_brute(triangles: &[Triangle], q: [f32; 3], dir: [f32; 3]) -> u32 {
    let ray = Ray {
        origin: q,
        tmin: 0.0,
        dir,
        tmax: f32::INFINITY,
    };
    ShearedRay::new(&ray).map_or(0, |sr| {
        triangles
            .iter()
            .filter(|tri| sr.crossing(tri, 0.0, f32::INFINITY).is_some())
            .count() as u32
    })
}

/// The brute-force signed crossings: the sum over `triangles` of `+1` for
/// each the ray from `q` along `dir` crosses at `t >= 0` (by the crossing
/// test) whose normal `(v1 - v0) x (v2 - v0)` points along the ray, `-1`
/// for each whose normal points against it. The oracle
/// [`TriangleTree::winding_crossings`](crate::TriangleTree::winding_crossings)
/// is held to, and the count over a few extra triangles (the caps that
/// close an open mesh's holes) to add to the tree's.
#[must_use]
pub fn winding_crossings_brute(triangles: &[Triangle], q: [f32; 3], dir: [f32; 3]) -> i32 {
    let ray = Ray {
        origin: q,
        tmin: 0.0,
        dir,
        tmax: f32::INFINITY,
    };
    ShearedRay::new(&ray).map_or(0, |sr| {
        triangles
            .iter()
            .fold(0i32, |s, tri| s.wrapping_add(sr.crossing_sign(tri)))
    })
}

/// The brute-force first hits: the first `out.len()` hits of `ray` in
/// `[tmin, tmax]` over all of `triangles`, sorted by `t` and at equal `t`
/// by the lower triangle index, written to the front of `out`; returns
/// how many. The oracle [`TriangleTree::first_hits`](crate::TriangleTree::first_hits) is held to.
#[must_use]
pub fn first_hits_brute(triangles: &[Triangle], ray: &Ray, out: &mut [Hit]) -> usize {
    let mut first = FirstHits::new(out);
    offer_every_triangle(&mut first, triangles, ray, 0);
    first.len()
}

/// Offers every triangle of the mesh tagged `tag` (a scene's instance;
/// `ray` in the mesh's space) to `first`: the brute-force first hits of a
/// mesh and of a scene.
pub(crate) fn offer_every_triangle<R: Ranked>(
    first: &mut FirstHits<'_, R>,
    triangles: &[Triangle],
    ray: &Ray,
    tag: u32,
) {
    if let Some(sr) = ShearedRay::new(ray) {
        for (i, tri) in triangles.iter().enumerate() {
            first.offer(&sr, tri, (i as u32, tag), ray.tmin, ray.tmax);
        }
    }
}
