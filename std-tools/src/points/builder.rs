//! The lecture's point k-d tree builder, for any dimension D and for f32
//! or f64 coordinates: split the widest dimension at the median (an O(n)
//! selection per level, so O(n log n) in all), keep the tight bounds of the
//! points under every node, stop at `leaf_size` points or when the widest
//! extent is at most `min_width`.
//!
//! The points are carried along with their indices and partitioned in
//! place, so when the recursion ends they are in leaf order: each leaf's
//! run is a slice of that one array, as the kernel's blob stores them.
//! Subtrees of at least `parallel_min` points are built on rayon tasks and
//! spliced into the depth-first layout afterwards; the output is the same
//! for any thread count.

use kdray_kernel::{
    BlobError, PointNode, PointNodeKind, PointTreeN, Scalar, MAX_DEPTH, MAX_POINT_FIELD,
};
use std::fmt;

/// The builder's parameters, defaults documented per field.
#[derive(Clone, Debug, PartialEq)]
pub struct PointParams {
    /// A node with at most this many points is a leaf (the lecture's m;
    /// median splits make leaves of m/2 to m points). Default 32: measured
    /// on the 1M-point anchor sets (uniform, clustered, bunny), one core,
    /// k = 1 and 10: m = 6 and 8 were 10-40% slower than 16 and 32, which
    /// were within noise of each other (32 ahead on the bunny), and 32
    /// builds ~10% faster.
    pub leaf_size: usize,
    /// A node whose widest extent is at most this is a leaf, however many
    /// points it holds. Default 0: only piles of equal points stop early
    /// (they cannot be split; the query scans such a pile in O(k)).
    pub min_width: f64,
    /// Subtrees of at least this many points are built in parallel.
    /// Default 65536.
    pub parallel_min: usize,
}

impl Default for PointParams {
    fn default() -> Self {
        PointParams {
            leaf_size: 32,
            min_width: 0.0,
            parallel_min: 1 << 16,
        }
    }
}

/// Why a point build failed.
#[derive(Debug, Clone, PartialEq)]
pub enum PointBuildError {
    /// A point with a NaN or infinite coordinate.
    NonFinite {
        /// The point's index.
        point: usize,
        /// The axis of the first bad coordinate.
        axis: usize,
        /// Its value.
        value: f64,
    },
    /// More points than a tree can index.
    TooManyPoints {
        /// How many there are.
        count: usize,
    },
}

/// The most points a tree holds: its node count (about 2n / leaf size,
/// at most 2n) and every index must fit the blob's 32-bit counts.
pub const MAX_POINTS: usize = (1 << 30) - 1;

impl fmt::Display for PointBuildError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PointBuildError::NonFinite { point, axis, value } => {
                write!(
                    f,
                    "point {point} has a non-finite coordinate {value} (axis {axis})"
                )
            }
            PointBuildError::TooManyPoints { count } => write!(
                f,
                "{count} points is more than a tree can index ({MAX_POINTS})"
            ),
        }
    }
}

impl std::error::Error for PointBuildError {}

/// A built point tree, in the kernel's layout (see `kdray_kernel::PointTreeN`).
#[derive(Clone, Debug, PartialEq)]
pub struct BuiltPoints<const D: usize, S: Scalar = f32> {
    /// Nodes in the depth-first layout; leaves hold runs of the arrays below.
    pub nodes: Vec<PointNode>,
    /// The split location of each interior node (0 for a leaf).
    pub splits: Vec<S>,
    /// The input index of each point of `points`.
    pub indices: Vec<u32>,
    /// The points' coordinates in leaf order, each leaf's run axis by axis
    /// (`kdray_kernel::PointTreeN::coords`).
    pub coords: Vec<S>,
    /// The tight bounds `[min, max]` of the points at or below each node.
    pub bounds: Vec<[[S; D]; 2]>,
    /// The depth of the deepest node.
    pub max_depth: u32,
}

impl<const D: usize, S: Scalar> BuiltPoints<D, S> {
    /// The validated kernel view ([`PointTreeN::from_parts`]).
    ///
    /// # Errors
    /// The kernel's [`BlobError`] (never, for a tree [`build_points`] made).
    pub fn view(&self) -> Result<PointTreeN<'_, D, S>, BlobError> {
        PointTreeN::from_parts(
            &self.nodes,
            &self.splits,
            &self.indices,
            &self.coords,
            &self.bounds,
        )
    }
}

/// A point and its input index, moved together by the partitioning.
#[derive(Clone, Copy)]
struct Item<const D: usize, S> {
    p: [S; D],
    index: u32,
}

/// Builds the tree over `points` (index = position).
///
/// # Errors
/// [`PointBuildError::NonFinite`] naming the first NaN or infinite
/// coordinate; [`PointBuildError::TooManyPoints`] past [`MAX_POINTS`].
pub fn build_points<const D: usize, S: Scalar>(
    points: &[[S; D]],
    params: &PointParams,
) -> Result<BuiltPoints<D, S>, PointBuildError> {
    for (point, p) in points.iter().enumerate() {
        if let Some(axis) = p.iter().position(|c| !c.is_finite()) {
            return Err(PointBuildError::NonFinite {
                point,
                axis,
                value: p[axis].to_f64(),
            });
        }
    }
    if points.len() > MAX_POINTS {
        return Err(PointBuildError::TooManyPoints {
            count: points.len(),
        });
    }
    let mut items: Vec<Item<D, S>> = points
        .iter()
        .enumerate()
        .map(|(i, &p)| Item { p, index: i as u32 })
        .collect();
    let params = PointParams {
        leaf_size: params.leaf_size.clamp(1, MAX_POINT_FIELD as usize),
        ..params.clone()
    };
    let mut spare = spare_for(&items);
    let tree = grow_parallel(
        Run {
            now: &mut items,
            spare: &mut spare,
            now_is_final: true,
        },
        0,
        0,
        &params,
    );
    Ok(BuiltPoints {
        coords: leaf_major(&tree.nodes, &items),
        nodes: tree.nodes,
        splits: tree.splits,
        indices: items.iter().map(|it| it.index).collect(),
        bounds: tree.bounds,
        max_depth: tree.max_depth,
    })
}

/// The coordinates of `items` (in leaf order) as the kernel stores them:
/// each leaf's run axis by axis.
fn leaf_major<const D: usize, S: Scalar>(nodes: &[PointNode], items: &[Item<D, S>]) -> Vec<S> {
    let mut coords = vec![S::ZERO; items.len() * D];
    for n in nodes {
        if let PointNodeKind::Leaf { offset, count } = n.kind() {
            let (o, c) = (offset as usize, count as usize);
            let block = &mut coords[o * D..(o + c) * D];
            for (j, it) in items[o..o + c].iter().enumerate() {
                for (a, &x) in it.p.iter().enumerate() {
                    block[a * c + j] = x;
                }
            }
        }
    }
    coords
}

/// A subtree in the depth-first layout with its root at 0; leaf offsets
/// are already absolute.
struct Subtree<const D: usize, S> {
    nodes: Vec<PointNode>,
    splits: Vec<S>,
    bounds: Vec<[[S; D]; 2]>,
    max_depth: u32,
}

/// The tight bounds of `items` (the zero box for none).
///
/// Compares, not `f32::min`: the points are finite (checked), and a plain
/// compare-and-select is one vector min per lane group where the NaN-aware
/// `min` is three instructions per coordinate (a fifth of a 16-D build's
/// instructions, callgrind).
fn bounds_of<const D: usize, S: Scalar>(items: &[Item<D, S>]) -> [[S; D]; 2] {
    // Up to 2-D a box's four compare-selects a point wait on the last
    // point's: four boxes over every fourth point, merged at the end, cut
    // the knn bench's 100k-point 2-D builds from 7.0-7.1 to 5.5 ms. From
    // 3-D on a point already gives the processor six or more independent
    // compare-selects, and four boxes no longer fit in its registers
    // (3-D 4.9-5.0 -> 5.1-5.3 ms).
    if D <= 2 {
        bounds_in::<4, D, S>(items)
    } else {
        bounds_in::<1, D, S>(items)
    }
}

/// [`bounds_of`] through `B` boxes, each over every `B`-th point.
fn bounds_in<const B: usize, const D: usize, S: Scalar>(items: &[Item<D, S>]) -> [[S; D]; 2] {
    let Some(first) = items.first() else {
        return [[S::ZERO; D]; 2];
    };
    let mut boxes = [[first.p; 2]; B];
    let mut groups = items.chunks_exact(B);
    for group in &mut groups {
        for (b, it) in boxes.iter_mut().zip(group) {
            grow_box(b, &it.p);
        }
    }
    let mut b = boxes[0];
    for it in groups.remainder() {
        grow_box(&mut b, &it.p);
    }
    for other in &boxes[1..] {
        grow_box(&mut b, &other[0]);
        grow_box(&mut b, &other[1]);
    }
    b
}

/// Widens the box `b` to hold `p`.
#[inline(always)]
fn grow_box<const D: usize, S: Scalar>(b: &mut [[S; D]; 2], p: &[S; D]) {
    for a in 0..D {
        let x = p[a];
        b[0][a] = if x < b[0][a] { x } else { b[0][a] };
        b[1][a] = if x > b[1][a] { x } else { b[1][a] };
    }
}

/// The split axis for a node, or `None` for a leaf: few points, too
/// narrow (a pile of equal points always is), or at the depth limit.
/// The widest axis; of equal extents the lowest.
fn split_axis<const D: usize, S: Scalar>(
    len: usize,
    b: &[[S; D]; 2],
    depth: u32,
    params: &PointParams,
) -> Option<usize> {
    if len <= params.leaf_size || depth >= MAX_DEPTH {
        return None;
    }
    let extent = |a: usize| b[1][a] - b[0][a];
    let mut widest = 0;
    for a in 1..D {
        if extent(a) > extent(widest) {
            widest = a;
        }
    }
    (extent(widest).to_f64() > params.min_width).then_some(widest)
}

/// Partitions `items` at the median of axis `a`: below `..mid`, above
/// `mid..`; returns `mid` and the split location (the median coordinate).
///
/// Points equal to the median all go below when some point is left above:
/// the above child's box then starts strictly past the split plane, so a
/// query sitting on a pile or plane of equal coordinates (where ties make
/// every subtree at distance 0 worth a visit) prunes the above side by the
/// plane's gap. Measured on the `dupes` anchor set (one core): k = 1
/// 0.8-0.9M -> 1.3-2.0M queries/s; no change on uniform points.
///
/// Which points go below depends only on their coordinates and indices,
/// never on the order the subtree holds them in: all those at or below
/// the median, or, when the median is the largest coordinate, those below
/// it and then the ties of lowest index up to `mid`.
///
/// Large points ([`through_coordinates`]) are
/// not moved by the selection: the median is selected among a copy of
/// the coordinates (`keys`, the caller's scratch), then one pass writes
/// each point to its side in the run's spare buffer, where the children's
/// points then are. No point moves twice, and no branch depends on the
/// side, a coin toss around a median. Against selecting the points
/// themselves (`select_nth_unstable`, which moves each several times),
/// one thread pinned, best of 7 interleaved `kdray build-points`: 300k
/// points at 8-D 35.7 -> 29.9 ms, 16-D 70.8 -> 45.6 ms, 1M `f64` points
/// at 3-D 94.1 -> 88.7 ms; small points lost (1M at 2-D 100 -> 106 ms,
/// 3-D 73 -> 81 ms), so they keep that. Tried: Hoare's two cursors
/// swapping in place (8-D 18% fewer instructions, slower on the clock:
/// its loops mispredicted); a radix selection on integer keys of the
/// coordinates (a byte histogram per pass, no compares: 1.33x the
/// instructions at 3-D, its filter passes cost more than the compares
/// they save); (coordinate, position) pairs selected and the points
/// gathered by position (12% more instructions at 16-D: the gather reads
/// out of order); a `u32` index array selected with ties broken by index
/// (1.2-1.5x the build time, the extra compare mispredicted); the item
/// aligned to 16 bytes (the same time); both children's boxes taken in
/// `partition_by`'s pass, branch-free (1.8x the time at 8-D and 16-D:
/// four masked compare-selects per coordinate instead of two); no
/// selection at all (branch `issue-20-presort`): each axis's order radix
/// sorted once, a node's box its orders' ends, its median the middle of
/// one order, the orders split stably per level by each point's ranks
/// (the same trees, byte for byte): `kdray build-points` 100k `f32`
/// points at 1-D 5.0 -> 3.4 ms and 2-D 8.2 -> 6.0 ms, but the knn
/// bench's builds (the same code, repeated in one process) 2-D 7.4 ->
/// 8.8 ms and duplicates 4.3 -> 7.1 ms, and lost at 3-D (6.4 -> 9.0 ms)
/// and in `f64` (1M 2-D points 74 -> 115 ms): a level moves `D` orders
/// of `D` ranks a point. Also lost: Floyd and Rivest's sampling select
/// (two pivots from an evenly spaced sample around the median's rank,
/// two branch-free in-place partition passes, quickselect below 1,024
/// points): 35.2M -> 38.2M instructions per 50k-point 2-D build, the knn
/// bench's 2-D builds 7.8 -> 8.7 ms and 3-D 5.9 -> 6.5 ms; it moves a
/// point fewer times only in the top levels, each move of a 12-byte
/// item costs more than quickselect's, and most levels are small nodes.
/// And a quickselect of its own on the large points' coordinates
/// (median-of-three pivots, branch-free partitions, a branch-free count
/// among the last 16 keys, to drop `std`'s final insertion sort, a third
/// of the mispredicts): 8-D `kdray build-points` of 100k points 108.9M
/// -> 129.5M instructions for 158k -> 140k mispredicts (callgrind).
fn partition<const D: usize, S: Scalar>(
    run: &mut Run<'_, D, S>,
    a: usize,
    keys: &mut Vec<S>,
) -> (usize, S) {
    let mid = run.now.len() / 2;
    // The points are finite, so `<` orders them (-0 and +0 as equals,
    // which the rule above puts on one side): 93M -> 78M instructions
    // for a 100k-point 3-D build against `total_cmp`'s bit twiddling.
    let order = |x: &S, y: &S| x.partial_cmp(y).unwrap_or(std::cmp::Ordering::Equal);
    let split = if through_coordinates::<D, S>() {
        keys.clear();
        keys.extend(run.now.iter().map(|it| it.p[a]));
        let split = *keys.select_nth_unstable_by(mid, order).1;
        let below = partition_by(run, |x| x[a] <= split);
        if below < run.now.len() {
            // The children's points are in the spare buffer now.
            std::mem::swap(&mut run.now, &mut run.spare);
            run.now_is_final = !run.now_is_final;
            return (below, split);
        }
        split
    } else {
        let items = &mut *run.now;
        items.select_nth_unstable_by(mid, |x, y| order(&x.p[a], &y.p[a]));
        let split = items[mid].p[a];
        // Move the ties after the median to the front of the above part.
        let above = &mut items[mid + 1..];
        let mut ties = 0;
        for j in 0..above.len() {
            if above[j].p[a] == split {
                above.swap(ties, j);
                ties += 1;
            }
        }
        let end = mid + 1 + ties;
        if end < items.len() {
            return (end, split);
        }
        split
    };
    // The median is the largest coordinate; every point is still in
    // `run.now`. The points below it first, then the ties of lowest index.
    let items = &mut *run.now;
    let mut below = 0;
    for j in 0..items.len() {
        // Swapped whichever side the point is on, without a branch (near
        // a median the side is a coin toss): `items[below..j]` are all
        // not below, so the swap moves one of them (or the point itself)
        // to `j`.
        let b = items[j].p[a] < split;
        items.swap(below, j);
        below += usize::from(b);
    }
    let take = mid - below; // the median is not below itself
    let ties = &mut items[below..];
    if take > 0 && take < ties.len() {
        ties.select_nth_unstable_by_key(take, |it| it.index);
    }
    (mid, split)
}

/// The spare buffer [`partition`] moves `items` into: a copy for large
/// points, none for those partitioned where they lie.
fn spare_for<const D: usize, S: Copy>(items: &[Item<D, S>]) -> Vec<Item<D, S>> {
    if through_coordinates::<D, S>() {
        items.to_vec()
    } else {
        Vec::new()
    }
}

/// Are points of this shape partitioned through a selection among their
/// coordinates ([`partition`])? Those over 16 bytes with their index.
const fn through_coordinates<const D: usize, S>() -> bool {
    size_of::<Item<D, S>>() > 16
}

/// Writes the points of `run.now` for which `below` holds to the front
/// of `run.spare`, in order, and the others to its back; returns how many
/// are below. `run.now` is left as it was.
fn partition_by<const D: usize, S: Scalar>(
    run: &mut Run<'_, D, S>,
    below: impl Fn(&[S; D]) -> bool,
) -> usize {
    let (mut lo, mut hi) = (0, run.now.len());
    for it in run.now.iter() {
        let b = below(&it.p);
        // `lo < hi` until the last point: each step fills one slot.
        run.spare[if b { lo } else { hi - 1 }] = *it;
        lo += usize::from(b);
        hi -= usize::from(!b);
    }
    lo
}

/// A node's points: in `now`, with `spare` (as long, or empty for points
/// partitioned where they lie) for the partition to write into.
/// `now_is_final` when `now` lies in the array the leaves' runs are read
/// from (`spare` then is the other one).
struct Run<'a, const D: usize, S> {
    now: &'a mut [Item<D, S>],
    spare: &'a mut [Item<D, S>],
    now_is_final: bool,
}

impl<'a, const D: usize, S: Copy> Run<'a, D, S> {
    /// The children's runs after a partition: below `..mid`, above
    /// `mid..` (an empty spare buffer stays empty).
    fn children(self, mid: usize) -> [Run<'a, D, S>; 2] {
        let (now_below, now_above) = self.now.split_at_mut(mid);
        let (spare_below, spare_above) = self.spare.split_at_mut(mid.min(self.spare.len()));
        [
            Run {
                now: now_below,
                spare: spare_below,
                now_is_final: self.now_is_final,
            },
            Run {
                now: now_above,
                spare: spare_above,
                now_is_final: self.now_is_final,
            },
        ]
    }

    /// The points in the final array, where their leaf's run is read.
    fn into_final(self) -> &'a mut [Item<D, S>] {
        if self.now_is_final {
            self.now
        } else {
            self.spare.copy_from_slice(self.now);
            self.spare
        }
    }
}

/// A leaf over `items` at `offset`: its indices sorted (the kernel's tie
/// rule relies on it) with their points.
fn leaf<const D: usize, S: Copy>(items: &mut [Item<D, S>], offset: usize) -> PointNode {
    sort_by_index(items);
    // Counts and offsets fit: the point count was checked against MAX_POINTS.
    PointNode::leaf(offset as u32, items.len() as u32).unwrap_or(PointNode::EMPTY_LEAF)
}

/// Sorts a leaf's items by index (all distinct).
///
/// Small points in leaves of up to [`RANKED_MAX`] go to their rank, the
/// count of lower indices: every index compared with every other, a
/// vector compare and sum without a branch, then one move per point. A
/// comparison sort mispredicts on about every other compare of indices in
/// random order (a quarter of the build's mispredicts at 2-D, callgrind):
/// the knn bench's 100k-point builds 2-D 7.4 -> 7.0 ms, 3-D 5.5 -> 4.9 ms
/// (best of 15, pinned, interleaved). Large points
/// ([`through_coordinates`]) keep the sort: the ranked copy of their
/// leaf cost more than the mispredicts (8-D 9.8 -> 10.2 ms, 16-D 16.5 ->
/// 17.0 ms), and so did scattering them by rank into the spare buffer in
/// place of the copy into the final array (8-D 9.3 -> 9.8 ms, 16-D 15.3
/// -> 16.2 ms, best of 9, three interleaved rounds).
fn sort_by_index<const D: usize, S: Copy>(items: &mut [Item<D, S>]) {
    let n = items.len();
    let Some(&first) = items.first() else {
        return;
    };
    if n > RANKED_MAX || through_coordinates::<D, S>() {
        items.sort_unstable_by_key(|it| it.index);
        return;
    }
    let mut keys = [u32::MAX; RANKED_MAX];
    for (k, it) in keys.iter_mut().zip(items.iter()) {
        *k = it.index;
    }
    let mut sorted = [first; RANKED_MAX];
    for it in items.iter() {
        let rank: u32 = keys.iter().map(|&k| u32::from(k < it.index)).sum();
        sorted[rank as usize] = *it;
    }
    items.copy_from_slice(&sorted[..n]);
}

/// The largest leaf [`sort_by_index`] sorts by ranks: the default leaf size.
const RANKED_MAX: usize = 32;

/// An interior node splitting axis `a` (below D, so it fits).
fn interior(a: usize, child: usize) -> PointNode {
    PointNode::interior(a as u32, child as u32).unwrap_or(PointNode::EMPTY_LEAF)
}

/// Builds the subtree over `run` into `t`, its root at `slot`.
fn grow<const D: usize, S: Scalar>(
    mut run: Run<'_, D, S>,
    offset: usize,
    depth: u32,
    slot: usize,
    t: &mut Subtree<D, S>,
    params: &PointParams,
    keys: &mut Vec<S>,
) {
    let b = bounds_of(run.now);
    t.bounds[slot] = b;
    t.max_depth = t.max_depth.max(depth);
    let Some(axis) = split_axis(run.now.len(), &b, depth, params) else {
        t.nodes[slot] = leaf(run.into_final(), offset);
        return;
    };
    let (mid, split) = partition(&mut run, axis, keys);
    let child = t.nodes.len();
    t.nodes[slot] = interior(axis, child);
    t.splits[slot] = split;
    t.nodes.extend([PointNode::EMPTY_LEAF; 2]);
    t.splits.extend([S::ZERO; 2]);
    t.bounds.extend([b; 2]);
    let [below, above] = run.children(mid);
    grow(below, offset, depth + 1, child, t, params, keys);
    grow(above, offset + mid, depth + 1, child + 1, t, params, keys);
}

/// [`grow`] for a subtree rooted at 0, forking the two halves of large
/// nodes onto rayon tasks.
fn grow_parallel<const D: usize, S: Scalar>(
    mut run: Run<'_, D, S>,
    offset: usize,
    depth: u32,
    params: &PointParams,
) -> Subtree<D, S> {
    let b = bounds_of(run.now);
    let axis = split_axis(run.now.len(), &b, depth, params);
    let (Some(axis), true) = (axis, run.now.len() >= params.parallel_min) else {
        let mut t = Subtree {
            nodes: vec![PointNode::EMPTY_LEAF],
            splits: vec![S::ZERO],
            bounds: vec![b],
            max_depth: 0,
        };
        grow(run, offset, depth, 0, &mut t, params, &mut Vec::new());
        return t;
    };
    let (mid, split) = partition(&mut run, axis, &mut Vec::new());
    let [below, above] = run.children(mid);
    let (below, above) = rayon::join(
        || grow_parallel(below, offset, depth + 1, params),
        || grow_parallel(above, offset + mid, depth + 1, params),
    );
    splice(interior(axis, 1), split, b, depth, below, above)
}

/// Joins two subtrees under a new root. Depth-first, the below subtree's
/// child pairs come first (right after the root's pair at 1, 2), then the
/// above subtree's: a child at local `c >= 1` moves to `c - 1 + base`.
fn splice<const D: usize, S: Scalar>(
    root: PointNode,
    split: S,
    b: [[S; D]; 2],
    depth: u32,
    below: Subtree<D, S>,
    above: Subtree<D, S>,
) -> Subtree<D, S> {
    let below_base = 3;
    let above_base = below_base + below.nodes.len() - 1;
    let moved = |n: PointNode, base: usize| match n.kind() {
        PointNodeKind::Interior { axis, child } => {
            interior(axis as usize, child as usize - 1 + base)
        }
        PointNodeKind::Leaf { .. } => n,
    };
    let mut nodes = Vec::with_capacity(below.nodes.len() + above.nodes.len() + 1);
    nodes.push(root);
    nodes.push(moved(below.nodes[0], below_base));
    nodes.push(moved(above.nodes[0], above_base));
    nodes.extend(below.nodes[1..].iter().map(|&n| moved(n, below_base)));
    nodes.extend(above.nodes[1..].iter().map(|&n| moved(n, above_base)));
    let mut splits = Vec::with_capacity(nodes.len());
    splits.extend([split, below.splits[0], above.splits[0]]);
    splits.extend_from_slice(&below.splits[1..]);
    splits.extend_from_slice(&above.splits[1..]);
    let mut bounds = Vec::with_capacity(nodes.len());
    bounds.extend([b, below.bounds[0], above.bounds[0]]);
    bounds.extend_from_slice(&below.bounds[1..]);
    bounds.extend_from_slice(&above.bounds[1..]);
    Subtree {
        nodes,
        splits,
        bounds,
        max_depth: depth.max(below.max_depth).max(above.max_depth),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lcg_points(n: usize, seed: u64) -> Vec<[f32; 3]> {
        let mut rng = crate::rng::Rng::new(seed);
        (0..n).map(|_| std::array::from_fn(|_| rng.f32())).collect()
    }

    #[test]
    fn parallel_and_serial_builds_are_identical_and_valid() {
        let pts = lcg_points(5000, 3);
        let serial = build_points(
            &pts,
            &PointParams {
                parallel_min: usize::MAX,
                ..Default::default()
            },
        )
        .unwrap();
        let parallel = build_points(
            &pts,
            &PointParams {
                parallel_min: 100,
                ..Default::default()
            },
        )
        .unwrap();
        assert_eq!(serial, parallel);
        let tree = serial.view().unwrap();
        assert_eq!(tree.len(), 5000);
        // Every point is where its index says, after the leaf-major transpose.
        for (at, &i) in tree.indices().iter().enumerate() {
            assert_eq!(tree.point(at), Some(pts[i as usize]));
        }
    }

    #[test]
    fn signed_zeros_split_as_equals_and_every_point_is_found() {
        // -0 and +0 compare equal in the median selection: the tree must
        // still validate (every point on its side of each split plane).
        let pts: Vec<[f32; 3]> = (0..500)
            .map(|i| {
                let z = if i % 3 == 0 { -0.0 } else { 0.0 };
                [z, (i % 7) as f32, if i % 2 == 0 { -0.0 } else { 0.0 }]
            })
            .collect();
        let built = build_points(&pts, &PointParams::default()).unwrap();
        let tree = built.view().unwrap();
        for p in &pts {
            let n = tree.nearest(*p).unwrap();
            assert_eq!(n.d2, 0.0);
        }
    }

    /// The indices `partition` sends below on axis 0 of points whose
    /// first coordinates are `xs` (the rest 0), in the order `order`
    /// gives them, with the split.
    fn below_set<const D: usize>(xs: &[f32], order: usize) -> (Vec<u32>, f32) {
        let mut now: Vec<Item<D, f32>> = xs
            .iter()
            .enumerate()
            .map(|(i, &x)| Item {
                p: std::array::from_fn(|a| if a == 0 { x } else { 0.0 }),
                index: i as u32,
            })
            .collect();
        match order {
            1 => now.reverse(),
            2 => now.rotate_left(37),
            3 => now.sort_by(|a, b| b.p[0].total_cmp(&a.p[0])),
            _ => {}
        }
        let mut spare = spare_for(&now);
        let mut run = Run {
            now: &mut now,
            spare: &mut spare,
            now_is_final: true,
        };
        let (mid, split) = partition(&mut run, 0, &mut Vec::new());
        let mut ids: Vec<u32> = run.now[..mid].iter().map(|it| it.index).collect();
        ids.sort_unstable();
        (ids, split)
    }

    #[test]
    fn which_points_go_below_depends_on_coordinates_and_indices_only() {
        // The median of the first set is below its largest coordinate;
        // in the second, two thirds of the points sit at the largest, so
        // ties split by index. 2-D points are selected where they lie,
        // 8-D ones through their coordinates: both send the same points.
        let mut rng = crate::rng::Rng::new(4);
        let lattice: Vec<f32> = (0..101).map(|_| rng.below(4) as f32).collect();
        let piled: Vec<f32> = (0..101)
            .map(|_| if rng.below(3) == 0 { rng.f32() } else { 1.0 })
            .collect();
        assert!(!through_coordinates::<2, f32>());
        assert!(through_coordinates::<8, f32>());
        for xs in [lattice, piled] {
            let (ids, split) = below_set::<2>(&xs, 0);
            let at_or_below = xs.iter().filter(|&&x| x <= split).count();
            let expected = if at_or_below < xs.len() {
                at_or_below
            } else {
                50
            };
            assert_eq!(ids.len(), expected);
            for order in 0..4 {
                assert_eq!(below_set::<2>(&xs, order), (ids.clone(), split), "{order}");
                assert_eq!(below_set::<8>(&xs, order), (ids.clone(), split), "{order}");
            }
        }
    }

    #[test]
    fn nan_points_are_rejected_by_index() {
        let mut pts = lcg_points(10, 1);
        pts[7][1] = f32::NAN;
        let e = build_points(&pts, &PointParams::default()).unwrap_err();
        assert!(matches!(e, PointBuildError::NonFinite { point: 7, .. }));
        assert!(e.to_string().contains("point 7"));
    }

    #[test]
    fn leaves_are_sorted_by_index_with_their_points() {
        let mut r = crate::rng::Rng::new(11);
        for n in 0..=(RANKED_MAX + 3) {
            // Distinct indices in random order, each point tagged by its index.
            let mut ids: Vec<u32> = (0..n as u32).map(|i| i * 7 + 3).collect();
            for i in (1..n).rev() {
                ids.swap(i, r.below(i + 1));
            }
            let small: Vec<Item<2, f32>> = ids
                .iter()
                .map(|&i| Item {
                    p: [i as f32, -(i as f32)],
                    index: i,
                })
                .collect();
            let large: Vec<Item<8, f64>> = ids
                .iter()
                .map(|&i| Item {
                    p: [f64::from(i); 8],
                    index: i,
                })
                .collect();
            let (mut a, mut b) = (small, large);
            sort_by_index(&mut a);
            sort_by_index(&mut b);
            let want: Vec<u32> = (0..n as u32).map(|i| i * 7 + 3).collect();
            assert_eq!(a.iter().map(|it| it.index).collect::<Vec<_>>(), want);
            assert_eq!(b.iter().map(|it| it.index).collect::<Vec<_>>(), want);
            assert!(a
                .iter()
                .all(|it| it.p == [it.index as f32, -(it.index as f32)]));
            assert!(b.iter().all(|it| it.p == [f64::from(it.index); 8]));
        }
    }

    /// `bounds_of` against one fold over every point, at each length
    /// around its four boxes' groups.
    fn bounds_match_a_fold<const D: usize>(r: &mut crate::rng::Rng) {
        for n in 1..20 {
            let items: Vec<Item<D, f32>> = (0..n)
                .map(|i| Item {
                    p: std::array::from_fn(|_| r.range(-5.0, 5.0)),
                    index: i,
                })
                .collect();
            let want = items.iter().fold([items[0].p; 2], |[lo, hi], it| {
                [
                    std::array::from_fn(|a| lo[a].min(it.p[a])),
                    std::array::from_fn(|a| hi[a].max(it.p[a])),
                ]
            });
            assert_eq!(bounds_of(&items), want, "D {D} n {n}");
        }
    }

    #[test]
    fn node_bounds_are_tight() {
        let mut r = crate::rng::Rng::new(4);
        bounds_match_a_fold::<1>(&mut r);
        bounds_match_a_fold::<2>(&mut r);
        bounds_match_a_fold::<3>(&mut r);
        assert_eq!(bounds_of::<2, f32>(&[]), [[0.0; 2]; 2]);
    }

    #[test]
    fn a_pile_is_one_leaf_and_empty_sets_build() {
        let pile = vec![[1.0f32, 2.0, 3.0]; 1000];
        let t = build_points(&pile, &PointParams::default()).unwrap();
        assert_eq!(t.nodes.len(), 1);
        assert!(t.view().is_ok());
        let empty = build_points::<3, f32>(&[], &PointParams::default()).unwrap();
        assert!(empty.view().is_ok());
    }
}
