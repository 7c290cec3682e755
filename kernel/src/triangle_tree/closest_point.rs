//! The closest point of the mesh to a query point: the lecture's
//! nearest-neighbour walk over the tree's cells. Descend into the near
//! child (the one on the query's side of the split plane) first, push the
//! far child with the squared distance from the query to its cell, scan
//! the leaf, then backtrack to the last pending cell that could still hold
//! a nearer triangle; every cell farther than the best so far is pruned.
//!
//! The cells are not stored, nor carried: the distance from the query to a
//! cell is the sum of three squared gaps, one per axis (Arya and Mount's
//! incremental distance). The near child's gaps are its parent's; the far
//! child's differ only along the split axis, where the gap is the distance
//! from the query to the split plane. So a pending far child carries its
//! three squared gaps, and the walk starts from the root cell's (a query
//! far outside the mesh's box starts clamped onto it). The sum is taken in
//! the order of `box_distance2`, so it is
//! bit for bit the box distance of the cell.

use super::{LeafPrims, TriangleTree};
use crate::blob::MAX_DEPTH;
use crate::triangle::{box_gaps2, ClosestPoint, NearestTriangle};
use core::mem::MaybeUninit;

/// A far child waiting on the stack: its node and the squared gaps from
/// the query to its cell along x, y and z.
#[derive(Clone, Copy)]
struct PendingCell {
    node: u32,
    gaps2: [f64; 3],
}

/// The last [`Seen::LEN`] triangles offered: neighbouring leaves list the
/// triangles that cross the split plane between them.
///
/// Tried 32: no faster than 16 on the bunny and sponza (within noise).
struct Seen {
    prims: [u32; Seen::LEN],
    next: usize,
}

impl Seen {
    const LEN: usize = 16;

    fn new() -> Seen {
        Seen {
            prims: [u32::MAX; Seen::LEN],
            next: 0,
        }
    }

    /// Remembers `prim`; `false` if it was among the last ones.
    #[inline(always)]
    fn insert(&mut self, prim: u32) -> bool {
        if self.prims.contains(&prim) {
            return false;
        }
        self.prims[self.next % Seen::LEN] = prim;
        self.next = self.next.wrapping_add(1);
        true
    }
}

/// The squared distance from the query to a cell of squared gaps `g`.
#[inline(always)]
fn cell_distance2(g: &[f64; 3]) -> f64 {
    g[0] + g[1] + g[2]
}

impl TriangleTree<'_> {
    /// The closest point of the mesh to `q`: its triangle (the lowest
    /// index among equally near ones), barycentrics and squared distance.
    /// Bit for bit [`closest_point_brute`](crate::closest_point_brute)
    /// over all triangles. `None` for an empty tree or a query with a NaN
    /// or infinite coordinate.
    ///
    /// # Panics
    /// Never. No allocation; the stack is [`MAX_DEPTH`](crate::MAX_DEPTH)
    /// entries of 32 bytes.
    ///
    /// # Example
    /// ```
    /// use kdray_kernel::{closest_point_brute, TriangleTree};
    /// static CUBE: &kdray_kernel::Aligned<[u8]> =
    ///     kdray_kernel::include_aligned!("../../golden/cube-v3.kdt");
    /// let tree = TriangleTree::from_bytes(&CUBE.bytes)?;
    ///
    /// // Half a unit below the cube's floor (z = 0): the point straight above.
    /// let c = tree.closest_point([0.25, 0.5, -0.5]).unwrap();
    /// assert_eq!(c.point, [0.25, 0.5, 0.0]);
    /// assert_eq!(c.distance2, 0.25);
    /// let brute = closest_point_brute(tree.triangles(), [0.25, 0.5, -0.5], f32::INFINITY);
    /// assert_eq!(c.bits(), brute.unwrap().bits());
    /// // Nothing within a tenth of a unit.
    /// assert!(tree.closest_point_within([0.25, 0.5, -0.5], 0.1).is_none());
    /// assert!(tree.closest_point([f32::NAN, 0.0, 0.0]).is_none());
    /// // Starting from any triangle gives the same answer.
    /// let from = tree.closest_point_from([0.25, 0.5, -0.5], f32::INFINITY, 7);
    /// assert_eq!(from.unwrap().bits(), c.bits());
    /// # Ok::<(), kdray_kernel::BlobError>(())
    /// ```
    #[must_use]
    pub fn closest_point(&self, q: [f32; 3]) -> Option<ClosestPoint> {
        self.closest_point_within(q, f32::INFINITY)
    }

    /// [`TriangleTree::closest_point`] among the points within
    /// `max_distance` of `q` (at distance `<= max_distance`, compared
    /// squared in `f64`). `None` also when nothing lies that close, or
    /// `max_distance` is NaN or negative.
    #[must_use]
    pub fn closest_point_within(&self, q: [f32; 3], max_distance: f32) -> Option<ClosestPoint> {
        self.closest_point_from(q, max_distance, u32::MAX)
    }

    /// [`TriangleTree::closest_point_within`], the search starting with
    /// triangle `start` already tested: the same answer, bit for bit, for
    /// any `start` (an index past the triangles is ignored). A `start`
    /// near `q` (the previous answer of a batch in space order) gives the
    /// walk a tight first bound, so it prunes from the first cell on.
    #[must_use]
    pub fn closest_point_from(
        &self,
        q: [f32; 3],
        max_distance: f32,
        start: u32,
    ) -> Option<ClosestPoint> {
        let b = self.bounds;
        let scale = b
            .min
            .iter()
            .chain(&b.max)
            .fold(0.0f32, |m, c| m.max(c.abs()));
        let mut best = NearestTriangle::new(q, max_distance, scale)?;
        if let Some(tri) = self.triangles.get(start as usize) {
            best.offer(tri, start);
        }
        self.nearest_triangle(&mut best);
        best.answer()
    }

    /// The walk of the module docs, into `best`.
    ///
    /// The stack holds at most one far child per level, so
    /// [`MAX_DEPTH`] entries suffice for a validated tree; for an
    /// unvalidated one a full stack drops the far child (a wrong answer,
    /// never a panic), and the walk stops after as many node visits as
    /// there are nodes (a blob whose children loop never hangs it).
    fn nearest_triangle(&self, best: &mut NearestTriangle) {
        let q = best.q;
        // Left uninitialised: writing the 2 KB per query was ~3% of a
        // query near the surface. Invariant: entries below `len` are
        // written (a push writes `stack[len]` before `len` grows past it).
        let mut stack = [MaybeUninit::<PendingCell>::uninit(); MAX_DEPTH as usize];
        let mut len = 0usize;
        let mut seen = Seen::new();
        let mut visits_left = self.nodes.len();
        let (mut node_idx, mut gaps2) = (0u32, box_gaps2(&self.bounds, &q));
        if cell_distance2(&gaps2) > best.cut() {
            return;
        }
        'descend: loop {
            let Some(&(mut node)) = self.nodes.get(node_idx as usize) else {
                return;
            };
            // Walk down to a leaf, near child first.
            loop {
                if visits_left == 0 {
                    return;
                }
                visits_left -= 1;
                if node.is_leaf() {
                    break;
                }
                let axis = node.axis_bits().min(2);
                let split = f64::from(node.split());
                let child = node.upper();
                // The near child holds the query's side (coordinates
                // `<= split` below); its gaps are its parent's. The far
                // child's gap along the axis is the distance to the split
                // plane.
                let off = q[axis] - split;
                let (near, far) = if off > 0.0 {
                    (child.wrapping_add(1), child)
                } else {
                    (child, child.wrapping_add(1))
                };
                // The far child, unless it is an empty cell or farther
                // than the best so far.
                // Selected per axis rather than written at `axis`: the
                // gaps stay in registers, not in a stack slot indexed at
                // run time.
                let o2 = off * off;
                let far_gaps2: [f64; 3] =
                    core::array::from_fn(|a| if a == axis { o2 } else { gaps2[a] });
                if cell_distance2(&far_gaps2) <= best.cut()
                    && self
                        .nodes
                        .get(far as usize)
                        .is_some_and(|n| !n.is_empty_leaf())
                {
                    if let Some(slot) = stack.get_mut(len) {
                        slot.write(PendingCell {
                            node: far,
                            gaps2: far_gaps2,
                        });
                        len += 1;
                    }
                }
                let Some(&n) = self.nodes.get(near as usize) else {
                    return;
                };
                node = n;
            }
            match self.leaf_prims(node) {
                LeafPrims::One(p) => self.offer(best, &mut seen, p),
                LeafPrims::Run(run) => {
                    for &p in run {
                        self.offer(best, &mut seen, p);
                    }
                }
            }
            // Backtrack: the last pushed far child still within the cut.
            while len > 0 {
                len -= 1;
                let Some(&slot) = stack.get(len) else {
                    return;
                };
                // SAFETY: `len` was above this entry, so it was written
                // (the invariant where `stack` is declared).
                let p = unsafe { slot.assume_init() };
                if cell_distance2(&p.gaps2) <= best.cut() {
                    (node_idx, gaps2) = (p.node, p.gaps2);
                    continue 'descend;
                }
            }
            return;
        }
    }

    /// Offers triangle `prim` to `best` when its box lies within the cut,
    /// unless it was offered lately: a triangle listed in several leaves
    /// answers the same each time, and against a best that only gets
    /// nearer it cannot win the second time. The box test comes first: it
    /// is cheaper than the look-up and turns most triangles away, and one
    /// turned away stays so (the cut only shrinks), so [`Seen`] keeps only
    /// triangles that passed it.
    #[inline(always)]
    fn offer(&self, best: &mut NearestTriangle, seen: &mut Seen, prim: u32) {
        if let Some(tri) = self.triangles.get(prim as usize) {
            if best.may_take(tri, prim) && seen.insert(prim) {
                best.offer(tri, prim);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    //! CI runs these under Miri (`.ci/run`'s filter
    //! `triangle_tree::closest_point::`): the walk's stack is left
    //! uninitialised.
    extern crate std;
    use super::*;
    use crate::geometry::Bounds;
    use crate::test_rng::Rng;
    use crate::triangle::{closest_point_brute, Triangle};
    use crate::Node;
    use std::vec::Vec;

    /// A hand-built tree over `tris`: split at x = 0, then the above side
    /// at y = 0; every triangle listed in every leaf whose cell it touches.
    fn hand_tree(tris: &[Triangle]) -> (Vec<Node>, Vec<u32>, Bounds) {
        let b = tris
            .iter()
            .fold(crate::geometry::Bounds::EMPTY, |b, t| b.union(&t.bounds()));
        let b = Bounds {
            min: b.min.map(|c| c.min(-1.0)),
            max: b.max.map(|c| c.max(1.0)),
        };
        let cells = [
            b.split(0, 0.0).0,
            b.split(0, 0.0).1.split(1, 0.0).0,
            b.split(0, 0.0).1.split(1, 0.0).1,
        ];
        let mut prims = Vec::new();
        let mut leaves = Vec::new();
        for c in cells {
            let start = prims.len() as u32;
            for (i, t) in tris.iter().enumerate() {
                let tb = t.bounds();
                if (0..3).all(|a| tb.min[a] <= c.max[a] && tb.max[a] >= c.min[a]) {
                    prims.push(i as u32);
                }
            }
            let n = prims.len() as u32 - start;
            leaves.push(Node::leaf(n, start).unwrap());
        }
        let nodes = std::vec![
            Node::interior(crate::Axis::X, 0.0, 2).unwrap(),
            Node::EMPTY_LEAF,
            leaves[0],
            Node::interior(crate::Axis::Y, 0.0, 4).unwrap(),
            leaves[1],
            leaves[2],
        ];
        (nodes, prims, b)
    }

    #[test]
    fn random_queries_match_brute_force_bit_for_bit() {
        // Fewer under Miri (CI runs this module there: it checks the
        // uninitialised stack).
        let queries = if cfg!(miri) { 200 } else { 2000 };
        let mut r = Rng(0x9e37_79b9_7f4a_7c15);
        let mut tris = Vec::new();
        for _ in 0..40 {
            let c = [r.f() * 4.0 - 2.0, r.f() * 4.0 - 2.0, r.f() * 4.0 - 2.0];
            tris.push(Triangle {
                v: core::array::from_fn(|_| core::array::from_fn(|a| c[a] + r.f() - 0.5)),
            });
        }
        // A duplicate of triangle 3 at index 40: every tie goes to 3.
        tris.push(tris[3]);
        let (nodes, prims, b) = hand_tree(&tris);
        let tree = TriangleTree::from_parts(&nodes, &prims, &tris, b).unwrap();
        for i in 0..queries {
            let q = if i % 4 == 0 {
                // On a vertex of a triangle: distance 0.
                tris[i % tris.len()].v[i % 3]
            } else {
                core::array::from_fn(|_| r.f() * 8.0 - 4.0)
            };
            for max in [f32::INFINITY, 0.5] {
                let a = tree.closest_point_within(q, max).map(|c| c.bits());
                let want = closest_point_brute(&tris, q, max).map(|c| c.bits());
                assert_eq!(a, want, "{q:?} {max}");
                // Any first triangle, or none (past the end), gives the same.
                let start = (i % (tris.len() + 3)) as u32;
                let from = tree.closest_point_from(q, max, start).map(|c| c.bits());
                assert_eq!(from, want, "{q:?} {max} from {start}");
            }
        }
    }

    #[test]
    fn empty_tree_and_bad_queries_miss() {
        let nodes = [Node::EMPTY_LEAF, Node::EMPTY_LEAF];
        let tree = TriangleTree::from_parts(&nodes, &[], &[], Bounds::ZERO).unwrap();
        assert_eq!(tree.closest_point([0.0; 3]), None);
    }
}
