//! The fast builder over boxes: the SAH at a few equal-width bin
//! boundaries on each cell's longest axis, boxes never clipped, each box
//! listed in every leaf whose closed cell it overlaps. It serves rebuilds
//! made every frame: the `fast` mesh builder for deforming meshes and the
//! scene's top level over instance world boxes.
//!
//! Why it is fast (one thread, no allocation per cell):
//! - The cells' boxes are copied beside their indices into one flat,
//!   stack-like array of 32-byte items, so binning and partitioning stream
//!   through memory instead of gathering boxes by index.
//! - A cell's above side is compacted in place and its below side written
//!   just past the cell's end, both in index order; the below side is
//!   built first (depth first, as the layout numbers interior nodes), and
//!   when the above side's turn comes everything past its end is free
//!   again. Nothing is moved back, and leaves need no sort.
//! - A bin is found with float arithmetic and a bit mask, no saturating
//!   cast or bounds check, four boxes at a time in `f32x4` lanes; two
//!   sets of counters take alternate boxes, so runs of boxes in one bin
//!   (meshes are stored in spatial order) do not wait on one counter.
//! - Planes are priced in `f32` with the child areas in closed form, four
//!   boundaries to a vector, in the one pass that sums and clears the bins.
//! - A plane that only cuts off empty space (half the splits of a mesh)
//!   moves no box: the binning pass also finds the boxes' extent on the
//!   axis, and when every box lies on one side the cell's boxes stay in
//!   place as that side's.
//!
//! Straddling boxes are only duplicated (the triangle is not clipped):
//! their bins are clamped to the cell's, which gives the bins of the box
//! clipped to the cell, so the SAH sees the clipped boxes' counts.
//!
//! Tried: a Morton builder (middle splits on a grid fixed up front, each
//! box sorted once by the common prefix of its corner cells' codes, only
//! the boxes straddling a plane carried down and partitioned): bunny
//! 24.1 ms against 20.0 ms here, SAH cost 62.9 against 40.2; top level
//! of 10,001 instances 1.6 ms at SAH cost 336 against 127. Slower on
//! meshes because nearly every box straddles some plane of the last
//! levels (1.2 M carried copies on the bunny, most at depths 15-21), and
//! middle splits close in on the geometry a level at a time.

use super::cost::CostModel;
use super::{BuildMonitor, BuiltTree};
use kdray_kernel::{Axis, Bounds, Node};
use std::mem::size_of;
use wide::{f32x4, i32x4};

/// The fast builder's parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FastParams {
    /// The SAH's constants.
    pub cost: CostModel,
    /// Equal-width bins on the longest axis (2 to [`MAX_BINS`]).
    pub bins: usize,
    /// Cells of at most this many boxes become leaves.
    pub leaf_size: usize,
    /// The deepest leaf allowed.
    pub depth: u32,
    /// Price cells of fewer than `bins` boxes at as many bins as boxes
    /// (at least 4). The bunny's tree: SAH cost 40.22 against 40.19. A
    /// scene's top level over 10,000 instances: 16% fewer instructions,
    /// but SAH cost 1.7% dearer there and 8.6% on the generated level of
    /// 2,001 instances, so the top level keeps every bin.
    pub shrink_bins: bool,
}

/// The most bins a cell is priced at.
pub const MAX_BINS: usize = 64;

/// One box of a cell: its bounds and its index in one array of 32 bytes
/// (`lo` at 0-2, the index's bits at 3, `hi` at 4-6), so a copy is two
/// 16-byte moves. The index's bits ride in an `f32` slot, only ever
/// copied, never computed with (moves keep every bit). (Tried: a struct
/// of fields, copied field by field: the partition took 33 instructions
/// per box; `u32` slots read as floats: 4% more instructions.)
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub(super) struct Item([f32; 8]);

/// Where an item keeps its index, and where its box's `hi` starts.
const ID: usize = 3;
const HI: usize = 4;

impl Item {
    pub(super) const NONE: Item = Item([0.0; 8]);

    pub(super) fn new(b: &Bounds, id: u32) -> Item {
        let [l0, l1, l2] = b.min;
        let [h0, h1, h2] = b.max;
        Item([l0, l1, l2, f32::from_bits(id), h0, h1, h2, 0.0])
    }

    pub(super) fn lo(&self, a: usize) -> f32 {
        self.0[a]
    }

    pub(super) fn hi(&self, a: usize) -> f32 {
        self.0[HI + a]
    }

    pub(super) fn id(&self) -> u32 {
        self.0[ID].to_bits()
    }
}

/// A cell still to build: its node's slot, where its items start and how
/// many, its bounds and depth.
struct Cell {
    slot: usize,
    start: usize,
    len: usize,
    bounds: Bounds,
    depth: u32,
}

/// The tree over `boxes` in `bounds` (which holds them all), in the
/// blob's line order. Empty boxes (`min > max`) are left out. Leaves
/// list their boxes in index order.
#[must_use]
pub fn build(boxes: &[Bounds], bounds: Bounds, p: &FastParams) -> BuiltTree {
    build_monitored(boxes, bounds, p, &BuildMonitor::new())
}

/// [`build`], telling `monitor` its working memory: the items (with the
/// room reserved for the below sides) and the cells still to build, at
/// their peak.
pub(super) fn build_monitored(
    boxes: &[Bounds],
    bounds: Bounds,
    p: &FastParams,
    monitor: &BuildMonitor,
) -> BuiltTree {
    let (tree, peak) = depth_first_measured(boxes, bounds, p);
    monitor.allocated(peak);
    monitor.freed(peak);
    BuiltTree {
        nodes: super::layout::into_line_groups(&tree.nodes),
        ..tree
    }
}

/// [`build`]'s tree in the depth-first layout (child pairs of the `k`-th
/// interior node at `2k + 1`), and the bytes its item and cell lists held
/// at most.
fn depth_first_measured(boxes: &[Bounds], bounds: Bounds, p: &FastParams) -> (BuiltTree, usize) {
    let mut items: Vec<Item> = boxes
        .iter()
        .zip(0u32..)
        .filter(|(b, _)| b.min[0] <= b.max[0])
        .map(|(b, id)| Item::new(b, id))
        .collect();
    // Room for the below sides written past the cells' ends, so growing
    // never copies: the peak is 2.02x the boxes on the top level over
    // 10,000 instances, 2.08x on the bunny. Only what is used is filled.
    items.reserve(2 * items.len());
    let bins = p.bins.clamp(2, MAX_BINS);
    let mut out = BuiltTree {
        nodes: vec![Node::EMPTY_LEAF],
        prims: Vec::with_capacity(items.len() * 2),
        bounds,
        max_depth: 0,
    };
    let mut counts = Counts::new();
    let mut interiors = 0usize;
    let mut todo = vec![Cell {
        slot: 0,
        start: 0,
        len: items.len(),
        bounds,
        depth: 0,
    }];
    while let Some(c) = todo.pop() {
        out.max_depth = out.max_depth.max(c.depth);
        let (start, n) = (c.start, c.len);
        let end = start + n;
        let split = if n <= p.leaf_size.max(1) || c.depth >= p.depth {
            None
        } else {
            // Small cells priced at fewer bins (as many as boxes, from 4
            // up): the pricing loop, not the binning, is most of their work.
            let bins = if p.shrink_bins {
                bins.min(n.next_power_of_two().max(4))
            } else {
                bins
            };
            counts
                .best_plane(&items[start..end], &c.bounds, bins, &p.cost)
                .filter(|&(_, _, cost, _)| f64::from(cost) < p.cost.leaf(n))
        };
        let Some((axis, plane, _, (lo_min, hi_max))) = split else {
            out.nodes[c.slot] = leaf(&items[start..end], &mut out.prims);
            continue;
        };
        // A plane that cuts off empty space (half the splits of a mesh)
        // moves nothing: the boxes stay where they are as the one side.
        let (n_above, n_below, below_at) = if plane <= lo_min {
            (n, 0, end)
        } else if hi_max < plane {
            (0, n, start)
        } else {
            let (a, b) = split_run(&mut items, start, n, axis, plane);
            (a, b, end)
        };
        if n_below == n && n_above == n {
            // Every box straddles the plane: splitting gains nothing.
            out.nodes[c.slot] = leaf(&items[start..end], &mut out.prims);
            continue;
        }
        let child = 2 * interiors + 1;
        interiors += 1;
        out.nodes[c.slot] = Node::interior([Axis::X, Axis::Y, Axis::Z][axis], plane, child as u32)
            .unwrap_or(Node::EMPTY_LEAF);
        // The children's slots are the next two (`child` is the length).
        out.nodes.extend([Node::EMPTY_LEAF; 2]);
        let (below, above) = c.bounds.split(axis, plane);
        let depth = c.depth + 1;
        todo.push(Cell {
            slot: child + 1,
            start,
            len: n_above,
            bounds: above,
            depth,
        });
        todo.push(Cell {
            slot: child,
            start: below_at,
            len: n_below,
            bounds: below,
            depth,
        });
    }
    let peak = items.capacity() * size_of::<Item>() + todo.capacity() * size_of::<Cell>();
    (out, peak)
}

/// Splits `cur` at `plane` on axis `A`: the above side compacted in place
/// at the front of `cur`, the below side written to the front of `spare`
/// (as long as `cur`), both in order; returns (above, below) counts.
/// Below when the box starts before the plane, above when it ends after it
/// or starts on it: every point of the box in a closed cell that holds it.
/// Branch-free: each item is written to both sides' next slot and kept
/// where its side holds it (the sides are unpredictable). The axis is a
/// constant so the compared coordinate is read in place.
pub(super) fn partition<const A: usize>(
    cur: &mut [Item],
    spare: &mut [Item],
    plane: f32,
) -> (usize, usize) {
    let (mut n_above, mut n_below) = (0, 0);
    for k in 0..cur.len() {
        // The coordinates read first and the item copied whole, memory to
        // memory: two 16-byte moves per side.
        let (lo, hi) = (cur[k].lo(A), cur[k].hi(A));
        spare[n_below] = cur[k];
        n_below += usize::from(lo < plane);
        cur[n_above] = cur[k];
        n_above += usize::from(hi > plane || lo >= plane);
    }
    (n_above, n_below)
}

/// Partitions the cell's run `items[start..start + n]` at `plane` on
/// `axis`: the above side compacted in place, the below side written
/// past the run's end (room made there). Returns `(n_above, n_below)`.
fn split_run(
    items: &mut Vec<Item>,
    start: usize,
    n: usize,
    axis: usize,
    plane: f32,
) -> (usize, usize) {
    let end = start + n;
    if items.len() < end + n {
        items.resize(end + n, Item::NONE);
    }
    let (cur, spare) = items[start..end + n].split_at_mut(n);
    match axis {
        0 => partition::<0>(cur, spare, plane),
        1 => partition::<1>(cur, spare, plane),
        _ => partition::<2>(cur, spare, plane),
    }
}

/// A leaf of `items` (in index order, each once); a run of several goes
/// to `prims`.
fn leaf(items: &[Item], prims: &mut Vec<u32>) -> Node {
    match items {
        [] => Node::EMPTY_LEAF,
        [it] => Node::leaf(1, it.id()).unwrap_or(Node::EMPTY_LEAF),
        _ => {
            let at = prims.len() as u32;
            prims.extend(items.iter().map(|it| it.id()));
            Node::leaf(items.len() as u32, at).unwrap_or(Node::EMPTY_LEAF)
        }
    }
}

/// A cell's equal-width bins on its longest axis and the SAH's terms for
/// pricing their boundaries in `f32`.
struct Grid {
    axis: usize,
    lo: f32,
    hi: f32,
    extent: f32,
    /// Bins per unit length.
    scale: f32,
    /// A child's area as a fraction of the cell's at boundary `k`:
    /// `base + per_bin k` below, `base + per_bin (bins - k)` above.
    base: f32,
    per_bin: f32,
    trav: f32,
    isect: f32,
    empty: f32,
}

impl Grid {
    /// The grid of `bins` bins over `cell`'s longest axis; `None` for a
    /// cell flat or NaN on it.
    fn new(cell: &Bounds, bins: usize, cost: &CostModel) -> Option<Grid> {
        let ext = |a: usize| cell.max[a] - cell.min[a];
        let axis = (0..3).fold(0, |b, a| if ext(a) > ext(b) { a } else { b });
        let (lo, hi) = (cell.min[axis], cell.max[axis]);
        let extent = hi - lo;
        if extent.is_nan() || extent <= 0.0 {
            return None;
        }
        // Child areas in closed form: the faces of a cell whose side on
        // this axis is `l` are 2 (l (u + v) + u v), `u`, `v` the other two;
        // as a fraction of the cell's, linear in the bin boundary `k`.
        let (u, v) = (ext((axis + 1) % 3), ext((axis + 2) % 3));
        let (sum, prod) = (u + v, u * v);
        let area = 2.0 * (extent * sum + prod);
        let (base, per_bin) = if area > 0.0 {
            (2.0 * prod / area, 2.0 * sum * (extent / bins as f32) / area)
        } else {
            (1.0, 0.0)
        };
        Some(Grid {
            axis,
            lo,
            hi,
            extent,
            scale: bins as f32 / extent,
            base,
            per_bin,
            trav: cost.traversal as f32,
            isect: cost.intersection as f32,
            empty: cost.empty_factor as f32,
        })
    }
}

/// Bin counters, kept across cells (only the bins used are cleared).
/// Two sets take alternate items.
struct Counts {
    starts: [[u32; MAX_BINS]; 2],
    ends: [[u32; MAX_BINS]; 2],
}

/// Adding this to a float in `[0, 2^22)` leaves the nearest integer in the
/// low bits of the sum's mantissa.
const ROUND: f32 = 12_582_912.0;

impl Counts {
    fn new() -> Counts {
        Counts {
            starts: [[0; MAX_BINS]; 2],
            ends: [[0; MAX_BINS]; 2],
        }
    }

    /// The cheapest bin boundary on the cell's longest axis: (axis,
    /// plane, cost, the lowest start and highest end of the boxes on that
    /// axis), the plane strictly inside the cell.
    fn best_plane(
        &mut self,
        items: &[Item],
        cell: &Bounds,
        bins: usize,
        cost: &CostModel,
    ) -> Option<(usize, f32, f32, (f32, f32))> {
        let Grid {
            axis,
            lo,
            hi,
            extent,
            scale,
            base,
            per_bin,
            trav,
            isect,
            empty,
        } = Grid::new(cell, bins, cost)?;
        let span = match axis {
            0 => self.count::<0>(items, lo, scale, bins),
            1 => self.count::<1>(items, lo, scale, bins),
            _ => self.count::<2>(items, lo, scale, bins),
        };
        let n = items.len() as u32;
        // One pass over the bins four at a time: the boxes below and above
        // boundaries `k + 1` as running sums of the two sets' starts and
        // ends (the counters cleared as they are read), those four
        // boundaries priced as one vector, each lane the scalar formula's
        // IEEE operations in the same order, and the first cheapest kept.
        // Counts stay below 2^31, so `i32` lanes convert to `f32` as the
        // `u32` counts would. Lanes from `last` on are past the cell and
        // never taken. (Tried: pricing one boundary at a time, 2.4x the
        // instructions; a scalar loop over arrays the compiler was left to
        // vectorize: it did not; the counters cleared by `fill`: a call to
        // `memset` each.)
        let last = bins - 1;
        let [s0, s1] = &mut self.starts;
        let [e0, e1] = &mut self.ends;
        let (base, per_bin, bins_f) = (
            f32x4::splat(base),
            f32x4::splat(per_bin),
            f32x4::splat(bins as f32),
        );
        let (trav, isect) = (f32x4::splat(trav), f32x4::splat(isect));
        let (empty, one, zero) = (f32x4::splat(empty), f32x4::splat(1.0), i32x4::splat(0));
        let (mut n_below, mut n_ended) = (0u32, 0u32);
        let (mut best_k, mut best) = (0, f32::INFINITY);
        let starts = s0.chunks_exact_mut(4).zip(s1.chunks_exact_mut(4));
        let ends = e0.chunks_exact_mut(4).zip(e1.chunks_exact_mut(4));
        for (j, ((s0, s1), (e0, e1))) in starts.zip(ends).take(last.div_ceil(4)).enumerate() {
            let (mut b, mut a) = ([0i32; 4], [0i32; 4]);
            for l in 0..4 {
                n_below += s0[l] + s1[l];
                n_ended += e0[l] + e1[l];
                (s0[l], s1[l], e0[l], e1[l]) = (0, 0, 0, 0);
                b[l] = n_below as i32;
                a[l] = (n - n_ended) as i32;
            }
            let kf = f32x4::new([1.0, 2.0, 3.0, 4.0]) + f32x4::splat((4 * j) as f32);
            let (pb, pa) = (base + per_bin * kf, base + per_bin * (bins_f - kf));
            let (b, a) = (i32x4::new(b), i32x4::new(a));
            let none: f32x4 = bytemuck::cast(b.simd_eq(zero) | a.simd_eq(zero));
            let lambda = none.select(empty, one);
            let c = lambda * (trav + isect * (pb * b.round_float() + pa * a.round_float()));
            for (k, c) in (4 * j..last).zip(c.to_array()) {
                if c < best {
                    (best_k, best) = (k + 1, c);
                }
            }
        }
        // The last bin when no group of four reached it.
        (s0[last], s1[last], e0[last], e1[last]) = (0, 0, 0, 0);
        let plane = lo + extent * best_k as f32 / bins as f32;
        (best_k > 0 && plane > lo && plane < hi).then_some((axis, plane, best, span))
    }

    /// Counts the items' start and end bins on axis `A` (the cell starts
    /// at `lo`, `scale` bins per unit), alternate items in alternate sets;
    /// returns the lowest start and the highest end.
    fn count<const A: usize>(
        &mut self,
        items: &[Item],
        lo: f32,
        scale: f32,
        bins: usize,
    ) -> (f32, f32) {
        let top = (bins - 1) as f32;
        // The bin of `x`, clamped to the cell's: round(t - 1/2) is floor(t)
        // but at ties, and a tie only moves a box to a neighbouring bin of
        // the estimate (the partition compares with the plane itself).
        let bin = |x: f32| {
            let t = min(max((x - lo) * scale - 0.5, 0.0), top);
            ((t + ROUND).to_bits() as usize) & (MAX_BINS - 1)
        };
        let [s0, s1] = &mut self.starts;
        let [e0, e1] = &mut self.ends;
        // Four boxes at a time: their eight coordinates gathered into two
        // vectors, so the bins and the extent are computed four lanes wide
        // (`fast_max` and `fast_min` are `maxps` and `minps`: [`max`] and
        // [`min`]). (Tried: arrays the compiler was left to vectorize: it
        // did not.)
        let (lo_v, scale_v, half) = (f32x4::splat(lo), f32x4::splat(scale), f32x4::splat(0.5));
        let (zero, top_v, round) = (f32x4::splat(0.0), f32x4::splat(top), f32x4::splat(ROUND));
        let mask = i32x4::splat((MAX_BINS - 1) as i32);
        let bin4 = |x: f32x4| {
            let t = ((x - lo_v) * scale_v - half).fast_max(zero).fast_min(top_v);
            (bytemuck::cast::<f32x4, i32x4>(t + round) & mask).to_array()
        };
        let (mut lo_min4, mut hi_max4) =
            (f32x4::splat(f32::INFINITY), f32x4::splat(f32::NEG_INFINITY));
        let mut quads = items.chunks_exact(4);
        for q in &mut quads {
            let lo4 = f32x4::new([q[0].lo(A), q[1].lo(A), q[2].lo(A), q[3].lo(A)]);
            let hi4 = f32x4::new([q[0].hi(A), q[1].hi(A), q[2].hi(A), q[3].hi(A)]);
            let (sb, eb) = (bin4(lo4), bin4(hi4));
            s0[sb[0] as usize] += 1;
            e0[eb[0] as usize] += 1;
            s1[sb[1] as usize] += 1;
            e1[eb[1] as usize] += 1;
            s0[sb[2] as usize] += 1;
            e0[eb[2] as usize] += 1;
            s1[sb[3] as usize] += 1;
            e1[eb[3] as usize] += 1;
            lo_min4 = lo_min4.fast_min(lo4);
            hi_max4 = hi_max4.fast_max(hi4);
        }
        let (mut lo_min, mut hi_max) = (
            lo_min4.to_array().into_iter().fold(f32::INFINITY, min),
            hi_max4.to_array().into_iter().fold(f32::NEG_INFINITY, max),
        );
        for a in quads.remainder() {
            s0[bin(a.lo(A))] += 1;
            e0[bin(a.hi(A))] += 1;
            lo_min = min(lo_min, a.lo(A));
            hi_max = max(hi_max, a.hi(A));
        }
        (lo_min, hi_max)
    }
}

/// The lesser of `a` and `b` as one `minss` (`f32::min`'s NaN rule costs
/// three more instructions; the builders' coordinates are finite, and a
/// NaN here only picks a bin).
#[inline]
fn min(a: f32, b: f32) -> f32 {
    if a < b {
        a
    } else {
        b
    }
}

/// The greater of `a` and `b` as one `maxss` ([`min`]).
#[inline]
fn max(a: f32, b: f32) -> f32 {
    if a > b {
        a
    } else {
        b
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::rng::Rng;
    use kdray_kernel::NodeKind;

    /// The leaves of `tree` (any layout) whose closed cells hold `p`
    /// (both sides of a plane through `p`).
    pub(in crate::builders) fn leaves_at(tree: &BuiltTree, p: [f32; 3]) -> Vec<Vec<u32>> {
        let mut out = Vec::new();
        let mut todo = vec![0u32];
        while let Some(i) = todo.pop() {
            match tree.nodes[i as usize].kind() {
                NodeKind::Interior { axis, split, child } => {
                    let a = axis.index();
                    if p[a] <= split {
                        todo.push(child);
                    }
                    if p[a] >= split {
                        todo.push(child + 1);
                    }
                }
                NodeKind::Leaf { count, word: first } => out.push(match count {
                    0 => vec![],
                    1 => vec![first],
                    _ => tree.prims[first as usize..(first + count) as usize].to_vec(),
                }),
            }
        }
        out
    }

    /// [`Counts::best_plane`] as a plain scalar scan: each box's two bins
    /// counted in turn, the boundaries priced in order in `f32`, the first
    /// cheapest kept.
    fn best_plane_scalar(
        items: &[Item],
        cell: &Bounds,
        bins: usize,
        cost: &CostModel,
    ) -> Option<(usize, f32, f32, (f32, f32))> {
        let g = Grid::new(cell, bins, cost)?;
        let bin = |x: f32| {
            let t = min(max((x - g.lo) * g.scale - 0.5, 0.0), (bins - 1) as f32);
            ((t + ROUND).to_bits() as usize) & (MAX_BINS - 1)
        };
        let (mut starts, mut ends) = ([0u32; MAX_BINS], [0u32; MAX_BINS]);
        let (mut lo_min, mut hi_max) = (f32::INFINITY, f32::NEG_INFINITY);
        for it in items {
            starts[bin(it.lo(g.axis))] += 1;
            ends[bin(it.hi(g.axis))] += 1;
            lo_min = min(lo_min, it.lo(g.axis));
            hi_max = max(hi_max, it.hi(g.axis));
        }
        let n = items.len() as u32;
        let (mut n_below, mut n_ended) = (0u32, 0u32);
        let (mut best_k, mut best) = (0, f32::INFINITY);
        for k in 0..bins - 1 {
            n_below += starts[k];
            n_ended += ends[k];
            let n_above = n - n_ended;
            let kf = (k + 1) as f32;
            let (pb, pa) = (
                g.base + g.per_bin * kf,
                g.base + g.per_bin * (bins as f32 - kf),
            );
            let lambda = if n_below == 0 || n_above == 0 {
                g.empty
            } else {
                1.0
            };
            let c = lambda * (g.trav + g.isect * (pb * n_below as f32 + pa * n_above as f32));
            if c < best {
                (best_k, best) = (k + 1, c);
            }
        }
        let plane = g.lo + g.extent * best_k as f32 / bins as f32;
        (best_k > 0 && plane > g.lo && plane < g.hi).then_some((
            g.axis,
            plane,
            best,
            (lo_min, hi_max),
        ))
    }

    /// The four-lane binning and pricing choose what the scalar scan does,
    /// bit for bit, at every bin count and for every remainder of four
    /// boxes, and leave the counters clear for the next cell (each cell is
    /// priced twice in a row on one `Counts`).
    #[test]
    fn four_lane_pricing_equals_the_scalar_scan() {
        let mut rng = Rng::new(19);
        let mut counts = Counts::new();
        let cost = CostModel {
            traversal: 1.0,
            intersection: 4.0,
            empty_factor: 0.8,
        };
        let mut taken = 0;
        for round in 0..3000 {
            let bins = [2, 3, 4, 5, 7, 8, 9, 15, 16, 17, 33, 64][round % 12];
            let lo: [f32; 3] = core::array::from_fn(|_| rng.range(-4.0, 4.0));
            let size: [f32; 3] = core::array::from_fn(|_| rng.range(0.5, 8.0));
            let cell = Bounds {
                min: lo,
                max: core::array::from_fn(|a| lo[a] + size[a]),
            };
            // Boxes inside, straddling and outside the cell, some on bin
            // boundaries.
            let items: Vec<Item> = (0..rng.below(41) as u32)
                .map(|id| {
                    let c: [f32; 3] = core::array::from_fn(|a| {
                        if rng.below(4) == 0 {
                            let k = rng.below(bins + 1) as f32;
                            cell.min[a] + size[a] * k / bins as f32
                        } else {
                            rng.range(cell.min[a] - 1.0, cell.max[a] + 1.0)
                        }
                    });
                    let h: [f32; 3] = core::array::from_fn(|_| rng.range(0.0, 1.5));
                    let b = Bounds {
                        min: core::array::from_fn(|a| c[a] - h[a]),
                        max: core::array::from_fn(|a| c[a] + h[a]),
                    };
                    Item::new(&b, id)
                })
                .collect();
            let want = best_plane_scalar(&items, &cell, bins, &cost);
            let bits = |r: Option<(usize, f32, f32, (f32, f32))>| {
                r.map(|(a, p, c, (l, h))| (a, p.to_bits(), c.to_bits(), l.to_bits(), h.to_bits()))
            };
            for _ in 0..2 {
                let got = counts.best_plane(&items, &cell, bins, &cost);
                assert_eq!(bits(got), bits(want), "round {round}, {bins} bins");
            }
            taken += usize::from(want.is_some());
        }
        assert!(taken > 1000, "most cells find a plane: {taken}");
    }

    /// Every corner and the centre of every box lies in the closed cell of
    /// a leaf that lists the box; leaves list boxes in index order, once.
    #[test]
    fn every_point_of_a_box_is_in_a_leaf_that_lists_it() {
        let mut rng = Rng::new(7);
        let mut boxes: Vec<Bounds> = (0..3000)
            .map(|_| {
                let c = [
                    rng.range(1.0, 15.0),
                    rng.range(1.0, 3.0),
                    rng.range(1.0, 3.0),
                ];
                let h: [f32; 3] = core::array::from_fn(|_| rng.range(0.0, 0.5));
                Bounds {
                    min: core::array::from_fn(|a| c[a] - h[a]),
                    max: core::array::from_fn(|a| c[a] + h[a]),
                }
            })
            .collect();
        // The root is [0, 16] on x, its longest axis, so bin boundaries
        // fall on integers: flat boxes lie in them. A box over everything,
        // an empty box.
        for k in 0..300 {
            let x = (k % 15 + 1) as f32;
            let y = (k % 7) as f32 * 0.5;
            boxes.push(Bounds {
                min: [x, y, 1.0],
                max: [x, y + 0.5, 1.5],
            });
        }
        boxes.push(Bounds {
            min: [0.0; 3],
            max: [16.0, 4.0, 4.0],
        });
        boxes.push(Bounds::EMPTY);
        let bounds = boxes
            .iter()
            .filter(|b| b.min[0] <= b.max[0])
            .fold(Bounds::EMPTY, |a, b| a.union(b));
        for shrink_bins in [false, true] {
            let p = FastParams {
                cost: CostModel {
                    traversal: 1.0,
                    intersection: 0.5,
                    empty_factor: 0.8,
                },
                bins: 16,
                leaf_size: 2,
                depth: 24,
                shrink_bins,
            };
            let tree = depth_first_measured(&boxes, bounds, &p).0;
            assert!(tree.nodes.len() > 100, "the boxes are split");
            for (i, b) in boxes.iter().enumerate() {
                if b.min[0] > b.max[0] {
                    assert!(!tree.prims.contains(&(i as u32)), "empty box listed");
                    continue;
                }
                let centre = core::array::from_fn(|a| b.min[a] * 0.5 + b.max[a] * 0.5);
                let corners = (0..8).map(|c| {
                    core::array::from_fn(|a| if c >> a & 1 == 0 { b.min[a] } else { b.max[a] })
                });
                for q in corners.chain([centre]) {
                    let found = leaves_at(&tree, q).iter().any(|l| l.contains(&(i as u32)));
                    assert!(found, "box {i} point {q:?} is in no leaf listing it");
                }
            }
            for n in &tree.nodes {
                if let NodeKind::Leaf { count, word } = n.kind() {
                    if count > 1 {
                        let run = &tree.prims[word as usize..(word + count) as usize];
                        assert!(run.windows(2).all(|w| w[0] < w[1]), "sorted, once");
                    }
                }
            }
        }
    }
}
