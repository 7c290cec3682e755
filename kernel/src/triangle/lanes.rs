//! The watertight test of one triangle against all lanes: the lane-wise
//! twin of [`ShearedRay::intersect`](crate::triangle::ShearedRay::intersect), the
//! same operations in the same order (no FMA, true division), so each
//! lane's `t`, edge functions and determinant are the single ray's bits.
//! Lanes whose `f32` edge function is exactly zero are recomputed by the
//! scalar [`edge_functions_f64`], as the single ray does.

use super::edge_functions_f64;
use crate::lanes::Lanes;

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
