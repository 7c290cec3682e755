//! The watertight test of one triangle against all lanes: the lane-wise
//! twin of [`ShearedRay::intersect`](crate::ShearedRay::intersect), the
//! same operations in the same order (no FMA, true division), so each
//! lane's `t`, edge functions and determinant are the single ray's bits.
//! Lanes whose `f32` edge function is exactly zero are recomputed by the
//! scalar [`edge_functions_f64`], as the single ray does.

use super::lane_rays::LaneRays;
use super::lanes::Lanes;
use crate::node::Axis;
use crate::triangle::{edge_functions_f64, Triangle};

/// The lanes a triangle hits, with the unreduced hit of each lane.
pub(crate) struct LaneHits<V> {
    /// Lanes hit within `[tmin, tmax]` (bitmask).
    pub(crate) hit: u32,
    /// Each lane's `t`.
    pub(crate) t: V,
    /// Each lane's edge function weighting vertex 1.
    pub(crate) v: V,
    /// Each lane's edge function weighting vertex 2.
    pub(crate) w: V,
    /// Each lane's determinant (the sum of the three edge functions).
    pub(crate) det: V,
}

impl<V: Lanes<N>, const N: usize> LaneRays<V, N> {
    /// Vertex `p` relative to each lane's origin, sheared so the lane's
    /// ray runs along +z: `(q[kx] - sx q[kz], q[ky] - sy q[kz], q[kz])`;
    /// `k` is [`LaneRays::k_uniform`], passed in by value so that a leaf's
    /// loop keeps it in registers (read through `self` it was reloaded,
    /// with its discriminant, for every coordinate of every triangle).
    /// `p` is read in place (a copy indexed by the permuted axes would be
    /// spilled and reloaded across its stores).
    #[inline(always)]
    fn shear_vertex(&self, k: Option<[Axis; 3]>, p: &[f32; 3]) -> (V, V, V) {
        // p[k[j]] per lane; the subtraction is then the scalar q[k[j]].
        let pk = |j: usize| match k {
            // An `Axis` is below 3, as the compiler knows: no bounds check,
            // and the fallback is never taken.
            Some(k) => V::splat(p.get(k[j].index()).copied().unwrap_or(f32::NAN)),
            None => {
                let [is0, is1] = self.k_is[j];
                let [x, y, z] = p.map(V::splat);
                V::select(is0, x, V::select(is1, y, z))
            }
        };
        let qx = pk(0) - self.org_k[0];
        let qy = pk(1) - self.org_k[1];
        let qz = pk(2) - self.org_k[2];
        (qx - self.shear[0] * qz, qy - self.shear[1] * qz, qz)
    }

    /// Tests `tri` against the lanes in `live` over each lane's
    /// `[tmin, tmax]`; `None` when it hits none of them. `k` is
    /// [`LaneRays::k_uniform`].
    #[inline(always)]
    pub(crate) fn intersect(
        &self,
        k: Option<[Axis; 3]>,
        tri: &Triangle,
        live: u32,
        tmax: V,
    ) -> Option<LaneHits<V>> {
        let [a, b, c] = tri.v.each_ref().map(|p| self.shear_vertex(k, p));
        watertight(a, b, c, self.shear[2], live, self.tmin, tmax)
    }
}

/// The watertight test's arithmetic after the shear, lane by lane: the
/// vertices `[a, b, c]` relative to each lane's ray and sheared so that it
/// runs along +z, `sz` the shear's `1/d[kz]`; the lanes in `live` that hit
/// within their `[tmin, tmax]`, `None` when none does. Lanes may hold rays
/// (a packet against one triangle) or triangles (one ray against a leaf's
/// triangles): the arithmetic is the same.
#[inline(always)]
pub(crate) fn watertight<V: Lanes<N>, const N: usize>(
    a: (V, V, V),
    b: (V, V, V),
    c: (V, V, V),
    sz: V,
    live: u32,
    tmin: V,
    tmax: V,
) -> Option<LaneHits<V>> {
    let ((ax, ay, az), (bx, by, bz), (cx, cy, cz)) = (a, b, c);
    // 2-D edge functions: u weighs vertex 0, v vertex 1, w vertex 2.
    let mut u = cx * by - cy * bx;
    let mut v = ax * cy - ay * cx;
    let mut w = bx * ay - by * ax;
    // Masks are combined in lanes: one bitmask per decision.
    let zero = V::splat(0.0);
    let exact_zero = (u.eq_mask(zero) | v.eq_mask(zero) | w.eq_mask(zero)).bits() & live;
    if exact_zero != 0 {
        [u, v, w] = f64_fixup(exact_zero, [u, v, w], [ax, ay, bx, by, cx, cy]);
    }
    // Edge functions of both signs: the ray passes outside.
    let neg = u.lt_mask(zero) | v.lt_mask(zero) | w.lt_mask(zero);
    let pos = u.gt_mask(zero) | v.gt_mask(zero) | w.gt_mask(zero);
    let mut hit = live & !(neg & pos).bits();
    if hit == 0 {
        return None;
    }
    let det = u + v + w;
    let t_scaled = u * (sz * az) + v * (sz * bz) + w * (sz * cz);
    let t = t_scaled / det;
    // As the scalar test: a zero or overflowed determinant is no hit,
    // nor is a t outside [tmin, tmax] or not finite. `0 < |x| < inf`
    // is `x != 0 && x.is_finite()`, and `|x| < inf` is
    // `x.is_finite()` (NaN fails every comparison).
    let inf = V::splat(f32::INFINITY);
    let (det_abs, t_abs) = (det.abs(), t.abs());
    let ok = det_abs.gt_mask(zero)
        & det_abs.lt_mask(inf)
        & t.ge_mask(tmin)
        & t.le_mask(tmax)
        & t_abs.lt_mask(inf);
    hit &= ok.bits();
    (hit != 0).then_some(LaneHits { hit, t, v, w, det })
}

/// Recomputes the edge functions of the lanes in `lanes` in `f64`.
#[cold]
#[inline(never)]
fn f64_fixup<V: Lanes<N>, const N: usize>(lanes: u32, uvw: [V; 3], p: [V; 6]) -> [V; 3] {
    let mut uvw = uvw.map(V::to_array);
    let p = p.map(V::to_array);
    for l in 0..N {
        if lanes >> l & 1 == 1 {
            let e = edge_functions_f64(p.map(|c| c[l]));
            for (f, x) in uvw.iter_mut().zip(e) {
                f[l] = x;
            }
        }
    }
    uvw.map(V::from_array)
}
