//! A packet's lanes against one triangle: each vertex sheared per lane, then
//! the lane-wise watertight test ([`crate::triangle::lanes::watertight`]).
//!
//! Tried: two triangles per register (an 8-lane packet twice in an
//! `f32x16`, a leaf's triangles in pairs): 8-wide 9% slower, 4-wide in
//! `f32x8` no change; the pairs' loads, joins and splits cost more than the
//! second test saved.

use super::lane_rays::LaneRays;
use crate::geometry::Axis;
use crate::lanes::Lanes;
use crate::triangle::lanes::{watertight, LaneHits};
use crate::triangle::{plane_t_lanes, Triangle};

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
        let qx = self.permuted(k, p, 0) - self.org_k[0];
        let qy = self.permuted(k, p, 1) - self.org_k[1];
        let qz = self.permuted(k, p, 2) - self.org_k[2];
        (qx - self.shear[0] * qz, qy - self.shear[1] * qz, qz)
    }

    /// `p[k[j]]` in each lane. (A method, not a closure: see
    /// [`crate::lanes::dispatch`].)
    #[inline(always)]
    fn permuted(&self, k: Option<[Axis; 3]>, p: &[f32; 3], j: usize) -> V {
        match k {
            // An `Axis` is below 3, as the compiler knows: no bounds check,
            // and the fallback is never taken.
            Some(k) => V::splat(p.get(k[j].index()).copied().unwrap_or(f32::NAN)),
            None => {
                let [is0, is1] = self.k_is.get(j).copied().unwrap_or(self.k_is[2]);
                let [x, y, z] = [V::splat(p[0]), V::splat(p[1]), V::splat(p[2])];
                V::select(is0, x, V::select(is1, y, z))
            }
        }
    }

    /// Tests `tri` against the lanes in `live` over each lane's
    /// `[tmin, tmax]`; `None` when it hits none of them. `k` is
    /// [`LaneRays::k_uniform`]. `ANY`: only the hit mask is wanted (the
    /// any-hit query), so lanes clearly inside their interval skip the
    /// `f64` `t` and their `t` is the estimate.
    #[inline(always)]
    pub(crate) fn intersect<const ANY: bool>(
        &self,
        k: Option<[Axis; 3]>,
        tri: &Triangle,
        live: u32,
        tmax: V,
    ) -> Option<LaneHits<V>> {
        let [p0, p1, p2] = &tri.v;
        let (a, b, c) = (
            self.shear_vertex(k, p0),
            self.shear_vertex(k, p1),
            self.shear_vertex(k, p2),
        );
        let tmin = self.tmin;
        let mut win = watertight::<V, N, ANY>(a, b, c, self.shear[2], live, tmin, tmax)?;
        // The `f64` `t` of every lane that needs one, now (eager). Tried
        // (8-wide / 16-wide camera tiles, the same hits each time):
        // - the single ray's deferral per lane (`Closest`'s windows in
        //   lanes, the deferred lanes resolved at the end, lanes sharing a
        //   best triangle together): bunny +3.5% / +7%, teapot 0% / +1%,
        //   sponza -3% / -3%; once the lanes' `t` was written by selects,
        //   bunny +1.6% / +4%, teapot -3% / -1%, sponza -6% / -6%. A lane
        //   is mostly hit by one triangle, so it takes one `f64` `t` either
        //   way, and the deferral's masks come on top. Resolved all at
        //   once, each lane against its own triangle's plane: sponza and
        //   teapot 4-10% slower still;
        // - a camera packet's one origin passed as such (`n·(v0 - org)`
        //   and the box margins formed once for all lanes): 8-wide 2.5-7%
        //   slower, 16-wide 3-4% faster, +1-2% instructions;
        // - origin and direction kept as lane arrays in `LaneRays` instead
        //   of converted here: +1.5-2% instructions.
        if win.exact != 0 {
            let (org, dir) = (self.org.map(V::to_array), self.dir.map(V::to_array));
            plane_t_lanes::<V, N>(&org, &dir, tri, win.exact, &mut win.t);
        }
        win.hits(tmin, tmax)
    }
}
