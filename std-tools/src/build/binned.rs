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

/// The most bins per axis: the SAH builder's large cells use 256.
pub(super) const MAX_BINS: usize = 256;

/// The extremes of a cell's boxes, per axis: (lowest start, highest end).
type Extremes = ([f32; 3], [f32; 3]);

/// A tally of at most `B` bins per axis: row `2 axis` counts the boxes
/// starting in each bin, row `2 axis + 1` the boxes ending in it. Fixed
/// rows, on the stack: allocated per cell, the tally was a tenth of the
/// build, and fixed rows need no bounds checks.
struct Tally<const B: usize> {
    counts: [[u32; B]; 6],
    ext: Extremes,
}

impl<const B: usize> Tally<B> {
    const EMPTY: Tally<B> = Tally {
        counts: [[0; B]; 6],
        ext: ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]),
    };

    /// Counts `items` into `bins` (at most `B`) equal bins per axis of
    /// `cell`.
    fn count(&mut self, items: &[Item], cell: &Aabb, bins: usize) {
        let last = (bins - 1) as f32;
        let scale: [f32; 3] = std::array::from_fn(|a| bins as f32 / (cell.max[a] - cell.min[a]));
        let (lo, hi) = &mut self.ext;
        for it in items {
            let edge = [
                it.b.min[0],
                it.b.max[0],
                it.b.min[1],
                it.b.max[1],
                it.b.min[2],
                it.b.max[2],
            ];
            // The bin, clamped in floating point (`max` takes 0 for NaN,
            // a flat axis), so the conversion is exact and vectorises.
            let bin: [usize; 6] = std::array::from_fn(|k| {
                let x = (edge[k] - cell.min[k / 2]) * scale[k / 2];
                x.max(0.0).min(last) as u32 as usize
            });
            for (row, b) in self.counts.iter_mut().zip(bin) {
                // `b < bins <= B`: the mask only spares a bounds check.
                row[b % B] += 1;
            }
            for a in 0..3 {
                lo[a] = lo[a].min(it.b.min[a]);
                hi[a] = hi[a].max(it.b.max[a]);
            }
        }
    }

    /// Adds `o` (integer sums and extremes: the same whichever way the
    /// chunks are scheduled).
    fn add(mut self: Box<Self>, o: Box<Self>) -> Box<Self> {
        for (r, s) in self.counts.iter_mut().zip(&o.counts) {
            for (u, v) in r.iter_mut().zip(s) {
                *u += v;
            }
        }
        for a in 0..3 {
            self.ext.0[a] = self.ext.0[a].min(o.ext.0[a]);
            self.ext.1[a] = self.ext.1[a].max(o.ext.1[a]);
        }
        self
    }
}

/// The cheapest candidate plane of `cell` (first of equal costs): the bin
/// boundaries, and the planes through the boxes' extremes, which cut off
/// the cell's empty space as exactly as the event sweep does. At most
/// [`MAX_BINS`] bins.
pub(super) fn choose(items: &[Item], cell: &Aabb, bins: usize, cost: &CostModel) -> Option<Choice> {
    // Small cells near the leaves get fewer bins (about half their
    // triangles): pricing 31 planes per axis for 6 triangles was most of
    // the build, and the bunny's tree costs the same (32.8).
    let bins = bins.min(items.len() / 2 + 4).clamp(2, MAX_BINS);
    match bins {
        0..=8 => choose_in::<8, 10>(items, cell, bins, cost),
        9..=16 => choose_in::<16, 18>(items, cell, bins, cost),
        17..=32 => choose_in::<32, 34>(items, cell, bins, cost),
        _ => choose_in::<MAX_BINS, { MAX_BINS + 2 }>(items, cell, bins, cost),
    }
}

/// [`choose`] with at most `B` bins, `M` = `B + 2` candidates per axis.
fn choose_in<const B: usize, const M: usize>(
    items: &[Item],
    cell: &Aabb,
    bins: usize,
    cost: &CostModel,
) -> Option<Choice> {
    if items.len() >= PARALLEL_MIN {
        let t = items
            .par_chunks(PARALLEL_MIN)
            .map(|chunk| {
                let mut t = Box::new(Tally::<B>::EMPTY);
                t.count(chunk, cell, bins);
                t
            })
            .reduce_with(Tally::add)?;
        return price::<B, M>(&t, items.len(), cell, bins, cost);
    }
    let mut t = Tally::<B>::EMPTY;
    t.count(items, cell, bins);
    price::<B, M>(&t, items.len(), cell, bins, cost)
}

/// The cheapest plane given the tally `t` of `n` boxes (see [`choose`]);
/// the first of equal costs, in the order axis, then the lowest start, the
/// highest end and the bin boundaries going up. The candidates sit in
/// fixed lanes (unused ones on the cell's wall, never inside it) and are
/// priced in a straight loop, which the compiler vectorises: priced one
/// by one they were a sixth of the build.
fn price<const B: usize, const M: usize>(
    t: &Tally<B>,
    n: usize,
    cell: &Aabb,
    bins: usize,
    cost: &CostModel,
) -> Option<Choice> {
    let (lo_box, hi_box) = t.ext;
    let bins = bins.min(B);
    let mut fraction = [0.0f32; M];
    for (j, f) in fraction.iter_mut().enumerate().take(bins) {
        *f = j as f32 / bins as f32;
    }
    let mut best: Option<Choice> = None;
    for axis in 0..3 {
        let Some(ratios) = AreaRatios::new(cell, axis) else {
            continue;
        };
        let (starts, ends) = (&t.counts[2 * axis], &t.counts[2 * axis + 1]);
        let (lo, hi) = (cell.min[axis], cell.max[axis]);
        let mut pos = [lo; M];
        let mut below = [0.0f64; M];
        let mut above = [0.0f64; M];
        // Every box starts at or after the lowest start (boxes lying in
        // that plane go above), and ends at or before the highest end.
        (pos[0], below[0], above[0]) = (lo_box[axis], 0.0, n as f64);
        (pos[1], below[1], above[1]) = (hi_box[axis], n as f64, 0.0);
        let (mut nb, mut ended) = (0u32, 0u32);
        for j in 1..bins {
            nb += starts[j - 1];
            ended += ends[j - 1];
            pos[j + 1] = lo + (hi - lo) * fraction[j];
            below[j + 1] = f64::from(nb);
            above[j + 1] = (n - ended as usize) as f64;
        }
        let mut prices = [f64::INFINITY; M];
        for j in 0..M {
            let (pb, pa) = ratios.at(pos[j]);
            let p = cost.split_counts(pb, below[j], pa, above[j]);
            let inside = pos[j] > lo && pos[j] < hi;
            prices[j] = if inside { p } else { f64::INFINITY };
        }
        let least = prices.iter().fold(f64::INFINITY, |a, &b| a.min(b));
        if least == f64::INFINITY || best.is_some_and(|b| b.cost <= Some(least)) {
            continue;
        }
        let Some(j) = prices.iter().position(|&p| p == least) else {
            continue;
        };
        best = Some(Choice {
            axis,
            pos: pos[j],
            // Planar boxes at the lowest start go above, the others below.
            planar_below: j != 0,
            cost: Some(least),
        });
    }
    best
}
