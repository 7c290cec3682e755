//! Whole-batch ray streams: the streams of `streams.rs` over as many rays
//! as the caller's scratch memory holds (not a block of 256), each split
//! plane tested against sixteen stream entries at a time on AVX-512
//! (compressed into the child streams in registers), one at a time
//! elsewhere.
//!
//! Everything a step reads of a ray lives in the scratch memory, by ray
//! id: its slab (origin, `1/dir`, twice the slack, the above-first bits),
//! its cutoff and its search state; the stream entries (ray id, `lo`,
//! `hi`) are three parallel arrays. The walk's rules are `streams.rs`'s
//! (the same three child streams in the same order, the same drops when a
//! stream is popped, the same fall-back to single rays), so each answer is
//! its single ray's, bit for bit.

use super::cell_ray::CellRay;
use super::streams::StreamQuery;
use super::walk::LeafIter;
use super::TriangleTree;
use crate::blob::{Node, MAX_DEPTH};
use crate::geometry::Ray;
use crate::lanes::{dispatch, Job, Level, Span};
use crate::triangle::{dominant_axis, ShearedRay};

#[doc(hidden)]
pub static WIDE_COUNTS: [core::sync::atomic::AtomicU64; 6] =
    [const { core::sync::atomic::AtomicU64::new(0) }; 6];
const COUNT: bool = false;
#[doc(hidden)]
pub static WIDE_SINGLE: core::sync::atomic::AtomicUsize = core::sync::atomic::AtomicUsize::new(12);
fn bump(i: usize, n: usize) {
    if !COUNT {
        return;
    }
    WIDE_COUNTS[i].fetch_add(n as u64, core::sync::atomic::Ordering::Relaxed);
}

/// Room for this many stream entries a ray.
const ENTRIES: usize = 6;

/// The columns of a stream entry: ray id, `lo`, `hi`, origin (3),
/// `1/dir` (3; the sign bit is the above-first bit, NaN included), twice
/// the slack. The entries carry their rays' numbers, so a step reads its
/// stream in order, not its rays scattered by id.
const COLS: usize = 10;
const ID: usize = 0;
const LO: usize = 1;
const HI: usize = 2;
const ORG: usize = 3;
const INV: usize = 6;
const S2: usize = 9;

/// The 32-bit words a ray takes: cutoff 1, state 8, entries.
const RAY_WORDS: usize = 1 + 8 + COLS * ENTRIES;

/// The scratch words ([`crate::Batch::scratch`]) whole-batch streams take
/// a ray.
pub const WIDE_STREAM_WORDS: usize = RAY_WORDS.div_ceil(2);

/// Lanes of room past each stream written (whole-vector stores).
const PAD: usize = 16;

/// The most rays traced as one batch of streams (ray id stays an `i32`
/// gather index).
const MAX_RAYS: usize = 1 << 24;

/// The fewest rays worth whole-batch streams.
pub(crate) const WIDE_MIN_RAYS: usize = 1024;

/// A stream waiting on the stack: the node it enters and where its
/// entries lie.
#[derive(Clone, Copy, Default)]
struct Frame {
    node: u32,
    start: u32,
    len: u32,
}

/// The rays' numbers in scratch memory, by ray id.
struct Rays<'s> {
    /// Cells starting after this cannot hold a better answer.
    cut: &'s mut [f32],
    /// The search states ([`StreamQuery::save`]).
    state: &'s mut [u32],
}

/// The stream entries, [`COLS`] parallel arrays of `f32` / `u32` bits.
struct Entries<'s> {
    cols: [&'s mut [u32]; COLS],
}

impl Entries<'_> {
    /// Room for this many entries (each array's length).
    fn room(&self) -> usize {
        self.cols.iter().map(|c| c.len()).min().unwrap_or(0)
    }

    /// Entry `i`, if in range.
    #[inline(always)]
    fn get(&self, i: usize) -> Option<[u32; COLS]> {
        let mut x = [0u32; COLS];
        for (x, c) in x.iter_mut().zip(&self.cols) {
            *x = *c.get(i)?;
        }
        Some(x)
    }

    /// Writes entry `i` (nothing when out of range).
    #[inline(always)]
    fn set(&mut self, i: usize, x: &[u32; COLS]) {
        for (c, &x) in self.cols.iter_mut().zip(x) {
            if let Some(y) = c.get_mut(i) {
                *y = x;
            }
        }
    }
}

/// An interior node's split plane, as the partition reads it.
#[derive(Clone, Copy)]
struct Plane {
    axis: usize,
    split: f32,
    /// Whether the below and the above child hold anything.
    keep: [bool; 2],
    /// Back to front ([`StreamQuery::FAR_FIRST`]).
    far_first: bool,
}

/// Carves `scratch` for `n` rays: their numbers and the entries.
fn carve(scratch: &mut [u64], n: usize) -> Option<(Rays<'_>, Entries<'_>)> {
    let words: &mut [u32] = bytemuck::cast_slice_mut(scratch);
    let (cut, rest) = words.split_at_mut_checked(n)?;
    let (state, mut rest) = rest.split_at_mut_checked(n.checked_mul(8)?)?;
    let room = rest.len() / COLS;
    let cols = core::array::from_fn(|_| {
        let (c, r) = core::mem::take(&mut rest).split_at_mut(room);
        rest = r;
        c
    });
    Some((
        Rays {
            cut: bytemuck::cast_slice_mut(cut),
            state,
        },
        Entries { cols },
    ))
}

/// Where a partition of the entries `start..start + len` writes its three
/// child streams: R0, the below child's entries of the rays that enter it
/// first (front to back), R1, the above child's, R2, the below child's of
/// the others. R2 over the stream itself (an entry is written at or before
/// the place it was read from, a 16-lane store within the lanes just
/// loaded), the others past it, so that nothing moves afterwards.
#[inline(always)]
fn regions(start: usize, len: usize) -> [usize; 3] {
    let r1 = start + len + PAD;
    [r1 + len + PAD, r1, start]
}

/// The room a partition of `len` entries from `start` needs.
#[inline(always)]
fn split_room(start: usize, len: usize) -> usize {
    start + 3 * (len + PAD)
}

/// Entries `start..start + len` against the plane `p`, one at a time,
/// into the child streams at [`regions`]. The counts `[R0, R1, R2]`.
#[inline(always)]
fn split_scalar(p: &Plane, e: &mut Entries<'_>, start: usize, len: usize) -> [usize; 3] {
    let [b0, b1, b2] = regions(start, len);
    let base = [b0, b1, b2];
    let mut k = [0usize; 3];
    let axis = p.axis.min(2);
    for i in start..start + len {
        let Some(x) = e.get(i) else {
            continue;
        };
        let f = x.map(f32::from_bits);
        let (lo, hi, o, v, s2) = (f[LO], f[HI], f[ORG + axis], f[INV + axis], f[S2]);
        let na = v.is_sign_negative();
        // Compute parametric distance along the ray to the split plane.
        let t_split = (p.split - o) * v;
        // As `split_step`: "not outside", so a NaN t_split visits both.
        #[allow(clippy::neg_cmp_op_on_partial_ord)] // NaN must visit
        let (vn, vf) = (!(t_split < lo), !(t_split > hi));
        let (near_hi, far_lo) = (hi.near_hi(t_split, s2), lo.far_lo(t_split, s2));
        // The below child is the near one unless the ray enters the above
        // child first (`na`).
        let (lb, hb, vb) = if na {
            (far_lo, hi, vf)
        } else {
            (lo, near_hi, vn)
        };
        let (la, ha, va) = if na {
            (lo, near_hi, vn)
        } else {
            (far_lo, hi, vf)
        };
        let rb = if na ^ p.far_first { 2 } else { 0 };
        for (r, l, h, vis) in [(rb, lb, hb, vb & p.keep[0]), (1, la, ha, va & p.keep[1])] {
            let mut y = x;
            (y[LO], y[HI]) = (l.to_bits(), h.to_bits());
            e.set(base[r] + k[r], &y);
            k[r] += usize::from(vis);
        }
    }
    k
}

/// Keeps those of entries `start..start + len` whose ray's best answer does
/// not lie before the cell (`lo <= cut`), each `hi` cut there, packed
/// from `start`; one at a time. How many.
#[inline(always)]
fn drop_scalar(cut: &[f32], e: &mut Entries<'_>, start: usize, len: usize) -> usize {
    let mut kept = 0;
    for i in start..start + len {
        let Some(mut x) = e.get(i) else {
            continue;
        };
        let c = cut
            .get(x[ID] as usize)
            .copied()
            .unwrap_or(f32::NEG_INFINITY);
        let lo = f32::from_bits(x[LO]);
        x[HI] = Span::min(f32::from_bits(x[HI]), c).to_bits();
        e.set(start + kept, &x);
        kept += usize::from(lo <= c);
    }
    kept
}

#[cfg(target_arch = "x86_64")]
mod avx512 {
    //! The partition and the drop sixteen entries at a time.
    //!
    //! # Safety
    //! Run only inside the AVX-512 level's function (`Level::X86_V4`),
    //! reached after `cpu` detected AVX-512 F/BW/DQ/VL. Every vector load
    //! and store lies inside its slice (checked on entry); every gather's
    //! index is clamped to the slice it reads.
    use super::{split_room, Entries, Plane, COLS, HI, ID, INV, LO, ORG, PAD, S2};
    use core::arch::x86_64::*;

    /// [`super::split_scalar`], sixteen entries at a time. `None` (nothing
    /// written) when the entries or their room lie outside the arrays.
    #[inline(always)]
    pub(super) fn split(
        p: &Plane,
        e: &mut Entries<'_>,
        start: usize,
        len: usize,
    ) -> Option<[usize; 3]> {
        let top = start + len;
        if split_room(start, len) > e.room() {
            return None;
        }
        let base = super::regions(start, len);
        let mut k = [0usize; 3];
        let axis = p.axis.min(2);
        let keep = |b: bool| if b { 0xffff_u16 } else { 0 };
        let (keep_b, keep_a) = (keep(p.keep[0]), keep(p.keep[1]));
        let c: [*mut u32; COLS] = core::array::from_fn(|j| e.cols[j].as_mut_ptr());
        // SAFETY: module docs. Loads read lanes `i..i + 16` masked to
        // `i..top`, inside the arrays (`top <= room`); the stores write
        // 16 lanes at `base[r] + k[r]`, where `k[r] <= len`, so below
        // `split_room(start, len) <= room`; R2's at `start + k[2] <= i`,
        // over lanes already loaded.
        unsafe {
            let split = _mm512_set1_ps(p.split);
            let mut i = start;
            while i < top {
                let rem = top - i;
                let m: __mmask16 = if rem >= 16 { 0xffff } else { (1u16 << rem) - 1 };
                let x: [__m512; COLS] =
                    core::array::from_fn(|j| _mm512_maskz_loadu_ps(m, c[j].add(i).cast()));
                let (lov, hiv, o, v, s2) = (x[LO], x[HI], x[ORG + axis], x[INV + axis], x[S2]);
                // Compute parametric distance along each ray to the split plane.
                let t = _mm512_mul_ps(_mm512_sub_ps(split, o), v);
                let na = _mm512_movepi32_mask(_mm512_castps_si512(v));
                // "Not outside": a NaN t_split visits both.
                let vn = _mm512_cmp_ps_mask::<_CMP_NLT_UQ>(t, lov);
                let vf = _mm512_cmp_ps_mask::<_CMP_NGT_UQ>(t, hiv);
                // `Span`'s near_hi and far_lo (`rhs` first: the scalar select).
                let near_hi = _mm512_min_ps(_mm512_add_ps(t, s2), hiv);
                let far_lo = _mm512_max_ps(_mm512_sub_ps(t, s2), lov);
                let lb = _mm512_mask_blend_ps(na, lov, far_lo);
                let hb = _mm512_mask_blend_ps(na, near_hi, hiv);
                let la = _mm512_mask_blend_ps(na, far_lo, lov);
                let ha = _mm512_mask_blend_ps(na, hiv, near_hi);
                let vb = ((na & vf) | (!na & vn)) & keep_b & m;
                let va = ((na & vn) | (!na & vf)) & keep_a & m;
                let later = if p.far_first { !na } else { na };
                for (r, mask, l, h) in [
                    (0, vb & !later, lb, hb),
                    (2, vb & later, lb, hb),
                    (1, va, la, ha),
                ] {
                    if mask == 0 {
                        continue;
                    }
                    let at = base[r] + k[r];
                    for (j, &col) in x.iter().enumerate() {
                        let y = match j {
                            LO => l,
                            HI => h,
                            _ => col,
                        };
                        _mm512_storeu_ps(c[j].add(at).cast(), _mm512_maskz_compress_ps(mask, y));
                    }
                    k[r] += mask.count_ones() as usize;
                }
                i += 16;
            }
        }
        Some(k)
    }

    /// [`super::drop_scalar`], sixteen entries at a time. `None` (nothing
    /// written) when the entries or the room past them lie outside the
    /// arrays.
    #[inline(always)]
    pub(super) fn drop(
        cut: &[f32],
        e: &mut Entries<'_>,
        start: usize,
        len: usize,
    ) -> Option<usize> {
        let top = start + len;
        let n = cut.len();
        if n == 0 || top + PAD > e.room() || n > super::MAX_RAYS {
            return None;
        }
        let c: [*mut u32; COLS] = core::array::from_fn(|j| e.cols[j].as_mut_ptr());
        let mut kept = 0usize;
        // SAFETY: module docs. Loads read lanes `i..top`; the stores write
        // 16 lanes from `start + kept <= i`, below `top + PAD <= room`,
        // over entries already loaded or past the stream; gathers read
        // `cut[min(id, n - 1)]`.
        unsafe {
            let last = _mm512_set1_epi32((n - 1) as i32);
            let mut i = start;
            while i < top {
                let rem = top - i;
                let m: __mmask16 = if rem >= 16 { 0xffff } else { (1u16 << rem) - 1 };
                let x: [__m512; COLS] =
                    core::array::from_fn(|j| _mm512_maskz_loadu_ps(m, c[j].add(i).cast()));
                let ids = _mm512_castps_si512(x[ID]);
                let cv = _mm512_mask_i32gather_ps::<4>(
                    _mm512_setzero_ps(),
                    m,
                    _mm512_min_epu32(ids, last),
                    cut.as_ptr().cast(),
                );
                let keep = _mm512_cmp_ps_mask::<_CMP_LE_OQ>(x[LO], cv) & m;
                let hi2 = _mm512_min_ps(cv, x[HI]);
                let at = start + kept;
                for (j, &col) in x.iter().enumerate() {
                    let y = if j == HI { hi2 } else { col };
                    _mm512_storeu_ps(c[j].add(at).cast(), _mm512_maskz_compress_ps(keep, y));
                }
                kept += keep.count_ones() as usize;
                i += 16;
            }
        }
        Some(kept)
    }
}

/// The walk of one batch of streams at a level's lanes.
struct WideWalk<'t, 'a, 's, Q> {
    tree: &'t TriangleTree<'a>,
    rays: &'t [Ray],
    r: Rays<'s>,
    e: Entries<'s>,
    n: usize,
    q: core::marker::PhantomData<Q>,
}

impl<Q: StreamQuery> Job for WideWalk<'_, '_, '_, Q> {
    type Out = ();
    #[inline(always)]
    fn run<L: Level>(self) {
        let WideWalk {
            tree,
            rays,
            mut r,
            mut e,
            n,
            ..
        } = self;
        tree.wide_walk::<Q, L>(rays, &mut r, &mut e, n);
    }
}

/// Ray `id`'s search state (word 7, which [`StreamQuery::save`] leaves
/// 0, marks a ray walked).
#[inline(always)]
fn load<Q: StreamQuery>(r: &Rays<'_>, id: usize) -> Option<Q::State> {
    let w = r
        .state
        .get(id.checked_mul(8)?..id.checked_mul(8)?.checked_add(8)?)?;
    Some(Q::load(w.try_into().ok()?))
}

/// Saves ray `id`'s search state and its cutoff.
#[inline(always)]
fn save<Q: StreamQuery>(r: &mut Rays<'_>, id: usize, s: &Q::State, ray: &Ray, s2: f32) {
    if let Some(w) = r.state.get_mut(id * 8..id * 8 + 7) {
        w.copy_from_slice(&Q::save(s)[..7]);
    }
    if let Some(c) = r.cut.get_mut(id) {
        *c = Q::bound(s, ray).cutoff(s2);
    }
}

impl TriangleTree<'_> {
    /// The entry `x`'s search from `node` on, as a single ray.
    #[inline(always)]
    fn wide_single<Q: StreamQuery>(
        &self,
        rays: &[Ray],
        r: &mut Rays<'_>,
        x: &[u32; COLS],
        node: u32,
    ) {
        let id = x[ID] as usize;
        let (Some(ray), Some(mut s)) = (rays.get(id), load::<Q>(r, id)) else {
            return;
        };
        let Some(sr) = ShearedRay::new(ray) else {
            return;
        };
        let f = x.map(f32::from_bits);
        let inv = [f[INV], f[INV + 1], f[INV + 2]];
        let above_first = inv.map(|i| u32::from(i.is_sign_negative()));
        let (lo, hi) = (f[LO], f[HI]);
        let cr = CellRay {
            org: [f[ORG], f[ORG + 1], f[ORG + 2]],
            inv,
            above_first,
            above_first_nibbles: Node::first_child_mask(above_first),
            t0: lo,
            t1: hi,
            slack: f[S2] / 2.0,
        };
        Q::single(self, &sr, &cr, ray, &mut s, (node, lo, hi));
        save::<Q>(r, id, &s, ray, f[S2]);
    }

    /// The entry `x`'s ray's test of a leaf's primitives.
    #[inline(always)]
    fn wide_leaf<Q: StreamQuery>(
        &self,
        rays: &[Ray],
        r: &mut Rays<'_>,
        x: &[u32; COLS],
        node: Node,
    ) {
        let id = x[ID] as usize;
        let (Some(ray), Some(mut s)) = (rays.get(id), load::<Q>(r, id)) else {
            return;
        };
        let Some(sr) = ShearedRay::new(ray) else {
            return;
        };
        Q::leaf(self, &sr, ray, &mut s, LeafIter::new(self.leaf_prims(node)));
        save::<Q>(r, id, &s, ray, f32::from_bits(x[S2]));
    }

    /// The walk of the stream of the `n` first entries from the root.
    #[inline(always)]
    fn wide_walk<Q: StreamQuery, L: Level>(
        &self,
        rays: &[Ray],
        r: &mut Rays<'_>,
        e: &mut Entries<'_>,
        n: usize,
    ) {
        #[cfg(target_arch = "x86_64")]
        let v4 = L::X86_V4;
        #[cfg(not(target_arch = "x86_64"))]
        let v4 = false;
        let room = e.room();
        let single_below = WIDE_SINGLE.load(core::sync::atomic::Ordering::Relaxed);
        // Two streams wait per level of the tree.
        let mut frames = [Frame::default(); 2 * MAX_DEPTH as usize + 1];
        frames[0] = Frame {
            node: 0,
            start: 0,
            len: n as u32,
        };
        let mut fp = 1usize;
        while fp > 0 {
            fp -= 1;
            let Some(&f) = frames.get(fp) else {
                return;
            };
            let mut start = f.start as usize;
            let flen = f.len as usize;
            // Drop the rays whose best answer lies before the cell.
            #[cfg(target_arch = "x86_64")]
            let dropped = if v4 {
                avx512::drop(r.cut, e, start, flen)
            } else {
                None
            };
            #[cfg(not(target_arch = "x86_64"))]
            let dropped = None;
            let mut len = match dropped {
                Some(k) => k,
                None => drop_scalar(r.cut, e, start, flen),
            };
            let mut at = f.node;
            while let Some(&node) = self.nodes.get(at as usize) {
                let top = start + len;
                if len == 0 {
                    break;
                }
                if len < single_below || (!node.is_leaf() && split_room(start, len) > room) {
                    bump(2, len);
                    bump(5, 1);
                    for i in start..top {
                        if let Some(x) = e.get(i) {
                            self.wide_single::<Q>(rays, r, &x, at);
                        }
                    }
                    break;
                }
                if node.is_leaf() {
                    bump(1, len);
                    bump(4, 1);
                    if node.upper() != 0 {
                        for i in start..top {
                            if let Some(x) = e.get(i) {
                                self.wide_leaf::<Q>(rays, r, &x, node);
                            }
                        }
                    }
                    break;
                }
                bump(0, len);
                bump(3, 1);
                let below = node.upper() as usize;
                let (Some(nb), Some(na)) = (self.nodes.get(below), self.nodes.get(below + 1))
                else {
                    break;
                };
                let p = Plane {
                    axis: node.axis_bits().min(2),
                    split: node.split(),
                    keep: [!nb.is_empty_leaf(), !na.is_empty_leaf()],
                    far_first: Q::FAR_FIRST,
                };
                #[cfg(target_arch = "x86_64")]
                let split = if v4 {
                    avx512::split(&p, e, start, len)
                } else {
                    None
                };
                #[cfg(not(target_arch = "x86_64"))]
                let split = None;
                let [n0, n1, n2] = match split {
                    Some(k) => k,
                    None => split_scalar(&p, e, start, len),
                };
                // They wait in this order: R2 deepest, R0 on top.
                let [r0, r1, r2] = regions(start, len);
                for (child, from, k) in [(0, r2, n2), (1, r1, n1)] {
                    if k == 0 {
                        continue;
                    }
                    let Some(slot) = frames.get_mut(fp) else {
                        // Deeper than MAX_DEPTH: only an unchecked, invalid blob.
                        return;
                    };
                    *slot = Frame {
                        node: (below + child) as u32,
                        start: from as u32,
                        len: k as u32,
                    };
                    fp += 1;
                }
                at = below as u32;
                start = r0;
                len = n0;
            }
        }
    }

    /// Traces `rays` as whole-batch streams, as many at a time as
    /// `scratch` holds ([`WIDE_STREAM_WORDS`] a ray), each answer into
    /// `answer(ray index, state, ray)`. `false` (nothing traced) when
    /// `scratch` holds fewer than [`WIDE_MIN_RAYS`] rays.
    pub(super) fn wide_streamed<Q: StreamQuery>(
        &self,
        rays: &[Ray],
        scratch: &mut [u64],
        mut answer: impl FnMut(usize, &mut Q::State, Option<&ShearedRay>),
    ) -> bool {
        let per = (scratch.len() / WIDE_STREAM_WORDS).min(MAX_RAYS);
        if per < WIDE_MIN_RAYS.min(rays.len()) || per == 0 {
            return false;
        }
        for (b, block) in rays.chunks(per).enumerate() {
            let n = block.len();
            let Some((mut r, mut e)) = carve(scratch, n) else {
                return false;
            };
            let room = e.room().saturating_sub(PAD);
            let mut k = 0usize;
            for (id, ray) in block.iter().enumerate() {
                let start = Q::start(ray);
                if let Some(w) = r.state.get_mut(id * 8..id * 8 + 8) {
                    w.copy_from_slice(&Q::save(&start));
                }
                let Some(cr) = CellRay::new(ray, dominant_axis(&ray.dir), &self.bounds) else {
                    continue;
                };
                if ShearedRay::new(ray).is_none() {
                    continue;
                }
                if let Some(w) = r.state.get_mut(id * 8 + 7) {
                    *w = 1;
                }
                let s2 = cr.slack + cr.slack;
                // The sign bit of `1/dir` is the above-first bit, NaN too.
                let inv: [f32; 3] = core::array::from_fn(|a| {
                    let neg = cr.above_first[a] == 1;
                    if neg == cr.inv[a].is_sign_negative() {
                        cr.inv[a]
                    } else {
                        -cr.inv[a]
                    }
                });
                if let Some(c) = r.cut.get_mut(id) {
                    *c = Q::bound(&start, ray).cutoff(s2);
                }
                let (lo, hi) = cr.start();
                let [o0, o1, o2] = cr.org.map(f32::to_bits);
                let [i0, i1, i2] = inv.map(f32::to_bits);
                let x = [
                    id as u32,
                    lo.to_bits(),
                    hi.to_bits(),
                    o0,
                    o1,
                    o2,
                    i0,
                    i1,
                    i2,
                    s2.to_bits(),
                ];
                if k < room {
                    e.set(k, &x);
                    k += 1;
                } else {
                    // No room: this ray alone.
                    self.wide_single::<Q>(block, &mut r, &x, 0);
                }
            }
            dispatch(WideWalk::<Q> {
                tree: self,
                rays: block,
                r: Rays {
                    cut: &mut *r.cut,
                    state: &mut *r.state,
                },
                e,
                n: k,
                q: core::marker::PhantomData,
            });
            for (id, ray) in block.iter().enumerate() {
                let walked = r.state.get(id * 8 + 7) == Some(&1);
                let sr = ShearedRay::new(ray).filter(|_| walked);
                let mut s = load::<Q>(&r, id).unwrap_or_else(|| Q::start(ray));
                answer(b * per + id, &mut s, sr.as_ref());
            }
        }
        true
    }
}
