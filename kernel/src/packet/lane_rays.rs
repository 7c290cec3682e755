//! The packet's rays prepared once, lane by lane, by the scalar code
//! itself: [`ShearedRay::new`] for the watertight test's permutation and
//! shear, [`CellRay::new`] for the clipped, slack-widened root interval,
//! `1/dir` and the near-child rule. The lanes then hold exactly the
//! numbers a single ray would compute, so every later lane operation
//! starts from the same bits.

use super::lanes::Lanes;
use super::Packet;
use crate::ray::Ray;
use crate::traverse::CellRay;
use crate::tree::Bounds;
use crate::triangle::ShearedRay;

/// Packet rays in lanes (structure of arrays).
pub(crate) struct LaneRays<V, const N: usize> {
    /// Lanes that take part: valid, and crossing the scene box. Every
    /// other lane misses, as the single ray does.
    pub(crate) active: u32,
    /// Whether the active lanes share their near child on every axis (the
    /// signs of their directions agree): only then does the packet walk
    /// the tree together; otherwise each lane goes alone (`walk.rs`).
    pub(crate) coherent: bool,
    /// Origin per axis.
    pub(crate) org: [V; 3],
    /// `1/dir` per axis.
    pub(crate) inv: [V; 3],
    /// Per axis, 1 when the (coherent) lanes enter the above child first.
    pub(crate) above_first: [u32; 3],
    /// The root interval as the single ray starts its walk,
    /// [`CellRay::start`]: widened by the slack once more.
    pub(crate) lo: V,
    /// End of the widened root interval.
    pub(crate) hi: V,
    /// Twice the slack, per lane (the slack rule's step).
    pub(crate) s2: V,
    /// The rays' own `tmin`.
    pub(crate) tmin: V,
    /// The rays' own `tmax`.
    pub(crate) tmax: V,
    /// The permuted axes `[kx, ky, kz]` when all active lanes share them
    /// (the common case for coherent rays): vertices are then splats.
    pub(crate) k_uniform: Option<[usize; 3]>,
    /// `k_is[j][c]`: lanes whose `k[j] == c`, for `c` in 0..2 (else 2).
    pub(crate) k_is: [[V; 2]; 3],
    /// The origin's permuted components `org[k[j]]`.
    pub(crate) org_k: [V; 3],
    /// The shear constants.
    pub(crate) shear: [V; 3],
    /// Each active lane as the single ray prepares it, with its
    /// `[tmin, tmax]`: lanes left alone in a subtree finish as single rays.
    pub(crate) single: [Option<Single>; N],
}

/// One lane as a single ray.
#[derive(Clone, Copy)]
pub(crate) struct Single {
    pub(crate) sr: ShearedRay,
    pub(crate) cr: CellRay,
    pub(crate) tmin: f32,
    pub(crate) tmax: f32,
}

impl<V: Lanes<N>, const N: usize> LaneRays<V, N> {
    /// Prepares the valid lanes of `packet` against the scene `bounds`.
    #[inline(always)]
    pub(crate) fn new(packet: &Packet<N>, bounds: &Bounds) -> Self {
        Self::from_fn(|l| packet.valid[l].then(|| packet.ray(l)), bounds)
    }

    /// Prepares the lanes `ray(l)` gives (`None`: an inactive lane)
    /// against the scene `bounds`; the slice entry points read their rays
    /// in place this way, without a [`Packet`] in between.
    #[inline(always)]
    pub(crate) fn from_fn(ray: impl Fn(usize) -> Option<Ray>, bounds: &Bounds) -> Self {
        let mut active = 0u32;
        let mut org = [[0.0f32; N]; 3];
        let mut inv = [[0.0f32; N]; 3];
        let mut above_first = [0u32; 3];
        // Inactive lanes keep an empty interval [1, 0].
        let (mut lo, mut hi, mut s2) = ([1.0f32; N], [0.0f32; N], [0.0f32; N]);
        let (mut tmin, mut tmax) = ([0.0f32; N], [0.0f32; N]);
        let mut ks = [[0usize; 3]; N];
        let mut org_k = [[0.0f32; N]; 3];
        let mut shear = [[0.0f32; N]; 3];
        let mut single = [None; N];
        for l in 0..N {
            let Some(ray) = ray(l) else {
                continue;
            };
            let Some(sr) = ShearedRay::new(&ray) else {
                continue;
            };
            let Some(cr) = CellRay::new(&ray, &sr, bounds) else {
                continue;
            };
            active |= 1 << l;
            for a in 0..3 {
                org[a][l] = cr.org[a];
                inv[a][l] = cr.inv[a];
                above_first[a] |= cr.above_first[a] << l;
                org_k[a][l] = sr.org[sr.k[a]];
                shear[a][l] = sr.s[a];
            }
            (lo[l], hi[l]) = cr.start();
            s2[l] = cr.slack + cr.slack;
            (tmin[l], tmax[l]) = (ray.tmin, ray.tmax);
            ks[l] = sr.k;
            single[l] = Some(Single {
                sr,
                cr,
                tmin: ray.tmin,
                tmax: ray.tmax,
            });
        }
        let coherent = above_first.iter().all(|&af| af == 0 || af == active);
        let first = ks[(active.trailing_zeros() as usize).min(N - 1)];
        let k_uniform = (0..N)
            .all(|l| active >> l & 1 == 0 || ks[l] == first)
            .then_some(first);
        let lanes_where = |j: usize, c: usize| {
            V::mask((0..N).fold(0, |m, l| m | (u32::from(ks[l][j] == c) << l)))
        };
        LaneRays {
            active,
            coherent,
            org: org.map(V::from_array),
            inv: inv.map(V::from_array),
            above_first: above_first.map(|af| u32::from(af != 0)),
            lo: V::from_array(lo),
            hi: V::from_array(hi),
            s2: V::from_array(s2),
            tmin: V::from_array(tmin),
            tmax: V::from_array(tmax),
            k_uniform,
            k_is: core::array::from_fn(|j| [lanes_where(j, 0), lanes_where(j, 1)]),
            org_k: org_k.map(V::from_array),
            shear: shear.map(V::from_array),
            single,
        }
    }
}
