//! The exact SAH for cells of a few triangles, without events: the same
//! candidate planes and counts as the event sweep, found by comparing every
//! candidate with every box.
//!
//! Near the leaves the event sweep spends more on keeping its sorted lists
//! (a split merges new events into both children's lists) and on its
//! per-event branches than on pricing planes: cells of 4 to 15 triangles
//! were two thirds of all cells and most of the build. Here a cell holds
//! its (triangle, box) items, splits them like the box builders (clipping
//! straddlers as event cells of its size do), and counts with comparisons
//! over fixed lanes, which vectorise. Measured on the bunny against the
//! event sweep (same tree): small below 16 triangles, 3% less build time;
//! below 32, 2.5% less again; below 64, slower than 32. Against binning
//! (the `sah` builder bins every larger cell), small below 16 is the
//! faster: cells of 16-31 triangles binned into 12-19 bins cost the
//! bunny, sponza and fandisk builds 10-14% less than priced exactly here,
//! for tree costs +0.01%, +0.44% and +0.09%.
//!
//! For a plane at `p` on one axis (as the sweep counts, see
//! [`sah`](super::sah)): below, the boxes starting before `p` (a box lying
//! in a plane before `p` starts there); above, the boxes ending after `p`;
//! in the plane, the boxes lying in it. Every box edge strictly inside the
//! cell is a candidate; the cheapest wins, the lowest position on a tie
//! (the sweep goes up the axis), then the lowest axis.
//!
//! Tried: counting across boxes (lanes = boxes) instead of across
//! candidates, and an early leaf for a cell of one triangle: no gain.

use super::cost::{least_price, AreaRatios, CostModel};
use super::item::Item;
use super::subdivide::Choice;
use super::thresholds::SMALL_MAX;
use kdray_kernel::Bounds;

/// Room for every box of a small cell.
const LANES: usize = 16;
const _: () = assert!(SMALL_MAX <= LANES);

/// The cheapest plane of the small cell `cell` holding `items` (module
/// docs), or `None` when no box edge lies strictly inside it.
pub(super) fn choose(items: &[Item], cell: &Bounds, cost: &CostModel) -> Option<Choice> {
    // The cheapest; the lower axis on a tie. Cells of up to 8 triangles
    // (most of them) price half as many candidates as the largest.
    let on = |axis| match items.len() {
        0..=8 => choose_on::<8, 16>(items, cell, axis, cost),
        _ => choose_on::<LANES, { 2 * LANES }>(items, cell, axis, cost),
    };
    (0..3)
        .filter_map(on)
        .fold(None, |best: Option<Choice>, c| match best {
            Some(b) if b.cost <= c.cost => Some(b),
            _ => Some(c),
        })
}

/// The cheapest plane on `axis` for at most `L` boxes, `P` = 2 `L`
/// candidates (each box's two edges), the lowest position on a tie. The
/// counts and prices are straight loops over all candidates (unused ones
/// sit on the cell's wall, never inside it), which the compiler
/// vectorises: a compare per box and candidate, a few `f64` operations
/// per candidate.
fn choose_on<const L: usize, const P: usize>(
    items: &[Item],
    cell: &Bounds,
    axis: usize,
    cost: &CostModel,
) -> Option<Choice> {
    let ratios = AreaRatios::new(cell, axis)?;
    let (lo, hi) = (cell.min[axis], cell.max[axis]);
    let items = items.get(..L).unwrap_or(items);
    let mut pos = [lo; P];
    for (i, it) in items.iter().enumerate() {
        pos[i] = it.b.min[axis];
        if let Some(p) = pos.get_mut(L + i) {
            *p = it.b.max[axis];
        }
    }
    let (mut below, mut above, mut planar) = ([0u32; P], [0u32; P], [0u32; P]);
    for it in items {
        let (start, end) = (it.b.min[axis], it.b.max[axis]);
        for j in 0..P {
            let (b, a) = (start < pos[j], end > pos[j]);
            below[j] += u32::from(b);
            above[j] += u32::from(a);
            // A box neither starts before nor ends after a plane only
            // when it lies in it (`start <= end`).
            planar[j] += u32::from(!(b || a));
        }
    }
    let price = |j: usize| {
        let (pb, pa) = ratios.at(pos[j]);
        let (nb, na, np) = (below[j] as usize, above[j] as usize, planar[j] as usize);
        cost.split_planar(pb, nb, pa, na, np)
    };
    let mut prices = [f64::INFINITY; P];
    for (j, p) in prices.iter_mut().enumerate() {
        let inside = pos[j] > lo && pos[j] < hi;
        *p = if inside { price(j).0 } else { f64::INFINITY };
    }
    let least = least_price(&prices);
    if least >= f64::INFINITY {
        return None;
    }
    let mut best: Option<usize> = None;
    // The boxes' edges only: unused candidates are never inside.
    for j in (0..items.len()).chain(L..L + items.len()) {
        let c = prices.get(j).copied().unwrap_or(f64::INFINITY);
        if c == least && best.is_none_or(|b| pos[j] < pos[b]) {
            best = Some(j);
        }
    }
    let j = best?;
    let (c, planar_below) = price(j);
    Some(Choice {
        axis,
        // As the events' keys: -0 taken as +0.
        pos: pos[j] + 0.0,
        planar_below,
        cost: Some(c),
    })
}
