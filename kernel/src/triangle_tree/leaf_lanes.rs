//! A leaf's triangles tested in lanes against one ray: the single-ray
//! walk's leaf test for leaves of [`LANE_LEAF_MIN`] triangles or more.
//!
//! The leaves a ray reaches are the larger ones (a leaf is entered in
//! proportion to its surface area): on the bunny's camera rays a visited
//! non-empty leaf holds ~7 triangles. Eight at a time in `f32x8` lanes, a
//! leaf costs one pass of the watertight test's arithmetic and one branch,
//! where the scalar test paid a data-dependent branch per triangle
//! (~5% faster on camera rays, ~1.5% on random rays).
//!
//! At the AVX levels each triangle's first 8 floats are loaded as one row
//! and the rows transposed in registers ([`Lanes::nine_rows`]), where 72
//! scalar stores read back as vectors stalled every vector load: camera
//! rays 1.03-1.04x on the bunny, sponza and teapot, random and shadow
//! rays unchanged (they wait on the triangles' cache misses instead).
//!
//! Tried: four lanes (`f32x4`): 4-7% slower than the scalar test, since
//! gathering a ~7-triangle leaf's 63 coordinates in two passes costs more
//! than the scalar test's early exits save.
//!
//! Each lane performs the scalar test's operations in the scalar test's
//! order ([`watertight`]), so each triangle's `t`, edge functions and
//! determinant are the bits [`ShearedRay::intersect`] computes, and the
//! winner is picked by the one closest-hit rule (smallest `t`, then lowest
//! triangle index): the answer stays brute force's, bit for bit.

use crate::geometry::MISS;
use crate::lanes::{dispatch, Job, Lanes, Level};
use crate::triangle::lanes::{watertight, LaneHits};
use crate::triangle::{plane_t_at, Closest, ShearedRay, Triangle, TriangleHit};

/// Leaves with at least this many triangles are tested in lanes; smaller
/// ones one triangle at a time (measured on bunny camera rays: 2 and 3
/// alike, 5 slower).
pub(crate) const LANE_LEAF_MIN: usize = 3;

/// A ray prepared for testing triangles in lanes: the scalar
/// [`ShearedRay`]'s permutation, and its origin (permuted) and shear,
/// splatted.
pub(crate) struct LeafRay<'r, V, const N: usize> {
    /// The ray, for the `f64` `t`.
    sr: &'r ShearedRay,
    /// [`ShearedRay`]'s permutation, clamped to 2 so that the compiler
    /// sees every index in range (it is never above 2).
    k: [usize; 3],
    org: [V; 3],
    shear: [V; 3],
}

impl<'r, V: Lanes<N>, const N: usize> LeafRay<'r, V, N> {
    /// Splats `sr`'s constants.
    #[inline(always)]
    pub(crate) fn new(sr: &'r ShearedRay) -> Self {
        let k = sr.k.map(|k| k.min(2));
        LeafRay {
            sr,
            k,
            org: [
                V::splat(sr.org[k[0]]),
                V::splat(sr.org[k[1]]),
                V::splat(sr.org[k[2]]),
            ],
            shear: [V::splat(sr.s[0]), V::splat(sr.s[1]), V::splat(sr.s[2])],
        }
    }

    /// The lanes of `tris[prims]` (at most `N`) that `sr` hits within
    /// `[tmin, tmax]` (`ANY`: as [`watertight`]'s), leaving out triangle
    /// `skip` (the best hit so far: tested again, in another leaf, it
    /// gives the same answer, which cannot win).
    #[inline(always)]
    fn hits<const ANY: bool>(
        &self,
        tris: &[Triangle],
        prims: &[u32],
        skip: u32,
        tmin: f32,
        tmax: f32,
    ) -> Option<LaneHits<V>> {
        // Coordinate c of vertex j of each triangle in row 3j + c,
        // permuted by choosing the rows (`k`).
        let (rows, live) = V::nine_rows(bytemuck::cast_slice(tris), prims, skip);
        // Each vertex relative to the origin, sheared so the ray is +z: the
        // scalar test's `rel`, lane by lane.
        let [x0, y0, z0, x1, y1, z1, x2, y2, z2] = rows;
        let (a, b, c) = (
            self.rel([x0, y0, z0]),
            self.rel([x1, y1, z1]),
            self.rel([x2, y2, z2]),
        );
        let sr = self.sr;
        let (tmin, tmax) = (V::splat(tmin), V::splat(tmax));
        let mut win = watertight::<V, N, ANY>(a, b, c, self.shear[2], live, tmin, tmax)?;
        // Usually one lane (the window settles the others): one at a time.
        let mut exact = win.exact;
        while exact != 0 {
            let l = exact.trailing_zeros() as usize;
            exact &= exact - 1;
            let tri = prims.get(l).and_then(|&p| tris.get(p as usize));
            if let Some(x) = win.t.get_mut(l) {
                // A `match`, not `map_or`'s closure, which could stay out
                // of line without the level's features.
                *x = match tri {
                    Some(tri) => plane_t_at::<V, N>(&sr.org, &sr.dir, tri),
                    None => f32::NAN,
                };
            }
        }
        win.hits(tmin, tmax)
    }

    /// A vertex row relative to the origin, sheared so the ray is +z: the
    /// scalar test's `rel`, lane by lane. (A method, not a closure: see
    /// [`crate::lanes::dispatch`].)
    #[inline(always)]
    fn rel(&self, v: [V; 3]) -> (V, V, V) {
        let [kx, ky, kz] = self.k;
        let x = v[kx] - self.org[0];
        let y = v[ky] - self.org[1];
        let z = v[kz] - self.org[2];
        (x - self.shear[0] * z, y - self.shear[1] * z, z)
    }

    /// Tests the triangles `prims` over `[tmin, best.t]`, `N` at a time,
    /// into `best`, the `f64` `t` of sure lanes deferred ([`Closest`]).
    #[inline(always)]
    pub(crate) fn closest(&self, tris: &[Triangle], prims: &[u32], tmin: f32, best: &mut Closest) {
        for chunk in prims.chunks(N) {
            let Some(h) = self.hits::<true>(tris, chunk, best.prim, tmin, best.t) else {
                continue;
            };
            // Each hit lane offered in turn (usually one): each was hit
            // within [tmin, t] for a `t` at least best.t's, as
            // `Closest::keep` and `keep_within` require.
            let mut hit = h.hit;
            while hit != 0 {
                let l = hit.trailing_zeros() as usize;
                hit &= hit - 1;
                let p = chunk.get(l).copied().unwrap_or(MISS);
                let lane_hit = TriangleHit {
                    t: h.t.lane(l),
                    v: h.v.lane(l),
                    w: h.w.lane(l),
                    det: h.det.lane(l),
                };
                if h.sure >> l & 1 == 1 {
                    let window = (h.window.0.lane(l), h.window.1.lane(l));
                    best.keep_within(lane_hit, window, p, self.sr, tris);
                } else {
                    best.keep(lane_hit, p, self.sr, tris);
                }
            }
        }
    }

    /// A triangle of `prims` that hits within `[tmin, tmax]` (the lowest
    /// lane of the first chunk with one), if any.
    #[inline(always)]
    pub(crate) fn any(
        &self,
        tris: &[Triangle],
        prims: &[u32],
        tmin: f32,
        tmax: f32,
    ) -> Option<u32> {
        for chunk in prims.chunks(N) {
            if let Some(h) = self.hits::<true>(tris, chunk, MISS, tmin, tmax) {
                let l = h.hit.trailing_zeros() as usize;
                return Some(chunk.get(l).copied().unwrap_or(MISS));
            }
        }
        None
    }
}

/// The closest-hit leaf test in 8 lanes at the current instruction set
/// level ([`crate::cpu`]): [`LeafRay::closest`]. Out of line (each level's
/// body is its own function): inlined, its vector registers crowded the
/// walk's own values out of registers (measured: ~5% slower on camera
/// rays).
#[inline(always)]
pub(crate) fn closest_x8(
    sr: &ShearedRay,
    tris: &[Triangle],
    prims: &[u32],
    tmin: f32,
    best: &mut Closest,
) {
    dispatch(LeafClosest {
        sr,
        tris,
        prims,
        tmin,
        best,
    });
}

/// The any-hit leaf test in 8 lanes: [`LeafRay::any`], as [`closest_x8`].
#[inline(always)]
pub(crate) fn any_x8(
    sr: &ShearedRay,
    tris: &[Triangle],
    prims: &[u32],
    tmin: f32,
    tmax: f32,
) -> Option<u32> {
    dispatch(LeafAny {
        sr,
        tris,
        prims,
        tmin,
        tmax,
    })
}

/// [`closest_x8`]'s arguments.
struct LeafClosest<'a, 'b> {
    sr: &'a ShearedRay,
    tris: &'a [Triangle],
    prims: &'a [u32],
    tmin: f32,
    best: &'b mut Closest,
}

impl Job for LeafClosest<'_, '_> {
    type Out = ();
    #[inline(always)]
    fn run<L: Level>(self) {
        LeafRay::<L::X8, 8>::new(self.sr).closest(self.tris, self.prims, self.tmin, self.best);
    }
}

/// [`any_x8`]'s arguments.
struct LeafAny<'a> {
    sr: &'a ShearedRay,
    tris: &'a [Triangle],
    prims: &'a [u32],
    tmin: f32,
    tmax: f32,
}

impl Job for LeafAny<'_> {
    type Out = Option<u32>;
    #[inline(always)]
    fn run<L: Level>(self) -> Option<u32> {
        LeafRay::<L::X8, 8>::new(self.sr).any(self.tris, self.prims, self.tmin, self.tmax)
    }
}

#[cfg(test)]
mod tests {
    //! Lanes against the scalar test over the same triangles, bitwise:
    //! grid-snapped triangles (rays through shared edges and vertices,
    //! exact-zero edge functions), repeated triangles (equal `t`, so the
    //! lower index must win), leaves listed in any order and axis-aligned
    //! rays.
    use super::*;
    use crate::geometry::Ray;
    use crate::test_rng::Rng;
    use crate::triangle::{any_hit_brute, closest_hit_brute};
    use wide::{f32x4, f32x8};

    /// A coordinate on a grid of quarters half the time.
    fn coord(rng: &mut Rng) -> f32 {
        let x = rng.f();
        if rng.f() < 0.5 {
            (x * 4.0).floor() / 4.0
        } else {
            x
        }
    }

    /// The brute-force answers over `tris[prims]`: all of `tris`, with
    /// the triangles not listed collapsed to a point (never hit), so each
    /// keeps its index and the list's order plays no part.
    fn brute(tris: &[Triangle; 12], prims: &[u32], ray: &Ray) -> ([u32; 4], bool) {
        let mut listed = [Triangle { v: [[0.0; 3]; 3] }; 12];
        for &p in prims {
            listed[p as usize] = tris[p as usize];
        }
        let h = closest_hit_brute(&listed, ray);
        (h.bits(), any_hit_brute(&listed, ray))
    }

    fn lanes<V: Lanes<N>, const N: usize>(
        tris: &[Triangle],
        prims: &[u32],
        ray: &Ray,
    ) -> ([u32; 4], bool) {
        let Some(sr) = ShearedRay::new(ray) else {
            return (crate::geometry::Hit::MISS.bits(), false);
        };
        let lr = LeafRay::<V, N>::new(&sr);
        let mut best = Closest::new(ray.tmax);
        lr.closest(tris, prims, ray.tmin, &mut best);
        let occluder = lr.any(tris, prims, ray.tmin, ray.tmax);
        // The occluder named is a listed triangle that hits.
        if let Some(p) = occluder {
            assert!(prims.contains(&p));
            assert!(sr.intersects(&tris[p as usize], ray.tmin, ray.tmax));
        }
        (best.hit(&sr, tris).bits(), occluder.is_some())
    }

    #[test]
    fn lanes_equal_the_scalar_test_bitwise() {
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        let mut hits = 0;
        let rounds = if cfg!(miri) { 200 } else { 3000 };
        for round in 0..rounds {
            let mut tris = [Triangle { v: [[0.0; 3]; 3] }; 12];
            for t in tris.iter_mut() {
                t.v = core::array::from_fn(|_| core::array::from_fn(|_| coord(&mut rng)));
            }
            // Repeats at higher indices, in the same chunk of lanes and in
            // another: ties at equal t, which the lower index must win.
            tris[3] = tris[1];
            tris[9] = tris[2];
            // 4 to 12 triangles, in increasing, decreasing or shuffled
            // order (a blob's leaves need not be sorted).
            let n = 4 + round % 9;
            let mut prims: [u32; 12] = core::array::from_fn(|i| i as u32);
            match round % 3 {
                0 => {}
                1 => prims[..n].reverse(),
                _ => prims[..n].swap(0, n - 1 - round % (n - 1)),
            }
            let prims = &prims[..n];
            let o = [coord(&mut rng) - 0.5, coord(&mut rng) - 0.5, -1.0];
            let mut d = [
                coord(&mut rng) * 2.0 - 1.0,
                coord(&mut rng) * 2.0 - 1.0,
                1.0,
            ];
            if round % 5 == 0 {
                d[round % 2] = 0.0; // parallel to an axis plane
            }
            let ray = Ray {
                origin: o.map(|x| x + 0.5),
                tmin: 0.0,
                dir: d,
                tmax: if round % 3 == 0 { 1.2 } else { f32::INFINITY },
            };
            let want = brute(&tris, prims, &ray);
            assert_eq!(lanes::<f32x4, 4>(&tris, prims, &ray), want, "round {round}");
            assert_eq!(lanes::<f32x8, 8>(&tris, prims, &ray), want, "round {round}");
            hits += usize::from(want.1);
        }
        // The rays must reach the triangles for the test to say anything.
        assert!(hits > rounds / 10, "only {hits} hits");
    }
}
