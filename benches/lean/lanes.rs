//! The lane arithmetic of the lean packet walk: `N` rays' numbers side by
//! side in one register, masks as bits (lane `l` in bit `l`), by
//! `std::arch` intrinsics: 16 lanes with AVX-512, 8 with AVX2.
//!
//! Tried: plain `[f32; 16]` arrays in loops inlined into an `avx512f`
//! function: 3.3-4.5x slower (bunny tiles 130-180 against 40 ns a ray),
//! because LLVM left the selects, the min / max and the divisions scalar.

use std::arch::x86_64::*;

/// `N` lanes of `f32` and what the walk does with them.
pub(crate) trait Lanes<const N: usize>: Copy {
    /// `x` in every lane.
    fn splat(x: f32) -> Self;
    /// The lanes of an array.
    fn from_array(a: [f32; N]) -> Self;
    /// The lanes as an array.
    fn to_array(self) -> [f32; N];
    /// Lane by lane `self + o`.
    fn add(self, o: Self) -> Self;
    /// Lane by lane `self - o`.
    fn sub(self, o: Self) -> Self;
    /// Lane by lane `self * o`.
    fn mul(self, o: Self) -> Self;
    /// Lane by lane `self / o`.
    fn div(self, o: Self) -> Self;
    /// Lane by lane the smaller (`o` when either is NaN).
    fn min(self, o: Self) -> Self;
    /// Lane by lane the larger (`o` when either is NaN).
    fn max(self, o: Self) -> Self;
    /// Lanes where `self < o`.
    fn lt(self, o: Self) -> u32;
    /// Lanes where `self <= o`.
    fn le(self, o: Self) -> u32;
    /// Lanes where `self != o` (a NaN lane included).
    fn ne(self, o: Self) -> u32;
    /// `a` in the lanes of `m`, `b` elsewhere.
    fn select(m: u32, a: Self, b: Self) -> Self;
}

/// Sixteen lanes in one AVX-512 register.
#[derive(Clone, Copy)]
pub(crate) struct Zmm(__m512);

/// Eight lanes in one AVX2 register.
#[derive(Clone, Copy)]
pub(crate) struct Ymm(__m256);

// SAFETY (every block in the two impls below): a `Zmm` (`Ymm`) is made
// and used only inside functions compiled for `avx512f` (`avx2`) that run
// after `is_x86_feature_detected!` found it, so the instructions exist.

impl Lanes<16> for Zmm {
    #[inline(always)]
    fn splat(x: f32) -> Self {
        // SAFETY: see above.
        unsafe { Zmm(_mm512_set1_ps(x)) }
    }
    #[inline(always)]
    fn from_array(a: [f32; 16]) -> Self {
        // SAFETY: `__m512` is sixteen `f32`s.
        unsafe { Zmm(std::mem::transmute::<[f32; 16], __m512>(a)) }
    }
    #[inline(always)]
    fn to_array(self) -> [f32; 16] {
        // SAFETY: `__m512` is sixteen `f32`s, any bits valid.
        unsafe { std::mem::transmute::<__m512, [f32; 16]>(self.0) }
    }
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        // SAFETY: see above.
        unsafe { Zmm(_mm512_add_ps(self.0, o.0)) }
    }
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        // SAFETY: see above.
        unsafe { Zmm(_mm512_sub_ps(self.0, o.0)) }
    }
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        // SAFETY: see above.
        unsafe { Zmm(_mm512_mul_ps(self.0, o.0)) }
    }
    #[inline(always)]
    fn div(self, o: Self) -> Self {
        // SAFETY: see above.
        unsafe { Zmm(_mm512_div_ps(self.0, o.0)) }
    }
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        // SAFETY: see above.
        unsafe { Zmm(_mm512_min_ps(self.0, o.0)) }
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        // SAFETY: see above.
        unsafe { Zmm(_mm512_max_ps(self.0, o.0)) }
    }
    #[inline(always)]
    fn lt(self, o: Self) -> u32 {
        // SAFETY: see above.
        unsafe { u32::from(_mm512_cmp_ps_mask::<_CMP_LT_OQ>(self.0, o.0)) }
    }
    #[inline(always)]
    fn le(self, o: Self) -> u32 {
        // SAFETY: see above.
        unsafe { u32::from(_mm512_cmp_ps_mask::<_CMP_LE_OQ>(self.0, o.0)) }
    }
    #[inline(always)]
    fn ne(self, o: Self) -> u32 {
        // SAFETY: see above.
        unsafe { u32::from(_mm512_cmp_ps_mask::<_CMP_NEQ_UQ>(self.0, o.0)) }
    }
    #[inline(always)]
    fn select(m: u32, a: Self, b: Self) -> Self {
        // SAFETY: see above.
        unsafe { Zmm(_mm512_mask_blend_ps(m as u16, b.0, a.0)) }
    }
}

impl Ymm {
    /// The lanes where the comparison `C` of `a` and `b` holds.
    #[inline(always)]
    fn cmp<const C: i32>(a: Self, b: Self) -> u32 {
        // SAFETY: see above.
        unsafe { _mm256_movemask_ps(_mm256_cmp_ps::<C>(a.0, b.0)) as u32 }
    }
}

impl Lanes<8> for Ymm {
    #[inline(always)]
    fn splat(x: f32) -> Self {
        // SAFETY: see above.
        unsafe { Ymm(_mm256_set1_ps(x)) }
    }
    #[inline(always)]
    fn from_array(a: [f32; 8]) -> Self {
        // SAFETY: `__m256` is eight `f32`s.
        unsafe { Ymm(std::mem::transmute::<[f32; 8], __m256>(a)) }
    }
    #[inline(always)]
    fn to_array(self) -> [f32; 8] {
        // SAFETY: `__m256` is eight `f32`s, any bits valid.
        unsafe { std::mem::transmute::<__m256, [f32; 8]>(self.0) }
    }
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        // SAFETY: see above.
        unsafe { Ymm(_mm256_add_ps(self.0, o.0)) }
    }
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        // SAFETY: see above.
        unsafe { Ymm(_mm256_sub_ps(self.0, o.0)) }
    }
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        // SAFETY: see above.
        unsafe { Ymm(_mm256_mul_ps(self.0, o.0)) }
    }
    #[inline(always)]
    fn div(self, o: Self) -> Self {
        // SAFETY: see above.
        unsafe { Ymm(_mm256_div_ps(self.0, o.0)) }
    }
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        // SAFETY: see above.
        unsafe { Ymm(_mm256_min_ps(self.0, o.0)) }
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        // SAFETY: see above.
        unsafe { Ymm(_mm256_max_ps(self.0, o.0)) }
    }
    #[inline(always)]
    fn lt(self, o: Self) -> u32 {
        Ymm::cmp::<_CMP_LT_OQ>(self, o)
    }
    #[inline(always)]
    fn le(self, o: Self) -> u32 {
        Ymm::cmp::<_CMP_LE_OQ>(self, o)
    }
    #[inline(always)]
    fn ne(self, o: Self) -> u32 {
        Ymm::cmp::<_CMP_NEQ_UQ>(self, o)
    }
    #[inline(always)]
    fn select(m: u32, a: Self, b: Self) -> Self {
        // SAFETY: see above.
        unsafe {
            // Bit l of `m` spread over lane l.
            let bits = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
            let on = _mm256_cmpeq_epi32(_mm256_and_si256(_mm256_set1_epi32(m as i32), bits), bits);
            Ymm(_mm256_blendv_ps(b.0, a.0, _mm256_castsi256_ps(on)))
        }
    }
}
