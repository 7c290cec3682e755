//! Reusing a tree's split planes for boxes that moved: every box is sent
//! down the fixed planes (to every child whose closed half-space it
//! overlaps, the fast builder's rule) and the leaves are refilled. No
//! plane is priced and no node is laid out.
//!
//! A frame touches only the boxes that crossed a plane. Each box's
//! descent is kept as the range each face may move in without changing
//! its side of any split plane it met; a box whose faces stay
//! in range reaches the same leaves, so only the others walk the tree
//! again, the old box and the new one together: they leave the leaves
//! only the old box reached and enter those only the new one reaches
//! (docs/results.md, `## Scenes`). The first frame after a build sends
//! every box down at once, cell by cell.
//! Tried: every box of the frame partitioned cell by cell down the planes
//! (the fast builder's partition), where a frame of small motions moves
//! ~3% of the boxes across a plane: ~350,000 box visits and 12.1 M
//! instructions a frame for 10,000 instances against 2.9 M here, and
//! ~1.2x the wall clock (not 4x: the state kept here, 72 bytes a box,
//! with the nodes and runs, passes the L2 cache).
//!
//! Any finite planes give a valid tree whose walk finds every hit: a box
//! is listed in every leaf whose closed cell it overlaps, whatever the
//! planes (a plane the boxes moved away from leaves an empty or a crowded
//! cell, which costs rays time, never an answer). How much time is the
//! tree's SAH cost, which [`Refill::refill`] returns, measured with the
//! cell areas of the tree as built, for the caller to rebuild when it has
//! drifted.

use super::cost::CostModel;
use super::BuiltTree;
use kdray_kernel::{Bounds, Node, NodeKind};

/// A tree kept from frame to frame with its SAH weights and each box's
/// leaves (no allocation after the first refill but a leaf outgrowing
/// its room).
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

/// What the last refill left for the next. The tree's `prims` hold each
/// leaf's run with room to grow after it ([`Run`]), so a box entering a
/// leaf moves no other leaf's run.
#[derive(Clone, Debug)]
struct Track {
    /// Each box as last sent down (empty ones too), read only for a box
    /// that left its [`Keep`].
    boxes: Vec<Bounds>,
    /// Where each box's faces may move without its leaves changing
    /// ([`Keep::NEVER`] for a box left out).
    keep: Vec<Keep>,
    /// Per node: its leaf's index in `runs` (`u32::MAX` for interior nodes).
    run_of: Vec<u32>,
    /// Each leaf's run in the tree's `prims`.
    runs: Vec<Run>,
    /// Entries of `prims` the runs own, their room included (the rest is
    /// left behind by runs that moved).
    live: usize,
    /// The SAH cost of the tree as it is.
    cost: f64,
    /// The descent's pending nodes (scratch).
    todo: Vec<(u32, Reach)>,
    /// The leaves one descent reached (scratch).
    reached: Vec<(usize, Reach)>,
}

/// A leaf's boxes: `prims[at..at + len]` in index order, room up to `cap`.
#[derive(Clone, Copy, Debug)]
struct Run {
    node: u32,
    at: u32,
    len: u32,
    cap: u32,
}

impl Run {
    /// The leaf node over this run (one box in the node itself).
    fn node(&self, prims: &[u32]) -> Node {
        let one = prims.get(self.at as usize).copied();
        match (self.len, one) {
            (0, _) | (1, None) => Node::EMPTY_LEAF,
            (1, Some(id)) => Node::leaf(1, id).unwrap_or(Node::EMPTY_LEAF),
            (n, _) => Node::leaf(n, self.at).unwrap_or(Node::EMPTY_LEAF),
        }
    }
}

/// Where a box's faces may lie and still meet every split plane of its
/// descent on the same side, per axis ([`Faces`]).
#[derive(Clone, Copy, Debug)]
struct Keep([Faces; 3]);

/// One axis of a [`Keep`]: `min[a]` in `[min_from, min_below)` and
/// `max[a]` in `(max_above, max_to]`. A box goes below a plane `s` when
/// `min < s`, above when `max > s` or `min >= s`; so `min`'s side of each
/// plane it met matters, and `max`'s where `min < s`. The four side by
/// side: a plane narrows one axis's 16 bytes.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
struct Faces {
    min_from: f32,
    min_below: f32,
    max_above: f32,
    max_to: f32,
}

impl Keep {
    /// No plane met: anywhere.
    const ANYWHERE: Keep = Keep(
        [Faces {
            min_from: f32::NEG_INFINITY,
            min_below: f32::INFINITY,
            max_above: f32::NEG_INFINITY,
            max_to: f32::INFINITY,
        }; 3],
    );

    /// Holds for no box: a box left out is looked at again every frame.
    const NEVER: Keep = Keep(
        [Faces {
            min_from: f32::NAN,
            ..Keep::ANYWHERE.0[0]
        }; 3],
    );

    /// Does `b` meet every plane of the descent on the same side? (A NaN
    /// face never does.)
    #[inline]
    fn holds(&self, b: &Bounds) -> bool {
        self.0
            .iter()
            .zip(b.min.iter().zip(&b.max))
            .all(|(f, (&lo, &hi))| {
                (f.min_from <= lo) & (lo < f.min_below) & (f.max_above < hi) & (hi <= f.max_to)
            })
    }

    /// Narrows the ranges of `b`'s faces to the side it takes of the
    /// split plane `split` on axis `a` ([`sides`]). Selects, not
    /// branches: which side a box takes is a coin toss per plane.
    #[inline]
    fn meet(&mut self, a: usize, b: &Bounds, split: f32) {
        let (Some(f), Some(&lo), Some(&hi)) = (self.0.get_mut(a), b.min.get(a), b.max.get(a))
        else {
            return;
        };
        let (below, crosses, from) = (lo < split, hi > split, lo >= split);
        // Plain compares, not `f32::min`: a split plane is finite (the
        // tree is validated) and so are the ranges a box narrows.
        let lower = |x: f32, take: bool| if take && split < x { split } else { x };
        let raise = |x: f32, take: bool| if take && split > x { split } else { x };
        f.min_below = lower(f.min_below, below);
        f.max_above = raise(f.max_above, below & crosses);
        f.max_to = lower(f.max_to, below & !crosses);
        f.min_from = raise(f.min_from, !below & from);
    }
}

/// The refill's rule for a box it lists: `min <= max` on x (an empty box,
/// or a NaN there, is left out).
fn is_listed(b: &Bounds) -> bool {
    b.min[0] <= b.max[0]
}

/// Which descents reached a leaf: a box's last one ([`OLD`]), its new
/// one ([`NEW`]), or both.
type Reach = u8;
/// The box as last sent down reached the leaf.
const OLD: Reach = 1;
/// The box as sent down now reached the leaf.
const NEW: Reach = 2;

/// Does a box with faces `lo`, `hi` on a split plane's axis go below
/// `split`, above it? The fast builder's partition: below when the box
/// starts before the plane, above when it ends after it or starts on it.
fn sides(lo: f32, hi: f32, split: f32) -> (bool, bool) {
    (lo < split, hi > split || lo >= split)
}

/// Sends `new` and `old` down `nodes` from the root together (`old` empty
/// for a box never sent down before): calls `at_leaf` with each leaf
/// either reaches and which did, and returns where `new`'s faces may move
/// without reaching other leaves. One walk for both, so a box that
/// crossed one plane costs one descent and the leaves it entered or left,
/// not all of its leaves twice.
fn descend(
    nodes: &[Node],
    new: &Bounds,
    old: &Bounds,
    todo: &mut Vec<(u32, Reach)>,
    mut at_leaf: impl FnMut(usize, Reach),
) -> Keep {
    let mut keep = Keep::ANYWHERE;
    let root = (if is_listed(old) { OLD } else { 0 }) | (if is_listed(new) { NEW } else { 0 });
    todo.clear();
    if root != 0 {
        todo.push((0, root));
    }
    while let Some((i, reach)) = todo.pop() {
        let Some(node) = nodes.get(i as usize) else {
            continue;
        };
        let NodeKind::Interior { axis, split, child } = node.kind() else {
            at_leaf(i as usize, reach);
            continue;
        };
        let a = axis.index();
        let (old_below, old_above) = sides(old.min[a], old.max[a], split);
        let (below, above) = sides(new.min[a], new.max[a], split);
        if reach & NEW != 0 {
            keep.meet(a, new, split);
        }
        let go = |old_side: bool, new_side: bool| {
            reach & ((if old_side { OLD } else { 0 }) | (if new_side { NEW } else { 0 }))
        };
        let up = go(old_above, above);
        if up != 0 {
            todo.push((child + 1, up));
        }
        let down = go(old_below, below);
        if down != 0 {
            todo.push((child, down));
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

    /// The tree as last refilled (or as built). After a refill its
    /// `prims` hold each leaf's run with room after it (unused entries
    /// name some box), so `prims.len()` is not the number of references.
    #[must_use]
    pub fn tree(&self) -> &BuiltTree {
        &self.tree
    }

    /// Lists `boxes` (empty ones, `min > max`, left out) in the leaves of
    /// the tree, whose planes stay: each box in every leaf whose closed cell
    /// it overlaps, each leaf's boxes in index order. Its bounds become
    /// the boxes' union; its interior nodes stay. Returns the tree's SAH
    /// cost with the weights of the tree as built ([`Refill::new`]; no
    /// empty-cell factor), `None` when no box is left (the tree is then
    /// unchanged).
    ///
    /// The first refill (and one with another number of boxes) sends
    /// every box down and lays the leaves' runs out in `prims` with room
    /// to grow; later ones send down only the boxes that crossed a plane.
    /// Either way each leaf lists the same boxes.
    pub fn refill(&mut self, boxes: &[Bounds]) -> Option<f64> {
        let union = boxes
            .iter()
            .filter(|b| is_listed(b))
            .fold(Bounds::EMPTY, |u, b| u.union(b));
        if !is_listed(&union) {
            return None;
        }
        let cost = match &mut self.track {
            Some(t) if t.boxes.len() == boxes.len() => {
                t.update(&mut self.tree, &self.weights, boxes);
                t.cost
            }
            _ => {
                let t = Track::new(&mut self.tree, &self.weights, self.interior_cost, boxes);
                self.track.insert(t).cost
            }
        };
        self.tree.bounds = union;
        Some(cost)
    }

    /// The SAH cost [`Refill::refill`] measures, of the tree as it is.
    #[must_use]
    pub fn cost(&self) -> f64 {
        sah_cost(&self.tree.nodes, &self.weights, self.interior_cost)
    }
}

/// The SAH cost of `nodes` with the leaves' `weights` and the interior
/// nodes' share `interior_cost` ([`Refill::new`]).
fn sah_cost(nodes: &[Node], weights: &[f32], interior_cost: f64) -> f64 {
    nodes.iter().zip(weights).fold(interior_cost, |s, (n, &w)| {
        let count = match n.kind() {
            NodeKind::Leaf { count, .. } => count,
            NodeKind::Interior { .. } => 0,
        };
        s + f64::from(w * count as f32)
    })
}

/// Room a leaf's run gets beyond its boxes when laid out.
fn room(len: u32) -> u32 {
    len + len / 2 + 2
}

impl Track {
    /// Every box of `boxes` sent down `tree`, its leaves written.
    fn new(tree: &mut BuiltTree, weights: &[f32], interior_cost: f64, boxes: &[Bounds]) -> Track {
        let mut t = Track {
            boxes: boxes.to_vec(),
            keep: vec![Keep::NEVER; boxes.len()],
            run_of: vec![u32::MAX; tree.nodes.len()],
            runs: Vec::new(),
            live: 0,
            cost: 0.0,
            todo: Vec::new(),
            reached: Vec::new(),
        };
        // Every box sent down at once, cell by cell, as the fast builder
        // partitions: a cell's boxes are `ids[start..end]` in index order,
        // its children's lists are appended past them (above, then below),
        // and a cell popped from `cells` frees everything past its end (the
        // cells still waiting were listed before it). So each leaf's boxes
        // come in index order, and the leaves in the order a depth-first
        // walk meets them, below before above, as a build lays out its
        // runs. (Tried: a descent per box from the root, then a counting
        // sort of (leaf, box) pairs: 7 ms for 10,000 instances against 3
        // ms here (`scene_move`, its first frame), each
        // descent waiting on node loads the partition streams through.)
        let mut ids: Vec<u32> = (0u32..)
            .zip(boxes)
            .filter(|(_, b)| is_listed(b))
            .map(|(id, _)| id)
            .collect();
        for &id in &ids {
            t.keep[id as usize] = Keep::ANYWHERE;
        }
        tree.prims.clear();
        let mut cells = vec![(0u32, 0usize, ids.len())];
        while let Some((i, start, end)) = cells.pop() {
            ids.truncate(end);
            match tree.nodes.get(i as usize).map(|n| n.kind()) {
                Some(NodeKind::Interior { axis, split, child }) => {
                    let a = axis.index();
                    // Each box written at the list's end, which moves on
                    // when the box goes to that side: no branch on the side.
                    ids.resize(end + 2 * (end - start), 0);
                    let mut mid = end;
                    for k in start..end {
                        let id = ids[k];
                        let b = &boxes[id as usize];
                        t.keep[id as usize].meet(a, b, split);
                        ids[mid] = id;
                        mid += usize::from(sides(b.min[a], b.max[a], split).1);
                    }
                    let mut last = mid;
                    for k in start..end {
                        let id = ids[k];
                        let b = &boxes[id as usize];
                        ids[last] = id;
                        last += usize::from(sides(b.min[a], b.max[a], split).0);
                    }
                    ids.truncate(last);
                    cells.push((child + 1, end, mid));
                    cells.push((child, mid, ids.len()));
                }
                Some(NodeKind::Leaf { .. }) => {
                    let to = tree.prims.len();
                    let run = ids.get(start..end).unwrap_or_default();
                    tree.prims.extend_from_slice(run);
                    let len = run.len() as u32;
                    tree.prims.resize(to + room(len) as usize, 0);
                    t.run_of[i as usize] = t.runs.len() as u32;
                    let r = Run {
                        node: i,
                        at: to as u32,
                        len,
                        cap: room(len),
                    };
                    tree.nodes[i as usize] = r.node(&tree.prims);
                    t.runs.push(r);
                }
                None => {}
            }
        }
        t.live = tree.prims.len();
        t.cost = sah_cost(&tree.nodes, weights, interior_cost);
        t
    }

    /// Takes each box of `boxes` that left its [`Keep`] out of its old
    /// leaves and sends it down again.
    fn update(&mut self, tree: &mut BuiltTree, weights: &[f32], boxes: &[Bounds]) {
        let mut reached = core::mem::take(&mut self.reached);
        for (id, b) in (0u32..).zip(boxes) {
            let i = id as usize;
            if is_listed(b) && self.keep[i].holds(b) {
                continue;
            }
            let old = self.boxes[i];
            reached.clear();
            let keep = descend(&tree.nodes, b, &old, &mut self.todo, |l, r| {
                reached.push((l, r))
            });
            for &(l, r) in &reached {
                match r {
                    OLD => self.list(tree, weights, l, id, false),
                    NEW => self.list(tree, weights, l, id, true),
                    _ => {}
                }
            }
            self.keep[i] = if is_listed(b) { keep } else { Keep::NEVER };
            self.boxes[i] = *b;
        }
        self.reached = reached;
        if tree.prims.len() > 2 * self.live + 4096 {
            self.compact(tree);
        }
    }

    /// Puts box `id` into leaf node `leaf` (`into`), in index order, or
    /// takes it out; a full run moves to the end of `prims` with more room.
    fn list(&mut self, tree: &mut BuiltTree, weights: &[f32], leaf: usize, id: u32, into: bool) {
        let Some(run) = self
            .run_of
            .get(leaf)
            .and_then(|&r| self.runs.get_mut(r as usize))
        else {
            return;
        };
        let (at, len) = (run.at as usize, run.len as usize);
        let w = f64::from(weights[leaf]);
        match (tree.prims[at..at + len].binary_search(&id), into) {
            (Ok(k), false) => {
                tree.prims.copy_within(at + k + 1..at + len, at + k);
                run.len -= 1;
                self.cost -= w;
            }
            (Err(k), true) => {
                if run.len == run.cap {
                    let cap = room(run.len);
                    let to = tree.prims.len();
                    tree.prims.extend_from_within(at..at + len);
                    tree.prims.resize(to + cap as usize, 0);
                    self.live += (cap - run.cap) as usize;
                    (run.at, run.cap) = (to as u32, cap);
                }
                let at = run.at as usize;
                tree.prims.copy_within(at + k..at + len, at + k + 1);
                tree.prims[at + k] = id;
                run.len += 1;
                self.cost += w;
            }
            _ => return,
        }
        tree.nodes[leaf] = run.node(&tree.prims);
    }

    /// Lays the runs out afresh, in leaf order, each with its room.
    fn compact(&mut self, tree: &mut BuiltTree) {
        let mut prims = Vec::with_capacity(self.live);
        for run in &mut self.runs {
            let (at, len) = (run.at as usize, run.len as usize);
            let to = prims.len();
            prims.extend_from_slice(&tree.prims[at..at + len]);
            run.cap = room(run.len);
            prims.resize(to + run.cap as usize, 0);
            run.at = to as u32;
            tree.nodes[run.node as usize] = run.node(&prims);
        }
        self.live = prims.len();
        tree.prims = prims;
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

    /// Each node's boxes: a leaf's list (interior nodes: none), and the
    /// interior nodes themselves, which a refill keeps.
    fn contents(tree: &BuiltTree) -> Vec<(Option<Node>, Vec<u32>)> {
        tree.nodes
            .iter()
            .map(|n| match n.kind() {
                NodeKind::Interior { .. } => (Some(*n), Vec::new()),
                NodeKind::Leaf { count: 0, .. } => (None, Vec::new()),
                NodeKind::Leaf { count: 1, word } => (None, vec![word]),
                NodeKind::Leaf { count, word } => (
                    None,
                    tree.prims[word as usize..(word + count) as usize].to_vec(),
                ),
            })
            .collect()
    }

    /// Costs equal but for rounding: a leaf's term `w * count` taken in
    /// `f32` once, or `w` added `count` times in `f64`.
    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= 1e-6 * a.abs().max(b.abs())
    }

    /// Refilled with the boxes it was built over, the tree lists in each
    /// leaf what the fast builder listed (the same rule sends every box
    /// down), and the cost measured is the built tree's.
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
            if n > 0 {
                assert_eq!(contents(tree), contents(&want), "{n} boxes");
                assert_eq!(tree.bounds, want.bounds, "{n} boxes");
                assert!(cost.is_some_and(|c| close(c, want_cost)), "{n} boxes");
            } else {
                assert_eq!(cost, None, "no box left");
            }
        }
    }

    /// A refill that sends only the crossing boxes down again lists in
    /// each leaf what one that sends every box down lists (a fresh
    /// `Refill`), with the same bounds and cost, frame after frame: small
    /// moves (most boxes keep their leaves), far jumps, boxes emptied and
    /// refilled, a face landing exactly on a plane; its `prims` stay
    /// within a bound while runs outgrow their room.
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
            if frame % 7 == 6 {
                // Compaction, which a long run of frames would reach.
                if let Some(t) = kept.track.as_mut() {
                    t.compact(&mut kept.tree);
                }
            }
            let cost = kept.refill(&b);
            let mut fresh = Refill::new(built.clone(), &COST);
            let want = fresh.refill(&b);
            assert!(
                cost.zip(want).is_some_and(|(c, w)| close(c, w)),
                "frame {frame}"
            );
            assert!(cost.is_some_and(|c| close(c, kept.cost())), "frame {frame}");
            assert_eq!(
                contents(kept.tree()),
                contents(fresh.tree()),
                "frame {frame}"
            );
            assert_eq!(kept.tree().bounds, fresh.tree().bounds, "frame {frame}");
            let live = kept.track.as_ref().map_or(0, |t| t.live);
            assert!(kept.tree().prims.len() <= 2 * live + 4096, "frame {frame}");
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
