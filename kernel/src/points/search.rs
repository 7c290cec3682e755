//! The one search loop every point query runs: descend into the near child
//! first, push the far child if its box may hold a better point, scan the
//! leaf, backtrack, and prune every subtree whose box is farther than the
//! current bound. What "better" and "bound" mean is the query's
//! [`Accumulator`].

use super::scalar::{box_distance2, larger};
use super::{distance2, PointNode, PointTreeN, Scalar, MAX_DEPTH};
use crate::lanes::prefetch;

/// What a query keeps while the search runs.
pub(crate) trait Accumulator<S> {
    /// Subtrees whose box is at a squared distance *above* this are pruned
    /// (equal is kept: it may hold an equally distant, lower-index point).
    fn bound(&self) -> S;

    /// Offers the point `index` at squared distance `d2`; `false` if it was
    /// rejected (not within the bound, or after the k-th best).
    fn offer(&mut self, d2: S, index: u32) -> bool;
}

impl<const D: usize, S: Scalar> PointTreeN<'_, D, S> {
    /// Runs the search for `q` (not NaN: checked by the callers) into `acc`.
    ///
    /// The stack holds at most one far child per level, so [`MAX_DEPTH`]
    /// entries suffice for a validated tree; for an unvalidated one a full
    /// stack drops the far child (a wrong answer, never a panic). In a
    /// tree each node is entered at most once per query, so the walk stops
    /// after as many node visits as there are nodes: a blob whose children
    /// loop (loaded unchecked) ends the query, never hangs it.
    #[inline(always)]
    pub(crate) fn search<A: Accumulator<S>>(&self, q: &[S; D], acc: &mut A) {
        // (far child, lower bound on its points' squared distances).
        // Tried: left uninitialised, as the triangle walk's (an `unsafe`
        // read): 4.7% fewer instructions at 2-D k = 1 (callgrind), but the
        // rates moved within +-3% (2-D +2%, 8-D k = 10 -3%, interleaved):
        // not worth the `unsafe`.
        let mut stack = [(0u32, S::ZERO); MAX_DEPTH as usize];
        let mut len = 0usize;
        let mut node_idx = 0u32;
        let mut visits_left = self.nodes.len();
        let Some(root) = self.bounds.first() else {
            return;
        };
        // The lower bound of the subtree being descended: its box distance.
        let mut lower = box_distance2(root, q);
        if lower > acc.bound() {
            return;
        }
        'descend: loop {
            let (Some(&(mut node)), Some(&(mut split))) = (
                self.nodes.get(node_idx as usize),
                self.splits.get(node_idx as usize),
            ) else {
                return;
            };
            // Walk down to a leaf, near child first. No box is read here:
            // the far child's bound is the larger of the split plane's gap
            // (every far point is beyond the plane, validated) and the
            // subtree's own bound; its box is read only if it is popped.
            let leaf = loop {
                if visits_left == 0 {
                    return;
                }
                visits_left -= 1;
                if node.is_leaf() {
                    break Some(node);
                }
                // Both children (side by side) are loaded before the side
                // is known, so the next node's load runs beside this
                // node's compare instead of after it: the descent's chain
                // is one load or one compare a level, not both.
                let child = node.word0();
                let c = child as usize;
                let (Some(&[below, above]), Some(&[s_below, s_above])) = (
                    self.nodes
                        .get(c..c.wrapping_add(2))
                        .and_then(|p| p.first_chunk()),
                    self.splits
                        .get(c..c.wrapping_add(2))
                        .and_then(|p| p.first_chunk()),
                ) else {
                    break None;
                };
                // A validated axis is below D; the clamp keeps an
                // unvalidated one in range without a branch. Tried: the
                // coordinate picked by `select_unpredictable` instead of
                // the compiler's branch on the axis (mispredicted about
                // one step in six at 2-D): 2-D unchanged, 3-D 0.80x ->
                // 0.78x kiddo (interleaved, pinned); again with both
                // children loaded ahead: 3-D 0.97x -> 0.93x.
                let axis = (node.field() as usize).min(D - 1);
                let gap = q[axis] - split;
                // Near child: the one on the query's side of the split
                // plane (below for coordinates <= split), picked by a
                // select: the side is a coin toss on scattered queries.
                let above_near = gap > S::ZERO;
                let far_d = larger(gap * gap, lower);
                // Written always, kept when within the bound: no branch.
                let far = child.wrapping_add(u32::from(!above_near));
                if let Some(slot) = stack.get_mut(len) {
                    *slot = (far, far_d);
                    len += usize::from(far_d <= acc.bound());
                }
                // The far child's box is read if it is popped: fetched
                // now, it is there by then (8-D 1.03x -> 1.08-1.10x
                // kiddo, 3-D +1-3%, 2-D unchanged; an 8-D box is a line).
                // Tried: the grandchildren's pairs prefetched too (nodes,
                // and splits): every row within +-3%.
                prefetch(self.bounds.as_ptr().wrapping_add(far as usize));
                node_idx = child.wrapping_add(u32::from(above_near));
                (node, split) = core::hint::select_unpredictable(
                    above_near,
                    (above, s_above),
                    (below, s_below),
                );
            };
            if let Some(node) = leaf {
                self.scan_leaf(node_idx, node, q, acc);
            }
            // Backtrack: the nearest pending far child whose box is still
            // within the bound (the tight box prunes empty space).
            while len > 0 {
                len -= 1;
                // `get`: `len` counts pushed entries, but an index would
                // leave a panic path the optimiser cannot remove (firmware/).
                let Some(&(far, far_d)) = stack.get(len) else {
                    return;
                };
                if far_d > acc.bound() {
                    continue;
                }
                let Some(far_box) = self.bounds.get(far as usize) else {
                    continue;
                };
                lower = larger(box_distance2(far_box, q), far_d);
                if lower <= acc.bound() {
                    node_idx = far;
                    continue 'descend;
                }
            }
            return;
        }
    }

    /// Offers every point of a leaf to `acc`, in position order.
    ///
    /// The leaf's coordinates are stored axis by axis, so its distances
    /// are computed [`CHUNK`] points at a time, one axis after the other:
    /// each step is one vector operation over the chunk, and each point's
    /// sum still runs over the axes left to right, as in [`distance2`],
    /// so the bits are the same.
    #[inline(always)]
    fn scan_leaf<A: Accumulator<S>>(
        &self,
        node_idx: u32,
        node: PointNode,
        q: &[S; D],
        acc: &mut A,
    ) {
        let (offset, count) = (node.word0() as usize, node.field() as usize);
        let (Some(block), Some(indices)) = (
            self.leaf_block(offset, count),
            self.indices.get(offset..offset.saturating_add(count)),
        ) else {
            return;
        };
        // Only a large leaf is worth the read of its box: a small pile is
        // scanned as fast as any leaf.
        let pile = count > PILE_MIN
            && self
                .bounds
                .get(node_idx as usize)
                .is_some_and(|b| b[0] == b[1]);
        if pile {
            // All points at one location, indices increasing: once one is
            // rejected, so is every later one (module docs, "Ties").
            let mut p = [S::ZERO; D];
            for (a, c) in p.iter_mut().enumerate() {
                let Some(&x) = block.get(a * count) else {
                    return;
                };
                *c = x;
            }
            let d2 = distance2(&p, q);
            for &i in indices {
                if !acc.offer(d2, i) {
                    break;
                }
            }
            return;
        }
        // One buffer for every chunk, filled in place: a returned array
        // was copied (the firmware's k-NN stack 1,036 -> 888 bytes).
        let mut d = [S::INFINITY; CHUNK];
        for (c, ids) in indices.chunks(CHUNK).enumerate() {
            chunk_distances(&mut d, block, count, c * CHUNK, ids.len(), q);
            // Most chunks lose whole: one vector min and one compare
            // decide it (`chunk_min`: a NaN never hides a point; the
            // per-point test below is the exact one).
            let nearest = chunk_min(&d);
            if nearest > acc.bound() {
                continue;
            }
            // Tried for k = 1: one offer of the chunk's first point at
            // `nearest` (a compare mask and its lowest bit) instead of a
            // branch per point: 0.72-0.75x kiddo against 0.81x at 2-D and
            // 3-D (uniform, interleaved): the branches predict well.
            // Tried for k = 1: each of 8 lanes keeping its best point by
            // compare and select over the whole leaf, one offer per leaf:
            // mispredicts 16.6 -> 5.9 a query at 2-D (callgrind, uniform)
            // but 1.34x the instructions (the selects stayed scalar) and
            // 0.58-0.61x kiddo against 0.81-0.83x: the mispredicts are
            // not what is left of the gap.
            // Tried: the whole search compiled at the run-time ISA level
            // (`lanes::dispatch`, a chunk's distances in one AVX
            // register): 2-D k = 1 0.95-0.98x -> 0.92-0.93x kiddo, 8-D and
            // 16-D within the noise; the scan's arithmetic is not the cost.
            // Tried for every k: a mask of the chunk's points within the
            // bound (one compare each), offered by its set bits: 2-D and
            // 3-D k = 1 0.97x -> 0.93x kiddo, k = 10 unchanged (0.88-0.93x).
            for (&d2, &i) in d.iter().zip(ids) {
                if d2 <= acc.bound() {
                    acc.offer(d2, i);
                }
            }
        }
    }
}

/// Writes to `d` the squared distances to `q` of the `len` (at most
/// [`CHUNK`]) points at `j0..j0 + len` of a leaf block of `count` points
/// (axis by axis), each summed over the axes left to right as in
/// [`distance2`], so the bits are the same; past `len` the entries are
/// +inf.
///
/// Tried: full chunks as fixed-size arrays with the tail copied into a
/// padded one (a `memcpy` call per axis), then read in place: 3-7% more
/// instructions than this one loop at 3-D k = 10 and 8-D (callgrind).
#[inline(always)]
fn chunk_distances<const D: usize, S: Scalar>(
    d: &mut [S; CHUNK],
    block: &[S],
    count: usize,
    j0: usize,
    len: usize,
    q: &[S; D],
) {
    *d = [S::INFINITY; CHUNK];
    for (a, &qa) in q.iter().enumerate() {
        let at = a * count + j0;
        let Some(col) = block.get(at..at + len) else {
            break;
        };
        for (dj, &x) in d.iter_mut().zip(col) {
            let t = x - qa;
            *dj = if a == 0 { t * t } else { dj.add(t * t) };
        }
    }
}

/// The least of a chunk's distances: eight running minimums side by side
/// (a vector min per eight distances, not a chain through all of them),
/// then their halves. A NaN distance may survive or drop out; either way
/// no point is lost, since the per-point test never offers a NaN and a
/// NaN minimum skips nothing.
#[inline(always)]
fn chunk_min<S: Scalar>(d: &[S; CHUNK]) -> S {
    let low = |a: S, b: S| if b < a { b } else { a };
    let mut m = [S::INFINITY; 8];
    for eight in d.chunks_exact(8) {
        for (m, &x) in m.iter_mut().zip(eight) {
            *m = low(*m, x);
        }
    }
    let m4: [S; 4] = core::array::from_fn(|i| low(m[i], m[i + 4]));
    let m2 = [low(m4[0], m4[2]), low(m4[1], m4[3])];
    low(m2[0], m2[1])
}

/// Points per step of the leaf scan: the builder's default leaf size
/// below 8-D, so a leaf is one pass of each axis over contiguous
/// coordinates and one skip decision (from 8-D on a default leaf of up to
/// 64 points takes two). Against chunks of 8 (two rounds, the knn bench): 2-D
/// and 3-D uniform k = 1 and 10 0.89-0.98x -> 1.04-1.12x kiddo, 8-D
/// 1.09-1.12x -> 1.26-1.41x, 16-D 1.1x -> 1.7-2.0x, 2-D clustered k = 1
/// 2.05x -> 2.25x; chunks of 16 and 64 fall between the two, 4 at
/// 0.65-0.76x.
const CHUNK: usize = 32;

/// Leaves of more points than this are checked for being a pile.
const PILE_MIN: usize = 64;
