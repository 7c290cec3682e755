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

/// Cells binned with at most this many bins per axis count on the stack:
/// a tally allocated per cell was a tenth of the build.
const STACK_BINS: usize = 32;

/// The extremes of a cell's boxes, per axis: (lowest start, highest end).
type Extremes = ([f32; 3], [f32; 3]);

/// The bin of a coordinate on one axis of a cell.
#[derive(Clone, Copy)]
struct Binning {
    min: [f32; 3],
    scale: [f32; 3],
    bins: usize,
}

impl Binning {
    fn new(cell: &Aabb, bins: usize) -> Binning {
        Binning {
            min: cell.min,
            scale: std::array::from_fn(|a| bins as f32 / (cell.max[a] - cell.min[a])),
            bins,
        }
    }

    #[inline]
    fn of(&self, x: f32, a: usize) -> usize {
        // `as` saturates: NaN (a flat axis) and negatives go to bin 0.
        (((x - self.min[a]) * self.scale[a]) as usize).min(self.bins - 1)
    }

    /// Counts `items` into `counts`: per axis, the boxes starting in each
    /// bin (`counts[2 bins axis..][..bins]`) and ending in each bin
    /// (`[bins..2 bins]`); returns the boxes' extremes.
    fn tally(&self, items: &[Item], counts: &mut [u32]) -> Extremes {
        let bins = self.bins;
        let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
        for it in items {
            for (a, ca) in counts.chunks_exact_mut(2 * bins).enumerate() {
                ca[self.of(it.b.min[a], a)] += 1;
                ca[bins + self.of(it.b.max[a], a)] += 1;
                lo[a] = lo[a].min(it.b.min[a]);
                hi[a] = hi[a].max(it.b.max[a]);
            }
        }
        (lo, hi)
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
    let binning = Binning::new(cell, bins);
    if items.len() >= PARALLEL_MIN {
        // Integer sums and extremes: the same whichever way the chunks
        // are scheduled.
        let (counts, ext) = items
            .par_chunks(PARALLEL_MIN)
            .map(|chunk| {
                let mut counts = vec![0u32; 6 * bins];
                let ext = binning.tally(chunk, &mut counts);
                (counts, ext)
            })
            .reduce_with(|(mut c, (lo, hi)), (d, (lo2, hi2))| {
                for (u, v) in c.iter_mut().zip(&d) {
                    *u += v;
                }
                let lo = std::array::from_fn(|a| lo[a].min(lo2[a]));
                let hi = std::array::from_fn(|a| hi[a].max(hi2[a]));
                (c, (lo, hi))
            })?;
        return price(&counts, ext, items.len(), cell, bins, cost);
    }
    if bins <= STACK_BINS {
        let mut counts = [0u32; 6 * STACK_BINS];
        let counts = &mut counts[..6 * bins];
        let ext = binning.tally(items, counts);
        return price(counts, ext, items.len(), cell, bins, cost);
    }
    let mut counts = vec![0u32; 6 * bins];
    let ext = binning.tally(items, &mut counts);
    price(&counts, ext, items.len(), cell, bins, cost)
}

/// The cheapest plane given the tally of `n` boxes (see [`choose`]); the
/// first of equal costs, in the order axis, then the lowest start, the
/// highest end and the bin boundaries going up. The prices are a straight
/// loop over the candidates, which the compiler vectorises (priced one by
/// one they were a sixth of the build).
fn price(
    counts: &[u32],
    ext: Extremes,
    n: usize,
    cell: &Aabb,
    bins: usize,
    cost: &CostModel,
) -> Option<Choice> {
    // Room for the two extremes and the bin boundaries, in fixed lanes
    // (unused ones lie on the cell's wall, never inside it): few for the
    // small cells, which are most of them.
    match bins {
        0..=14 => price_in::<16>(counts, ext, n, cell, bins, cost),
        15..=STACK_BINS => price_in::<{ STACK_BINS + 2 }>(counts, ext, n, cell, bins, cost),
        _ => price_in::<258>(counts, ext, n, cell, bins, cost),
    }
}

/// [`price`] with room for `M` candidates per axis (at most `M - 1` bins).
fn price_in<const M: usize>(
    counts: &[u32],
    (lo_box, hi_box): Extremes,
    n: usize,
    cell: &Aabb,
    bins: usize,
    cost: &CostModel,
) -> Option<Choice> {
    let m = (bins + 1).min(M);
    let mut best: Option<Choice> = None;
    for (axis, c) in counts.chunks_exact(2 * bins).enumerate() {
        let Some(ratios) = AreaRatios::new(cell, axis) else {
            continue;
        };
        let (lo, hi) = (cell.min[axis], cell.max[axis]);
        let mut pos = [lo; M];
        let mut below = [0.0f64; M];
        let mut above = [0.0f64; M];
        // Every box starts at or after the lowest start (boxes lying in
        // that plane go above), and ends at or before the highest end.
        (pos[0], below[0], above[0]) = (lo_box[axis], 0.0, n as f64);
        (pos[1], below[1], above[1]) = (hi_box[axis], n as f64, 0.0);
        let (mut nb, mut ended) = (0u32, 0u32);
        for j in 1..bins.min(m) {
            nb += c[j - 1];
            ended += c[bins + j - 1];
            pos[j + 1] = lo + (hi - lo) * (j as f32 / bins as f32);
            below[j + 1] = f64::from(nb);
            above[j + 1] = (n - ended as usize) as f64;
        }
        let mut prices = [f64::INFINITY; M];
        for j in 0..m {
            let (pb, pa) = ratios.at(pos[j]);
            let p = cost.split_counts(pb, below[j], pa, above[j]);
            let inside = pos[j] > lo && pos[j] < hi;
            prices[j] = if inside { p } else { f64::INFINITY };
        }
        let least = prices[..m].iter().fold(f64::INFINITY, |a, &b| a.min(b));
        if least == f64::INFINITY || best.is_some_and(|b| b.cost <= Some(least)) {
            continue;
        }
        let Some(j) = prices[..m].iter().position(|&p| p == least) else {
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
