//! A design direction measured, not built: seven split planes evaluated in
//! one vector step (`RESEARCH.md`, "cache-line treelets of 8-byte
//! nodes"), against the one-plane step of today's walk.
//!
//! Both walks take the same set-up, the same cell intervals (widened by
//! the slack as the kernel widens them) and the same cutoff, fixed at the
//! ray's closest hit from the kernel; leaves are only counted, no
//! triangle is tested, so the figures are the walks alone. Per ray, both
//! visit the same leaves (checked: their count and a sum of their hashed
//! indices), so the ratio is the cost of reaching them.
//!
//! - `scalar`: the kernel's step (`triangle_tree/walk.rs`): one plane,
//!   near child first, the far child pushed.
//! - `treelets`: the tree regrouped into complete 3-level treelets, 7
//!   planes and 8 exits (96 bytes here: 7 splits, 7 axes, 8 exit codes). A
//!   step computes the 7 `t_split` with one permute of the origin and of
//!   `1/dir` by the slots' axes, the 8 exits' intervals three levels down
//!   in lanes that hold the exits in front-to-back order (lane `7 - k`
//!   the `k`-th exit met: the near side at each level is a fixed lane
//!   pattern, and the exit a lane stands for follows from the slots'
//!   near bits), goes on with the nearest live exit and pushes the rest
//!   with one compress each. Leaves and empty cells inside a treelet fall
//!   through planes at `+inf` (the whole cell below, for either sign of
//!   the direction). AVX-512VL, and AVX2 (masks by compare and blend,
//!   the compress a permute from a table); rays walked alone, or four in
//!   turns.
//!
//! ```sh
//! taskset -c 0 cargo bench --bench treelets
//! ```
//!
//! Results (docs/results.md, "Seven planes a step"): one ray at a time
//! the treelet walk wins only on random rays, whose scalar steps
//! mispredict (0.44-1.24x the scalar walk's speed); four rays in turns,
//! 1.4-1.9x on random rays and 0.63-1.3x on camera rays, at either level.

#[cfg(target_arch = "x86_64")]
mod walks {
    use core::arch::x86_64::*;
    use kdray::kernel::{Bounds, Ray};

    /// A ray clipped to the root cell: what both walks start from.
    #[derive(Clone, Copy)]
    pub(crate) struct Start {
        /// The origin, `1/dir` and, per axis, 1 where the above child is
        /// met first.
        o: [f32; 3],
        inv: [f32; 3],
        above_first: [u32; 3],
        /// The root cell's interval, widened by the slack twice.
        lo: f32,
        hi: f32,
        /// Twice the slack, and the cutoff: the closest hit plus it.
        s2: f32,
        cutoff: f32,
    }

    impl Start {
        /// `ray` clipped to `b`, with the kernel's slack (2^-18 of the
        /// ray's extent along its dominant axis), its cutoff at `hit_t`.
        pub(crate) fn new(ray: &Ray, b: &Bounds, hit_t: f32) -> Option<Start> {
            let inv = ray.dir.map(|d| 1.0 / d);
            let (mut enter, mut exit) = (f32::NEG_INFINITY, f32::INFINITY);
            for (a, &i) in inv.iter().enumerate() {
                if i.is_infinite() {
                    if ray.origin[a] < b.min[a] || ray.origin[a] > b.max[a] {
                        return None;
                    }
                    continue;
                }
                let ta = (b.min[a] - ray.origin[a]) * i;
                let tb = (b.max[a] - ray.origin[a]) * i;
                enter = enter.max(ta.min(tb));
                exit = exit.min(ta.max(tb));
            }
            let k = (0..3).max_by(|&x, &y| ray.dir[x].abs().total_cmp(&ray.dir[y].abs()))?;
            let reach = (b.min[k] - ray.origin[k])
                .abs()
                .max((b.max[k] - ray.origin[k]).abs());
            let s = (reach * inv[k].abs() / 262_144.0).max(f32::MIN_POSITIVE);
            let (t0, t1) = (ray.tmin.max(enter) - s, ray.tmax.min(exit) + s);
            (t0 <= t1).then_some(Start {
                o: ray.origin,
                inv,
                above_first: inv.map(|i| u32::from(i < 0.0)),
                lo: t0 - s,
                hi: t1 + s,
                s2: s + s,
                cutoff: if hit_t.is_finite() {
                    hit_t
                } else {
                    f32::INFINITY
                } + s
                    + s,
            })
        }
    }

    /// What a walk reports: leaves visited and a sum of their hashed node
    /// indices (the same for both walks when they visit the same leaves).
    #[derive(Clone, Copy, Default, PartialEq, Eq, Debug)]
    pub(crate) struct Seen {
        pub(crate) leaves: u32,
        pub(crate) hash: u64,
    }

    impl Seen {
        fn add(&mut self, node: u32) {
            self.leaves += 1;
            self.hash =
                (self.hash).wrapping_add(u64::from(node).wrapping_mul(0x9E37_79B9_7F4A_7C15));
        }
    }

    /// The one-plane walk: the kernel's step over the v2 nodes (`[split
    /// bits, child << 2 | axis]`, 3 in the low bits for a leaf).
    pub(crate) struct Scalar {
        stack: [(u32, f32, f32); 64],
        sp: usize,
        node: usize,
        lo: f32,
        hi: f32,
        slab: [f32; 8],
        nibbles: u64,
        s2: f32,
        cutoff: f32,
        pub(crate) seen: Seen,
        pub(crate) done: bool,
    }

    impl Scalar {
        pub(crate) fn new() -> Scalar {
            Scalar {
                stack: [(0, 0.0, 0.0); 64],
                sp: 0,
                node: 0,
                lo: 0.0,
                hi: 0.0,
                slab: [0.0; 8],
                nibbles: 0,
                s2: 0.0,
                cutoff: 0.0,
                seen: Seen::default(),
                done: true,
            }
        }

        pub(crate) fn start(&mut self, st: &Start) {
            let (o, i, a) = (st.o, st.inv, st.above_first);
            self.slab = [o[0], o[1], o[2], 0.0, i[0], i[1], i[2], 0.0];
            self.nibbles = u64::from(a[0] | a[1] << 1 | a[2] << 2) * 0x1111_1111_1111_1111;
            (self.s2, self.cutoff) = (st.s2, st.cutoff);
            (self.node, self.lo, self.hi) = (0, st.lo, st.hi.min(st.cutoff));
            (self.sp, self.seen, self.done) = (0, Seen::default(), false);
        }

        /// One node, and the pops after a leaf or a dead end.
        #[inline(always)]
        pub(crate) fn step(&mut self, nodes: &[[u32; 2]]) {
            let [w0, w1] = nodes[self.node];
            let axis = (w1 & 3) as usize;
            if axis < 3 {
                let t = (f32::from_bits(w0) - self.slab[axis]) * self.slab[axis + 4];
                let child = (w1 >> 2) as usize;
                let first = child + (self.nibbles.wrapping_shr(w1) & 1) as usize;
                let second = 2 * child + 1 - first;
                // "Not outside", so a NaN `t_split` visits both children.
                #[allow(clippy::neg_cmp_op_on_partial_ord)]
                let (visit_near, visit_far) = (!(t < self.lo), !(t > self.hi));
                let visit_near = visit_near & (nodes[first][1] != 3);
                let visit_far = visit_far & (nodes[second][1] != 3);
                let far_lo = if t - self.s2 > self.lo {
                    t - self.s2
                } else {
                    self.lo
                };
                self.stack[self.sp & 63] = (second as u32, far_lo, self.hi);
                if visit_near {
                    self.sp += usize::from(visit_far);
                    let near_hi = t + self.s2;
                    if near_hi < self.hi {
                        self.hi = near_hi;
                    }
                    self.node = first;
                    return;
                }
                if visit_far {
                    (self.lo, self.node) = (far_lo, second);
                    return;
                }
            } else if w1 != 3 {
                self.seen.add(self.node as u32);
            }
            while self.sp > 0 {
                self.sp -= 1;
                let (node, lo, hi) = self.stack[self.sp];
                if lo <= self.cutoff {
                    (self.node, self.lo, self.hi) = (node as usize, lo, hi.min(self.cutoff));
                    return;
                }
            }
            self.done = true;
        }

        pub(crate) fn walk(&mut self, nodes: &[[u32; 2]], st: &Start) -> Seen {
            self.start(st);
            while !self.done {
                self.step(nodes);
            }
            self.seen
        }
    }

    /// A complete 3-level treelet: slot 0 its root, slots `2s + 1`, `2s +
    /// 2` the below and above children of slot `s`; exits `2(s - 3)` and
    /// `2(s - 3) + 1` the children of bottom slot `s`.
    #[derive(Clone, Copy, Default)]
    #[repr(C, align(32))]
    pub(crate) struct Treelet {
        split: [f32; 8],
        axis: [u32; 8],
        exit: [u32; 8],
    }

    const DEAD: u32 = u32::MAX;

    /// For each 8-bit mask, the indices of its set bits, lowest first: the
    /// permute that packs those lanes to the front.
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
    const LEAF: u32 = 1 << 31;

    #[derive(Clone, Copy)]
    enum Slot {
        Interior(usize),
        Leaf(usize),
        Dead,
    }

    fn slot(nodes: &[[u32; 2]], i: usize) -> Slot {
        match nodes[i][1] {
            3 => Slot::Dead,
            w if w & 3 == 3 => Slot::Leaf(i),
            _ => Slot::Interior(i),
        }
    }

    /// The treelets below interior node `root` into `out`; its index.
    pub(crate) fn treelets(nodes: &[[u32; 2]], root: usize, out: &mut Vec<Treelet>) -> u32 {
        let at = out.len();
        out.push(Treelet::default());
        let mut slots = [Slot::Dead; 7];
        slots[0] = Slot::Interior(root);
        let children = |s: Slot| match s {
            Slot::Interior(n) => {
                let c = (nodes[n][1] >> 2) as usize;
                (slot(nodes, c), slot(nodes, c + 1))
            }
            // A leaf falls through to the below side.
            Slot::Leaf(l) => (Slot::Leaf(l), Slot::Dead),
            Slot::Dead => (Slot::Dead, Slot::Dead),
        };
        for s in 0..3 {
            (slots[2 * s + 1], slots[2 * s + 2]) = children(slots[s]);
        }
        let mut t = Treelet {
            split: [f32::INFINITY; 8],
            ..Treelet::default()
        };
        for (s, c) in slots.iter().enumerate() {
            if let Slot::Interior(n) = *c {
                t.split[s] = f32::from_bits(nodes[n][0]);
                t.axis[s] = nodes[n][1] & 3;
            }
        }
        for (s, &bottom) in slots.iter().enumerate().skip(3) {
            let (below, above) = children(bottom);
            for (e, c) in [(2 * (s - 3), below), (2 * (s - 3) + 1, above)] {
                t.exit[e] = match c {
                    Slot::Interior(n) => treelets(nodes, n, out),
                    Slot::Leaf(l) => LEAF | l as u32,
                    Slot::Dead => DEAD,
                };
            }
        }
        out[at] = t;
        at as u32
    }

    /// The seven-plane walk of one ray.
    pub(crate) struct Seven {
        /// Pending exits (codes, interval starts and ends), `sp` of them.
        pending: ([u32; 256], [f32; 256], [f32; 256]),
        sp: usize,
        /// The exit walked now and its interval.
        now: (u32, f32, f32),
        /// The ray, and its origin, `1/dir` and near bits as 8 lanes.
        ray: Start,
        lanes: ([f32; 8], [f32; 8], [i32; 8]),
        pub(crate) seen: Seen,
        pub(crate) done: bool,
    }

    impl Seven {
        pub(crate) fn new() -> Seven {
            Seven {
                pending: ([0; 256], [0.0; 256], [0.0; 256]),
                sp: 0,
                now: (0, 0.0, 0.0),
                ray: Start {
                    o: [0.0; 3],
                    inv: [0.0; 3],
                    above_first: [0; 3],
                    lo: 0.0,
                    hi: 0.0,
                    s2: 0.0,
                    cutoff: 0.0,
                },
                lanes: ([0.0; 8], [0.0; 8], [0; 8]),
                seen: Seen::default(),
                done: true,
            }
        }

        pub(crate) fn start(&mut self, st: &Start, root: u32) {
            self.ray = *st;
            self.lanes.0[..3].copy_from_slice(&st.o);
            self.lanes.1[..3].copy_from_slice(&st.inv);
            for (lane, &bit) in self.lanes.2.iter_mut().zip(&st.above_first) {
                *lane = bit as i32;
            }
            self.now = (root, st.lo, st.hi.min(st.cutoff));
            (self.sp, self.seen, self.done) = (0, Seen::default(), false);
        }

        /// One treelet (going on with its nearest live exit), or a leaf
        /// and the pops after it.
        ///
        /// # Safety
        /// The processor has AVX2, AVX-512F and AVX-512VL.
        #[inline(always)]
        pub(crate) unsafe fn step<const AVX512: bool>(&mut self, ts: &[Treelet]) {
            let cur = self.now.0;
            if cur & LEAF != 0 {
                self.seen.add(cur & !LEAF);
            } else if self.treelet::<AVX512>(&ts[cur as usize]) {
                return;
            }
            let (refs, los, his) = &self.pending;
            while self.sp > 0 {
                self.sp -= 1;
                let lo = los[self.sp];
                if lo <= self.ray.cutoff {
                    self.now = (refs[self.sp], lo, his[self.sp].min(self.ray.cutoff));
                    return;
                }
            }
            self.done = true;
        }

        /// The vector step; `false` when no exit is live. Without
        /// AVX-512 the lane masks are compares and blends, the compress a
        /// permute from [`COMPRESS`].
        #[inline(always)]
        unsafe fn treelet<const AVX512: bool>(&mut self, t: &Treelet) -> bool {
            // SAFETY (every load and store below): the pointers come from
            // arrays of 8 lanes, or from 8-lane slices of the pending
            // arrays (bounds-checked); the caller has the target features.
            let axes = _mm256_load_si256(t.axis.as_ptr().cast());
            let ol = _mm256_permutevar8x32_ps(_mm256_loadu_ps(self.lanes.0.as_ptr()), axes);
            let il = _mm256_permutevar8x32_ps(_mm256_loadu_ps(self.lanes.1.as_ptr()), axes);
            let ts = _mm256_mul_ps(_mm256_sub_ps(_mm256_load_ps(t.split.as_ptr()), ol), il);
            let af = _mm256_loadu_si256(self.lanes.2.as_ptr().cast());
            let near_bit = _mm256_permutevar8x32_epi32(af, axes);
            // Lane j stands for the exit met (7 - j)-th: its key bits say
            // near (0) or far (1) at each level, and with the slots' near
            // bits which slot and exit that is.
            let key = _mm256_setr_epi32(7, 6, 5, 4, 3, 2, 1, 0);
            let one = _mm256_set1_epi32(1);
            let zero = _mm256_setzero_si256();
            let b0 = _mm256_xor_si256(
                _mm256_srli_epi32(key, 2),
                _mm256_permutevar8x32_epi32(near_bit, zero),
            );
            let s1 = _mm256_add_epi32(b0, one);
            let b1 = _mm256_xor_si256(
                _mm256_and_si256(_mm256_srli_epi32(key, 1), one),
                _mm256_permutevar8x32_epi32(near_bit, s1),
            );
            let s2 = _mm256_add_epi32(
                _mm256_add_epi32(_mm256_slli_epi32(b0, 1), b1),
                _mm256_set1_epi32(3),
            );
            let b2 = _mm256_xor_si256(
                _mm256_and_si256(key, one),
                _mm256_permutevar8x32_epi32(near_bit, s2),
            );
            let exit = _mm256_add_epi32(
                _mm256_add_epi32(_mm256_slli_epi32(b0, 2), _mm256_slli_epi32(b1, 1)),
                b2,
            );
            let slack = _mm256_set1_ps(self.ray.s2);
            let (mut lo, mut hi) = (_mm256_set1_ps(self.now.1), _mm256_set1_ps(self.now.2));
            let mut live: u8 = 0xff;
            // The near side at each level, as lanes.
            for (near, t) in [
                (0b1111_0000u8, _mm256_permutevar8x32_ps(ts, zero)),
                (0b1100_1100, _mm256_permutevar8x32_ps(ts, s1)),
                (0b1010_1010, _mm256_permutevar8x32_ps(ts, s2)),
            ] {
                // As the scalar step: the near child when !(t < lo), the
                // far one when !(t > hi); a NaN visits both.
                let (up, down) = (_mm256_add_ps(t, slack), _mm256_sub_ps(t, slack));
                if AVX512 {
                    live &= _mm256_mask_cmp_ps_mask(near, t, lo, _CMP_NLT_UQ)
                        | _mm256_mask_cmp_ps_mask(!near, t, hi, _CMP_NGT_UQ);
                    let new_hi = _mm256_mask_min_ps(hi, near, up, hi);
                    lo = _mm256_mask_max_ps(lo, !near, down, lo);
                    hi = new_hi;
                } else {
                    let bits = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
                    let near_lanes = _mm256_castsi256_ps(_mm256_cmpeq_epi32(
                        _mm256_and_si256(_mm256_set1_epi32(i32::from(near)), bits),
                        bits,
                    ));
                    let pass = _mm256_blendv_ps(
                        _mm256_cmp_ps(t, hi, _CMP_NGT_UQ),
                        _mm256_cmp_ps(t, lo, _CMP_NLT_UQ),
                        near_lanes,
                    );
                    live &= _mm256_movemask_ps(pass) as u8;
                    let new_hi = _mm256_blendv_ps(hi, _mm256_min_ps(up, hi), near_lanes);
                    lo = _mm256_blendv_ps(_mm256_max_ps(down, lo), lo, near_lanes);
                    hi = new_hi;
                }
            }
            let exits =
                _mm256_permutevar8x32_epi32(_mm256_load_si256(t.exit.as_ptr().cast()), exit);
            let dead = _mm256_cmpeq_epi32(exits, _mm256_set1_epi32(DEAD as i32));
            live &= !(_mm256_movemask_ps(_mm256_castsi256_ps(dead)) as u8);
            if live == 0 {
                return false;
            }
            let j = 31 - u32::from(live).leading_zeros();
            let rest = live & !(1u8 << j);
            let sp = self.sp;
            let (refs, los, his) = &mut self.pending;
            let (r, l, h) = if AVX512 {
                (
                    _mm256_maskz_compress_epi32(rest, exits),
                    _mm256_maskz_compress_ps(rest, lo),
                    _mm256_maskz_compress_ps(rest, hi),
                )
            } else {
                let order = _mm256_loadu_si256(COMPRESS[usize::from(rest)].as_ptr().cast());
                (
                    _mm256_permutevar8x32_epi32(exits, order),
                    _mm256_permutevar8x32_ps(lo, order),
                    _mm256_permutevar8x32_ps(hi, order),
                )
            };
            _mm256_storeu_si256(refs[sp..sp + 8].as_mut_ptr().cast(), r);
            _mm256_storeu_ps(los[sp..sp + 8].as_mut_ptr(), l);
            _mm256_storeu_ps(his[sp..sp + 8].as_mut_ptr(), h);
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

    /// Walks every ray, `N` at a time in turns (a step each), calling
    /// `seen` with each ray's index and what it saw.
    #[inline(always)]
    pub(crate) fn in_turns<const N: usize, W>(
        starts: &[Start],
        walkers: &mut [W; N],
        begin: impl Fn(&mut W, &Start),
        mut step: impl FnMut(&mut W),
        state: impl Fn(&W) -> (bool, Seen),
        mut seen: impl FnMut(usize, Seen),
    ) {
        let mut ray = [usize::MAX; N];
        let mut next = 0;
        loop {
            let mut busy = false;
            for (w, r) in walkers.iter_mut().zip(ray.iter_mut()) {
                if *r == usize::MAX || state(w).0 {
                    if *r != usize::MAX {
                        seen(*r, state(w).1);
                        *r = usize::MAX;
                    }
                    if next == starts.len() {
                        continue;
                    }
                    begin(w, &starts[next]);
                    (*r, next) = (next, next + 1);
                }
                busy = true;
                step(w);
            }
            if !busy {
                return;
            }
        }
    }
    /// Every ray's treelet walk, `N` in turns, reporting to `seen`.
    pub(crate) struct Turns<'a, const N: usize, F> {
        starts: &'a [Start],
        walkers: &'a mut [Seven; N],
        treelets: &'a [Treelet],
        root: u32,
        seen: F,
    }

    impl<'a, const N: usize, F: FnMut(usize, Seen)> Turns<'a, N, F> {
        pub(crate) fn new(
            starts: &'a [Start],
            walkers: &'a mut [Seven; N],
            treelets: &'a [Treelet],
            root: u32,
            seen: F,
        ) -> Self {
            Turns {
                starts,
                walkers,
                treelets,
                root,
                seen,
            }
        }

        /// Runs them, inlined into the level's function below.
        #[inline(always)]
        unsafe fn run<const AVX512: bool>(self) {
            let (ts, root) = (self.treelets, self.root);
            in_turns(
                self.starts,
                self.walkers,
                |w, st| w.start(st, root),
                // SAFETY: the caller's features are the step's.
                |w| unsafe { w.step::<AVX512>(ts) },
                |w| (w.done, w.seen),
                self.seen,
            );
        }
    }

    /// The walks at the AVX-512 level.
    ///
    /// # Safety
    /// The processor has AVX2, AVX-512F and AVX-512VL.
    #[target_feature(enable = "avx2,avx512f,avx512vl,bmi1,lzcnt,popcnt")]
    pub(crate) unsafe fn at_avx512<const N: usize, F: FnMut(usize, Seen)>(t: Turns<'_, N, F>) {
        t.run::<true>();
    }

    /// The walks at the AVX2 level.
    ///
    /// # Safety
    /// The processor has AVX2.
    #[target_feature(enable = "avx2,bmi1,lzcnt,popcnt")]
    pub(crate) unsafe fn at_avx2<const N: usize, F: FnMut(usize, Seen)>(t: Turns<'_, N, F>) {
        t.run::<false>();
    }
}

#[cfg(target_arch = "x86_64")]
fn main() {
    use kdray::kernel::{Bounds, Ray, Triangle};
    use kdray::tools::blob::write_triangle_tree;
    use kdray::tools::builders::{build, BuildParams, BuilderKind};
    use kdray::tools::camera::{random_rays, Camera};
    use kdray::tools::{mesh, scene};
    use std::path::PathBuf;
    use std::time::Instant;
    use walks::*;

    let features = ["avx2", "avx512f", "avx512vl"];
    if !(std::arch::is_x86_feature_detected!("avx2")
        && std::arch::is_x86_feature_detected!("avx512f")
        && std::arch::is_x86_feature_detected!("avx512vl"))
    {
        println!("treelets: skipped, the processor lacks one of {features:?}");
        return;
    }
    let s = scene::teapot_in_stadium();
    let mut scenes: Vec<(String, Vec<Triangle>, Bounds)> =
        vec![("teapot-stadium".into(), s.triangles, s.focus)];
    for name in ["stanford-bunny", "teapot", "sponza"] {
        let path = PathBuf::from(format!(
            "{}/../shared/meshes/{name}.obj",
            env!("CARGO_MANIFEST_DIR")
        ));
        if let Ok(t) = mesh::load(&path) {
            let b = t.iter().fold(Bounds::EMPTY, |b, x| b.union(&x.bounds()));
            scenes.push((name.into(), t, b));
        }
    }
    println!(
        "ns per ray, the walks alone (leaves counted, no triangle tested); best of 7 interleaved"
    );
    for (name, tris, focus) in &scenes {
        let built = build(tris, BuilderKind::default(), &BuildParams::default()).unwrap();
        let blob = write_triangle_tree(&built, tris).expect("the bench tree fits a blob");
        let tree = blob.tree().unwrap();
        let nodes: &[[u32; 2]] = bytemuck::cast_slice(tree.nodes());
        if nodes[0][1] & 3 == 3 {
            continue; // a root leaf: nothing to walk
        }
        let mut ts = Vec::new();
        let root = treelets(nodes, 0, &mut ts);
        let bounds = tree.bounds();
        for (kind, rays) in [
            ("camera", Camera::framing(focus).rays(256, 256)),
            ("random", random_rays(&bounds, 65_536, 1)),
        ] {
            let starts: Vec<Start> = (rays.iter())
                .filter_map(|r: &Ray| Start::new(r, &bounds, tree.closest_hit(r).t))
                .collect();
            let mut want = vec![Seen::default(); starts.len()];
            let mut scalar = Scalar::new();
            for (w, st) in want.iter_mut().zip(&starts) {
                *w = scalar.walk(nodes, st);
            }
            let mut one = [Seven::new()];
            let mut four = [Seven::new(), Seven::new(), Seven::new(), Seven::new()];
            let mut time = [f64::INFINITY; 4];
            for round in 0..7 {
                let check = round == 0;
                let mut got =
                    |i: usize, s: Seen| assert!(!check || s == want[i], "{name} {kind} ray {i}");
                let mut timed = |slot: usize, run: &mut dyn FnMut()| {
                    let t = Instant::now();
                    run();
                    time[slot] = time[slot].min(t.elapsed().as_secs_f64());
                };
                timed(0, &mut || {
                    for st in &starts {
                        std::hint::black_box(scalar.walk(nodes, st));
                    }
                });
                // SAFETY (the three): the features were detected above.
                timed(1, &mut || unsafe {
                    at_avx512(Turns::new(&starts, &mut one, &ts, root, &mut got))
                });
                timed(2, &mut || unsafe {
                    at_avx512(Turns::new(&starts, &mut four, &ts, root, &mut got))
                });
                timed(3, &mut || unsafe {
                    at_avx2(Turns::new(&starts, &mut four, &ts, root, &mut got))
                });
            }
            let n = rays.len() as f64 / 1e9;
            println!(
                "{name:>15} {kind}: scalar {:.1}, treelets alone {:.1} ({:.2}x), four in turns {:.1} ({:.2}x), at AVX2 {:.1} ({:.2}x); {} treelets, {} nodes",
                time[0] / n,
                time[1] / n,
                time[0] / time[1],
                time[2] / n,
                time[0] / time[2],
                time[3] / n,
                time[0] / time[3],
                ts.len(),
                nodes.len()
            );
        }
    }
}

#[cfg(not(target_arch = "x86_64"))]
fn main() {
    println!("treelets: x86-64 only");
}
