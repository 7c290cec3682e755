//! The closest point of a scene: the lecture's nearest-neighbour walk
//! over the top-level tree's cells, each instance met in a leaf answered
//! in its own space ([`Instance::local_point`]) by its mesh tree
//! ([`TriangleTree::closest_point`](crate::TriangleTree::closest_point)).
//!
//! Distances are measured in world space. For a transform that is a
//! rotation (or reflection) times a uniform scale `s` (a similarity,
//! [`Instance::similarity_scale2`]) the nearest point in the mesh's space
//! is the nearest in the world, at `s` times the distance: the instance's
//! world squared distance is `s^2` times the mesh tree's. Under a
//! non-uniform scale or a shear it is not (a nearer point in the mesh's
//! metric can be a farther one in the world's), so a selected instance
//! with such a transform makes the query refuse ([`NotSimilar`]) instead
//! of answering wrongly.
//!
//! The winner is the smallest world squared distance, then the lower
//! instance, then (within an instance) the lower triangle: bit for bit
//! [`Scene::closest_point_brute`].
//!
//! # The walk
//! Descend into the near child (the query's side of the split plane)
//! first, push the far child with its squared gaps (the mesh walk's
//! incremental cell distance, `triangle_tree/closest_point.rs`), test the
//! leaf's instances, then backtrack to the last pending cell that is not
//! pruned. An instance whose world box ([`Instance::world_bounds`]) lies
//! beyond the instance cut is skipped: twice the best squared distance
//! plus `2^-28` of the squared coordinate magnitudes of the query, the
//! scene bounds, the query in the instance's space and the mesh's box
//! (scaled by `s^2`), far above the rounding of the query's transform and
//! the `2^-16` a similarity may be off. So a skipped instance's computed
//! distance exceeds the best: it could neither win nor tie.
//!
//! A cell is pruned by the cell cut: twice the best plus `2^-28` of
//! `64 m^2 + 4 r^2`, `m` the largest coordinate magnitude of the query and
//! the scene bounds and `r^2` the largest `s^2` times squared magnitude of
//! an instance's mesh box (measured once, when the scene is validated). An
//! instance listed in a cell lies in the world box at most `2 m` from the
//! query in each coordinate, so its local query is within `sqrt(3) 2 m /
//! s` of its mesh box and its cut's slack below `33 m^2 + 2.1 r^2`: the
//! cell cut is above every instance cut. The point of an instance's box
//! nearest the query lies in a leaf listing it (the top level lists an
//! instance in every leaf its box overlaps), whose cell is no farther than
//! the box; so when that cell is pruned the instance would have been
//! skipped too, and the walk's answer is the brute force's.

use super::walk::Mailbox;
use super::{Instance, Scene};
use crate::blob::MAX_DEPTH;
use crate::geometry::Bounds;
use crate::triangle::{box_distance2, box_gaps2, ClosestPoint};
use core::fmt;

/// A scene's closest point to a query.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SceneClosestPoint {
    /// The closest point in world space (the mesh's point through the
    /// instance's transform in `f64`, rounded once).
    pub point: [f32; 3],
    /// The instance's index in the scene.
    pub instance: u32,
    /// The triangle's index in its mesh.
    pub prim: u32,
    /// Barycentric weight of the triangle's vertex 1.
    pub u: f32,
    /// Barycentric weight of the triangle's vertex 2.
    pub v: f32,
    /// The world squared distance: the instance's `s^2` times the mesh
    /// tree's `distance2`.
    pub distance2: f64,
}

impl SceneClosestPoint {
    /// The fields' bits, for bitwise comparisons in tests.
    #[must_use]
    pub fn bits(&self) -> [u64; 8] {
        let [x, y, z] = self.point.map(|c| u64::from(c.to_bits()));
        [
            x,
            y,
            z,
            u64::from(self.instance),
            u64::from(self.prim),
            u64::from(self.u.to_bits()),
            u64::from(self.v.to_bits()),
            self.distance2.to_bits(),
        ]
    }

    /// The point, its triangle, weights and world squared distance, as a
    /// tree's closest point reports them (without the instance).
    #[must_use]
    pub fn point_only(&self) -> ClosestPoint {
        ClosestPoint {
            point: self.point,
            prim: self.prim,
            u: self.u,
            v: self.v,
            distance2: self.distance2,
        }
    }
}

/// A selected instance whose transform is not a similarity (a non-uniform
/// scale or a shear): the scene's closest point is refused (module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct NotSimilar {
    /// The instance's index in the scene.
    pub instance: u32,
}

impl fmt::Display for NotSimilar {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "instance {} is scaled unevenly or sheared: the closest point in its mesh's space is not the closest in the world",
            self.instance
        )
    }
}

/// The running best over instances: smallest world squared distance, then
/// lower instance. Shared by the walk and the brute force.
pub(super) struct NearestInstance {
    pub(super) best: Option<SceneClosestPoint>,
}

impl NearestInstance {
    /// Keeps instance `i`'s answer `c` (in its space, scale `s2`) if it
    /// wins.
    pub(super) fn keep(&mut self, i: u32, inst: &Instance, s2: f64, c: ClosestPoint) {
        let d2 = s2 * c.distance2;
        if self
            .best
            .is_none_or(|b| d2 < b.distance2 || (d2 == b.distance2 && i < b.instance))
        {
            self.best = Some(SceneClosestPoint {
                point: inst.world_point(c.point),
                instance: i,
                prim: c.prim,
                u: c.u,
                v: c.v,
                distance2: d2,
            });
        }
    }
}

/// The largest squared coordinate magnitude of `p` and `b`, in `f64`.
fn magnitude2(p: &[f32; 3], b: &Bounds) -> f64 {
    let m = p
        .iter()
        .chain(&b.min)
        .chain(&b.max)
        .fold(0.0f64, |m, c| m.max(f64::from(c.abs())));
    m * m
}

/// `2^-28`: the slack of both cuts, relative to squared magnitudes
/// (module docs).
const SLACK: f64 = 1.0 / 268_435_456.0;

/// An instance's mesh box magnitude as the cell cut counts it: `s^2`
/// times its squared largest coordinate (module docs, `r^2`).
pub(super) fn reach2(s2: f64, local: &Bounds) -> f64 {
    s2 * magnitude2(&[0.0; 3], local)
}

/// A far cell waiting on the stack: its node and the squared gaps from
/// the query to its cell along x, y and z.
#[derive(Clone, Copy, Default)]
struct PendingCell {
    node: u32,
    gaps2: [f64; 3],
}

/// The walk's state: the query, the best so far and the cuts' parts.
struct Search<'s, 'a> {
    scene: &'s Scene<'a>,
    q: [f32; 3],
    qw: [f64; 3],
    mask: u32,
    /// `max_distance` squared: an instance beyond it cannot be the answer.
    limit: f64,
    near: NearestInstance,
    /// `m^2` (module docs): the query's and the scene bounds' magnitude.
    m2: f64,
    /// The cell cut's slack.
    cell_slack: f64,
    traced: Mailbox,
}

impl Search<'_, '_> {
    /// The squared distance no answer can exceed: the best so far, or the
    /// limit before one is found.
    fn bound(&self) -> f64 {
        self.near
            .best
            .map_or(self.limit, |b| b.distance2.min(self.limit))
    }

    /// Cells farther than this hold no instance that could win or tie.
    fn cell_cut(&self) -> f64 {
        2.0 * self.bound() + self.cell_slack
    }

    /// Tests instance `i` unless it cannot win (module docs) or was tested
    /// lately (a second test answers the same and cannot win again).
    fn instance(&mut self, i: u32) {
        if self.near.best.is_some_and(|b| b.instance == i) || self.traced.seen(i) {
            return;
        }
        let Some((inst, mesh)) = self.scene.selected(i, self.mask) else {
            return;
        };
        // Selected and not a similarity: refused before the walk.
        let Some(s2) = inst.similarity_scale2() else {
            return;
        };
        let local = mesh.bounds();
        let lq = inst.local_point(self.q);
        let slack = (self.m2 + s2 * magnitude2(&lq, &local)) * SLACK;
        if box_distance2(&inst.world_bounds(&local), &self.qw) > 2.0 * self.bound() + slack {
            return;
        }
        if let Some(c) = mesh.closest_point(lq) {
            self.near.keep(i, inst, s2, c);
        }
    }
}

impl<'a> Scene<'a> {
    /// Does [`Scene::closest_point`] answer for `mask`: is every instance
    /// it selects a similarity? O(1) when so (the masks of the others are
    /// merged once, at validation).
    ///
    /// # Errors
    /// [`NotSimilar`] naming the first selected instance that is scaled
    /// unevenly or sheared: the closest-point queries' refusal.
    pub fn check_similar(&self, mask: u32) -> Result<(), NotSimilar> {
        if self.unsimilar_masks & mask == 0 {
            return Ok(());
        }
        for i in 0..self.instances.len() as u32 {
            if let Some((inst, _)) = self.selected(i, mask) {
                if inst.similarity_scale2().is_none() {
                    return Err(NotSimilar { instance: i });
                }
            }
        }
        Ok(())
    }

    /// The closest point to `q` (world space) over the instances `mask`
    /// selects (`instance mask & mask != 0`), measured in world space
    /// (module docs): bit for bit [`Scene::closest_point_brute`].
    /// `Ok(None)` when no instance is selected or `q` has a NaN or
    /// infinite coordinate.
    ///
    /// # Errors
    /// [`NotSimilar`] when a selected instance is scaled unevenly or
    /// sheared.
    ///
    /// # Panics
    /// Never. No allocation, no recursion; the stack is
    /// [`MAX_DEPTH`](crate::MAX_DEPTH) entries of 32 bytes here and one
    /// mesh walk's below.
    pub fn closest_point(
        &self,
        q: [f32; 3],
        mask: u32,
    ) -> Result<Option<SceneClosestPoint>, NotSimilar> {
        self.closest_point_within(q, mask, f32::INFINITY)
    }

    /// [`Scene::closest_point`] when it lies within `max_distance` of `q`
    /// (world squared distance `<=` `max_distance` squared, in `f64`):
    /// bit for bit [`Scene::closest_point_brute`] filtered so. `Ok(None)`
    /// also when nothing lies that close or `max_distance` is NaN or
    /// negative.
    ///
    /// # Errors
    /// [`NotSimilar`] as [`Scene::closest_point`].
    pub fn closest_point_within(
        &self,
        q: [f32; 3],
        mask: u32,
        max_distance: f32,
    ) -> Result<Option<SceneClosestPoint>, NotSimilar> {
        if !q.iter().all(|c| c.is_finite()) {
            return Ok(None);
        }
        self.check_similar(mask)?;
        if max_distance.is_nan() || max_distance < 0.0 {
            return Ok(None);
        }
        let max = f64::from(max_distance);
        let limit = max * max;
        let m2 = magnitude2(&q, &self.bounds);
        let mut search = Search {
            scene: self,
            q,
            qw: q.map(f64::from),
            mask,
            limit,
            near: NearestInstance { best: None },
            m2,
            cell_slack: (64.0 * m2 + 4.0 * self.reach2) * SLACK,
            traced: Mailbox::default(),
        };
        self.nearest_instance(&mut search);
        Ok(search.near.best.filter(|b| b.distance2 <= limit))
    }

    /// The walk of the module docs, into `search`.
    fn nearest_instance(&self, search: &mut Search<'_, 'a>) {
        let q = search.qw;
        let mut stack = [PendingCell::default(); MAX_DEPTH as usize];
        let mut len = 0usize;
        let (mut node_idx, mut gaps2) = (0u32, box_gaps2(&self.bounds, &q));
        if cell_distance2(&gaps2) > search.cell_cut() {
            return;
        }
        'descend: loop {
            let Some(&(mut node)) = self.nodes.get(node_idx as usize) else {
                return;
            };
            // Down to a leaf, near child first.
            while !node.is_leaf() {
                let axis = node.axis_bits().min(2);
                let child = node.upper();
                let off = q[axis] - f64::from(node.split());
                let (near, far) = if off > 0.0 {
                    (child.wrapping_add(1), child)
                } else {
                    (child, child.wrapping_add(1))
                };
                // The far child, unless it is an empty cell or beyond the
                // cell cut; its gap along the axis is the split plane's.
                let mut far_gaps2 = gaps2;
                far_gaps2[axis] = off * off;
                if cell_distance2(&far_gaps2) <= search.cell_cut()
                    && self
                        .nodes
                        .get(far as usize)
                        .is_some_and(|n| !n.is_empty_leaf())
                {
                    if let Some(slot) = stack.get_mut(len) {
                        *slot = PendingCell {
                            node: far,
                            gaps2: far_gaps2,
                        };
                        len += 1;
                    }
                }
                let Some(&n) = self.nodes.get(near as usize) else {
                    return;
                };
                node = n;
            }
            if node.upper() == 1 {
                search.instance(node.word0());
            } else {
                let start = node.word0() as usize;
                let run = self
                    .prims
                    .get(start..start.saturating_add(node.upper() as usize))
                    .unwrap_or(&[]);
                for &i in run {
                    search.instance(i);
                }
            }
            // Backtrack: the last pushed far cell still within the cut.
            while len > 0 {
                len -= 1;
                let Some(&p) = stack.get(len) else {
                    return;
                };
                if cell_distance2(&p.gaps2) <= search.cell_cut() {
                    (node_idx, gaps2) = (p.node, p.gaps2);
                    continue 'descend;
                }
            }
            return;
        }
    }
}

/// The squared distance from the query to a cell of squared gaps `g`, in
/// the order of `box_distance2`.
#[inline(always)]
fn cell_distance2(g: &[f64; 3]) -> f64 {
    g[0] + g[1] + g[2]
}
