//! The binned SAH rule (Shevtsov, Soupikov and Kapustin, "Highly parallel
//! fast kd-tree construction for interactive ray tracing of dynamic
//! scenes", 2007): min-max binning. Each axis of the cell is cut into equal
//! bins; one pass counts, per bin, the boxes starting in it and the boxes
//! ending in it; prefix sums then give the triangles below and above every
//! bin boundary, which are the candidate planes. O(N) per cell, no sort:
//! for fast rebuilds, at a small loss of tree quality.

// What paid (bunny, one thread): fixed tally rows on the stack, an item's
// six bins in one `f32x8` clamped in floating point, every candidate of
// the three axes priced in fixed lanes with the fractions divided eight at
// a time, `MIN_GAIN` (below), straddlers cut rather than clipped, leaves
// copying their triangles into their own lists, 32-byte items (28-byte
// copies stalled store forwarding). Tried and dropped:
// - 8 or 16 bins instead of 32: no faster once the fractions are divided
//   in lanes, tree cost up to +2.6% (fandisk, lost-empire); fewer bins in
//   small cells (n/4 + 2): -1% build, +0.2-0.5% cost;
// - cutting triangles from 64 triangles instead of 32: 4-7% faster, +1-1.6%
//   tree cost; from 8 or 16: more nodes, 10-15% slower; in every cell, with
//   or without exact clipping above 64 / 256: 7-13% slower;
// - only cutting boxes, never triangles: tree cost +13%;
// - binning only the widest axis: 1.5-2.5x faster, trees 17-36% dearer;
// - `MIN_GAIN` 0.2: a third faster again, tree cost +17%;
// - two tallies (odd and even boxes, so increments of one bin do not wait
//   on each other), power-of-two list capacities: no change.

use super::cost::{least_price, AreaRatios, CostModel};
use super::item::Item;
use super::subdivide::Choice;
use super::thresholds::{MIN_GAIN, PARALLEL_MIN};
use kdray_kernel::Bounds;
use rayon::prelude::*;
use wide::f32x8;

/// The binned builder's plane for `cell`: [`choose`]'s, if it saves
/// [`MIN_GAIN`] of the leaf's cost.
pub(super) fn choose_saving(
    items: &[Item],
    cell: &Bounds,
    bins: usize,
    cost: &CostModel,
) -> Option<Choice> {
    let most = cost.leaf(items.len()) * (1.0 - MIN_GAIN);
    // No split costs less than a traversal step (with the empty-cell
    // bonus): no plane to price for a leaf this cheap (one triangle, with
    // the default costs).
    if cost.empty_factor.min(1.0) * cost.traversal >= most {
        return None;
    }
    choose(items, cell, bins, cost).filter(|c| c.cost.is_some_and(|x| x < most))
}

/// The most bins per axis: the SAH builder's large cells use 256.
pub(super) const MAX_BINS: usize = 256;

/// The extremes of a cell's boxes, per axis: (lowest start, highest end).
type Extremes = ([f32; 3], [f32; 3]);

/// A tally of at most `B` bins per axis: row `axis` counts the boxes
/// starting in each bin, row `3 + axis` the boxes ending in it. Fixed
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
    fn count(&mut self, items: &[Item], cell: &Bounds, bins: usize) {
        // Eight lanes: the box's six edges as they lie in memory (starts,
        // then ends), and two unused.
        let lanes = |v: [f32; 3]| f32x8::from([v[0], v[1], v[2], v[0], v[1], v[2], 0.0, 0.0]);
        let base = lanes(cell.min);
        let scale = lanes(std::array::from_fn(|a| {
            bins as f32 / (cell.max[a] - cell.min[a])
        }));
        let last = f32x8::splat((bins - 1) as f32);
        let (mut lo, mut hi) = (f32x8::splat(f32::INFINITY), f32x8::splat(f32::NEG_INFINITY));
        for it in items {
            let (s, e) = (it.b.min, it.b.max);
            let edge = f32x8::from([s[0], s[1], s[2], e[0], e[1], e[2], 0.0, 0.0]);
            // The bins, clamped in floating point (`fast_max` takes the
            // 0 for a NaN from a flat axis), so the truncation is exact.
            let x = ((edge - base) * scale).fast_max(f32x8::ZERO).fast_min(last);
            let bin = x.fast_trunc_int().to_array();
            for (row, &b) in self.counts.iter_mut().zip(&bin) {
                // `b < bins <= B`: the mask only spares a bounds check.
                row[b as usize % B] += 1;
            }
            // Box edges are finite: no NaN to take care of.
            lo = lo.fast_min(edge);
            hi = hi.fast_max(edge);
        }
        let (lo, hi) = (lo.to_array(), hi.to_array());
        for a in 0..3 {
            self.ext.0[a] = self.ext.0[a].min(lo[a]);
            self.ext.1[a] = self.ext.1[a].max(hi[3 + a]);
        }
    }

    /// Adds `o` (integer sums and extremes: the same whichever way the
    /// chunks are scheduled).
    fn add(mut self: Box<Self>, o: &Self) -> Box<Self> {
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
pub(super) fn choose(
    items: &[Item],
    cell: &Bounds,
    bins: usize,
    cost: &CostModel,
) -> Option<Choice> {
    // Small cells near the leaves get fewer bins (about half their
    // triangles): pricing 31 planes per axis for 6 triangles was most of
    // the build, and the bunny's tree costs the same (32.8).
    let bins = bins.min(items.len() / 2 + 4).clamp(2, MAX_BINS);
    match bins {
        0..=7 => choose_in::<8, 8>(items, cell, bins, cost),
        8..=15 => choose_in::<16, 16>(items, cell, bins, cost),
        16..=31 => choose_in::<32, 32>(items, cell, bins, cost),
        32 => choose_in::<32, 40>(items, cell, bins, cost),
        _ => choose_in::<MAX_BINS, { MAX_BINS + 8 }>(items, cell, bins, cost),
    }
}

/// [`choose`] with at most `B` bins, `M` > `bins` candidates per axis (a
/// multiple of 8: whole vectors).
fn choose_in<const B: usize, const M: usize>(
    items: &[Item],
    cell: &Bounds,
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
            .reduce_with(|t, o| t.add(&o))?;
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
    cell: &Bounds,
    bins: usize,
    cost: &CostModel,
) -> Option<Choice> {
    let (lo_box, hi_box) = t.ext;
    let bins = bins.min(B);
    // Lane 0: the lowest start, lane 1: the highest end, lane `j + 1`: the
    // boundary after bin `j - 1`; unused lanes sit on the cell's wall.
    let mut fraction = [0.0f32; M];
    // Eight true divisions at a time: the same quotients as one by one,
    // where a chain of `divss` was a third of the pricing (bunny binned
    // build 44.2 -> 42.4 ms, one thread, best of 8 interleaved). Whole
    // chunks of eight fill every candidate: `choose` picks such `M`s.
    const { assert!(M.is_multiple_of(8), "M must be whole chunks of 8 lanes") };
    let (count, denom) = (
        f32x8::from([0., 1., 2., 3., 4., 5., 6., 7.]),
        f32x8::splat(bins as f32),
    );
    for (c, chunk) in fraction.chunks_exact_mut(8).enumerate() {
        let j = f32x8::splat((8 * c) as f32) + count;
        let used = j.simd_ge(f32x8::splat(2.0)) & j.simd_le(denom);
        let f = (j - f32x8::ONE) / denom;
        chunk.copy_from_slice(&used.select(f, f32x8::ZERO).to_array());
    }
    let area = cell.area();
    // All three axes' prices, so one search finds the cheapest: the first
    // of equal prices is the lowest axis, then the lowest lane.
    let mut prices = [[f64::INFINITY; M]; 3];
    let mut pos = [[0.0f32; M]; 3];
    for axis in 0..3 {
        let Some(ratios) = AreaRatios::with_area(cell, axis, area) else {
            continue;
        };
        let (starts, ends) = (&t.counts[axis], &t.counts[3 + axis]);
        let (lo, hi) = (cell.min[axis], cell.max[axis]);
        // Every box starts at or after the lowest start (boxes lying in
        // that plane go above), and ends at or before the highest end.
        let (mut below, mut ended) = ([0u32; M], [0u32; M]);
        (below[1], ended[1]) = (n as u32, n as u32);
        let (mut nb, mut ne) = (0u32, 0u32);
        for j in 1..bins {
            nb += starts[j - 1];
            ne += ends[j - 1];
            (below[j + 1], ended[j + 1]) = (nb, ne);
        }
        let pos = &mut pos[axis];
        for j in 0..M {
            pos[j] = lo + (hi - lo) * fraction[j];
        }
        (pos[0], pos[1]) = (lo_box[axis], hi_box[axis]);
        for j in 0..M {
            let (pb, pa) = ratios.at(pos[j]);
            let (nb, na) = (f64::from(below[j]), f64::from(n as u32 - ended[j]));
            let p = cost.split_counts(pb, nb, pa, na);
            let inside = pos[j] > lo && pos[j] < hi;
            prices[axis][j] = if inside { p } else { f64::INFINITY };
        }
    }
    // The least price (no NaN can occur: the cell has an area), then its
    // first lane.
    let least = least_price(prices.as_flattened());
    if least == f64::INFINITY {
        return None;
    }
    let at = prices.as_flattened().iter().position(|&p| p == least)?;
    let (axis, j) = (at / M, at % M);
    Some(Choice {
        axis,
        pos: pos[axis][j],
        // Planar boxes at the lowest start go above, the others below.
        planar_below: j != 0,
        cost: Some(least),
    })
}
