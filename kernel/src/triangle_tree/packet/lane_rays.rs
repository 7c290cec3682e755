//! The packet's rays prepared once for all lanes: the permutation and
//! shear of the watertight test ([`ShearedRay::new`]) and the clipped,
//! slack-widened root interval, `1/dir` and near-child rule
//! ([`CellRay::new`]), computed in lanes by the same operations in the
//! same order, so every lane holds its single ray's numbers.
//!
//! The lane-wise set-up covers rays with finite origins and directions
//! whose `1/dir` is finite on every axis (no component zero or
//! subnormal) and whose slab distances are numbers: there, none of the
//! scalar code's NaN and infinity branches is taken. A packet with any
//! other valid lane is prepared lane by lane by the scalar code itself.
//! (The scalar set-up for every packet was ~21% of an 8-wide camera trace.)
//!
//! `t0`/`t1` may differ from the scalar ones in the sign of a zero (the
//! lane `min`/`max` pick either of two equal operands): the walk only
//! compares them, where `-0 == +0`.

use super::super::cell_ray::{CellRay, ROOT_MARGIN, SLACK, SLACK_FLOOR};
use super::Packet;
use crate::blob::Node;
use crate::geometry::{Axis, Bounds, Ray};
use crate::lanes::Lanes;
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
    /// Direction per axis (for the `f64` `t`).
    pub(crate) dir: [V; 3],
    /// `1/dir` per axis.
    pub(crate) inv: [V; 3],
    /// The (coherent) lanes' above-first bits, x in bit 0, y in 1, z in
    /// 2, repeated in every nibble: the form `Node::first_child` reads, as
    /// [`CellRay`] keeps it.
    pub(crate) above_first_nibbles: u64,
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
    /// As axes, whose index the compiler knows is below 3 (a `usize`
    /// index was bounds-checked for every vertex coordinate).
    pub(crate) k_uniform: Option<[Axis; 3]>,
    /// `k_is[j][c]`: lanes whose `k[j] == c`, for `c` in 0..2 (else 2).
    pub(crate) k_is: [[V; 2]; 3],
    /// The origin's permuted components `org[k[j]]`.
    pub(crate) org_k: [V; 3],
    /// The shear constants.
    pub(crate) shear: [V; 3],
    /// `k_is` as bitmasks.
    k_bits: [[u32; 2]; 3],
    /// Per axis, the lanes with `1/dir < 0` (each lane's `above_first`).
    above_bits: [u32; 3],
    /// The clipped, widened root interval of each lane ([`CellRay::t0`]).
    t0: V,
    /// Its end ([`CellRay::t1`]).
    t1: V,
    /// Each lane's slack ([`CellRay::slack`]).
    slack: V,
}

/// One lane as its single ray: each lane of a packet that does not walk
/// together is traced so, from the root (`LaneRays::alone`).
#[derive(Clone, Copy)]
pub(crate) struct Single {
    pub(crate) sr: ShearedRay,
    pub(crate) cr: CellRay,
    pub(crate) tmin: f32,
    pub(crate) tmax: f32,
}

/// Rays in lanes as they arrive: origins, directions, intervals.
pub(crate) struct Columns<V> {
    org: [V; 3],
    dir: [V; 3],
    tmin: V,
    tmax: V,
    /// Lanes holding a ray.
    valid: u32,
}

impl<V: Lanes<N>, const N: usize> LaneRays<V, N> {
    /// The first `N` rays of `rays` in lanes (lanes past its end
    /// inactive): a transpose in registers.
    #[inline(always)]
    pub(crate) fn columns(rays: &[Ray]) -> Columns<V> {
        let [ox, oy, oz, tmin, dx, dy, dz, tmax] = V::columns(rays);
        Columns {
            org: [ox, oy, oz],
            dir: [dx, dy, dz],
            tmin,
            tmax,
            valid: (1u32 << rays.len().min(N)) - 1,
        }
    }

    /// Whether the rays' directions share their sign bits on every axis:
    /// the cheap test, before any lane is prepared, that the packet can
    /// walk together (`LaneRays::coherent` is the exact one). Random rays
    /// almost never pass it and are traced as single rays without the
    /// packet set-up, so a packet of random rays costs what its single
    /// rays cost. A lane's bitmask is its sign bit.
    #[inline(always)]
    pub(crate) fn signs_agree(cols: &Columns<V>) -> bool {
        let v = cols.valid;
        let [x, y, z] = [
            cols.dir[0].bits() & v,
            cols.dir[1].bits() & v,
            cols.dir[2].bits() & v,
        ];
        (x == 0 || x == v) && (y == 0 || y == v) && (z == 0 || z == v)
    }
}

impl<V: Lanes<N>, const N: usize> LaneRays<V, N> {
    /// Prepares the valid lanes of `packet` against the scene `bounds`.
    #[inline(always)]
    pub(crate) fn new(packet: &Packet<N>, bounds: &Bounds) -> Self {
        let valid = (0..N).fold(0, |m, l| m | u32::from(packet.valid[l]) << l);
        let cols = Columns {
            org: packet.origin.map(V::from_array),
            dir: packet.dir.map(V::from_array),
            tmin: V::from_array(packet.tmin),
            tmax: V::from_array(packet.tmax),
            valid,
        };
        Self::in_lanes(&cols, bounds).unwrap_or_else(|| {
            Self::lane_by_lane(|l| packet.valid[l].then(|| packet.ray(l)), bounds)
        })
    }

    /// Prepares the rays `cols` holds, the first `N` rays of `rays` (lanes
    /// past its end inactive), against the scene `bounds`.
    #[inline(always)]
    pub(crate) fn from_rays(cols: &Columns<V>, rays: &[Ray], bounds: &Bounds) -> Self {
        Self::in_lanes(cols, bounds)
            .unwrap_or_else(|| Self::lane_by_lane(|l| rays.get(l).copied(), bounds))
    }

    /// The lane-wise twin of [`ShearedRay::new`] and [`CellRay::new`], for
    /// packets whose valid rays are all of the plain kind (module docs);
    /// `None` otherwise.
    #[inline(always)]
    fn in_lanes(c: &Columns<V>, bounds: &Bounds) -> Option<Self> {
        let (zero, one, inf) = (V::splat(0.0), V::splat(1.0), V::splat(f32::INFINITY));
        // No closures here (`crate::lanes::dispatch`).
        let inv = [one / c.dir[0], one / c.dir[1], one / c.dir[2]];
        let mut plain = c.tmin.le_mask(c.tmax);
        let (mut enter, mut exit) = (V::splat(f32::NEG_INFINITY), V::splat(f32::INFINITY));
        let mut zmax_of = [zero; 3];
        for a in 0..3 {
            // `|x| < inf` is `x.is_finite()`; a finite `1/d` excludes zero
            // and subnormal components.
            plain = plain
                & c.org[a].abs().lt_mask(inf)
                & c.dir[a].abs().lt_mask(inf)
                & inv[a].abs().lt_mask(inf);
            // The slab test over the root cell, as `CellRay::new`.
            let (lo, hi) = (V::splat(bounds.min[a]), V::splat(bounds.max[a]));
            let (margin, oa) = (V::splat(ROOT_MARGIN), c.org[a].abs());
            let m = margin * ((lo.abs() + hi.abs()) + oa);
            let to_min = (lo - m) - c.org[a];
            let to_max = (hi + m) - c.org[a];
            let ta = to_min * inv[a];
            let tb = to_max * inv[a];
            plain = plain & ta.eq_mask(ta) & tb.eq_mask(tb);
            enter = enter.max(ta.min(tb));
            exit = exit.min(ta.max(tb));
            zmax_of[a] = to_min.abs().max(to_max.abs()) * inv[a].abs();
        }
        if c.valid & !plain.bits() != 0 {
            return None;
        }
        // The dominant axis kz (ties to the lower axis), kx and ky after
        // it, swapped when dir[kz] < 0: `ShearedRay::new`.
        let d = [c.dir[0].abs(), c.dir[1].abs(), c.dir[2].abs()];
        let (is0, is1_else_2) = (d[0].ge_mask(d[1]) & d[0].ge_mask(d[2]), d[1].ge_mask(d[2]));
        let kz0 = is0.bits();
        let kz1 = !kz0 & is1_else_2.bits();
        let kz2 = !kz0 & !kz1;
        let dkz = V::select(is0, c.dir[0], V::select(is1_else_2, c.dir[1], c.dir[2]));
        let swap = dkz.lt(zero);
        let keep = !swap;
        let k_bits = [
            [kz2 & keep | kz1 & swap, kz0 & keep | kz2 & swap],
            [kz1 & keep | kz2 & swap, kz2 & keep | kz0 & swap],
            [kz0, kz1],
        ];
        let k_is = [
            [V::mask(k_bits[0][0]), V::mask(k_bits[0][1])],
            [V::mask(k_bits[1][0]), V::mask(k_bits[1][1])],
            [V::mask(k_bits[2][0]), V::mask(k_bits[2][1])],
        ];
        let dk = [pick(&c.dir, &k_is[0]), pick(&c.dir, &k_is[1])];
        // Floored as the single ray's; a NaN slack fails the compare and
        // stays NaN.
        let slack = V::splat(SLACK) * pick(&zmax_of, &k_is[2]);
        let floor = V::splat(SLACK_FLOOR);
        let slack = V::select(slack.lt_mask(floor), floor, slack);
        let t0 = c.tmin.max(enter) - slack;
        let t1 = c.tmax.min(exit) + slack;
        let active = c.valid & t0.le(t1);
        Some(Self::settle(LaneRays {
            active,
            coherent: false,
            org: c.org,
            dir: c.dir,
            inv,
            above_first_nibbles: 0,
            lo: t0 - slack,
            hi: t1 + slack,
            s2: slack + slack,
            tmin: c.tmin,
            tmax: c.tmax,
            k_uniform: None,
            k_is,
            org_k: [
                pick(&c.org, &k_is[0]),
                pick(&c.org, &k_is[1]),
                pick(&c.org, &k_is[2]),
            ],
            // 1/dir[kz] is the lane's inv[kz], the same division.
            shear: [dk[0] / dkz, dk[1] / dkz, pick(&inv, &k_is[2])],
            k_bits,
            above_bits: [inv[0].lt(zero), inv[1].lt(zero), inv[2].lt(zero)],
            t0,
            t1,
            slack,
        }))
    }

    /// Prepares the lanes `ray(l)` gives (`None`: an inactive lane) by
    /// the scalar code, lane by lane.
    #[cold]
    #[inline(never)]
    fn lane_by_lane(ray: impl Fn(usize) -> Option<Ray>, bounds: &Bounds) -> Self {
        let mut active = 0u32;
        let mut org = [[0.0f32; N]; 3];
        let mut dir = [[0.0f32; N]; 3];
        let mut inv = [[0.0f32; N]; 3];
        let mut above_bits = [0u32; 3];
        // Inactive lanes keep an empty interval [1, 0].
        let (mut t0, mut t1, mut slack) = ([1.0f32; N], [0.0f32; N], [0.0f32; N]);
        let (mut tmin, mut tmax) = ([0.0f32; N], [0.0f32; N]);
        let mut k_bits = [[0u32; 2]; 3];
        let mut org_k = [[0.0f32; N]; 3];
        let mut shear = [[0.0f32; N]; 3];
        for l in 0..N {
            let Some(ray) = ray(l) else {
                continue;
            };
            let Some(sr) = ShearedRay::new(&ray) else {
                continue;
            };
            let Some(cr) = CellRay::new(&ray, sr.k[2], bounds) else {
                continue;
            };
            active |= 1 << l;
            for a in 0..3 {
                org[a][l] = cr.org[a];
                dir[a][l] = sr.dir[a];
                inv[a][l] = cr.inv[a];
                above_bits[a] |= cr.above_first[a] << l;
                org_k[a][l] = sr.org[sr.k[a]];
                shear[a][l] = sr.s[a];
                for (c, bits) in k_bits[a].iter_mut().enumerate() {
                    *bits |= u32::from(sr.k[a] == c) << l;
                }
            }
            (t0[l], t1[l], slack[l]) = (cr.t0, cr.t1, cr.slack);
            (tmin[l], tmax[l]) = (ray.tmin, ray.tmax);
        }
        let (t0, t1, slack) = (V::from_array(t0), V::from_array(t1), V::from_array(slack));
        Self::settle(LaneRays {
            active,
            coherent: false,
            org: org.map(V::from_array),
            dir: dir.map(V::from_array),
            inv: inv.map(V::from_array),
            above_first_nibbles: 0,
            lo: t0 - slack,
            hi: t1 + slack,
            s2: slack + slack,
            tmin: V::from_array(tmin),
            tmax: V::from_array(tmax),
            k_uniform: None,
            k_is: k_bits.map(|b| b.map(V::mask)),
            org_k: org_k.map(V::from_array),
            shear: shear.map(V::from_array),
            k_bits,
            above_bits,
            t0,
            t1,
            slack,
        })
    }

    /// Fills in what follows from the lanes' bits: whether the active lanes
    /// walk together, their shared near-child rule and permutation.
    #[inline(always)]
    fn settle(mut self) -> Self {
        let active = self.active;
        let shared = |bits: u32| bits & active == 0 || bits & active == active;
        let above_first = self.above_bits.map(|b| u32::from(b & active != 0));
        self.above_first_nibbles = Node::first_child_mask(above_first);
        self.coherent = self.above_bits.iter().all(|&b| shared(b));
        if self.k_bits.iter().flatten().all(|&b| shared(b)) {
            let k = self.k((active.trailing_zeros() as usize).min(N - 1));
            // `k` holds 0, 1 and 2: `Axis::Z` is never the fallback.
            self.k_uniform = Some(k.map(|a| Axis::from_index(a).unwrap_or(Axis::Z)));
        }
        self
    }

    /// Lane `l`'s permuted axes `[kx, ky, kz]`.
    #[inline]
    fn k(&self, l: usize) -> [usize; 3] {
        self.k_bits.map(|[is0, is1]| {
            if is0 >> l & 1 == 1 {
                0
            } else if is1 >> l & 1 == 1 {
                1
            } else {
                2
            }
        })
    }

    /// `one(lane, start)` for each active lane, traced alone from the root
    /// (`start`: the root and the lane's interval), `none` for the others:
    /// lanes that disagree on a near child do not walk together, and a
    /// packet of random rays costs its single rays, not more.
    #[inline(always)]
    pub(crate) fn alone<T: Copy>(
        &self,
        none: T,
        one: impl Fn(&Single, (u32, f32, f32)) -> T,
    ) -> [T; N] {
        core::array::from_fn(|l| {
            if self.active >> l & 1 == 1 {
                one(&self.single(l), (0, self.lo.lane(l), self.hi.lane(l)))
            } else {
                none
            }
        })
    }

    /// Lane `l` as its single ray prepares it.
    #[inline]
    pub(crate) fn single(&self, l: usize) -> Single {
        let at = |v: &V| v.lane(l);
        let org = self.org.each_ref().map(at);
        let above_first = self.above_bits.map(|b| b >> l & 1);
        Single {
            sr: ShearedRay {
                org,
                dir: self.dir.each_ref().map(at),
                k: self.k(l),
                s: self.shear.each_ref().map(at),
            },
            cr: CellRay {
                org,
                inv: self.inv.each_ref().map(at),
                above_first,
                above_first_nibbles: Node::first_child_mask(above_first),
                t0: at(&self.t0),
                t1: at(&self.t1),
                slack: at(&self.slack),
            },
            tmin: at(&self.tmin),
            tmax: at(&self.tmax),
        }
    }
}

/// `v[c]` in each lane, where `is[c]` marks the lanes of `c` (0, 1, else 2).
#[inline(always)]
fn pick<V: Lanes<N>, const N: usize>(v: &[V; 3], is: &[V; 2]) -> V {
    V::select(is[0], v[0], V::select(is[1], v[1], v[2]))
}
