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
const ENTRIES: usize = 16;

/// The 32-bit words a ray takes: slab 8, cutoff 1, state 8, entries 3
/// each.
const RAY_WORDS: usize = 8 + 1 + 8 + 3 * ENTRIES;

/// The scratch words ([`crate::Batch::scratch`]) whole-batch streams take
/// a ray.
pub const WIDE_STREAM_WORDS: usize = RAY_WORDS.div_ceil(2);

/// Lanes of room past each stream written (whole-vector stores).
const PAD: usize = 16;

/// The most rays traced as one batch of streams (ray id times 8 stays an
/// `i32` gather index).
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
    /// `[ox, oy, oz, s2, ix, iy, iz, bits]` a ray (`f32` bits; `bits`:
    /// above-first bits x, y, z in bits 0-2, bit 3 set for a ray walked).
    slab: &'s mut [u32],
    /// Cells starting after this cannot hold a better answer.
    cut: &'s mut [f32],
    /// The search states ([`StreamQuery::save`]).
    state: &'s mut [u32],
}

/// The stream entries, three parallel arrays.
struct Entries<'s> {
    ids: &'s mut [u32],
    lo: &'s mut [f32],
    hi: &'s mut [f32],
}

impl Entries<'_> {
    /// Room for this many entries (each array's length).
    fn room(&self) -> usize {
        self.ids.len().min(self.lo.len()).min(self.hi.len())
    }

    /// Moves `n` entries from `from` down to `to` (nothing when out of range).
    fn move_down(&mut self, from: usize, to: usize, n: usize) {
        let end = from.saturating_add(n);
        if to < from && end <= self.room() {
            self.ids.copy_within(from..end, to);
            self.lo.copy_within(from..end, to);
            self.hi.copy_within(from..end, to);
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
    let (slab, rest) = words.split_at_mut_checked(n.checked_mul(8)?)?;
    let (cut, rest) = rest.split_at_mut_checked(n)?;
    let (state, rest) = rest.split_at_mut_checked(n * 8)?;
    let room = rest.len() / 3;
    let (ids, rest) = rest.split_at_mut(room);
    let (lo, rest) = rest.split_at_mut(room);
    let hi = rest.get_mut(..room)?;
    Some((
        Rays {
            slab,
            cut: bytemuck::cast_slice_mut(cut),
            state,
        },
        Entries {
            ids,
            lo: bytemuck::cast_slice_mut(lo),
            hi: bytemuck::cast_slice_mut(hi),
        },
    ))
}

/// Ray `id`'s slab.
#[inline(always)]
fn slab_of(slab: &[u32], id: usize) -> Option<&[u32; 8]> {
    slab.get(id.wrapping_mul(8)..id.wrapping_mul(8).wrapping_add(8))?
        .try_into()
        .ok()
}

/// Entries `start..start + len` against the plane `p`, one at a time:
/// the below child's entries of the rays that enter it first (front to
/// back) written from `top + 2 * (len + PAD)` (R0), the above child's from
/// `top + len + PAD` (R1), the below child's of the others from `top` (R2).
/// The counts `[R0, R1, R2]`.
#[inline(always)]
fn split_scalar(
    p: &Plane,
    slab: &[u32],
    e: &mut Entries<'_>,
    start: usize,
    len: usize,
) -> [usize; 3] {
    let top = start + len;
    let base = [top + 2 * (len + PAD), top + len + PAD, top];
    let mut k = [0usize; 3];
    for i in start..top {
        let (Some(&id), Some(&lo), Some(&hi)) = (e.ids.get(i), e.lo.get(i), e.hi.get(i)) else {
            continue;
        };
        let Some(r) = slab_of(slab, id as usize) else {
            continue;
        };
        let axis = p.axis.min(2);
        let (o, v) = (f32::from_bits(r[axis]), f32::from_bits(r[axis + 4]));
        let (s2, na) = (f32::from_bits(r[3]), r[7] >> axis & 1 == 1);
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
            let at = base[r] + k[r];
            if let (Some(x), Some(y), Some(z)) =
                (e.ids.get_mut(at), e.lo.get_mut(at), e.hi.get_mut(at))
            {
                (*x, *y, *z) = (id, l, h);
            }
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
        let (Some(&id), Some(&lo), Some(&hi)) = (e.ids.get(i), e.lo.get(i), e.hi.get(i)) else {
            continue;
        };
        let c = cut.get(id as usize).copied().unwrap_or(f32::NEG_INFINITY);
        let at = start + kept;
        if let (Some(x), Some(y), Some(z)) = (e.ids.get_mut(at), e.lo.get_mut(at), e.hi.get_mut(at))
        {
            (*x, *y, *z) = (id, lo, Span::min(hi, c));
        }
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
    //! index is clamped to the slab's rays.
    use super::{Entries, Plane, PAD};
    use core::arch::x86_64::*;

    /// [`super::split_scalar`], sixteen entries at a time. `None` (nothing
    /// written) when the entries or their room lie outside the arrays.
    #[inline(always)]
    pub(super) fn split(
        p: &Plane,
        slab: &[u32],
        e: &mut Entries<'_>,
        start: usize,
        len: usize,
    ) -> Option<[usize; 3]> {
        let top = start + len;
        let n = slab.len() / 8;
        if n == 0 || top + 3 * (len + PAD) > e.room() || n > super::MAX_RAYS {
            return None;
        }
        let base = [top + 2 * (len + PAD), top + len + PAD, top];
        let mut k = [0usize; 3];
        let axis = p.axis.min(2) as i32;
        let keep = |b: bool| if b { 0xffff_u16 } else { 0 };
        let (keep_b, keep_a) = (keep(p.keep[0]), keep(p.keep[1]));
        let (ids, lo, hi) = (e.ids.as_mut_ptr(), e.lo.as_mut_ptr(), e.hi.as_mut_ptr());
        let sp = slab.as_ptr();
        // SAFETY: module docs. Loads read lanes `i..i + 16` masked to
        // `i..top`, inside the arrays (`top <= room`); the stores write
        // 16 lanes at `base[r] + k[r]`, where `k[r] <= len`, so below
        // `top + 3 * (len + PAD) <= room`; gathers read ray
        // `min(id, n - 1)`'s words `0..8` of the slab's `8 * n`.
        unsafe {
            let split = _mm512_set1_ps(p.split);
            let last = _mm512_set1_epi32((n - 1) as i32);
            let (off_o, off_v) = (_mm512_set1_epi32(axis), _mm512_set1_epi32(axis + 4));
            let (off_s, off_b) = (_mm512_set1_epi32(3), _mm512_set1_epi32(7));
            let bit = _mm512_set1_epi32(1 << axis);
            let zero = _mm512_setzero_ps();
            let mut i = start;
            while i < top {
                let rem = top - i;
                let m: __mmask16 = if rem >= 16 { 0xffff } else { (1u16 << rem) - 1 };
                let idv = _mm512_maskz_loadu_epi32(m, ids.add(i).cast());
                let lov = _mm512_maskz_loadu_ps(m, lo.add(i));
                let hiv = _mm512_maskz_loadu_ps(m, hi.add(i));
                let row = _mm512_slli_epi32::<3>(_mm512_min_epu32(idv, last));
                let o =
                    _mm512_mask_i32gather_ps::<4>(zero, m, _mm512_add_epi32(row, off_o), sp.cast());
                let v =
                    _mm512_mask_i32gather_ps::<4>(zero, m, _mm512_add_epi32(row, off_v), sp.cast());
                let s2 =
                    _mm512_mask_i32gather_ps::<4>(zero, m, _mm512_add_epi32(row, off_s), sp.cast());
                let bits = _mm512_mask_i32gather_epi32::<4>(
                    _mm512_setzero_si512(),
                    m,
                    _mm512_add_epi32(row, off_b),
                    sp.cast(),
                );
                // Compute parametric distance along each ray to the split plane.
                let t = _mm512_mul_ps(_mm512_sub_ps(split, o), v);
                let na = _mm512_test_epi32_mask(bits, bit);
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
                    let at = base[r] + k[r];
                    _mm512_storeu_si512(ids.add(at).cast(), _mm512_maskz_compress_epi32(mask, idv));
                    _mm512_storeu_ps(lo.add(at), _mm512_maskz_compress_ps(mask, l));
                    _mm512_storeu_ps(hi.add(at), _mm512_maskz_compress_ps(mask, h));
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
        let (ids, lo, hi) = (e.ids.as_mut_ptr(), e.lo.as_mut_ptr(), e.hi.as_mut_ptr());
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
                let idv = _mm512_maskz_loadu_epi32(m, ids.add(i).cast());
                let lov = _mm512_maskz_loadu_ps(m, lo.add(i));
                let hiv = _mm512_maskz_loadu_ps(m, hi.add(i));
                let c = _mm512_mask_i32gather_ps::<4>(
                    _mm512_setzero_ps(),
                    m,
                    _mm512_min_epu32(idv, last),
                    cut.as_ptr().cast(),
                );
                let keep = _mm512_cmp_ps_mask::<_CMP_LE_OQ>(lov, c) & m;
                let hi2 = _mm512_min_ps(c, hiv);
                let at = start + kept;
                _mm512_storeu_si512(ids.add(at).cast(), _mm512_maskz_compress_epi32(keep, idv));
                _mm512_storeu_ps(lo.add(at), _mm512_maskz_compress_ps(keep, lov));
                _mm512_storeu_ps(hi.add(at), _mm512_maskz_compress_ps(keep, hi2));
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

impl TriangleTree<'_> {
    /// Ray `id`'s search from `(node, lo, hi)` on, as a single ray.
    #[inline(always)]
    fn wide_single<Q: StreamQuery>(
        &self,
        rays: &[Ray],
        r: &mut Rays<'_>,
        id: usize,
        at: (u32, f32, f32),
    ) {
        let Some(ray) = rays.get(id) else {
            return;
        };
        let Some(&g) = slab_of(r.slab, id) else {
            return;
        };
        let Some(sr) = ShearedRay::new(ray) else {
            return;
        };
        let f = g.map(f32::from_bits);
        let above_first = [0, 1, 2].map(|a| g[7] >> a & 1);
        let cr = CellRay {
            org: [f[0], f[1], f[2]],
            inv: [f[4], f[5], f[6]],
            above_first,
            above_first_nibbles: Node::first_child_mask(above_first),
            t0: at.1,
            t1: at.2,
            slack: f[3] / 2.0,
        };
        let Some(w) = r.state.get_mut(id * 8..id * 8 + 8) else {
            return;
        };
        let Ok(words) = <[u32; 8]>::try_from(&*w) else {
            return;
        };
        let mut s = Q::load(words);
        Q::single(self, &sr, &cr, ray, &mut s, at);
        w.copy_from_slice(&Q::save(&s));
        if let Some(c) = r.cut.get_mut(id) {
            *c = Q::bound(&s, ray).cutoff(f[3]);
        }
    }

    /// Ray `id`'s test of a leaf's primitives.
    #[inline(always)]
    fn wide_leaf<Q: StreamQuery>(&self, rays: &[Ray], r: &mut Rays<'_>, id: usize, node: Node) {
        let (Some(ray), Some(g)) = (rays.get(id), slab_of(r.slab, id)) else {
            return;
        };
        let s2 = f32::from_bits(g[3]);
        let Some(sr) = ShearedRay::new(ray) else {
            return;
        };
        let Some(w) = r.state.get_mut(id * 8..id * 8 + 8) else {
            return;
        };
        let Ok(words) = <[u32; 8]>::try_from(&*w) else {
            return;
        };
        let mut s = Q::load(words);
        Q::leaf(self, &sr, ray, &mut s, LeafIter::new(self.leaf_prims(node)));
        w.copy_from_slice(&Q::save(&s));
        if let Some(c) = r.cut.get_mut(id) {
            *c = Q::bound(&s, ray).cutoff(s2);
        }
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
                if len < single_below || (!node.is_leaf() && top + 3 * (len + PAD) > room) {
                    bump(2, len);
                    bump(5, 1);
                    for i in start..top {
                        let (Some(&id), Some(&lo), Some(&hi)) =
                            (e.ids.get(i), e.lo.get(i), e.hi.get(i))
                        else {
                            continue;
                        };
                        self.wide_single::<Q>(rays, r, id as usize, (at, lo, hi));
                    }
                    break;
                }
                if node.is_leaf() {
                    bump(1, len);
                    bump(4, 1);
                    if node.upper() != 0 {
                        for i in start..top {
                            if let Some(&id) = e.ids.get(i) {
                                self.wide_leaf::<Q>(rays, r, id as usize, node);
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
                    avx512::split(&p, r.slab, e, start, len)
                } else {
                    None
                };
                #[cfg(not(target_arch = "x86_64"))]
                let split = None;
                let [n0, n1, n2] = match split {
                    Some(k) => k,
                    None => split_scalar(&p, r.slab, e, start, len),
                };
                // Packed down in the order they wait: R2 deepest, R0 on top.
                e.move_down(top, start, n2);
                e.move_down(top + len + PAD, start + n2, n1);
                e.move_down(top + 2 * (len + PAD), start + n2 + n1, n0);
                for (child, from, k) in [(0, start, n2), (1, start + n2, n1)] {
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
                start += n2 + n1;
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
            let Some((mut r, e)) = carve(scratch, n) else {
                return false;
            };
            let room = e.room().saturating_sub(PAD);
            let mut k = 0usize;
            for (id, ray) in block.iter().enumerate() {
                let start = Q::start(ray);
                if let Some(w) = r.state.get_mut(id * 8..id * 8 + 8) {
                    w.copy_from_slice(&Q::save(&start));
                }
                let Some(g) = r.slab.get_mut(id * 8..id * 8 + 8) else {
                    continue;
                };
                g[7] = 0;
                let Some(cr) = CellRay::new(ray, dominant_axis(&ray.dir), &self.bounds) else {
                    continue;
                };
                if ShearedRay::new(ray).is_none() {
                    continue;
                }
                let s2 = cr.slack + cr.slack;
                let [x, y, z] = cr.above_first;
                let [o0, o1, o2] = cr.org.map(f32::to_bits);
                let [i0, i1, i2] = cr.inv.map(f32::to_bits);
                g.copy_from_slice(&[
                    o0,
                    o1,
                    o2,
                    s2.to_bits(),
                    i0,
                    i1,
                    i2,
                    x | y << 1 | z << 2 | 8,
                ]);
                if let Some(c) = r.cut.get_mut(id) {
                    *c = Q::bound(&start, ray).cutoff(s2);
                }
                let (lo, hi) = cr.start();
                if k < room {
                    if let (Some(a), Some(b), Some(c)) =
                        (e.ids.get_mut(k), e.lo.get_mut(k), e.hi.get_mut(k))
                    {
                        (*a, *b, *c) = (id as u32, lo, hi);
                        k += 1;
                    }
                } else {
                    // No room: this ray alone.
                    self.wide_single::<Q>(block, &mut r, id, (0, lo, hi));
                }
            }
            dispatch(WideWalk::<Q> {
                tree: self,
                rays: block,
                r: Rays {
                    slab: &mut *r.slab,
                    cut: &mut *r.cut,
                    state: &mut *r.state,
                },
                e,
                n: k,
                q: core::marker::PhantomData,
            });
            for (id, ray) in block.iter().enumerate() {
                let walked = slab_of(r.slab, id).is_some_and(|g| g[7] & 8 != 0);
                let sr = ShearedRay::new(ray).filter(|_| walked);
                let words = r
                    .state
                    .get(id * 8..id * 8 + 8)
                    .and_then(|w| <[u32; 8]>::try_from(w).ok())
                    .unwrap_or_else(|| Q::save(&Q::start(ray)));
                let mut s = Q::load(words);
                answer(b * per + id, &mut s, sr.as_ref());
            }
        }
        true
    }
}
