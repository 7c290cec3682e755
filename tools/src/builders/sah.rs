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
//! ([perfect splits](super::clip); in cells of fewer than
//! `PERFECT_MIN` triangles their boxes are only cut by the plane), and
//! the new events, sorted, are merged
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
//!
//! The upper levels split the work: cells of at least `sweep_max`
//! triangles hold their clipped boxes instead of events and pick their
//! plane by [min-max binning](super::binned), counted and partitioned in
//! parallel chunks (perfect splits all the same); a cell below that size
//! sorts its events and is swept exactly from there down. Cells of fewer
//! than [`SMALL_MAX`] triangles drop their events again: they hold their
//! boxes and find the same plane by comparisons ([`small`]), which is
//! cheaper than keeping event lists sorted that near the leaves.
//!
//! Two builders share this code. `sweep` (Wald & Havran's, the exact
//! reference) bins above [`SWEEP_MAX`](super::thresholds::SWEEP_MAX) triangles only: the sweep and the
//! event split are O(N) per cell but serial per axis, which left one core
//! idle at the top of the tree. `sah`, the default, bins every cell down
//! to [`SMALL_MAX`] triangles ([`SWEEP_NONE`](super::thresholds::SWEEP_NONE)) and prices every box edge
//! exactly below: keeping event lists sorted through split after split
//! cost more than binning the same cells, and the greedy SAH's trees came
//! out no worse (bunny 28.95 against 29.07, sponza 53.57 against 53.70,
//! the 1.1M-triangle bunny 33.33 against 33.49; camera and random rays
//! within the noise), in 55-60% of the build time.
//!
//! Tried: a binary search per straddler's new event to merge it (12% of
//! the build; the merge is now a select while the one-sided events are
//! filtered); a two-pass sweep (counts gathered, then priced in a straight
//! loop): no gain. Thresholds between binning and the sweep, bunny tree
//! cost / CPU time: `sweep_max` 4096 29.073 / 311 ms, 512 29.111 / 298 ms,
//! 128 29.023 / 289 ms, 32 (no event cells) 28.946 / 256 ms.

use super::binned;
use super::boxes::{self};
use super::clip::{cut_box, split_boxes};
use super::cost::{AreaRatios, CostModel};
use super::events::{self, END, PLANAR, START};
use super::item::Item;
use super::small::{self};
use super::subdivide::{Choice, Splitter};
use super::thresholds::{PERFECT_MIN, SMALL_MAX};
use kdray_kernel::Bounds;
use kdray_kernel::Triangle;
use std::cell::RefCell;

/// A cell's triangles: their events on each axis, sorted, the three axes'
/// runs one after another in one buffer (one allocation per cell).
pub(super) struct Events {
    ev: Vec<u64>,
    /// Where the runs of axes 1 and 2 start.
    starts: [usize; 2],
    n: usize,
}

impl Events {
    /// The events on `axis`.
    fn axis(&self, axis: usize) -> &[u64] {
        let [one, two] = self.starts;
        match axis {
            0 => &self.ev[..one],
            1 => &self.ev[one..two],
            _ => &self.ev[two..],
        }
    }

    /// A cell without triangles.
    const EMPTY: Events = Events {
        ev: Vec::new(),
        starts: [0; 2],
        n: 0,
    };

    /// `BELOW` or `ABOVE` when every triangle goes to that side of the
    /// plane of `c` (module docs). Events at the plane sort ends, then
    /// planars, then starts: so the first event is planar when any is,
    /// and an end cannot come first (its start lies before the plane).
    fn one_side(&self, c: &Choice) -> Option<u8> {
        let on_k = self.axis(c.axis);
        let (&first, &last) = (on_k.first()?, on_k.last()?);
        let goes = |e: u64, side: bool| {
            let at = events::pos(e);
            at == c.pos && (events::kind(e) != PLANAR || c.planar_below == side)
        };
        if events::pos(first) > c.pos || goes(first, false) {
            Some(ABOVE)
        } else if events::pos(last) < c.pos || goes(last, true) {
            Some(BELOW)
        } else {
            None
        }
    }

    /// The events of `items`, sorted (one sort per axis; keys are unique,
    /// so the order does not depend on the sort).
    fn of_items(items: &[Item]) -> Events {
        // Written in place, run after run: no per-axis buffers to copy.
        let mut ev = Vec::with_capacity(6 * items.len());
        let mut starts = [0; 2];
        for axis in 0..3 {
            let from = ev.len();
            if axis > 0 {
                starts[axis - 1] = from;
            }
            for it in items {
                events::push(&mut ev, &it.b, axis, it.tri);
            }
            ev[from..].sort_unstable();
        }
        ev.shrink_to_fit();
        Events {
            ev,
            starts,
            n: items.len(),
        }
    }
}

/// Bins per axis in the cells binned: pricing the planes is O(bins), the
/// tally O(N) whatever the bins, so many bins cost nothing in cells this
/// large. Bunny / fandisk / 1M-bunny tree cost: 29.41 / 24.43 / 33.59
/// with 32 bins, 28.87 / 23.76 / 33.37 with 256 (the full sweep: 29.02 /
/// 24.30 / 34.06); 64 to 512 bins scatter within those.
const BINS: usize = 256;

/// The SAH splitter: binning in cells of at least `sweep_max` triangles,
/// the event sweep below, comparisons in small cells.
pub(super) struct EventSah<'a> {
    pub(super) triangles: &'a [Triangle],
    pub(super) cost: CostModel,
    /// [`SWEEP_MAX`](super::thresholds::SWEEP_MAX) (`sweep`) or [`SWEEP_NONE`](super::thresholds::SWEEP_NONE) (`sah`).
    pub(super) sweep_max: usize,
}

/// A cell's triangles: clipped boxes in a large cell, events in a small one.
pub(super) enum Cell {
    /// At least `sweep_max` triangles, in index order.
    Boxes(Vec<Item>),
    /// Fewer, as sorted events.
    Events(Events),
    /// Fewer than [`SMALL_MAX`], in index order: the exact SAH by
    /// comparisons ([`small`](super::small)).
    Small(Vec<Item>),
}

impl Cell {
    /// The cell of `items`: boxes if at least `sweep_max`, items if small,
    /// else their events.
    fn of_items(items: Vec<Item>, sweep_max: usize) -> Cell {
        if items.len() >= sweep_max.max(SMALL_MAX) {
            Cell::Boxes(items)
        } else if items.len() < SMALL_MAX {
            Cell::Small(items)
        } else {
            Cell::Events(Events::of_items(&items))
        }
    }
}

/// Where a triangle goes (the classification of the split step).
const BOTH: u8 = 0;
const BELOW: u8 = 1;
const ABOVE: u8 = 2;

/// A straddling triangle and its boxes in the cells below and above.
type Clipped = (u32, Option<Bounds>, Option<Bounds>);

/// The reusable buffers of one split, so small cells allocate only their
/// children's event lists.
#[derive(Default)]
struct Scratch {
    /// The sides of the triangles of the cell being split (indexed by
    /// triangle; only the cell's own entries are written, then read).
    sides: Vec<u8>,
    /// The straddling triangles.
    straddlers: Vec<u32>,
    /// The straddling triangles, clipped.
    clipped: Vec<Clipped>,
    /// The straddlers' new events, below and above, axis after axis.
    new: [Vec<u64>; 2],
    /// The one-sided events kept below and above, axis after axis.
    kept: [Vec<u64>; 2],
    /// Where each triangle's item is in a small child being made (indexed
    /// by triangle, like `sides`).
    slot: Vec<u32>,
}

thread_local! {
    /// Per-thread buffers for the cells split on one thread.
    static SCRATCH: RefCell<Scratch> = RefCell::new(Scratch::default());
}

/// Appends to `out` the merge of two sorted runs: `kept` (a side's
/// one-sided events on one axis) and `new` (the straddlers' new events).
/// The smaller head is picked by a select, not a branch: which run it
/// comes from is unpredictable. (Binary-searching each new event's place
/// was slower: straddlers are a third of a small cell's triangles.)
fn merge_into(out: &mut Vec<u64>, kept: &[u64], new: &[u64]) {
    let (mut i, mut j) = (0, 0);
    while let (Some(&a), Some(&b)) = (kept.get(i), new.get(j)) {
        // Keys are unique, so the merge order is the sort order.
        let take_kept = a < b;
        out.push(if take_kept { a } else { b });
        i += usize::from(take_kept);
        j += usize::from(!take_kept);
    }
    out.extend_from_slice(&kept[i..]);
    out.extend_from_slice(&new[j..]);
}

/// One child's events as sorted runs, per axis: its kept one-sided events
/// (`kept`, axis runs ending at `kept_ends`) and the straddlers' new ones
/// (`new`, runs ending at `new_ends`).
struct ChildRuns<'a> {
    kept: &'a [u64],
    kept_ends: [usize; 3],
    new: &'a [u64],
    new_ends: [usize; 3],
}

impl ChildRuns<'_> {
    /// Axis `axis`'s two runs: kept, new.
    fn axis(&self, axis: usize) -> (&[u64], &[u64]) {
        let (k, j) = match axis {
            0 => (0, 0),
            _ => (self.kept_ends[axis - 1], self.new_ends[axis - 1]),
        };
        (
            &self.kept[k..self.kept_ends[axis]],
            &self.new[j..self.new_ends[axis]],
        )
    }

    /// The child's events: per axis, the merge of its two runs, in one
    /// exactly sized buffer.
    fn events(&self, n: usize) -> Events {
        let mut ev = Vec::with_capacity(self.kept_ends[2] + self.new_ends[2]);
        let mut starts = [0; 2];
        for axis in 0..3 {
            if axis > 0 {
                starts[axis - 1] = ev.len();
            }
            let (kept, new) = self.axis(axis);
            merge_into(&mut ev, kept, new);
        }
        Events { ev, starts, n }
    }

    /// A small child's items: each triangle's box is read off its events,
    /// so nothing is merged. `slot` is scratch indexed by triangle.
    fn items(&self, slot: &mut [u32]) -> Vec<Item> {
        // The triangles in index order (a leaf lists them sorted): each has
        // one event on axis 0 that is not an end.
        let (kept0, new0) = self.axis(0);
        let mut items: Vec<Item> = kept0
            .iter()
            .chain(new0)
            .filter(|&&e| events::kind(e) != END)
            .map(|&e| Item {
                tri: events::tri(e),
                b: Bounds::EMPTY,
            })
            .collect();
        items.sort_unstable_by_key(|it| it.tri);
        for (i, it) in items.iter().enumerate() {
            if let Some(s) = slot.get_mut(it.tri as usize) {
                *s = i as u32;
            }
        }
        for axis in 0..3 {
            let (kept, new) = self.axis(axis);
            for &e in kept.iter().chain(new) {
                let s = slot.get(events::tri(e) as usize);
                let Some(it) = s.and_then(|&s| items.get_mut(s as usize)) else {
                    continue;
                };
                let at = events::pos(e);
                match events::kind(e) {
                    START => it.b.min[axis] = at,
                    END => it.b.max[axis] = at,
                    _ => (it.b.min[axis], it.b.max[axis]) = (at, at),
                }
            }
        }
        items
    }

    /// The child cell of `n` triangles: small ones as items
    /// ([`small`](super::small)), the others as events.
    fn cell(&self, n: usize, slot: &mut [u32]) -> Cell {
        if n < SMALL_MAX {
            Cell::Small(self.items(slot))
        } else {
            Cell::Events(self.events(n))
        }
    }
}

impl EventSah<'_> {
    /// The boxes of triangle `t`, straddling the plane at `pos` on `axis`,
    /// in the children of `cell` (a cell of `n` triangles): clipped in
    /// cells of at least [`PERFECT_MIN`] triangles, else the triangle's
    /// box in the cell cut by the plane.
    fn straddler(
        &self,
        n: usize,
        t: u32,
        cell: &Bounds,
        axis: usize,
        pos: f32,
    ) -> (Option<Bounds>, Option<Bounds>) {
        let tri = &self.triangles[t as usize];
        if n >= PERFECT_MIN {
            split_boxes(tri, cell, axis, pos)
        } else {
            cut_box(&tri.hit_bounds().intersect(cell), cell, axis, pos)
        }
    }

    /// The root cell from the triangles' boxes.
    pub(super) fn root(&self, boxes: &[Bounds]) -> Cell {
        Cell::of_items(boxes::BoxSplitter::root(boxes), self.sweep_max)
    }

    /// The cheapest plane on `axis` (first of equal costs).
    fn sweep(&self, ev: &[u64], n: usize, axis: usize, cell: &Bounds) -> Option<Choice> {
        let ratios = AreaRatios::new(cell, axis)?;
        // Planes strictly inside the cell, compared as position keys: the
        // key order is the position order, so no event is decoded to test it.
        let (lo, hi) = (
            events::position_key(cell.min[axis]),
            events::position_key(cell.max[axis]),
        );
        let mut best: Option<Choice> = None;
        let mut best_cost = f64::INFINITY;
        let (mut n_below, mut n_above) = (0usize, n);
        let mut i = 0;
        while let Some(&first) = ev.get(i) {
            let at = events::position_key_of(first);
            // The events at this position, counted by kind in registers.
            let (mut ends, mut planars, mut starts) = (0usize, 0usize, 0usize);
            while let Some(&e) = ev.get(i).filter(|&&e| events::position_key_of(e) == at) {
                let kind = events::kind(e);
                ends += usize::from(kind == END);
                planars += usize::from(kind == PLANAR);
                starts += usize::from(kind == START);
                i += 1;
            }
            n_above -= planars + ends;
            if at > lo && at < hi {
                let pos = events::pos(first);
                let (pb, pa) = ratios.at(pos);
                let (cost, planar_below) =
                    self.cost.split_planar(pb, n_below, pa, n_above, planars);
                if best.is_none() || cost < best_cost {
                    best_cost = cost;
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

    /// Splits `set` with the buffers `scratch` (whose sides array has an
    /// entry per triangle).
    fn split_events(
        &self,
        set: &Events,
        cell: &Bounds,
        c: &Choice,
        scratch: &mut Scratch,
    ) -> (Cell, Cell) {
        let (k, p) = (c.axis, c.pos);
        let on_k = set.axis(k);
        let sides = &mut scratch.sides;
        // Classify on the split axis's events (module docs), in one pass:
        // a box's start sorts before its end, so a triangle is first taken
        // as straddling and settled at its end. One event per triangle is
        // not an end, so each triangle is counted once.
        let (mut nb, mut na) = (0, 0);
        let straddlers = &mut scratch.straddlers;
        straddlers.clear();
        for &e in on_k {
            let (t, at) = (events::tri(e), events::pos(e));
            let side = &mut sides[t as usize];
            match events::kind(e) {
                START if at >= p => *side = ABOVE,
                START => *side = BOTH,
                END if *side == BOTH && at <= p => *side = BELOW,
                END if *side == BOTH => straddlers.push(t),
                END => continue,
                _ => {
                    *side = if at < p || (at == p && c.planar_below) {
                        BELOW
                    } else {
                        ABOVE
                    }
                }
            }
            match *side {
                BELOW => nb += 1,
                ABOVE => na += 1,
                _ => {}
            }
        }
        let sides = &*sides;
        // Straddling triangles: clip to each child's cell.
        let clip = |&t: &u32| {
            let (b, a) = self.straddler(set.n, t, cell, k, p);
            (t, b, a)
        };
        let clipped = &mut scratch.clipped;
        clipped.clear();
        clipped.extend(straddlers.iter().map(clip));
        let clipped = &*clipped;
        nb += clipped.iter().filter(|c| c.1.is_some()).count();
        na += clipped.iter().filter(|c| c.2.is_some()).count();
        // The one-sided events, filtered without a branch per event:
        // each is written to both sides and kept where its triangle goes
        // (a straddler's old events are kept by neither).
        let ev = &set.ev;
        let [kb, ka] = &mut scratch.kept;
        if kb.len() < ev.len() {
            kb.resize(ev.len(), 0);
            ka.resize(ev.len(), 0);
        }
        let (mut ib, mut ia) = (0, 0);
        let (mut kept_b, mut kept_a) = ([0; 3], [0; 3]);
        let [one, two] = set.starts;
        for (axis, run) in [&ev[..one], &ev[one..two], &ev[two..]]
            .into_iter()
            .enumerate()
        {
            for &e in run {
                let side = sides[events::tri(e) as usize];
                kb[ib] = e;
                ka[ia] = e;
                ib += usize::from(side == BELOW);
                ia += usize::from(side == ABOVE);
            }
            (kept_b[axis], kept_a[axis]) = (ib, ia);
        }
        // The straddlers' new events, each axis's run sorted.
        let [new_b, new_a] = &mut scratch.new;
        new_b.clear();
        new_a.clear();
        let (mut ends_b, mut ends_a) = ([0; 3], [0; 3]);
        for axis in 0..3 {
            let (fb, fa) = (new_b.len(), new_a.len());
            for (t, b, a) in clipped {
                if let Some(b) = b {
                    events::push(new_b, b, axis, *t);
                }
                if let Some(a) = a {
                    events::push(new_a, a, axis, *t);
                }
            }
            new_b[fb..].sort_unstable();
            new_a[fa..].sort_unstable();
            (ends_b[axis], ends_a[axis]) = (new_b.len(), new_a.len());
        }
        let slot = &mut scratch.slot;
        let below = ChildRuns {
            kept: kb,
            kept_ends: kept_b,
            new: new_b,
            new_ends: ends_b,
        };
        let above = ChildRuns {
            kept: ka,
            kept_ends: kept_a,
            new: new_a,
            new_ends: ends_a,
        };
        (below.cell(nb, slot), above.cell(na, slot))
    }
}

impl EventSah<'_> {
    fn choose_events(&self, set: &Events, cell: &Bounds) -> Option<Choice> {
        // The cheapest; the lower axis on a tie.
        (0..3)
            .filter_map(|axis| self.sweep(set.axis(axis), set.n, axis, cell))
            .fold(None, |best: Option<Choice>, c| match best {
                Some(b) if b.cost <= c.cost => Some(b),
                _ => Some(c),
            })
    }

    fn partition_events(&self, set: Events, cell: &Bounds, c: &Choice) -> (Cell, Cell) {
        // A plane that cuts off empty space (more than half the splits
        // near the leaves): one side takes every event as it is.
        match set.one_side(c) {
            Some(BELOW) => return (Cell::Events(set), Cell::Events(Events::EMPTY)),
            Some(_) => return (Cell::Events(Events::EMPTY), Cell::Events(set)),
            None => {}
        }
        // No rayon calls while the thread's own buffers are borrowed (the
        // subtrees' joins come after the split), so they cannot be
        // borrowed twice.
        SCRATCH.with_borrow_mut(|scratch| {
            if scratch.sides.len() < self.triangles.len() {
                scratch.sides.resize(self.triangles.len(), BOTH);
                scratch.slot.resize(self.triangles.len(), 0);
            }
            self.split_events(&set, cell, c, scratch)
        })
    }
}

impl Splitter for EventSah<'_> {
    type Set = Cell;

    fn count(&self, set: &Cell) -> usize {
        match set {
            Cell::Boxes(items) | Cell::Small(items) => items.len(),
            Cell::Events(ev) => ev.n,
        }
    }

    fn bytes(&self, set: &Cell) -> usize {
        match set {
            Cell::Boxes(items) | Cell::Small(items) => boxes::bytes(items),
            Cell::Events(ev) => ev.ev.capacity() * 8,
        }
    }

    fn prims(&self, set: Cell) -> Vec<u32> {
        match set {
            Cell::Boxes(items) | Cell::Small(items) => boxes::prims(items),
            Cell::Events(ev) => {
                let mut p: Vec<u32> = ev
                    .axis(0)
                    .iter()
                    .filter(|&&e| events::kind(e) != END)
                    .map(|&e| events::tri(e))
                    .collect();
                p.sort_unstable();
                p
            }
        }
    }

    fn choose(&self, set: &Cell, cell: &Bounds) -> Option<Choice> {
        match set {
            Cell::Boxes(items) => binned::choose(items, cell, BINS, &self.cost),
            Cell::Events(ev) => self.choose_events(ev, cell),
            Cell::Small(items) => small::choose(items, cell, &self.cost),
        }
    }

    fn partition(&self, set: Cell, cell: &Bounds, c: &Choice) -> (Cell, Cell) {
        match set {
            Cell::Boxes(items) => {
                // Perfect splits: straddlers clipped to each child's cell.
                let (b, a) = boxes::partition(items, c, |it| {
                    split_boxes(&self.triangles[it.tri as usize], cell, c.axis, c.pos)
                });
                let m = self.sweep_max;
                rayon::join(|| Cell::of_items(b, m), || Cell::of_items(a, m))
            }
            Cell::Events(ev) => self.partition_events(ev, cell, c),
            Cell::Small(items) => {
                let n = items.len();
                let (b, a) = boxes::partition(items, c, |it| {
                    self.straddler(n, it.tri, cell, c.axis, c.pos)
                });
                (Cell::Small(b), Cell::Small(a))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::thresholds::SWEEP_MAX;
    use super::*;
    use crate::rng::Rng;

    /// Boxes on a coarse grid inside the cell: shared edges, boxes lying
    /// in planes, boxes touching the walls.
    fn cell_items(rng: &mut Rng, n: usize) -> Vec<Item> {
        let coord = |rng: &mut Rng| rng.below(9) as f32;
        (0..n as u32)
            .map(|tri| {
                let (mut min, mut max) = ([0.0; 3], [0.0; 3]);
                for a in 0..3 {
                    let (x, y) = (coord(rng), coord(rng));
                    (min[a], max[a]) = (x.min(y), x.max(y));
                }
                Item {
                    tri,
                    b: Bounds { min, max },
                }
            })
            .collect()
    }

    #[test]
    fn small_cells_choose_the_sweeps_plane() {
        let s = EventSah {
            triangles: &[],
            cost: CostModel::from_params(&super::super::BuildParams::default()),
            sweep_max: SWEEP_MAX,
        };
        let cell = Bounds {
            min: [0.0; 3],
            max: [8.0, 8.0, 8.0],
        };
        let mut rng = Rng::new(3);
        let mut splits = 0;
        for round in 0..2000 {
            let items = cell_items(&mut rng, 1 + round % (SMALL_MAX - 1));
            let sweep = s.choose_events(&Events::of_items(&items), &cell);
            let small = small::choose(&items, &cell, &s.cost);
            let key =
                |c: Option<Choice>| c.map(|c| (c.axis, c.pos.to_bits(), c.planar_below, c.cost));
            assert_eq!(key(sweep), key(small), "round {round}: {items:?}");
            splits += usize::from(small.is_some());
        }
        assert!(splits > 1000, "{splits}");
    }
}
