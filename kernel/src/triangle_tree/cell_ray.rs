//! A ray clipped to the root cell, with `1/dir` and the near-child rule: what
//! every step of the walk reads.
//!
//! # Exactness
//! The answer must be the brute-force answer bit for bit, yet `t_split`
//! and the triangle's `t` are rounded. So every cell interval is widened by
//! a slack `s` = [`SLACK`] × (the ray's extent through the scene bounds),
//! at least [`SLACK_FLOOR`], far above the few ulps of rounding in either: a cell is skipped only when
//! its interval misses the current `[t_min, t_max]` by more than `s`, and a
//! far cell popped after a hit is skipped only when it starts more than `s`
//! beyond the best hit. Triangles are always tested against the ray's own
//! `[tmin, best t]`, never the cell's, so a triangle referenced by several
//! leaves gives the same answer in each, and a hit beyond the current cell
//! never ends the search early. The cost is a few extra cells within
//! `s` of a hit: nothing measurable.

use crate::blob::Node;
use crate::geometry::{Bounds, Ray};
use crate::lanes::Span;

/// The cell slack relative to the ray's extent through the scene
/// (2^-18 ≈ 3.8e-6, about 32 ulps of the largest `t` in the scene).
pub(crate) const SLACK: f32 = 1.0 / 262_144.0;

/// The least slack: below `f32::MIN_POSITIVE` rounding is absolute
/// (`2^-150` a step), which a slack relative to the extent does not cover
/// when that extent is itself subnormal (a direction near `f32::MAX`:
/// a fuzzed scene ray whose mesh walk missed the lower of two triangles
/// at `t = 2^-128`). `2^-126` is `2^24` such steps, and far below the
/// relative slack of any ray whose extent is a normal number.
pub(crate) const SLACK_FLOOR: f32 = f32::MIN_POSITIVE;

/// How far the root cell reaches past each face of the scene bounds,
/// relative to `|min| + |max| + |o|` on that axis (2^-17, `o` the
/// origin coordinate): twice the margin by which the triangle test takes a
/// hit point outside its triangle's box (`triangle::widen`), so a hit
/// brute force accepts is never clipped away with the ray, whatever the
/// `f32` rounding here.
pub(crate) const ROOT_MARGIN: f32 = 1.0 / 131_072.0;

/// The scene bounds widened by [`ROOT_MARGIN`] for a ray from `org`: the
/// root cell the walk clips a ray to.
#[inline(always)]
fn root_cell(bounds: &Bounds, org: &[f32; 3]) -> Bounds {
    // Per axis by name, no indexing: indexed forms left a bounds check (a
    // panic path) at opt-level "s".
    let ([x0, y0, z0], [x1, y1, z1], [ox, oy, oz]) = (bounds.min, bounds.max, *org);
    let m = |lo: f32, hi: f32, o: f32| ROOT_MARGIN * (lo.abs() + hi.abs() + o.abs());
    let (mx, my, mz) = (m(x0, x1, ox), m(y0, y1, oy), m(z0, z1, oz));
    Bounds {
        min: [x0 - mx, y0 - my, z0 - mz],
        max: [x1 + mx, y1 + my, z1 + mz],
    }
}

/// A ray clipped to the scene bounds, ready for the traversal loop.
#[derive(Clone, Copy, Debug)]
pub(crate) struct CellRay {
    /// The origin.
    pub(crate) org: [f32; 3],
    /// `1/dir`, `±inf` for a zero component (sign kept), NaN for a
    /// component whose inverse overflows (`new`).
    pub(crate) inv: [f32; 3],
    /// 1 where the ray enters the above child first (`inv < 0`), else 0.
    pub(crate) above_first: [u32; 3],
    /// The same three bits (x in bit 0) repeated in each nibble, the form
    /// `Node::first_child` takes.
    pub(crate) above_first_nibbles: u64,
    /// The widened interval over the root cell.
    pub(crate) t0: f32,
    /// End of the widened interval over the root cell.
    pub(crate) t1: f32,
    /// The slack `s` (module docs).
    pub(crate) slack: f32,
}

impl CellRay {
    /// Clips `ray` to `bounds` widened to the root cell (slab test),
    /// widening the interval by the slack, which scales with the ray's
    /// extent along its dominant axis `kz` ([`ShearedRay`]'s `k[2]`).
    /// `None` when the ray misses the box or is invalid.
    ///
    /// [`ShearedRay`]: crate::triangle::ShearedRay
    #[inline(always)]
    #[must_use]
    pub(crate) fn new(ray: &Ray, kz: usize, bounds: &Bounds) -> Option<CellRay> {
        let org = ray.origin;
        let bounds = &root_cell(bounds, &org);
        // Whole arrays, not element stores in the loop: those were spilled
        // one lane at a time and reloaded whole, a store-forwarding stall
        // per ray (measured: ~4% of a camera-ray trace).
        let inv = ray.dir.map(|d| 1.0 / d);
        let above_first = inv.map(|i| u32::from(i < 0.0));
        let (mut enter, mut exit) = (f32::NEG_INFINITY, f32::INFINITY);
        let mut nearly_parallel = false;
        for a in 0..3 {
            if inv[a].is_infinite() {
                if ray.dir[a] != 0.0 {
                    // |d| so small that 1/d overflows (< 2^-128) is not
                    // parallel: the ray still crosses this axis's planes,
                    // at t = (p - o) / d, which is any size (t = -1 for an
                    // origin and a direction of the same subnormal size; a
                    // proptest found the ray skipping the cell of its
                    // hit). Its slab clips nothing, and its inverse
                    // becomes NaN below.
                    nearly_parallel = true;
                    continue;
                }
                // Parallel to this slab (d = ±0): inside it for all t, or
                // never. (Taking the slab test here would compute
                // 0 * inf = NaN for an origin on a face.)
                if org[a] < bounds.min[a] || org[a] > bounds.max[a] {
                    return None;
                }
                continue;
            }
            let ta = (bounds.min[a] - org[a]) * inv[a];
            let tb = (bounds.max[a] - org[a]) * inv[a];
            // ta and tb are never NaN (finite inv, finite coordinates):
            // plain selects, not f32::min/max's NaN handling.
            enter = Span::max(enter, Span::min(ta, tb));
            exit = Span::min(exit, Span::max(ta, tb));
        }
        // A NaN inverse makes every split plane on a nearly parallel axis
        // visit both children over the whole interval (NaN t_split),
        // written only on this rare branch. Tried: a select per component
        // on every ray, or a store into `inv` in the loop: camera rays
        // 1.6-2% slower either way.
        let inv = if nearly_parallel {
            core::array::from_fn(|a| {
                let tiny = inv[a].is_infinite() && ray.dir[a] != 0.0;
                if tiny {
                    f32::NAN
                } else {
                    inv[a]
                }
            })
        } else {
            inv
        };
        // Slack from the ray's extent through the scene along its dominant
        // axis, which bounds every t the scene's triangles can produce.
        let kz = kz.min(2);
        let zmax = (bounds.min[kz] - org[kz])
            .abs()
            .max((bounds.max[kz] - org[kz]).abs())
            * inv[kz].abs();
        // No finite extent (the dominant component's inverse overflowed
        // too): an infinite slack, every cell visited over every t.
        let slack = SLACK * zmax;
        let slack = if slack.is_nan() {
            f32::INFINITY
        } else {
            Span::max(slack, SLACK_FLOOR)
        };
        let t0 = ray.tmin.max(enter) - slack;
        let t1 = ray.tmax.min(exit) + slack;
        if t0 <= t1 {
            Some(CellRay {
                org,
                inv,
                above_first,
                above_first_nibbles: Node::first_child_mask(above_first),
                t0,
                t1,
                slack,
            })
        } else {
            None
        }
    }
}

impl CellRay {
    /// The root cell's interval as the walk keeps intervals: widened by
    /// the slack once more, `[lo, hi] = [t0 - s, t1 + s]` (the slack rule).
    #[inline(always)]
    #[must_use]
    pub(crate) fn start(&self) -> (f32, f32) {
        (self.t0 - self.slack, self.t1 + self.slack)
    }
}
