//! Reusing a tree's split planes for boxes that moved: every box is sent
//! down the fixed planes (to every child whose closed half-space it
//! overlaps, the fast builder's rule) and the leaves are refilled. No
//! plane is priced and no node is laid out, so a frame's update of a
//! scene's top level costs one descent per box (docs/results.md,
//! `## Scenes`), where a rebuild bins and partitions every cell.
//!
//! Any finite planes give a valid tree whose walk finds every hit: a box
//! is listed in every leaf whose closed cell it overlaps, whatever the
//! planes (a plane the boxes moved away from leaves an empty or a crowded
//! cell, which costs rays time, never an answer). How much time is the
//! tree's SAH cost, which [`Refill::refill`] returns, measured with the
//! cell areas of the tree as built, for the caller to rebuild when it has
//! drifted.

use super::cost::CostModel;
use super::fast::{leaf, split_run, Item};
use super::BuiltTree;
use kdray_kernel::{Bounds, NodeKind};

/// A tree kept from frame to frame with its SAH weights and the scratch
/// a refill uses (no allocation after the first refill).
#[derive(Clone, Debug)]
pub struct Refill {
    /// The tree: its planes as built, its leaves as last refilled.
    tree: BuiltTree,
    /// Per node: a leaf's cell area over the root cell's, times the
    /// intersection cost, as built (0 for interior nodes).
    weights: Vec<f32>,
    /// The interior nodes' share of the SAH cost (traversal steps), as built.
    interior_cost: f64,
    /// The cells' boxes: a stack of runs, each cell's below side written
    /// past its end (the fast builder's items and scheme).
    items: Vec<Item>,
}

impl Refill {
    /// Keeps `tree` (in any layout where children follow their parent),
    /// its weights from the cells of `tree.bounds` under `cost`.
    #[must_use]
    pub fn new(tree: BuiltTree, cost: &CostModel) -> Refill {
        let nodes = &tree.nodes;
        let root = tree.bounds.area();
        let share = |a: f64| if root > 0.0 { a / root } else { 1.0 };
        let mut weights = vec![0.0f32; nodes.len()];
        let mut todo = vec![(0u32, tree.bounds)];
        let mut interior_cost = 0.0;
        while let Some((i, cell)) = todo.pop() {
            let Some(node) = nodes.get(i as usize) else {
                continue;
            };
            match node.kind() {
                NodeKind::Interior { axis, split, child } => {
                    interior_cost += cost.traversal * share(cell.area());
                    let (lo, hi) = cell.split(axis.index(), split);
                    todo.push((child, lo));
                    todo.push((child + 1, hi));
                }
                NodeKind::Leaf { .. } => {
                    weights[i as usize] = (cost.intersection * share(cell.area())) as f32;
                }
            }
        }
        Refill {
            tree,
            weights,
            interior_cost,
            items: Vec::new(),
        }
    }

    /// The tree as last refilled (or as built).
    #[must_use]
    pub fn tree(&self) -> &BuiltTree {
        &self.tree
    }

    /// Lists `boxes` (empty ones, `min > max`, left out) in the leaves of
    /// the tree, whose planes stay: each box in every leaf whose closed cell
    /// it overlaps, each leaf's boxes in index order. Its bounds become
    /// the boxes' union; its interior nodes and layout stay. Returns the tree's SAH cost with the weights of the tree as
    /// built ([`Refill::new`]; no empty-cell factor), `None` when no box is
    /// left (the tree is then unchanged).
    pub fn refill(&mut self, boxes: &[Bounds]) -> Option<f64> {
        let tree = &mut self.tree;
        self.items.clear();
        let mut union = Bounds::EMPTY;
        for (id, b) in (0u32..).zip(boxes) {
            if b.min[0] <= b.max[0] {
                union = union.union(b);
                self.items.push(Item::new(b, id));
            }
        }
        let n = self.items.len();
        if n == 0 {
            return None;
        }
        // The fast builder's peak room (its `depth_first`).
        self.items.reserve(2 * n);
        let nodes = &mut tree.nodes;
        tree.prims.clear();
        let mut cost = self.interior_cost;
        let mut todo = vec![(0u32, 0usize, n)];
        while let Some((node, start, n)) = todo.pop() {
            let Some(&nd) = nodes.get(node as usize) else {
                continue;
            };
            let end = start + n;
            let NodeKind::Interior { axis, split, child } = nd.kind() else {
                cost += f64::from(self.weights[node as usize] * n as f32);
                nodes[node as usize] = leaf(&self.items[start..end], &mut tree.prims);
                continue;
            };
            // A plane that cut off empty space last frame most likely
            // still does: when a scan confirms it, nothing moves (the
            // fast builder's shortcut). The children are still last
            // frame's: they are refilled after this node.
            let a = axis.index();
            let run = &self.items[start..end];
            let empty = |c: u32| nodes.get(c as usize).is_some_and(|c| c.is_empty_leaf());
            let (n_above, n_below, below_at) =
                if empty(child) && run.iter().all(|it| it.lo(a) >= split) {
                    (n, 0, end)
                } else if empty(child + 1)
                    && run
                        .iter()
                        .all(|it| (it.lo(a) < split) & (it.hi(a) <= split))
                {
                    (0, n, start)
                } else {
                    let (n_above, n_below) = split_run(&mut self.items, start, n, a, split);
                    (n_above, n_below, end)
                };
            todo.push((child + 1, start, n_above));
            todo.push((child, below_at, n_below));
        }
        tree.bounds = union;
        Some(cost)
    }

    /// The SAH cost [`Refill::refill`] measures, of the tree as it is.
    #[must_use]
    pub fn cost(&self) -> f64 {
        self.tree
            .nodes
            .iter()
            .zip(&self.weights)
            .fold(self.interior_cost, |s, (n, &w)| {
                let count = match n.kind() {
                    NodeKind::Leaf { count, .. } => count,
                    NodeKind::Interior { .. } => 0,
                };
                s + f64::from(w * count as f32)
            })
    }
}

#[cfg(test)]
mod tests {
    use super::super::fast::{self, tests::leaves_at, FastParams};
    use super::*;
    use crate::rng::Rng;

    const COST: CostModel = CostModel {
        traversal: 1.0,
        intersection: 4.0,
        empty_factor: 0.8,
    };

    /// Boxes about `n` random centres in a 40 x 4 x 40 slab, a few of them
    /// flat, and an empty one.
    fn boxes(rng: &mut Rng, n: usize) -> Vec<Bounds> {
        let mut out: Vec<Bounds> = (0..n)
            .map(|k| {
                let c = [
                    rng.range(0.0, 40.0),
                    rng.range(0.0, 4.0),
                    rng.range(0.0, 40.0),
                ];
                let mut h: [f32; 3] = core::array::from_fn(|_| rng.range(0.1, 1.5));
                if k % 17 == 0 {
                    h[k % 3] = 0.0;
                }
                Bounds {
                    min: core::array::from_fn(|a| c[a] - h[a]),
                    max: core::array::from_fn(|a| c[a] + h[a]),
                }
            })
            .collect();
        out.push(Bounds::EMPTY);
        out
    }

    fn built(boxes: &[Bounds]) -> BuiltTree {
        let bounds = boxes
            .iter()
            .filter(|b| b.min[0] <= b.max[0])
            .fold(Bounds::EMPTY, |a, b| a.union(b));
        let p = FastParams {
            cost: COST,
            bins: 16,
            leaf_size: 2,
            depth: 20,
            shrink_bins: false,
        };
        fast::build(boxes, bounds, &p)
    }

    /// Refilled with the boxes it was built over, the tree is the fast
    /// builder's bit for bit (the same rule sends every box down), and the
    /// cost measured is the built tree's.
    #[test]
    fn a_refill_with_the_built_boxes_is_the_built_tree() {
        let mut rng = Rng::new(5);
        for n in [0, 1, 3, 40, 700] {
            let b = boxes(&mut rng, n);
            let want = built(&b);
            let want_cost = Refill::new(want.clone(), &COST).cost();
            let mut tree = want.clone();
            tree.prims.clear();
            let mut refill = Refill::new(tree, &COST);
            let cost = refill.refill(&b);
            let tree = refill.tree();
            assert_eq!(tree.nodes, want.nodes, "{n} boxes");
            assert_eq!(tree.prims, want.prims, "{n} boxes");
            assert_eq!(tree.bounds, want.bounds, "{n} boxes");
            if n > 0 {
                assert_eq!(cost, Some(want_cost));
            } else {
                assert_eq!(cost, None, "no box left");
            }
        }
    }

    /// After the boxes moved (some far, some out of the old bounds), every
    /// corner and the centre of every box lies in the closed cell of a leaf
    /// listing it, leaves list boxes in index order once, and the bounds
    /// are the boxes' union; over several frames on one refill.
    #[test]
    fn moved_boxes_are_listed_in_every_leaf_they_reach() {
        let mut rng = Rng::new(9);
        let mut b = boxes(&mut rng, 500);
        let mut refill = Refill::new(built(&b), &COST);
        for frame in 0..4 {
            for (k, x) in b.iter_mut().enumerate() {
                if x.min[0] > x.max[0] {
                    continue;
                }
                let d = if k % 50 == 0 {
                    [rng.range(-30.0, 30.0), 5.0, rng.range(-30.0, 30.0)]
                } else {
                    core::array::from_fn(|_| rng.range(-0.5, 0.5))
                };
                *x = Bounds {
                    min: core::array::from_fn(|a| x.min[a] + d[a]),
                    max: core::array::from_fn(|a| x.max[a] + d[a]),
                };
            }
            let cost = refill.refill(&b).expect("boxes");
            let tree = refill.tree();
            assert!(cost > 0.0);
            let union = b
                .iter()
                .filter(|x| x.min[0] <= x.max[0])
                .fold(Bounds::EMPTY, |a, x| a.union(x));
            assert_eq!(tree.bounds, union);
            for (i, x) in b.iter().enumerate() {
                if x.min[0] > x.max[0] {
                    assert!(!tree.prims.contains(&(i as u32)), "empty box listed");
                    continue;
                }
                let centre = core::array::from_fn(|a| x.min[a] * 0.5 + x.max[a] * 0.5);
                let corners = (0..8).map(|c| {
                    core::array::from_fn(|a| if c >> a & 1 == 0 { x.min[a] } else { x.max[a] })
                });
                for q in corners.chain([centre]) {
                    let found = leaves_at(tree, q).iter().any(|l| l.contains(&(i as u32)));
                    assert!(
                        found,
                        "frame {frame}: box {i} point {q:?} in no leaf listing it"
                    );
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
