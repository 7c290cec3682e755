//! The watertight test of one triangle against all lanes: the lane-wise
//! twin of [`ShearedRay::intersect`](crate::triangle::ShearedRay::intersect), the
//! same operations in the same order (no FMA, true division), so each
//! lane's `t`, edge functions and determinant are the single ray's bits.
//! Lanes whose `f32` edge function is exactly zero are recomputed by the
//! scalar [`edge_functions_f64`], as the single ray does; lanes whose `t`
//! window ([`t_window`], shared with the scalar test) straddles the
//! interval get the `f64` `t` ([`plane_t`](super::plane_t)) from the
//! caller, all such lanes at once (a packet's lanes against one triangle
//! run [`plane_t_lanes`](super::plane_t_lanes)).

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
    /// Lanes taken without the `f64` `t` ([`sure_hit`](super::sure_hit)):
    /// their `t` is the estimate, their `f64` `t` lies in their window.
    pub(crate) sure: u32,
    /// Each lane's window `(lo, hi)`.
    pub(crate) window: (V, V),
}

/// The watertight test's arithmetic after the shear, lane by lane: the
/// vertices `[a, b, c]` relative to each lane's ray and sheared so that it
/// runs along +z, `sz` the shear's `1/d[kz]`; the lanes in `live` that hit
/// within their `[tmin, tmax]`, `None` when none does. Lanes may hold rays
/// (a packet against one triangle) or triangles (one ray against a leaf's
/// triangles): the arithmetic is the same. The caller writes
/// [`plane_t`](super::plane_t) into [`LaneWindow::t`] for the lanes in
/// [`LaneWindow::exact`], then takes [`LaneWindow::hits`] (not a closure
/// passed in: a closure stays out of line, compiled without the level's
/// vector features, [`crate::lanes::dispatch`]). `SURE`: lanes clearly
/// inside their interval ([`sure_hit`](super::sure_hit)) skip the `f64`
/// `t` (an any-hit test, and the single ray's deferred closest hit,
/// [`Closest`](super::Closest)).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn watertight<V: Lanes<N>, const N: usize, const SURE: bool>(
    a: (V, V, V),
    b: (V, V, V),
    c: (V, V, V),
    sz: V,
    live: u32,
    tmin: V,
    tmax: V,
) -> Option<LaneWindow<V, N>> {
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
    // `sure_hit`, lane by lane.
    let sure = if SURE {
        let well = shape.lt_mask(V::splat(WELL_SHAPED));
        let finite = V::splat(f32::NEG_INFINITY).lt_mask(lo) & hi.lt_mask(inf);
        hit & (lo.ge_mask(tmin) & hi.le_mask(tmax) & finite & well).bits()
    } else {
        0
    };
    Some(LaneWindow {
        hit,
        sure,
        exact: hit & !sure,
        t: t_est.to_array(),
        window: (lo, hi),
        v,
        w,
        det,
    })
}

/// The lanes [`watertight`] passes, before the `f64` `t`.
pub(crate) struct LaneWindow<V, const N: usize> {
    /// Lanes whose window meets `[tmin, tmax]`.
    hit: u32,
    /// Lanes an any-hit query takes without the `f64` `t`.
    sure: u32,
    /// Lanes that need the `f64` `t`, written into [`LaneWindow::t`].
    pub(crate) exact: u32,
    /// Each lane's `t`: the estimate, until the caller writes the `f64` `t`.
    pub(crate) t: [f32; N],
    /// Each lane's window `(lo, hi)`.
    window: (V, V),
    v: V,
    w: V,
    det: V,
}

impl<V: Lanes<N>, const N: usize> LaneWindow<V, N> {
    /// The lanes hit, once [`LaneWindow::t`] holds the `f64` `t` of the
    /// lanes in [`LaneWindow::exact`]: the `f64` t's verdict, as
    /// [`exact_t_hits`](super::exact_t_hits): within `[tmin, tmax]`, finite
    /// and within the window (a NaN window holds every t), or the lane sure.
    #[inline(always)]
    pub(crate) fn hits(self, tmin: V, tmax: V) -> Option<LaneHits<V>> {
        let t = V::from_array(self.t);
        let inf = V::splat(f32::INFINITY);
        let ok = t.ge_mask(tmin) & t.le_mask(tmax) & t.abs().lt_mask(inf);
        let (lo, hi) = self.window;
        let outside = t.lt_mask(lo) | t.gt_mask(hi);
        let hit = self.hit & ((ok.bits() & !outside.bits()) | self.sure);
        (hit != 0).then_some(LaneHits {
            hit,
            t,
            v: self.v,
            w: self.w,
            det: self.det,
            sure: self.sure,
            window: self.window,
        })
    }
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
