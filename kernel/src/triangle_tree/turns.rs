//! Several single rays walked in turns: the batch calls' one-ray
//! closest-hit path for rays that share no cells (random rays, bounces).
//! Any hit walks back to front instead, which needs no turns (the
//! `AnyHit` query in `batch.rs`).
//!
//! Such a ray's walk waits on memory: each step's child pair and each
//! leaf's triangles are a cache miss more often than not, and the next
//! step depends on it. Walking [`WALKS`] rays in turns, one step each,
//! and prefetching what each ray's next step reads, lets their misses
//! overlap instead of queueing. Each ray's steps are exactly its single
//! walk's (`walk.rs`), in the same order, with the same tests, so each
//! answer is the single ray's bit for bit; only the interleaving of
//! independent rays changes.

use super::cell_ray::CellRay;
use super::walk::{ClosestVisit, LeafIter, Pending, Visit};
use super::TriangleTree;
use crate::blob::{Node, LINE_NODES, MAX_DEPTH};
use crate::geometry::{Hit, Ray};
use crate::lanes::{prefetch, Span};
use crate::triangle::{Closest, ShearedRay};
use core::mem::MaybeUninit;

/// How many rays take turns: eight, so that a ray's prefetched pair or
/// leaf has seven other turns to arrive. Measured (bunny, one core, same
/// hits): 8 against 4 walks shadow rays 1.3-1.45x, random rays 1.2x, 6
/// walks 1.1x, 12 as 8; not taken: a leaf's triangles tested in the turn
/// that fetches its indices (no separate prefetch turn), 0.75-0.8x.
pub(crate) const WALKS: usize = 8;

/// Where one ray's walk stands between its turns: the walk's loop
/// variables (`walk.rs`).
struct Walk {
    node: Node,
    lo: f32,
    hi: f32,
    sp: usize,
    cutoff: f32,
    /// Set once a leaf's triangles were prefetched: the next turn tests them.
    armed: bool,
    /// Entries below `sp` are written (as in `walk.rs`).
    stack: [MaybeUninit<Pending>; MAX_DEPTH as usize],
}

impl<'a> TriangleTree<'a> {
    /// Prefetches what the walk reads at `node` next: an interior node's
    /// child pair, a leaf's run of primitive indices (or its one triangle).
    #[inline(always)]
    pub(super) fn prefetch_node(&self, node: Node) {
        let at = node.upper() as usize;
        if !node.is_leaf() {
            if let Some(n) = self.nodes.get(at) {
                prefetch(n as *const _);
            }
        } else if at == 1 {
            if let Some(t) = self.triangles.get(node.word0() as usize) {
                prefetch(t as *const _);
            }
        } else if let Some(p) = self.prims.get(node.word0() as usize) {
            prefetch(p as *const _);
        }
    }

    /// Prefetches the triangles of a leaf of several.
    #[inline(always)]
    fn prefetch_leaf(&self, node: Node) {
        if let super::LeafPrims::Run(run) = self.leaf_prims(node) {
            for &p in run {
                if let Some(t) = self.triangles.get(p as usize) {
                    prefetch(t as *const _);
                }
            }
        }
    }

    /// One turn of a ray's walk: `walk.rs`'s loop, run until the ray's
    /// next step reads a line it has not read yet (a child pair in another
    /// line, a leaf's indices or triangles, a popped cell), which it
    /// prefetches before handing over. `Some(stopped)` when the walk
    /// ended, as `walk` returns it. Tried: no hand-over for the first 3,
    /// 6 or 10 lines of a descent (the top of the tree stays cached):
    /// bunny random rays 1.00-1.05x, sponza's 1.01-1.03x, within the noise.
    #[inline(always)]
    fn turn<V: Visit<'a, ()>>(&self, cr: &CellRay, w: &mut Walk, visit: &mut V) -> Option<bool> {
        let s2 = cr.slack + cr.slack;
        let (mut node, mut lo, mut hi, mut sp) = (w.node, w.lo, w.hi, w.sp);
        loop {
            let axis = node.axis_bits();
            if axis < 3 {
                let (Some(&o), Some(&i)) = (cr.org.get(axis), cr.inv.get(axis)) else {
                    return Some(false);
                };
                let t_split = (node.split() - o) * i;
                let nibbles = cr.above_first_nibbles;
                let step = (t_split, s2);
                let stack = &mut w.stack;
                match self.split_step(
                    node,
                    (nibbles, V::FAR_FIRST),
                    step,
                    (&mut lo, &mut hi),
                    stack,
                    &mut sp,
                ) {
                    None => return Some(false),
                    Some(Some((n, at))) => {
                        node = n;
                        // Hand over unless the pair `node` points to shares
                        // the line `node` was read from.
                        if node.is_leaf() || (node.upper() as usize ^ at) >= LINE_NODES {
                            self.prefetch_node(node);
                            (w.node, w.lo, w.hi, w.sp) = (node, lo, hi, sp);
                            return None;
                        }
                        continue;
                    }
                    Some(None) => {}
                }
            } else if node.upper() != 0 {
                if node.upper() > 1 && !w.armed {
                    // The leaf's indices arrived (prefetched last turn):
                    // fetch its triangles while the other rays take turns.
                    w.armed = true;
                    self.prefetch_leaf(node);
                    (w.node, w.lo, w.hi, w.sp) = (node, lo, hi, sp);
                    return None;
                }
                w.armed = false;
                let prims = LeafIter::new(self.leaf_prims(node));
                if visit.leaf(self.triangles, prims, &mut ()) {
                    return Some(true);
                }
                w.cutoff = visit.bound().cutoff(s2);
            }
            loop {
                if sp == 0 {
                    return Some(false);
                }
                sp -= 1;
                let Some(slot) = w.stack.get(sp) else {
                    return Some(false);
                };
                // SAFETY: `sp` was above this entry, so it was written.
                let p = unsafe { slot.assume_init() };
                if p.lo <= w.cutoff {
                    let Some(&n) = self.nodes.get(p.node as usize) else {
                        return Some(false);
                    };
                    (node, lo, hi) = (n, p.lo, Span::min(p.hi, w.cutoff));
                    break;
                }
            }
            // A popped cell's pair was read long ago: hand over.
            self.prefetch_node(node);
            (w.node, w.lo, w.hi, w.sp) = (node, lo, hi, sp);
            return None;
        }
    }
}

/// A ray's set-up for its walk; `None` for an invalid ray or one that
/// misses the scene box (its answer is a miss).
#[inline(always)]
fn start(tree: &TriangleTree<'_>, ray: &Ray, w: &mut Walk) -> Option<(ShearedRay, CellRay)> {
    let sr = ShearedRay::new(ray)?;
    let cr = CellRay::new(ray, sr.k[2], &tree.bounds)?;
    let (lo, hi) = cr.start();
    let node = *tree.nodes.first()?;
    (w.node, w.lo, w.hi, w.sp, w.armed) = (node, lo, hi, 0, false);
    Some((sr, cr))
}

/// The slots' walks; a slot holds ray `at` of the slice, or none.
struct Slots {
    walks: [Walk; WALKS],
    at: [usize; WALKS],
}

impl Slots {
    fn new() -> Slots {
        Slots {
            walks: core::array::from_fn(|_| Walk {
                node: Node::EMPTY_LEAF,
                lo: 0.0,
                hi: 0.0,
                sp: 0,
                cutoff: 0.0,
                armed: false,
                stack: [MaybeUninit::uninit(); MAX_DEPTH as usize],
            }),
            at: [usize::MAX; WALKS],
        }
    }
}

/// The closest-hit search a slot holds besides its walk: `tmin` and the
/// best hit so far.
struct Nearest(f32, Closest);

impl Nearest {
    #[inline(always)]
    fn new(ray: &Ray) -> Nearest {
        Nearest(ray.tmin, Closest::new(ray.tmax))
    }

    /// The leaf search of `sr` (`walk.rs`'s visitor).
    #[inline(always)]
    fn visit<'r>(&'r mut self, sr: &'r ShearedRay) -> ClosestVisit<'r> {
        ClosestVisit {
            sr,
            tmin: self.0,
            best: &mut self.1,
        }
    }
}

impl TriangleTree<'_> {
    /// `hits[i] = closest_hit(&rays[i])` for the first
    /// `min(rays.len(), hits.len())` rays, [`WALKS`] walks in turns: a
    /// slot whose walk ends takes the next ray.
    pub(crate) fn closest_hits_in_turns(&self, rays: &[Ray], hits: &mut [Hit]) {
        let n = rays.len().min(hits.len());
        let mut slots = Slots::new();
        let mut rs: [Option<(ShearedRay, CellRay, Nearest)>; WALKS] =
            core::array::from_fn(|_| None);
        let mut next = 0usize;
        let mut live = 0usize;
        loop {
            for (k, slot) in rs.iter_mut().enumerate() {
                let (Some(w), Some(at)) = (slots.walks.get_mut(k), slots.at.get_mut(k)) else {
                    continue;
                };
                // Refill an empty slot with the next ray that needs a walk.
                while slot.is_none() && next < n {
                    let Some(ray) = rays.get(next) else { break };
                    if let Some((sr, cr)) = start(self, ray, w) {
                        let mut q = Nearest::new(ray);
                        w.cutoff = Visit::<()>::bound(&q.visit(&sr)).cutoff(cr.slack + cr.slack);
                        *slot = Some((sr, cr, q));
                        *at = next;
                        live += 1;
                    } else if let Some(h) = hits.get_mut(next) {
                        *h = Hit::MISS;
                    }
                    next += 1;
                }
                let Some((sr, cr, q)) = slot else {
                    continue;
                };
                if self.turn(cr, w, &mut q.visit(sr)).is_some() {
                    if let Some(h) = hits.get_mut(*at) {
                        *h = q.1.hit(sr, self.triangles);
                    }
                    *slot = None;
                    live -= 1;
                }
            }
            if live == 0 && next >= n {
                return;
            }
        }
    }
}
