//! The watertight test of one triangle against all lanes: the lane-wise
//! twin of [`ShearedRay::intersect`](crate::triangle::ShearedRay::intersect), the
//! same operations in the same order (no FMA, true division), so each
//! lane's `t`, edge functions and determinant are the single ray's bits.
//! Lanes whose `f32` edge function is exactly zero are recomputed by the
//! scalar [`edge_functions_f64`], as the single ray does; lanes whose `t`
//! window ([`t_window`], shared with the scalar test) straddles the
//! interval get the scalar `f64` `t` ([`plane_t`](super::plane_t)), one
//! lane at a time.

use super::{edge_functions_f64, t_window, WELL_SHAPED};
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
/// triangles): the arithmetic is the same. `exact_t(l)` is lane `l`'s
/// [`plane_t`](super::plane_t); `ANY`: only the hit mask is wanted (any hit), and lanes
/// clearly inside their interval skip the `f64` `t`.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn watertight<V: Lanes<N>, const N: usize, const ANY: bool>(
    a: (V, V, V),
    b: (V, V, V),
    c: (V, V, V),
    sz: V,
    live: u32,
    tmin: V,
    tmax: V,
    exact_t: impl Fn(usize) -> f32,
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
    // As the scalar test: a zero or overflowed determinant is no hit.
    // `0 < |x| < inf` is `x != 0 && x.is_finite()` (NaN fails every
    // comparison).
    let inf = V::splat(f32::INFINITY);
    let det_abs = det.abs();
    hit &= (det_abs.gt_mask(zero) & det_abs.lt_mask(inf)).bits();
    if hit == 0 {
        return None;
    }
    let (t_est, slack, shape) =
        t_window([ax, ay, bx, by, cx, cy], [az, bz, cz], [u, v, w], det, sz);
    let (lo, hi) = (t_est - slack, t_est + slack);
    // Windows clearly outside [tmin, tmax] (a NaN window rejects nothing).
    hit &= !(hi.lt_mask(tmin) | lo.gt_mask(tmax)).bits();
    if hit == 0 {
        return None;
    }
    // An any-hit query takes the windows clearly inside as they are.
    let sure = if ANY {
        let well = shape.lt_mask(V::splat(WELL_SHAPED));
        hit & (lo.ge_mask(tmin) & hi.le_mask(tmax) & hi.lt_mask(inf) & well).bits()
    } else {
        0
    };
    let mut t = t_est.to_array();
    let mut exact = hit & !sure;
    while exact != 0 {
        let l = exact.trailing_zeros() as usize;
        exact &= exact - 1;
        if let Some(x) = t.get_mut(l) {
            *x = exact_t(l);
        }
    }
    let t = V::from_array(t);
    // The f64 t's verdict, as `exact_t_hits`: within [tmin, tmax], finite
    // and within the window (a NaN window holds every t).
    let ok = t.ge_mask(tmin) & t.le_mask(tmax) & t.abs().lt_mask(inf);
    let outside = t.lt_mask(lo) | t.gt_mask(hi);
    hit &= (ok.bits() & !outside.bits()) | sure;
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
