//! Ray streams: a block of rays walked down the tree together (Wald et
//! al., "SIMD Ray Stream Tracing", 2007; Barringer & Akenine-Möller,
//! "Dynamic Ray Stream Traversal", 2014).
//!
//! A stream is the list of rays that reach one node, each with its own
//! interval `[lo, hi]` (ids and intervals in the caller's scratch memory).
//! At an interior node every ray of the stream is tested against the one
//! split plane (`t_split`, the single walk's slack rule) with no branch per
//! ray, and written to the below child's stream, the above child's, or
//! both, each with its interval narrowed at `t_split`, into three streams
//! walked in this order: the below child for the rays that enter it first
//! (front to back; back to front for any hit), the above child for all,
//! the below child for the rest; so each ray meets its two children in
//! its own order. The two later streams wait on a stack of streams, and
//! when one is popped each ray whose best hit lies before the cell (more
//! than the slack) drops out, as a popped far cell does in the
//! single walk. At a leaf each ray of the stream tests the leaf's
//! triangles. A stream of fewer than [`SINGLE_BELOW`] rays, or one that
//! finds no room in the scratch memory, goes on as single rays from its
//! node (`walk.rs`), each with its own interval: the per-ray fall-back of
//! dynamic ray stream traversal.
//!
//! Each ray visits every cell its single walk visits (the same tests on
//! the same numbers), perhaps more (a cell its single walk would have
//! popped after the best hit moved, if its stream was not popped yet),
//! and the tie rule does not depend on the order hits arrive in: each
//! answer is its single ray's, bit for bit.

use super::cell_ray::CellRay;
use super::walk::{AnyVisit, ClosestVisit, LeafIter, Visit, STACK};
use super::TriangleTree;
use crate::blob::{Node, MAX_DEPTH};
use crate::geometry::{Hit, Ray};
use crate::lanes::Span;
use crate::triangle::{dominant_axis, Closest, ShearedRay};

/// The rays walked as one stream block (a block of the batch calls);
/// 1024 ran as 256 (bunny random rays, 0.89x against 0.87x of single
/// rays) on four times the stack.
pub(crate) const STREAM_RAYS: usize = 256;

/// Streams of fewer rays go on as single rays from their node: the
/// stream's bookkeeping costs more than it saves there (bunny random rays,
/// one core: 4 rays 0.87x of single rays, 12 0.98x, 32 0.93x).
pub(crate) const SINGLE_BELOW: usize = 12;

/// The scratch words ([`crate::Batch::scratch`]) a stream block needs:
/// room for 16 stream entries (ray id, `lo`, `hi`: 12 bytes) a ray, 48 KiB.
/// Streams that find no room go on as single rays.
pub const STREAM_SCRATCH_WORDS: usize = STREAM_RAYS * 16 * 3 / 2;

/// A stream waiting on the stack: the node it enters and where its
/// entries lie.
#[derive(Clone, Copy, Default)]
struct Frame {
    node: u32,
    start: u32,
    len: u32,
}

/// The numbers every step reads of one ray of a block (by ray id).
#[derive(Clone, Copy)]
struct StreamRay {
    org: [f32; 3],
    inv: [f32; 3],
    /// The above-first bit of each axis (x in bit 0), `CellRay`'s.
    above_first: u32,
    /// Twice the slack.
    s2: f32,
    /// Cells starting after this cannot hold a better answer.
    cutoff: f32,
}

/// One stream entry: a ray and its interval over the stream's cell.
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
struct Entry {
    id: u32,
    lo: f32,
    hi: f32,
}

/// The stream entries, in the caller's scratch memory.
struct Entries<'s>(&'s mut [Entry]);

impl Entries<'_> {
    /// `scratch` as entries (all of it but a last partial entry).
    fn new(scratch: &mut [u64]) -> Entries<'_> {
        let words: &mut [u32] = bytemuck::cast_slice_mut(scratch);
        let whole = words.len() / 3 * 3;
        let words = words.get_mut(..whole).unwrap_or(&mut []);
        Entries(bytemuck::try_cast_slice_mut(words).unwrap_or(&mut []))
    }

    /// Room for this many entries.
    #[inline(always)]
    fn len(&self) -> usize {
        self.0.len()
    }

    /// Entry `i`, if in range.
    #[inline(always)]
    fn get(&self, i: usize) -> Option<(usize, f32, f32)> {
        self.0.get(i).map(|e| (e.id as usize, e.lo, e.hi))
    }

    /// Writes entry `i` (nothing when out of range).
    #[inline(always)]
    fn set(&mut self, i: usize, (id, lo, hi): (u32, f32, f32)) {
        if let Some(e) = self.0.get_mut(i) {
            *e = Entry { id, lo, hi };
        }
    }

    /// Moves `n` entries from `from` down to `to` (`to <= from`; nothing
    /// when out of range).
    #[inline(always)]
    fn move_down(&mut self, from: usize, to: usize, n: usize) {
        let end = from.saturating_add(n);
        if to < from && end <= self.0.len() {
            self.0.copy_within(from..end, to);
        }
    }
}

/// What a stream walk asks of each ray: the single walks' searches.
pub(super) trait StreamQuery {
    /// One ray's state and answer.
    type State: Copy;
    /// Back to front ([`Visit::FAR_FIRST`]).
    const FAR_FIRST: bool;
    /// Before the walk.
    fn start(ray: &Ray) -> Self::State;
    /// The end of the ray's interval ([`Visit::bound`]); `-inf` once the
    /// answer is known.
    fn bound(state: &Self::State, ray: &Ray) -> f32;
    /// Tests a leaf's primitives.
    fn leaf(
        tree: &TriangleTree<'_>,
        sr: &ShearedRay,
        ray: &Ray,
        s: &mut Self::State,
        prims: LeafIter<'_>,
    );
    /// The single walk from `start` = `(node, lo, hi)` on.
    fn single(
        tree: &TriangleTree<'_>,
        sr: &ShearedRay,
        cr: &CellRay,
        ray: &Ray,
        s: &mut Self::State,
        start: (u32, f32, f32),
    );
}

/// The closest hit.
pub(super) struct ClosestStream;

impl StreamQuery for ClosestStream {
    type State = Closest;
    const FAR_FIRST: bool = false;
    #[inline(always)]
    fn start(ray: &Ray) -> Closest {
        Closest::new(ray.tmax)
    }
    #[inline(always)]
    fn bound(s: &Closest, _: &Ray) -> f32 {
        s.t
    }
    #[inline(always)]
    fn leaf(
        tree: &TriangleTree<'_>,
        sr: &ShearedRay,
        ray: &Ray,
        s: &mut Closest,
        prims: LeafIter<'_>,
    ) {
        let mut v = ClosestVisit {
            sr,
            tmin: ray.tmin,
            best: s,
        };
        Visit::<()>::leaf(&mut v, tree.triangles, prims, &mut ());
    }
    #[inline(always)]
    fn single(
        tree: &TriangleTree<'_>,
        sr: &ShearedRay,
        cr: &CellRay,
        ray: &Ray,
        s: &mut Closest,
        start: (u32, f32, f32),
    ) {
        tree.closest_from::<(), STACK>(sr, cr, ray.tmin, s, start, &mut ());
    }
}

/// Any hit.
pub(super) struct AnyStream;

impl StreamQuery for AnyStream {
    type State = bool;
    const FAR_FIRST: bool = true;
    #[inline(always)]
    fn start(_: &Ray) -> bool {
        false
    }
    #[inline(always)]
    fn bound(s: &bool, ray: &Ray) -> f32 {
        if *s {
            f32::NEG_INFINITY
        } else {
            ray.tmax
        }
    }
    #[inline(always)]
    fn leaf(
        tree: &TriangleTree<'_>,
        sr: &ShearedRay,
        ray: &Ray,
        s: &mut bool,
        prims: LeafIter<'_>,
    ) {
        let mut v = AnyVisit {
            sr,
            tmin: ray.tmin,
            tmax: ray.tmax,
            occluder: crate::geometry::MISS,
        };
        *s |= Visit::<()>::leaf(&mut v, tree.triangles, prims, &mut ());
    }
    #[inline(always)]
    fn single(
        tree: &TriangleTree<'_>,
        sr: &ShearedRay,
        cr: &CellRay,
        ray: &Ray,
        s: &mut bool,
        start: (u32, f32, f32),
    ) {
        *s |= tree
            .any_from::<(), STACK>(sr, cr, (ray.tmin, ray.tmax), start, &mut ())
            .is_some();
    }
}

/// A ray prepared as a stream member, or nothing for one that misses the
/// scene or is invalid.
const NO_RAY: ShearedRay = ShearedRay {
    org: [0.0; 3],
    dir: [0.0; 3],
    k: [0, 1, 2],
    s: [0.0; 3],
};

impl TriangleTree<'_> {
    /// Traces `rays` (at most [`STREAM_RAYS`]; more are left alone) as
    /// streams, each answer into `out` (`answer(state, sr)`), with
    /// `scratch` for the streams' entries.
    #[inline(always)]
    pub(super) fn streamed<Q: StreamQuery>(
        &self,
        rays: &[Ray],
        scratch: &mut [u64],
        mut answer: impl FnMut(usize, &mut Q::State, Option<&ShearedRay>),
    ) {
        let rays = rays.get(..STREAM_RAYS).unwrap_or(rays);
        let mut g = [StreamRay {
            org: [0.0; 3],
            inv: [0.0; 3],
            above_first: 0,
            s2: 0.0,
            cutoff: 0.0,
        }; STREAM_RAYS];
        let mut srs = [NO_RAY; STREAM_RAYS];
        let mut states = [Q::start(&Ray::new(Default::default(), Default::default())); STREAM_RAYS];
        let mut live = [false; STREAM_RAYS];
        let mut e = Entries::new(scratch);
        let mut n = 0usize;
        for (id, ray) in rays.iter().enumerate() {
            let Some(cr) = CellRay::new(ray, dominant_axis(&ray.dir), &self.bounds) else {
                continue;
            };
            let Some(sr) = ShearedRay::new(ray) else {
                continue;
            };
            let (lo, hi) = cr.start();
            if n >= e.len() {
                // No room: this ray alone.
                if let (Some(s), Some(l)) = (states.get_mut(id), live.get_mut(id)) {
                    *s = Q::start(ray);
                    Q::single(self, &sr, &cr, ray, s, (0, lo, hi));
                    *l = true;
                }
                if let Some(x) = srs.get_mut(id) {
                    *x = sr;
                }
                continue;
            }
            let s2 = cr.slack + cr.slack;
            if let (Some(g), Some(st), Some(l), Some(x)) = (
                g.get_mut(id),
                states.get_mut(id),
                live.get_mut(id),
                srs.get_mut(id),
            ) {
                *st = Q::start(ray);
                let [x0, y0, z0] = cr.above_first;
                *g = StreamRay {
                    org: cr.org,
                    inv: cr.inv,
                    above_first: x0 | y0 << 1 | z0 << 2,
                    s2,
                    cutoff: Q::bound(st, ray).cutoff(s2),
                };
                *l = true;
                *x = sr;
                e.set(n, (id as u32, lo, hi));
                n += 1;
            }
        }
        self.walk_streams::<Q>(rays, &mut g, &srs, &mut states, &mut e, n);
        for (id, ((s, sr), l)) in states
            .iter_mut()
            .zip(&srs)
            .zip(&live)
            .enumerate()
            .take(rays.len())
        {
            answer(id, s, l.then_some(sr));
        }
    }

    /// The walk of the stream of the `n` first entries of `e` from the root.
    #[inline(always)]
    fn walk_streams<Q: StreamQuery>(
        &self,
        rays: &[Ray],
        g: &mut [StreamRay; STREAM_RAYS],
        srs: &[ShearedRay; STREAM_RAYS],
        states: &mut [Q::State; STREAM_RAYS],
        e: &mut Entries<'_>,
        n: usize,
    ) {
        let cap = e.len();
        // Two streams wait per level of the tree.
        let mut frames = [Frame::default(); 2 * MAX_DEPTH as usize + 1];
        frames[0] = Frame {
            node: 0,
            start: 0,
            len: n as u32,
        };
        let mut fp = 1usize;
        // Each ray of entries `from..to` on its own from `node`.
        let singles = |from: usize,
                       to: usize,
                       node: u32,
                       e: &Entries<'_>,
                       states: &mut [Q::State; STREAM_RAYS],
                       g: &mut [StreamRay; STREAM_RAYS]| {
            for i in from..to {
                let Some((id, lo, hi)) = e.get(i) else {
                    continue;
                };
                let (Some(ray), Some(sr), Some(s)) =
                    (rays.get(id), srs.get(id), states.get_mut(id))
                else {
                    continue;
                };
                let Some(g) = g.get_mut(id) else {
                    continue;
                };
                // The ray's `CellRay` again, from what the streams keep of
                // it (the walk reads no more of it; `s2 / 2` is exact).
                let above_first = [0, 1, 2].map(|a| g.above_first >> a & 1);
                let cr = CellRay {
                    org: g.org,
                    inv: g.inv,
                    above_first,
                    above_first_nibbles: Node::first_child_mask(above_first),
                    t0: lo,
                    t1: hi,
                    slack: g.s2 / 2.0,
                };
                Q::single(self, sr, &cr, ray, s, (node, lo, hi));
                g.cutoff = Q::bound(s, ray).cutoff(g.s2);
            }
        };
        while fp > 0 {
            fp -= 1;
            let Some(&f) = frames.get(fp) else {
                return;
            };
            let start = f.start as usize;
            // Drop the rays whose best hit lies before the cell.
            let mut len = 0usize;
            for i in start..start + f.len as usize {
                let Some((id, lo, hi)) = e.get(i) else {
                    continue;
                };
                let c = g.get(id).map_or(f32::NEG_INFINITY, |g| g.cutoff);
                e.set(start + len, (id as u32, lo, Span::min(hi, c)));
                len += usize::from(lo <= c);
            }
            let mut at = f.node;
            let mut start = start;
            while let Some(&node) = self.nodes.get(at as usize) {
                let top = start + len;
                if len == 0 {
                    break;
                }
                if len < SINGLE_BELOW || (!node.is_leaf() && top + 3 * len > cap) {
                    singles(start, top, at, e, states, g);
                    break;
                }
                if node.is_leaf() {
                    if node.upper() != 0 {
                        for i in start..top {
                            let Some((id, _, _)) = e.get(i) else {
                                continue;
                            };
                            let (Some(ray), Some(sr), Some(s)) =
                                (rays.get(id), srs.get(id), states.get_mut(id))
                            else {
                                continue;
                            };
                            let prims = LeafIter::new(self.leaf_prims(node));
                            Q::leaf(self, sr, ray, s, prims);
                            if let Some(g) = g.get_mut(id) {
                                g.cutoff = Q::bound(s, ray).cutoff(g.s2);
                            }
                        }
                    }
                    break;
                }
                // Compute parametric distance along each ray to the split plane.
                let axis = node.axis_bits().min(2);
                let split = node.split();
                let below = node.upper() as usize;
                let (Some(nb), Some(na)) = (self.nodes.get(below), self.nodes.get(below + 1))
                else {
                    break;
                };
                // Whether each child holds anything (an empty cell is skipped here).
                let keep = [
                    usize::from(!nb.is_empty_leaf()),
                    usize::from(!na.is_empty_leaf()),
                ];
                // Three streams come out, in the order they are walked:
                // R0, the below child for the rays that enter it first
                // (front to back; back to front for any hit); R1, the above
                // child for all; R2, the below child for the rest. So each
                // ray meets its two children in its own order. In memory,
                // room for R2, R1, R0 after the stream's entries.
                let ff = usize::from(Q::FAR_FIRST);
                let mut k = [0usize; 3];
                let (head, room) = e.0.split_at_mut(top.min(cap));
                let (r2, room) = room.split_at_mut(len.min(room.len()));
                let (r1, r0) = room.split_at_mut(len.min(room.len()));
                let outs = [r0, r1, r2];
                for &Entry { id, lo, hi } in head.get(start..).unwrap_or(&[]) {
                    let Some(r) = g.get(id as usize) else {
                        continue;
                    };
                    let (o, v, af, s2) = (r.org[axis], r.inv[axis], r.above_first, r.s2);
                    let t_split = (split - o) * v;
                    // The near child: 0 (below) or 1 (above).
                    let near = (af >> axis & 1) as usize;
                    let far = near ^ 1;
                    // The stream of each child: the above child's is R1, the
                    // below child's R0 if the ray enters it first, else R2.
                    let region = [2 * (near ^ ff), 1];
                    let (rn, rf) = (region[near], region[far]);
                    // As `split_step`: "not outside", so a NaN t_split visits both.
                    #[allow(clippy::neg_cmp_op_on_partial_ord)] // NaN must visit
                    let (vn, vf) = (usize::from(!(t_split < lo)), usize::from(!(t_split > hi)));
                    let (kn, kf) = (k[rn], k[rf]);
                    if let Some(x) = outs[rn].get_mut(kn) {
                        *x = Entry {
                            id,
                            lo,
                            hi: hi.near_hi(t_split, s2),
                        };
                    }
                    if let Some(x) = outs[rf].get_mut(kf) {
                        *x = Entry {
                            id,
                            lo: lo.far_lo(t_split, s2),
                            hi,
                        };
                    }
                    k[rn] = kn + (vn & keep[near]);
                    k[rf] = kf + (vf & keep[far]);
                }
                // Packed down in the order they wait: R2 deepest, R0 on top.
                let [n0, n1, n2] = k;
                e.move_down(top, start, n2);
                e.move_down(top + len, start + n2, n1);
                e.move_down(top + 2 * len, start + n2 + n1, n0);
                for (child, from, n) in [(0, start, n2), (1, start + n2, n1)] {
                    if n == 0 {
                        continue;
                    }
                    let Some(slot) = frames.get_mut(fp) else {
                        // Deeper than MAX_DEPTH: only an unchecked, invalid blob.
                        return;
                    };
                    *slot = Frame {
                        node: (below + child) as u32,
                        start: from as u32,
                        len: n as u32,
                    };
                    fp += 1;
                }
                at = below as u32;
                start += n2 + n1;
                len = n0;
            }
        }
    }

    /// [`crate::TriangleTree::closest_hits`] as streams, blocks of
    /// [`STREAM_RAYS`].
    pub(crate) fn closest_hits_streamed(
        &self,
        rays: &[Ray],
        hits: &mut [Hit],
        scratch: &mut [u64],
    ) {
        for (rays, hits) in rays.chunks(STREAM_RAYS).zip(hits.chunks_mut(STREAM_RAYS)) {
            self.streamed::<ClosestStream>(rays, scratch, |i, best, sr| {
                if let Some(h) = hits.get_mut(i) {
                    *h = match sr {
                        Some(sr) => best.hit(sr, self.triangles),
                        None => Hit::MISS,
                    };
                }
            });
        }
    }

    /// [`crate::TriangleTree::any_hits`] as streams, blocks of
    /// [`STREAM_RAYS`].
    pub(crate) fn any_hits_streamed(
        &self,
        rays: &[Ray],
        occluded: &mut [bool],
        scratch: &mut [u64],
    ) {
        for (rays, occ) in rays
            .chunks(STREAM_RAYS)
            .zip(occluded.chunks_mut(STREAM_RAYS))
        {
            self.streamed::<AnyStream>(rays, scratch, |i, s, sr| {
                if let Some(o) = occ.get_mut(i) {
                    *o = sr.is_some() && *s;
                }
            });
        }
    }
}
