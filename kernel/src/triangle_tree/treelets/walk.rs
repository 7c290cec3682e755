//! Walking the treelets: scattered rays, four in turns, 7 split planes a
//! vector step at the AVX2 level (the module docs of `treelets`).

use crate::geometry::{Hit, Ray};
#[cfg(target_arch = "x86_64")]
use crate::lanes::{dispatch, Job, Level};
use crate::triangle_tree::TriangleTree;

impl TriangleTree<'_> {
    /// `hits[i] = closest_hit(&rays[i])` for the first
    /// `min(rays.len(), hits.len())` rays, for rays that share no cells
    /// (random rays, bounces): walked in turns, through the treelets where
    /// the tree has them and the processor AVX2, otherwise with the
    /// one-plane walk. The batch calls take this path for the blocks of
    /// 256 rays they find scattered where their trials find it cheaper
    /// than single rays (`walk_choice.rs`). No allocation (the four walks
    /// in turns take ~9 KiB of stack).
    pub(crate) fn closest_hits_scattered(&self, rays: &[Ray], hits: &mut [Hit]) {
        #[cfg(target_arch = "x86_64")]
        if !self.lines.is_empty() && dispatch(TreeletWalks(self, rays, &mut *hits)) {
            return;
        }
        self.closest_hits_in_turns(rays, hits);
    }
}

/// The treelet walks of a slice at the dispatched level; `false` (and
/// nothing done) below AVX2.
#[cfg(target_arch = "x86_64")]
struct TreeletWalks<'t, 'a>(&'t TriangleTree<'a>, &'t [Ray], &'t mut [Hit]);

#[cfg(target_arch = "x86_64")]
impl Job for TreeletWalks<'_, '_> {
    type Out = bool;
    #[inline(always)]
    fn run<L: Level>(self) -> bool {
        if L::X86_V3 {
            // SAFETY: `L` is AVX2 or AVX-512, whose `dispatch` wrapper
            // enables AVX2 and runs only on a processor that has it.
            unsafe { closest_hits_treelets(self.0, self.1, self.2) };
        }
        L::X86_V3
    }
}

/// How many rays take turns through the treelets: four (two ran at 1.6x
/// the one-plane walk on random rays, four at 1.7-1.8x, eight as four;
/// `benches/treelets.rs`).
#[cfg(target_arch = "x86_64")]
pub(crate) const TURNS: usize = 4;

#[cfg(target_arch = "x86_64")]
use x86::closest_hits_treelets;

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::super::{Treelet, DEAD, LEAF};
    use super::TURNS;
    use crate::geometry::{Hit, Ray};
    use crate::lanes::{prefetch, Span};
    use crate::triangle::{dominant_axis, Closest, ShearedRay};
    use crate::triangle_tree::cell_ray::CellRay;
    use crate::triangle_tree::walk::{ClosestVisit, LeafIter, Visit};
    use crate::triangle_tree::TriangleTree;
    use core::arch::x86_64::*;

    /// Pending exits a walk holds: 7 a treelet, treelets nested at most
    /// `MAX_DEPTH / 3 + 1` deep, and 8 more for a whole-vector store.
    const PENDING: usize = 7 * (crate::blob::MAX_DEPTH as usize / 3 + 1) + 8;

    /// For each 8-bit mask, the indices of its set lanes, lowest first:
    /// the permute that packs those lanes to the front.
    static COMPRESS: [[u32; 8]; 256] = {
        let mut t = [[0u32; 8]; 256];
        let mut m = 0;
        while m < 256 {
            let (mut lane, mut at) = (0, 0);
            while lane < 8 {
                if m >> lane & 1 == 1 {
                    t[m][at] = lane as u32;
                    at += 1;
                }
                lane += 1;
            }
            m += 1;
        }
        t
    };

    /// One ray's treelet walk between turns.
    struct Walk {
        sr: ShearedRay,
        tmin: f32,
        best: Closest,
        /// Origin, `1/dir` and the near bits (1: the above child first)
        /// as 8 lanes, the axes' values in lanes 0-2.
        org: [f32; 8],
        inv: [f32; 8],
        near: [i32; 8],
        s2: f32,
        cutoff: f32,
        /// The exit walked now and its interval.
        now: (u32, f32, f32),
        /// Pending exits (codes, interval starts, ends), `sp` of them.
        pending: ([u32; PENDING], [f32; PENDING], [f32; PENDING]),
        sp: usize,
        /// The slice index of the ray, `usize::MAX` for none.
        at: usize,
    }

    impl Walk {
        fn idle() -> Walk {
            Walk {
                sr: ShearedRay {
                    org: [0.0; 3],
                    dir: [0.0; 3],
                    k: [0, 1, 2],
                    s: [0.0; 3],
                },
                tmin: 0.0,
                best: Closest::new(0.0),
                org: [0.0; 8],
                inv: [0.0; 8],
                near: [0; 8],
                s2: 0.0,
                cutoff: 0.0,
                now: (DEAD, 0.0, 0.0),
                pending: ([0; PENDING], [0.0; PENDING], [0.0; PENDING]),
                sp: 0,
                at: usize::MAX,
            }
        }

        /// Starts ray `at`; `false` for a ray that hits nothing (invalid,
        /// or missing the scene box).
        #[inline(always)]
        fn start(&mut self, tree: &TriangleTree<'_>, ray: &Ray, at: usize) -> bool {
            // The root clip first, as `closest_hit_tallied` makes it: a
            // ray that misses the tree's box skips the shear's divisions.
            let Some(cr) = CellRay::new(ray, dominant_axis(&ray.dir), &tree.bounds) else {
                return false;
            };
            let Some(sr) = ShearedRay::new(ray) else {
                return false;
            };
            let (lo, hi) = cr.start();
            self.sr = sr;
            self.tmin = ray.tmin;
            self.best = Closest::new(ray.tmax);
            for a in 0..3 {
                self.org[a] = cr.org[a];
                self.inv[a] = cr.inv[a];
                self.near[a] = cr.above_first[a] as i32;
            }
            self.s2 = cr.slack + cr.slack;
            self.cutoff = self.best.t.cutoff(self.s2);
            (self.now, self.sp, self.at) = ((0, lo, hi), 0, at);
            true
        }

        /// One treelet, or one leaf and the pops after it; `true` when the
        /// walk has ended.
        ///
        /// # Safety
        /// The processor has AVX2 (and the function this inlines into
        /// enables it).
        #[inline(always)]
        unsafe fn step(&mut self, tree: &TriangleTree<'_>) -> bool {
            let cur = self.now.0;
            if cur & LEAF != 0 {
                if let Some(&node) = tree.nodes.get((cur & !LEAF) as usize) {
                    let prims = LeafIter::new(tree.leaf_prims(node));
                    let mut visit = ClosestVisit {
                        sr: &self.sr,
                        tmin: self.tmin,
                        best: &mut self.best,
                    };
                    visit.leaf(tree.triangles, prims, &mut ());
                    self.cutoff = self.best.t.cutoff(self.s2);
                }
            } else if let Some(t) = tree.lines.get(cur as usize) {
                // SAFETY: the caller's promise.
                if unsafe { self.treelet(t) } {
                    prefetch_exit(tree, self.now.0);
                    return false;
                }
            }
            let (refs, los, his) = &self.pending;
            while self.sp > 0 {
                self.sp -= 1;
                let (Some(&r), Some(&lo), Some(&hi)) =
                    (refs.get(self.sp), los.get(self.sp), his.get(self.sp))
                else {
                    return true;
                };
                if lo <= self.cutoff {
                    self.now = (r, lo, Span::min(hi, self.cutoff));
                    prefetch_exit(tree, r);
                    return false;
                }
            }
            true
        }

        /// The vector step over treelet `t`: goes on with the nearest live
        /// exit and pushes the others; `false` when none is live.
        ///
        /// # Safety
        /// As [`Walk::step`].
        #[inline(always)]
        unsafe fn treelet(&mut self, t: &Treelet) -> bool {
            // SAFETY: the caller has AVX2; every load reads 8
            // lanes of an array of 8 (the splits and the axes word as one
            // 32-byte load from the treelet's start), every store writes
            // an 8-lane slice, bounds-checked.
            unsafe {
                let line = (t as *const Treelet).cast::<f32>();
                let shifts = _mm256_setr_epi32(0, 2, 4, 6, 8, 10, 12, 14);
                let axes = _mm256_and_si256(
                    _mm256_srlv_epi32(_mm256_set1_epi32(t.axes as i32), shifts),
                    _mm256_set1_epi32(3),
                );
                let org = _mm256_permutevar8x32_ps(_mm256_loadu_ps(self.org.as_ptr()), axes);
                let inv = _mm256_permutevar8x32_ps(_mm256_loadu_ps(self.inv.as_ptr()), axes);
                let ts = _mm256_mul_ps(_mm256_sub_ps(_mm256_load_ps(line), org), inv);
                let near = _mm256_loadu_si256(self.near.as_ptr().cast());
                let near = _mm256_permutevar8x32_epi32(near, axes);
                // Lane j stands for the exit met (7 - j)-th: its key's
                // bits say near (0) or far (1) at each level, and with the
                // slots' near bits which slot and exit that is.
                let key = _mm256_setr_epi32(7, 6, 5, 4, 3, 2, 1, 0);
                let one = _mm256_set1_epi32(1);
                let zero = _mm256_setzero_si256();
                let b0 = _mm256_xor_si256(
                    _mm256_srli_epi32(key, 2),
                    _mm256_permutevar8x32_epi32(near, zero),
                );
                let s1 = _mm256_add_epi32(b0, one);
                let b1 = _mm256_xor_si256(
                    _mm256_and_si256(_mm256_srli_epi32(key, 1), one),
                    _mm256_permutevar8x32_epi32(near, s1),
                );
                let s2 = _mm256_add_epi32(
                    _mm256_add_epi32(_mm256_slli_epi32(b0, 1), b1),
                    _mm256_set1_epi32(3),
                );
                let b2 = _mm256_xor_si256(
                    _mm256_and_si256(key, one),
                    _mm256_permutevar8x32_epi32(near, s2),
                );
                let exit = _mm256_add_epi32(
                    _mm256_add_epi32(_mm256_slli_epi32(b0, 2), _mm256_slli_epi32(b1, 1)),
                    b2,
                );
                let slack = _mm256_set1_ps(self.s2);
                let (mut lo, mut hi) = (_mm256_set1_ps(self.now.1), _mm256_set1_ps(self.now.2));
                let mut live = 0xffu32;
                // Per level, the lanes on the near side: keys 0-3, then
                // those with bit 1 clear, then the even ones.
                for (near_lanes, t) in [
                    (
                        _mm256_setr_epi32(0, 0, 0, 0, -1, -1, -1, -1),
                        _mm256_permutevar8x32_ps(ts, zero),
                    ),
                    (
                        _mm256_setr_epi32(0, 0, -1, -1, 0, 0, -1, -1),
                        _mm256_permutevar8x32_ps(ts, s1),
                    ),
                    (
                        _mm256_setr_epi32(0, -1, 0, -1, 0, -1, 0, -1),
                        _mm256_permutevar8x32_ps(ts, s2),
                    ),
                ] {
                    let near_lanes = _mm256_castsi256_ps(near_lanes);
                    // The near child when !(t < lo), the far one when
                    // !(t > hi): a NaN visits both (`walk.rs`).
                    let visit = _mm256_blendv_ps(
                        _mm256_cmp_ps::<_CMP_NGT_UQ>(t, hi),
                        _mm256_cmp_ps::<_CMP_NLT_UQ>(t, lo),
                        near_lanes,
                    );
                    live &= _mm256_movemask_ps(visit) as u32;
                    // `Span`'s min and max: a NaN `t` keeps the interval.
                    let up = _mm256_min_ps(_mm256_add_ps(t, slack), hi);
                    let down = _mm256_max_ps(_mm256_sub_ps(t, slack), lo);
                    hi = _mm256_blendv_ps(hi, up, near_lanes);
                    lo = _mm256_blendv_ps(down, lo, near_lanes);
                }
                let exits = _mm256_loadu_si256(t.exit.as_ptr().cast());
                let exits = _mm256_permutevar8x32_epi32(exits, exit);
                let dead = _mm256_cmpeq_epi32(exits, _mm256_set1_epi32(DEAD as i32));
                live &= !(_mm256_movemask_ps(_mm256_castsi256_ps(dead)) as u32) & 0xff;
                if live == 0 {
                    return false;
                }
                let j = 31 - live.leading_zeros();
                let rest = live & !(1 << j);
                let sp = self.sp;
                let (refs, los, his) = &mut self.pending;
                let (Some(order), Some(r), Some(l), Some(h)) = (
                    COMPRESS.get(rest as usize),
                    refs.get_mut(sp..sp + 8),
                    los.get_mut(sp..sp + 8),
                    his.get_mut(sp..sp + 8),
                ) else {
                    return false;
                };
                let order = _mm256_loadu_si256(order.as_ptr().cast());
                _mm256_storeu_si256(
                    r.as_mut_ptr().cast(),
                    _mm256_permutevar8x32_epi32(exits, order),
                );
                _mm256_storeu_ps(l.as_mut_ptr(), _mm256_permutevar8x32_ps(lo, order));
                _mm256_storeu_ps(h.as_mut_ptr(), _mm256_permutevar8x32_ps(hi, order));
                self.sp = sp + rest.count_ones() as usize;
                let lane = _mm256_set1_epi32(j as i32);
                self.now = (
                    _mm256_cvtsi256_si32(_mm256_permutevar8x32_epi32(exits, lane)) as u32,
                    _mm256_cvtss_f32(_mm256_permutevar8x32_ps(lo, lane)),
                    _mm256_cvtss_f32(_mm256_permutevar8x32_ps(hi, lane)),
                );
                true
            }
        }
    }

    /// Prefetches what the walk reads at exit `code` next: a treelet's
    /// line, a leaf's run of indices (or its one triangle). Its next turn
    /// comes after the other walks' (`matrix.sh`'s random rays, one core:
    /// bunny 1.15x -> 1.5x the one-plane walk in turns with the prefetch).
    /// Tried: a leaf's triangles prefetched in a turn of their own before
    /// its test, as `turns.rs` does: teapot 1.17x -> 1.05x, sponza 1.33x
    /// -> 1.22x, the bunny the same; eight walks in turns as four.
    #[inline(always)]
    fn prefetch_exit(tree: &TriangleTree<'_>, code: u32) {
        if code & LEAF != 0 {
            if let Some(&node) = tree.nodes.get((code & !LEAF) as usize) {
                tree.prefetch_node(node);
            }
        } else if let Some(t) = tree.lines.get(code as usize) {
            prefetch(t as *const Treelet);
        }
    }

    /// `hits[i] = tree.closest_hit(&rays[i])`, [`TURNS`] treelet walks in
    /// turns (a slot whose walk ends takes the next ray).
    ///
    /// # Safety
    /// The processor has AVX2 (the caller inlines this into a function
    /// that enables it: `lanes::dispatch` at the AVX2 level or above).
    #[inline(always)]
    pub(crate) unsafe fn closest_hits_treelets(
        tree: &TriangleTree<'_>,
        rays: &[Ray],
        hits: &mut [Hit],
    ) {
        let n = rays.len().min(hits.len());
        let mut walks: [Walk; TURNS] = core::array::from_fn(|_| Walk::idle());
        let mut next = 0;
        loop {
            let mut busy = false;
            for w in &mut walks {
                // Refill an idle slot with the next ray that needs a walk.
                while w.at == usize::MAX && next < n {
                    let (Some(ray), Some(h)) = (rays.get(next), hits.get_mut(next)) else {
                        break;
                    };
                    if !w.start(tree, ray, next) {
                        *h = Hit::MISS;
                    }
                    next += 1;
                }
                if w.at == usize::MAX {
                    continue;
                }
                busy = true;
                // SAFETY: the caller's promise.
                if unsafe { w.step(tree) } {
                    if let Some(h) = hits.get_mut(w.at) {
                        *h = w.best.hit(&w.sr, tree.triangles);
                    }
                    w.at = usize::MAX;
                }
            }
            if !busy {
                return;
            }
        }
    }
}
