//! Reusing a tree's split planes for boxes that moved: every box is sent
//! down the fixed planes (to every child whose closed half-space it
//! overlaps, the fast builder's rule) and the leaves are refilled. No
//! plane is priced and no node is laid out.
//!
//! A frame touches only the boxes that crossed a plane. Each box's
//! descent is kept as the range each face may move in without changing
//! its side of any split plane it met ([`Keep`]); a box whose faces stay
//! in range reaches the same leaves, so only the others are taken out of
//! their old leaves and sent down again (docs/results.md, `## Scenes`).
//! Tried: the whole frame's boxes partitioned cell by cell down the planes
//! (the fast builder's partition): ~350,000 box visits a frame for 10,000
//! instances, 12.6 M instructions, where a frame of small motions crosses
//! a plane with a few hundred boxes.
//!
//! Any finite planes give a valid tree whose walk finds every hit: a box
//! is listed in every leaf whose closed cell it overlaps, whatever the
//! planes (a plane the boxes moved away from leaves an empty or a crowded
//! cell, which costs rays time, never an answer). How much time is the
//! tree's SAH cost, which [`Refill::refill`] returns, measured with the
//! cell areas of the tree as built, for the caller to rebuild when it has
//! drifted.

use super::cost::CostModel;
use super::fast::leaf_of;
use super::BuiltTree;
use kdray_kernel::{Bounds, Node, NodeKind};

/// A tree kept from frame to frame with its SAH weights and each box's
/// leaves (no allocation after the first refill but a leaf growing).
#[derive(Clone, Debug)]
pub struct Refill {
    /// The tree: its planes as built, its leaves as last refilled.
    tree: BuiltTree,
    /// Per node: a leaf's cell area over the root cell's, times the
    /// intersection cost, as built (0 for interior nodes).
    weights: Vec<f32>,
    /// The interior nodes' share of the SAH cost (traversal steps), as built.
    interior_cost: f64,
    /// The boxes as last sent down, from the first refill on.
    track: Option<Track>,
}

/// What the last refill left for the next.
#[derive(Clone, Debug)]
struct Track {
    /// Each box as last sent down (empty ones too).
    boxes: Vec<Bounds>,
    /// Where each box's faces may move without its leaves changing.
    keep: Vec<Keep>,
    /// Per node: a leaf's boxes, in index order (empty for interior nodes).
    lists: Vec<Vec<u32>>,
    /// The leaves in the order a depth-first walk meets them, below
    /// before above: the order of their runs in `prims`.
    leaves: Vec<u32>,
    /// The SAH cost of the tree as last written.
    cost: f64,
    /// The descent's pending nodes (scratch).
    todo: Vec<u32>,
}

/// Where a box's faces may lie and still meet every split plane of its
/// descent on the same side: `min[a]` in `[min_from, min_below)` and
/// `max[a]` in `(max_above, max_to]` per axis. A box goes below a plane
/// `s` when `min < s`, above when `max > s` or `min >= s`; so `min`'s side
/// of each plane it met matters, and `max`'s where `min < s`.
#[derive(Clone, Copy, Debug)]
struct Keep {
    min_from: [f32; 3],
    min_below: [f32; 3],
    max_above: [f32; 3],
    max_to: [f32; 3],
}

impl Keep {
    /// No plane met: anywhere.
    const ANYWHERE: Keep = Keep {
        min_from: [f32::NEG_INFINITY; 3],
        min_below: [f32::INFINITY; 3],
        max_above: [f32::NEG_INFINITY; 3],
        max_to: [f32::INFINITY; 3],
    };

    /// Does `b` meet every plane of the descent on the same side? (A NaN
    /// face never does.)
    #[inline]
    fn holds(&self, b: &Bounds) -> bool {
        (0..3).all(|a| {
            (self.min_from[a] <= b.min[a])
                & (b.min[a] < self.min_below[a])
                & (self.max_above[a] < b.max[a])
                & (b.max[a] <= self.max_to[a])
        })
    }
}

/// The refill's rule for a box it lists: `min <= max` on x (an empty box,
/// or a NaN there, is left out).
fn is_listed(b: &Bounds) -> bool {
    b.min[0] <= b.max[0]
}

/// Sends `b` down `nodes` from the root: calls `at_leaf` with each leaf
/// it reaches (below before above, as the tree is laid out) and returns
/// where its faces may move without reaching others.
fn descend(
    nodes: &[Node],
    b: &Bounds,
    todo: &mut Vec<u32>,
    mut at_leaf: impl FnMut(usize),
) -> Keep {
    let mut keep = Keep::ANYWHERE;
    todo.clear();
    todo.push(0);
    while let Some(i) = todo.pop() {
        let Some(node) = nodes.get(i as usize) else {
            continue;
        };
        let NodeKind::Interior { axis, split, child } = node.kind() else {
            at_leaf(i as usize);
            continue;
        };
        let a = axis.index();
        let (lo, hi) = (b.min[a], b.max[a]);
        // The fast builder's partition: below when the box starts before
        // the plane, above when it ends after it or starts on it.
        let below = lo < split;
        if below {
            keep.min_below[a] = keep.min_below[a].min(split);
            if hi > split {
                keep.max_above[a] = keep.max_above[a].max(split);
            } else {
                keep.max_to[a] = keep.max_to[a].min(split);
            }
        } else if lo >= split {
            keep.min_from[a] = keep.min_from[a].max(split);
        }
        if hi > split || lo >= split {
            todo.push(child + 1);
        }
        if below {
            todo.push(child);
        }
    }
    keep
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
            track: None,
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
    /// the boxes' union; its interior nodes and layout stay. Returns the
    /// tree's SAH cost with the weights of the tree as built
    /// ([`Refill::new`]; no empty-cell factor), `None` when no box is
    /// left (the tree is then unchanged).
    ///
    /// The first refill (and one with another number of boxes) sends
    /// every box down; later ones only the boxes that crossed a plane.
    /// Either way the tree is the same, bit for bit.
    pub fn refill(&mut self, boxes: &[Bounds]) -> Option<f64> {
        let union = boxes
            .iter()
            .filter(|b| is_listed(b))
            .fold(Bounds::EMPTY, |u, b| u.union(b));
        if !is_listed(&union) {
            return None;
        }
        let nodes = &self.tree.nodes;
        let track = match &mut self.track {
            Some(t) if t.boxes.len() == boxes.len() => {
                if !t.update(nodes, boxes) {
                    self.tree.bounds = union;
                    return Some(t.cost);
                }
                t
            }
            _ => self.track.insert(Track::new(nodes, boxes)),
        };
        track.cost = track.write(&mut self.tree, &self.weights, self.interior_cost);
        self.tree.bounds = union;
        Some(track.cost)
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

impl Track {
    /// Every box of `boxes` sent down `nodes`.
    fn new(nodes: &[Node], boxes: &[Bounds]) -> Track {
        let mut t = Track {
            boxes: boxes.to_vec(),
            keep: vec![Keep::ANYWHERE; boxes.len()],
            lists: vec![Vec::new(); nodes.len()],
            leaves: Vec::new(),
            cost: 0.0,
            todo: vec![0],
        };
        while let Some(i) = t.todo.pop() {
            match nodes.get(i as usize).map(|n| n.kind()) {
                Some(NodeKind::Interior { child, .. }) => t.todo.extend([child + 1, child]),
                Some(NodeKind::Leaf { .. }) => t.leaves.push(i),
                None => {}
            }
        }
        for (id, b) in (0u32..).zip(boxes) {
            if is_listed(b) {
                // Boxes in index order: each list stays sorted by a push.
                t.keep[id as usize] = descend(nodes, b, &mut t.todo, |l| t.lists[l].push(id));
            }
        }
        t
    }

    /// Takes each box of `boxes` that left its [`Keep`] out of its old
    /// leaves and sends it down again. `false` when no leaf changed.
    fn update(&mut self, nodes: &[Node], boxes: &[Bounds]) -> bool {
        let mut changed = false;
        for (id, b) in (0u32..).zip(boxes) {
            let i = id as usize;
            let (Some(old), Some(keep)) = (self.boxes.get(i), self.keep.get(i)) else {
                continue;
            };
            let (was, is) = (is_listed(old), is_listed(b));
            if was == is && (!is || keep.holds(b)) {
                continue;
            }
            changed = true;
            let lists = &mut self.lists;
            if was {
                descend(nodes, old, &mut self.todo, |l| {
                    if let Ok(k) = lists[l].binary_search(&id) {
                        lists[l].remove(k);
                    }
                });
            }
            self.keep[i] = if is {
                descend(nodes, b, &mut self.todo, |l| {
                    if let Err(k) = lists[l].binary_search(&id) {
                        lists[l].insert(k, id);
                    }
                })
            } else {
                Keep::ANYWHERE
            };
            self.boxes[i] = *b;
        }
        changed
    }

    /// Writes the leaves into `tree` (their runs in `prims` in the order
    /// of `leaves`) and returns its SAH cost.
    fn write(&self, tree: &mut BuiltTree, weights: &[f32], interior_cost: f64) -> f64 {
        tree.prims.clear();
        let mut cost = interior_cost;
        for &i in &self.leaves {
            let (Some(node), Some(list), Some(w)) = (
                tree.nodes.get_mut(i as usize),
                self.lists.get(i as usize),
                weights.get(i as usize),
            ) else {
                continue;
            };
            cost += f64::from(w * list.len() as f32);
            *node = leaf_of(list.iter().copied(), &mut tree.prims);
        }
        cost
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

    /// A refill that sends only the crossing boxes down again writes the
    /// tree, prims, bounds and cost of one that sends every box down (a
    /// fresh `Refill`), bit for bit, frame after frame: small moves (most
    /// boxes keep their leaves), far jumps, boxes emptied and refilled,
    /// a face landing exactly on a plane.
    #[test]
    fn crossing_boxes_only_equals_every_box_sent_down() {
        let mut rng = Rng::new(12);
        let mut b = boxes(&mut rng, 400);
        let built = built(&b);
        let planes: Vec<(usize, f32)> = built
            .nodes
            .iter()
            .filter_map(|n| match n.kind() {
                NodeKind::Interior { axis, split, .. } => Some((axis.index(), split)),
                NodeKind::Leaf { .. } => None,
            })
            .collect();
        let mut kept = Refill::new(built.clone(), &COST);
        let mut touched = 0;
        for frame in 0..30 {
            for (k, x) in b.iter_mut().enumerate() {
                let r = rng.range(0.0, 1.0);
                if r < 0.01 {
                    *x = Bounds::EMPTY;
                } else if !is_listed(x) {
                    let c = rng.range(0.0, 40.0);
                    *x = Bounds {
                        min: [c, 1.0, c],
                        max: [c + 1.0, 2.0, c + 0.5],
                    };
                } else if r < 0.03 {
                    // A face onto a plane of the tree.
                    let (a, s) = planes[k % planes.len()];
                    let d = s - x.min[a];
                    x.min[a] += d;
                    x.max[a] += d;
                } else {
                    let d = if r < 0.05 { 20.0 } else { 0.05 };
                    let m: [f32; 3] = core::array::from_fn(|_| rng.range(-d, d));
                    *x = Bounds {
                        min: core::array::from_fn(|a| x.min[a] + m[a]),
                        max: core::array::from_fn(|a| x.max[a] + m[a]),
                    };
                }
            }
            let moved = kept.track.as_ref().map_or(0, |t| {
                (0..b.len())
                    .filter(|&i| !is_listed(&b[i]) || !t.keep[i].holds(&b[i]))
                    .count()
            });
            touched += moved;
            let cost = kept.refill(&b);
            let mut fresh = Refill::new(built.clone(), &COST);
            assert_eq!(cost, fresh.refill(&b), "frame {frame}");
            assert_eq!(kept.tree().nodes, fresh.tree().nodes, "frame {frame}");
            assert_eq!(kept.tree().prims, fresh.tree().prims, "frame {frame}");
            assert_eq!(kept.tree().bounds, fresh.tree().bounds, "frame {frame}");
            assert_eq!(cost, Some(kept.cost()), "frame {frame}");
        }
        // Most boxes kept their leaves (else this tests only the first refill).
        assert!(touched > 0 && touched < 30 * b.len() / 2, "{touched}");
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
