//! The SAH builder: Wald & Havran, "On building fast kd-Trees for Ray
//! Tracing, and on doing that in O(N log N)", 2006.
//!
//! Each cell holds, per axis, the sorted [events](super::events) of its
//! triangles' clipped boxes. One sweep per axis visits every candidate
//! plane (every box edge strictly inside the cell) knowing how many
//! triangles lie below, above and in it, and prices it with the
//! [cost model](super::cost); triangles lying in the plane are tried on
//! each side and go where it is cheaper.
//!
//! After a split the triangles on one side only keep their events, still
//! sorted, filtered in one linear pass. Only the triangles straddling the
//! plane get new events: each is clipped to each child's cell
//! ([perfect splits](super::clip)), and the new events, sorted, are merged
//! in. With the one sort at the root, the build is O(N log N).
//!
//! Which side a triangle goes to (split plane at `p` on axis `k`):
//! - its box ends at or before `p`: below only (it may touch the plane);
//! - its box starts at or after `p`: above only;
//! - it lies in the plane: the side the sweep chose for planar triangles;
//! - otherwise it straddles the plane and is clipped to both cells.
//!
//! So every point of a triangle lies in the closed cell of some leaf that
//! references it: a triangle touching or lying in a split plane is held by
//! one side only, and the traversal's slack finds it from the other.

use super::aabb::Aabb;
use super::clip::split_boxes;
use super::cost::{AreaRatios, CostModel};
use super::events::{self, END, PLANAR, START};
use super::subdivide::{Choice, Splitter, PARALLEL_MIN};
use kdray_kernel::Triangle;
use rayon::prelude::*;
use std::cell::RefCell;

/// A cell's triangles: their events on each axis, sorted.
pub(super) struct Events {
    ev: [Vec<u64>; 3],
    n: usize,
}

/// The event-sweep splitter.
pub(super) struct EventSah<'a> {
    pub(super) triangles: &'a [Triangle],
    pub(super) cost: CostModel,
}

/// Where a triangle goes (the classification of the split step).
const BOTH: u8 = 0;
const BELOW: u8 = 1;
const ABOVE: u8 = 2;

thread_local! {
    /// Per-thread sides of the triangles of the cell being split (indexed by
    /// triangle; only the cell's own entries are written, then read).
    static SIDES: RefCell<Vec<u8>> = const { RefCell::new(Vec::new()) };
}

impl EventSah<'_> {
    /// The root cell's events from the triangles' boxes.
    pub(super) fn root(&self, boxes: &[Aabb]) -> Events {
        let axis_events = |axis: usize| {
            let mut ev = Vec::with_capacity(2 * boxes.len());
            for (i, b) in boxes.iter().enumerate() {
                events::push(&mut ev, b, axis, i as u32);
            }
            ev.par_sort_unstable();
            ev
        };
        let (x, (y, z)) = rayon::join(
            || axis_events(0),
            || rayon::join(|| axis_events(1), || axis_events(2)),
        );
        Events {
            ev: [x, y, z],
            n: boxes.len(),
        }
    }

    /// The cheapest plane on `axis` (first of equal costs).
    fn sweep(&self, ev: &[u64], n: usize, axis: usize, cell: &Aabb) -> Option<Choice> {
        let ratios = AreaRatios::new(cell, axis)?;
        let (lo, hi) = (cell.min[axis], cell.max[axis]);
        let mut best: Option<Choice> = None;
        let (mut n_below, mut n_above) = (0usize, n);
        let mut i = 0;
        while i < ev.len() {
            let at = ev[i] >> 32;
            let mut count = [0usize; 3];
            while i < ev.len() && ev[i] >> 32 == at {
                count[events::kind(ev[i]) as usize] += 1;
                i += 1;
            }
            let [ends, planars, starts] = [
                count[END as usize],
                count[PLANAR as usize],
                count[START as usize],
            ];
            n_above -= planars + ends;
            let pos = events::pos(ev[i - 1]);
            if pos > lo && pos < hi {
                let (pb, pa) = ratios.at(pos);
                let below = self.cost.split(pb, n_below + planars, pa, n_above);
                let above = self.cost.split(pb, n_below, pa, n_above + planars);
                let (planar_below, cost) = if below <= above {
                    (true, below)
                } else {
                    (false, above)
                };
                if best.is_none_or(|b| cost < b.cost.unwrap_or(f64::INFINITY)) {
                    best = Some(Choice {
                        axis,
                        pos,
                        planar_below,
                        cost: Some(cost),
                    });
                }
            }
            n_below += starts + planars;
        }
        best
    }

    /// Splits `set` with the sides array `sides` (one entry per triangle).
    fn split_events(
        &self,
        set: Events,
        cell: &Aabb,
        c: &Choice,
        sides: &mut [u8],
        parallel: bool,
    ) -> (Events, Events) {
        let Events { ev, .. } = set;
        let (k, p) = (c.axis, c.pos);
        // Classify on the split axis's events (module docs).
        for &e in &ev[k] {
            sides[events::tri(e) as usize] = BOTH;
        }
        for &e in &ev[k] {
            let (t, at) = (events::tri(e) as usize, events::pos(e));
            match events::kind(e) {
                END if at <= p => sides[t] = BELOW,
                START if at >= p => sides[t] = ABOVE,
                PLANAR => {
                    sides[t] = if at < p || (at == p && c.planar_below) {
                        BELOW
                    } else {
                        ABOVE
                    };
                }
                _ => {}
            }
        }
        let sides = &*sides;
        // Straddling triangles: clip to each child's cell.
        let straddling: Vec<u32> = ev[k]
            .iter()
            .filter(|&&e| events::kind(e) == START && sides[events::tri(e) as usize] == BOTH)
            .map(|&e| events::tri(e))
            .collect();
        let clip = |t: u32| {
            let (b, a) = split_boxes(&self.triangles[t as usize], cell, k, p);
            (t, b, a)
        };
        let clipped: Vec<(u32, Option<Aabb>, Option<Aabb>)> = if parallel {
            straddling.par_iter().map(|&t| clip(t)).collect()
        } else {
            straddling.iter().map(|&t| clip(t)).collect()
        };
        let only = |side: u8| {
            ev[k]
                .iter()
                .filter(|&&e| events::kind(e) != END && sides[events::tri(e) as usize] == side)
                .count()
        };
        let nb = only(BELOW) + clipped.iter().filter(|c| c.1.is_some()).count();
        let na = only(ABOVE) + clipped.iter().filter(|c| c.2.is_some()).count();
        let split_axis = |axis: usize| {
            let (mut below, mut above) = (Vec::new(), Vec::new());
            for &e in &ev[axis] {
                match sides[events::tri(e) as usize] {
                    BELOW => below.push(e),
                    ABOVE => above.push(e),
                    _ => {}
                }
            }
            let (mut new_b, mut new_a) = (Vec::new(), Vec::new());
            for (t, b, a) in &clipped {
                if let Some(b) = b {
                    events::push(&mut new_b, b, axis, *t);
                }
                if let Some(a) = a {
                    events::push(&mut new_a, a, axis, *t);
                }
            }
            new_b.sort_unstable();
            new_a.sort_unstable();
            (events::merge(below, new_b), events::merge(above, new_a))
        };
        let ((xb, xa), ((yb, ya), (zb, za))) = if parallel {
            rayon::join(
                || split_axis(0),
                || rayon::join(|| split_axis(1), || split_axis(2)),
            )
        } else {
            (split_axis(0), (split_axis(1), split_axis(2)))
        };
        (
            Events {
                ev: [xb, yb, zb],
                n: nb,
            },
            Events {
                ev: [xa, ya, za],
                n: na,
            },
        )
    }
}

impl Splitter for EventSah<'_> {
    type Set = Events;

    fn count(&self, set: &Events) -> usize {
        set.n
    }

    fn bytes(&self, set: &Events) -> usize {
        set.ev.iter().map(|e| e.capacity() * 8).sum()
    }

    fn prims(&self, set: Events) -> Vec<u32> {
        let mut p: Vec<u32> = set.ev[0]
            .iter()
            .filter(|&&e| events::kind(e) != END)
            .map(|&e| events::tri(e))
            .collect();
        p.sort_unstable();
        p
    }

    fn choose(&self, set: &Events, cell: &Aabb) -> Option<Choice> {
        let sweep = |axis: usize| self.sweep(&set.ev[axis], set.n, axis, cell);
        let (x, (y, z)) = if set.n >= PARALLEL_MIN {
            rayon::join(|| sweep(0), || rayon::join(|| sweep(1), || sweep(2)))
        } else {
            (sweep(0), (sweep(1), sweep(2)))
        };
        // The cheapest; the lower axis on a tie.
        [x, y, z]
            .into_iter()
            .flatten()
            .fold(None, |best: Option<Choice>, c| match best {
                Some(b) if b.cost <= c.cost => Some(b),
                _ => Some(c),
            })
    }

    fn partition(&self, set: Events, cell: &Aabb, c: &Choice) -> (Events, Events) {
        if set.n >= PARALLEL_MIN {
            // Large cells split in parallel, so a shared, fresh sides array.
            let mut sides = vec![BOTH; self.triangles.len()];
            self.split_events(set, cell, c, &mut sides, true)
        } else {
            // Small cells run on one thread with no rayon calls inside, so
            // the thread's own array cannot be borrowed twice.
            SIDES.with_borrow_mut(|sides| {
                if sides.len() < self.triangles.len() {
                    sides.resize(self.triangles.len(), BOTH);
                }
                self.split_events(set, cell, c, sides, false)
            })
        }
    }
}
