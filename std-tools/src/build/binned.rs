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

/// Counts per axis: `[starts in bin 0..bins, ends in bin 0..bins]`.
type Counts = [Vec<u32>; 3];

/// The cheapest bin boundary of `cell` (first of equal costs).
pub(super) fn choose(items: &[Item], cell: &Aabb, bins: usize, cost: &CostModel) -> Option<Choice> {
    let bins = bins.max(2);
    let bin_of = |x: f32, a: usize| {
        let (lo, hi) = (cell.min[a], cell.max[a]);
        let f = (x - lo) / (hi - lo) * bins as f32;
        // `as` saturates: NaN (a flat axis) and negatives go to bin 0.
        (f as usize).min(bins - 1)
    };
    let count = |chunk: &[Item]| {
        let mut c: Counts = std::array::from_fn(|_| vec![0u32; 2 * bins]);
        for it in chunk {
            for (a, ca) in c.iter_mut().enumerate() {
                ca[bin_of(it.b.min[a], a)] += 1;
                ca[bins + bin_of(it.b.max[a], a)] += 1;
            }
        }
        c
    };
    let add = |mut x: Counts, y: Counts| {
        for (xa, ya) in x.iter_mut().zip(&y) {
            for (u, v) in xa.iter_mut().zip(ya) {
                *u += v;
            }
        }
        x
    };
    // Integer sums: the same counts however the chunks are scheduled.
    let counts = if items.len() >= PARALLEL_MIN {
        items.par_chunks(PARALLEL_MIN).map(count).reduce_with(add)?
    } else {
        count(items)
    };
    let n = items.len();
    let mut best: Option<Choice> = None;
    for (axis, c) in counts.iter().enumerate() {
        let Some(ratios) = AreaRatios::new(cell, axis) else {
            continue;
        };
        let (lo, hi) = (cell.min[axis], cell.max[axis]);
        let (mut below, mut ended) = (0usize, 0usize);
        for j in 1..bins {
            below += c[j - 1] as usize;
            ended += c[bins + j - 1] as usize;
            let pos = lo + (hi - lo) * (j as f32 / bins as f32);
            if !(pos > lo && pos < hi) {
                continue;
            }
            let (pb, pa) = ratios.at(pos);
            let cost = cost.split(pb, below, pa, n - ended);
            if best.is_none_or(|b| Some(cost) < b.cost) {
                best = Some(Choice {
                    axis,
                    pos,
                    planar_below: true,
                    cost: Some(cost),
                });
            }
        }
    }
    best
}
