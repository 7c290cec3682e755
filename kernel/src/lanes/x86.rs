//! Lane vectors of one AVX register: [`Avx8`] (8 lanes, `__m256`) and
//! [`Avx16`] (16 lanes, AVX-512's `__m512`), for code compiled inside the
//! `#[target_feature]` functions of [`crate::cpu`]'s levels.
//!
//! `wide` picks its representation when the crate is compiled: in a plain
//! x86-64 build its `f32x8` is two SSE registers, whatever function it is
//! used in. These types are one register wherever the level's features
//! are enabled, and each operation is the `wide` one's IEEE operation
//! (the same comparisons, `min`/`max` with the operands in the same
//! order, true division), so every lane computes the same bits.
//!
//! # Safety
//! The intrinsics need AVX (AVX2, AVX-512 F/DQ for [`Avx16`]). A value of
//! these types is only made by code that runs after [`crate::cpu`]
//! detected those features: the generic walks are instantiated with them
//! only in the level's `#[target_feature]` functions (`dispatch.rs`),
//! which the entry points call only at that detected level. Each
//! `unsafe` block below rests on that rule ([`avx!`]).

use super::{ray_floats, Lanes, Real, Span};
use crate::geometry::Ray;
use core::arch::x86_64::*;
use core::ops::{Add, BitAnd, BitOr, Div, Mul, Sub};

/// Runs an intrinsic of the level these types belong to.
macro_rules! avx {
    ($e:expr) => {
        // SAFETY: values of `Avx8`/`Avx16` exist only in code reached
        // after the level's features were detected (module docs).
        unsafe { $e }
    };
}

/// Eight `f32` lanes in one `__m256` (AVX, AVX2).
#[derive(Clone, Copy)]
#[repr(transparent)]
pub(crate) struct Avx8(__m256);

/// Sixteen `f32` lanes in one `__m512` (AVX-512 F, DQ).
#[derive(Clone, Copy)]
#[repr(transparent)]
pub(crate) struct Avx16(__m512);

macro_rules! binop {
    ($t:ident, $tr:ident, $f:ident, $op:ident) => {
        impl $tr for $t {
            type Output = $t;
            #[inline(always)]
            fn $f(self, rhs: $t) -> $t {
                $t(avx!($op(self.0, rhs.0)))
            }
        }
    };
}

binop!(Avx8, Add, add, _mm256_add_ps);
binop!(Avx8, Sub, sub, _mm256_sub_ps);
binop!(Avx8, Mul, mul, _mm256_mul_ps);
binop!(Avx8, Div, div, _mm256_div_ps);
binop!(Avx8, BitAnd, bitand, _mm256_and_ps);
binop!(Avx8, BitOr, bitor, _mm256_or_ps);
binop!(Avx16, Add, add, _mm512_add_ps);
binop!(Avx16, Sub, sub, _mm512_sub_ps);
binop!(Avx16, Mul, mul, _mm512_mul_ps);
binop!(Avx16, Div, div, _mm512_div_ps);
binop!(Avx16, BitAnd, bitand, _mm512_and_ps);
binop!(Avx16, BitOr, bitor, _mm512_or_ps);

// `minps(a, b)` is `a < b ? a : b` (`b` when either is NaN), `maxps`
// likewise: with `rhs` first, the scalar walk's select.
impl Span for Avx8 {
    #[inline(always)]
    fn min(self, rhs: Self) -> Self {
        Avx8(avx!(_mm256_min_ps(rhs.0, self.0)))
    }
    #[inline(always)]
    fn max(self, rhs: Self) -> Self {
        Avx8(avx!(_mm256_max_ps(rhs.0, self.0)))
    }
}

impl Span for Avx16 {
    #[inline(always)]
    fn min(self, rhs: Self) -> Self {
        Avx16(avx!(_mm512_min_ps(rhs.0, self.0)))
    }
    #[inline(always)]
    fn max(self, rhs: Self) -> Self {
        Avx16(avx!(_mm512_max_ps(rhs.0, self.0)))
    }
}

impl Real for Avx8 {
    #[inline(always)]
    fn splat(x: f32) -> Self {
        Avx8(avx!(_mm256_set1_ps(x)))
    }
    #[inline(always)]
    fn abs(self) -> Self {
        let m = avx!(_mm256_castsi256_ps(_mm256_set1_epi32(i32::MAX)));
        Avx8(avx!(_mm256_and_ps(self.0, m)))
    }
}

impl Real for Avx16 {
    #[inline(always)]
    fn splat(x: f32) -> Self {
        Avx16(avx!(_mm512_set1_ps(x)))
    }
    #[inline(always)]
    fn abs(self) -> Self {
        let m = avx!(_mm512_castsi512_ps(_mm512_set1_epi32(i32::MAX)));
        Avx16(avx!(_mm512_and_ps(self.0, m)))
    }
}

/// An 8x8 transpose: row `r`, lane `c` to row `c`, lane `r`.
#[inline(always)]
fn transpose8(r: [__m256; 8]) -> [__m256; 8] {
    avx!({
        let t0 = _mm256_unpacklo_ps(r[0], r[1]);
        let t1 = _mm256_unpackhi_ps(r[0], r[1]);
        let t2 = _mm256_unpacklo_ps(r[2], r[3]);
        let t3 = _mm256_unpackhi_ps(r[2], r[3]);
        let t4 = _mm256_unpacklo_ps(r[4], r[5]);
        let t5 = _mm256_unpackhi_ps(r[4], r[5]);
        let t6 = _mm256_unpacklo_ps(r[6], r[7]);
        let t7 = _mm256_unpackhi_ps(r[6], r[7]);
        let s0 = _mm256_shuffle_ps::<0x44>(t0, t2);
        let s1 = _mm256_shuffle_ps::<0xEE>(t0, t2);
        let s2 = _mm256_shuffle_ps::<0x44>(t1, t3);
        let s3 = _mm256_shuffle_ps::<0xEE>(t1, t3);
        let s4 = _mm256_shuffle_ps::<0x44>(t4, t6);
        let s5 = _mm256_shuffle_ps::<0xEE>(t4, t6);
        let s6 = _mm256_shuffle_ps::<0x44>(t5, t7);
        let s7 = _mm256_shuffle_ps::<0xEE>(t5, t7);
        [
            _mm256_permute2f128_ps::<0x20>(s0, s4),
            _mm256_permute2f128_ps::<0x20>(s1, s5),
            _mm256_permute2f128_ps::<0x20>(s2, s6),
            _mm256_permute2f128_ps::<0x20>(s3, s7),
            _mm256_permute2f128_ps::<0x31>(s0, s4),
            _mm256_permute2f128_ps::<0x31>(s1, s5),
            _mm256_permute2f128_ps::<0x31>(s2, s6),
            _mm256_permute2f128_ps::<0x31>(s3, s7),
        ]
    })
}

/// [`Lanes::columns`] for 8 lanes: a ray is 8 floats, so an 8x8 transpose.
#[inline(always)]
fn columns8(rays: &[Ray]) -> [Avx8; 8] {
    // No closures around the intrinsics (`dispatch.rs`).
    #[inline(always)]
    fn row(rays: &[Ray], l: usize) -> __m256 {
        Avx8::from_array(ray_floats(rays, l)).0
    }
    let mut rows = [avx!(_mm256_setzero_ps()); 8];
    for (l, r) in rows.iter_mut().enumerate() {
        *r = row(rays, l);
    }
    transposed(rows)
}

/// Eight rows of eight floats as eight lane vectors, row `r` in lane `r`.
#[inline(always)]
fn transposed(rows: [__m256; 8]) -> [Avx8; 8] {
    transpose8(rows).map(Avx8)
}

/// [`Lanes::nine_rows`] for 8 lanes: each record's first eight floats
/// loaded as one row and the rows transposed in registers, the ninth
/// floats put together from scalars. The default's 72 scalar stores,
/// read back as vectors, stall each vector load until the stores reach
/// the cache (a store cannot forward to a wider load).
#[inline(always)]
fn nine_rows8(items: &[[f32; 9]], at: &[u32], skip: u32) -> ([Avx8; 9], u32) {
    // Lanes not live read a zero record.
    const NONE: [f32; 9] = [0.0; 9];
    let mut live = 0u32;
    let mut rec = [&NONE; 8];
    for (l, (r, &p)) in rec.iter_mut().zip(at).enumerate() {
        if let Some(item) = items.get(p as usize).filter(|_| p != skip) {
            *r = item;
            live |= 1 << l;
        }
    }
    // SAFETY (besides `avx!`'s): each record is 36 readable bytes, and a
    // row reads its first 32.
    #[inline(always)]
    fn row(x: &[f32; 9]) -> __m256 {
        avx!(_mm256_loadu_ps(x.as_ptr()))
    }
    let mut rows = [avx!(_mm256_setzero_ps()); 8];
    for (r, x) in rows.iter_mut().zip(rec) {
        *r = row(x);
    }
    let [r0, r1, r2, r3, r4, r5, r6, r7] = transposed(rows);
    let ninth = avx!(_mm256_setr_ps(
        rec[0][8], rec[1][8], rec[2][8], rec[3][8], rec[4][8], rec[5][8], rec[6][8], rec[7][8],
    ));
    ([r0, r1, r2, r3, r4, r5, r6, r7, Avx8(ninth)], live)
}

impl Lanes<8> for Avx8 {
    // Both levels that make `Avx8` values include AVX2.
    const AVX2: bool = true;
    #[inline(always)]
    fn nine_rows(items: &[[f32; 9]], at: &[u32], skip: u32) -> ([Self; 9], u32) {
        nine_rows8(items, at, skip)
    }
    #[inline(always)]
    fn from_array(a: [f32; 8]) -> Self {
        // SAFETY (besides `avx!`'s): an `[f32; 8]` is 32 readable bytes.
        Avx8(avx!(_mm256_loadu_ps(a.as_ptr())))
    }
    #[inline(always)]
    fn to_array(self) -> [f32; 8] {
        bytemuck::cast(avx!(core::mem::transmute::<__m256, [u32; 8]>(self.0)))
    }
    #[inline(always)]
    fn lane(&self, l: usize) -> f32 {
        self.to_array().get(l).copied().unwrap_or(f32::NAN)
    }
    #[inline(always)]
    fn columns(rays: &[Ray]) -> [Self; 8] {
        columns8(rays)
    }
    #[inline(always)]
    fn records(cols: [Self; 4]) -> [[f32; 4]; 8] {
        // Four more (unused) columns make it the 8x8 transpose; row `l`'s
        // first four floats are lane `l`'s record.
        let z = avx!(_mm256_setzero_ps());
        let rows = transpose8([cols[0].0, cols[1].0, cols[2].0, cols[3].0, z, z, z, z]);
        rows.map(|r| {
            let [a, b, c, d, ..] = Avx8(r).to_array();
            [a, b, c, d]
        })
    }
    #[inline(always)]
    fn lt(self, rhs: Self) -> u32 {
        self.lt_mask(rhs).bits()
    }
    #[inline(always)]
    fn gt(self, rhs: Self) -> u32 {
        self.gt_mask(rhs).bits()
    }
    #[inline(always)]
    fn le(self, rhs: Self) -> u32 {
        self.le_mask(rhs).bits()
    }
    #[inline(always)]
    fn lt_mask(self, rhs: Self) -> Self {
        Avx8(avx!(_mm256_cmp_ps::<_CMP_LT_OQ>(self.0, rhs.0)))
    }
    #[inline(always)]
    fn gt_mask(self, rhs: Self) -> Self {
        Avx8(avx!(_mm256_cmp_ps::<_CMP_GT_OQ>(self.0, rhs.0)))
    }
    #[inline(always)]
    fn le_mask(self, rhs: Self) -> Self {
        Avx8(avx!(_mm256_cmp_ps::<_CMP_LE_OQ>(self.0, rhs.0)))
    }
    #[inline(always)]
    fn ge_mask(self, rhs: Self) -> Self {
        Avx8(avx!(_mm256_cmp_ps::<_CMP_GE_OQ>(self.0, rhs.0)))
    }
    #[inline(always)]
    fn eq_mask(self, rhs: Self) -> Self {
        Avx8(avx!(_mm256_cmp_ps::<_CMP_EQ_OQ>(self.0, rhs.0)))
    }
    #[inline(always)]
    fn bits(self) -> u32 {
        avx!(_mm256_movemask_ps(self.0)) as u32
    }
    #[inline(always)]
    fn select(mask: Self, if_true: Self, if_false: Self) -> Self {
        Avx8(avx!(_mm256_blendv_ps(if_false.0, if_true.0, mask.0)))
    }
    #[inline(always)]
    fn mask(bits: u32) -> Self {
        // Lane l tests bit l of a splat.
        avx!({
            let bit = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
            let b = _mm256_and_si256(_mm256_set1_epi32(bits as i32), bit);
            Avx8(_mm256_castsi256_ps(_mm256_cmpeq_epi32(b, bit)))
        })
    }
}

impl Avx16 {
    /// The lanes set in a `__mmask16` as a lane mask.
    #[inline(always)]
    fn of_kmask(k: __mmask16) -> Self {
        Avx16(avx!(_mm512_castsi512_ps(_mm512_movm_epi32(k))))
    }

    /// Lanes `0..8` and `8..16` from two 8-lane vectors.
    #[inline(always)]
    fn join(lo: __m256, hi: __m256) -> Self {
        Avx16(avx!(_mm512_insertf32x8::<1>(
            _mm512_castps256_ps512(lo),
            hi
        )))
    }

    /// Lanes `8 h..8 h + 8`.
    #[inline(always)]
    fn half<const H: i32>(self) -> Avx8 {
        Avx8(avx!(_mm512_extractf32x8_ps::<H>(self.0)))
    }
}

impl Lanes<16> for Avx16 {
    // The AVX-512 level includes AVX2.
    const AVX2: bool = true;
    #[inline(always)]
    fn from_array(a: [f32; 16]) -> Self {
        // SAFETY (besides `avx!`'s): an `[f32; 16]` is 64 readable bytes.
        Avx16(avx!(_mm512_loadu_ps(a.as_ptr())))
    }
    #[inline(always)]
    fn to_array(self) -> [f32; 16] {
        bytemuck::cast(avx!(core::mem::transmute::<__m512, [u32; 16]>(self.0)))
    }
    #[inline(always)]
    fn lane(&self, l: usize) -> f32 {
        self.to_array().get(l).copied().unwrap_or(f32::NAN)
    }
    #[inline(always)]
    fn columns(rays: &[Ray]) -> [Self; 8] {
        let (lo, hi) = rays.split_at(rays.len().min(8));
        let (a, b) = (columns8(lo), columns8(hi));
        let j = Avx16::join;
        [
            j(a[0].0, b[0].0),
            j(a[1].0, b[1].0),
            j(a[2].0, b[2].0),
            j(a[3].0, b[3].0),
            j(a[4].0, b[4].0),
            j(a[5].0, b[5].0),
            j(a[6].0, b[6].0),
            j(a[7].0, b[7].0),
        ]
    }
    #[inline(always)]
    fn records(cols: [Self; 4]) -> [[f32; 4]; 16] {
        let [a, b, c, d] = cols;
        let lo = Avx8::records([a.half::<0>(), b.half::<0>(), c.half::<0>(), d.half::<0>()]);
        let hi = Avx8::records([a.half::<1>(), b.half::<1>(), c.half::<1>(), d.half::<1>()]);
        bytemuck::cast([lo, hi])
    }
    #[inline(always)]
    fn lt(self, rhs: Self) -> u32 {
        u32::from(avx!(_mm512_cmp_ps_mask::<_CMP_LT_OQ>(self.0, rhs.0)))
    }
    #[inline(always)]
    fn gt(self, rhs: Self) -> u32 {
        u32::from(avx!(_mm512_cmp_ps_mask::<_CMP_GT_OQ>(self.0, rhs.0)))
    }
    #[inline(always)]
    fn le(self, rhs: Self) -> u32 {
        u32::from(avx!(_mm512_cmp_ps_mask::<_CMP_LE_OQ>(self.0, rhs.0)))
    }
    #[inline(always)]
    fn lt_mask(self, rhs: Self) -> Self {
        Avx16::of_kmask(avx!(_mm512_cmp_ps_mask::<_CMP_LT_OQ>(self.0, rhs.0)))
    }
    #[inline(always)]
    fn gt_mask(self, rhs: Self) -> Self {
        Avx16::of_kmask(avx!(_mm512_cmp_ps_mask::<_CMP_GT_OQ>(self.0, rhs.0)))
    }
    #[inline(always)]
    fn le_mask(self, rhs: Self) -> Self {
        Avx16::of_kmask(avx!(_mm512_cmp_ps_mask::<_CMP_LE_OQ>(self.0, rhs.0)))
    }
    #[inline(always)]
    fn ge_mask(self, rhs: Self) -> Self {
        Avx16::of_kmask(avx!(_mm512_cmp_ps_mask::<_CMP_GE_OQ>(self.0, rhs.0)))
    }
    #[inline(always)]
    fn eq_mask(self, rhs: Self) -> Self {
        Avx16::of_kmask(avx!(_mm512_cmp_ps_mask::<_CMP_EQ_OQ>(self.0, rhs.0)))
    }
    #[inline(always)]
    fn bits(self) -> u32 {
        u32::from(avx!(_mm512_movepi32_mask(_mm512_castps_si512(self.0))))
    }
    #[inline(always)]
    fn select(mask: Self, if_true: Self, if_false: Self) -> Self {
        let k = avx!(_mm512_movepi32_mask(_mm512_castps_si512(mask.0)));
        Avx16(avx!(_mm512_mask_blend_ps(k, if_false.0, if_true.0)))
    }
    #[inline(always)]
    fn mask(bits: u32) -> Self {
        Avx16::of_kmask(bits as __mmask16)
    }
}
