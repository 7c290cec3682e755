//! The binned SAH rule (Shevtsov, Soupikov and Kapustin, "Highly parallel
//! fast kd-tree construction for interactive ray tracing of dynamic
//! scenes", 2007): min-max binning. Each axis of the cell is cut into equal
//! bins; one pass counts, per bin, the boxes starting in it and the boxes
//! ending in it; prefix sums then give the triangles below and above every
//! bin boundary, which are the candidate planes. O(N) per cell, no sort:
//! for fast rebuilds, at a small loss of tree quality.

use super::aabb::Aabb;
use super::boxes::Item;
use super::cost::{AreaRatios, CostModel};
use super::subdivide::{Choice, PARALLEL_MIN};
use rayon::prelude::*;

/// One pass's tally: per axis, the boxes starting in each bin
/// (`counts[2 bins axis..][0..bins]`) and ending in each bin
/// (`[bins..2 bins]`), and the extremes of the boxes. One allocation: per
/// small cell, three were a tenth of the build.
struct Tally {
    counts: Vec<u32>,
    lo: [f32; 3],
    hi: [f32; 3],
}

impl Tally {
    /// The sum of two tallies (integer sums and extremes: the same
    /// whichever way the chunks are scheduled).
    fn add(mut self, o: Tally) -> Tally {
        for (u, v) in self.counts.iter_mut().zip(&o.counts) {
            *u += v;
        }
        for a in 0..3 {
            self.lo[a] = self.lo[a].min(o.lo[a]);
            self.hi[a] = self.hi[a].max(o.hi[a]);
        }
        self
    }
}

/// The cheapest candidate plane of `cell` (first of equal costs): the bin
/// boundaries, and the planes through the boxes' extremes, which cut off
/// the cell's empty space as exactly as the event sweep does.
pub(super) fn choose(items: &[Item], cell: &Aabb, bins: usize, cost: &CostModel) -> Option<Choice> {
    // Small cells near the leaves get fewer bins (about half their
    // triangles): pricing 31 planes per axis for 6 triangles was most of
    // the build, and the bunny's tree costs the same (32.8).
    let bins = bins.min(items.len() / 2 + 4).max(2);
    let scale: [f32; 3] = std::array::from_fn(|a| bins as f32 / (cell.max[a] - cell.min[a]));
    let bin_of = |x: f32, a: usize| {
        // `as` saturates: NaN (a flat axis) and negatives go to bin 0.
        (((x - cell.min[a]) * scale[a]) as usize).min(bins - 1)
    };
    let tally = |chunk: &[Item]| {
        let mut t = Tally {
            counts: vec![0u32; 6 * bins],
            lo: [f32::INFINITY; 3],
            hi: [f32::NEG_INFINITY; 3],
        };
        for it in chunk {
            for (a, ca) in t.counts.chunks_exact_mut(2 * bins).enumerate() {
                ca[bin_of(it.b.min[a], a)] += 1;
                ca[bins + bin_of(it.b.max[a], a)] += 1;
                t.lo[a] = t.lo[a].min(it.b.min[a]);
                t.hi[a] = t.hi[a].max(it.b.max[a]);
            }
        }
        t
    };
    let t = if items.len() >= PARALLEL_MIN {
        items
            .par_chunks(PARALLEL_MIN)
            .map(tally)
            .reduce_with(Tally::add)?
    } else {
        tally(items)
    };
    let n = items.len();
    let mut best: Option<Choice> = None;
    for (axis, c) in t.counts.chunks_exact(2 * bins).enumerate() {
        let Some(ratios) = AreaRatios::new(cell, axis) else {
            continue;
        };
        let (lo, hi) = (cell.min[axis], cell.max[axis]);
        let mut consider = |pos: f32, below: usize, above: usize, planar_below: bool| {
            if !(pos > lo && pos < hi) {
                return;
            }
            let (pb, pa) = ratios.at(pos);
            let cost = cost.split(pb, below, pa, above);
            if best.is_none_or(|b| Some(cost) < b.cost) {
                best = Some(Choice {
                    axis,
                    pos,
                    planar_below,
                    cost: Some(cost),
                });
            }
        };
        // Every box starts at or after the lowest start (boxes lying in
        // that plane go above), and ends at or before the highest end.
        consider(t.lo[axis], 0, n, false);
        consider(t.hi[axis], n, 0, true);
        let (mut below, mut ended) = (0usize, 0usize);
        for j in 1..bins {
            below += c[j - 1] as usize;
            ended += c[bins + j - 1] as usize;
            let pos = lo + (hi - lo) * (j as f32 / bins as f32);
            consider(pos, below, n - ended, true);
        }
    }
    best
}
