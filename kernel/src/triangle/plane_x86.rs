//! [`plane_t`](super::plane_t) in AVX2 registers, for code compiled
//! inside the AVX2 and AVX-512 levels' `#[target_feature]` functions
//! ([`crate::lanes::dispatch`]): the three coordinates of each vector in
//! the lanes of one register (the fourth lane unused), so the cross
//! product, the normal's magnitudes and the four dot products (`n·d`,
//! `n·a` and their zero thresholds) are a few vector operations instead of
//! the scalar code's shuffles between pairs.
//!
//! Each lane performs the scalar operation on the scalar operands (no
//! fused multiply-add, the sums in the scalar order `(x + y) + z`, `min`
//! and `max` as the scalar compare-and-select), so the result is
//! [`plane_t`](super::plane_t)'s bits; the plane test's verdicts and the
//! division are taken in scalar code, and the rare box clamp is the
//! scalar [`box_clamp`](super::box_clamp).

use super::{box_clamp, Triangle, BOX_INSIDE, PLANE_NOISE};
use core::arch::x86_64::*;

/// [`plane_t`](super::plane_t), bit for bit.
///
/// # Safety
/// The CPU must support AVX2 (callers: the lane types of the AVX2 and
/// AVX-512 levels, which exist only in code run after those features were
/// detected, `crate::lanes::x86`).
#[inline(always)]
pub(crate) unsafe fn plane_t(org: &[f32; 3], dir: &[f32; 3], tri: &Triangle) -> f32 {
    // The nine coordinates are 36 contiguous bytes (`repr(C)`): each
    // vertex read as 4 floats within them (vertex 2 from one float early,
    // moved down a lane).
    let p = tri.v.as_ptr().cast::<f32>();
    // SAFETY: AVX2 by the caller; the reads are floats 0-3, 3-6 and 5-8
    // of the triangle's 9.
    let (v0, v1, v2) = unsafe {
        (
            _mm_loadu_ps(p),
            _mm_loadu_ps(p.add(3)),
            _mm_permute_ps::<0b11_11_10_01>(_mm_loadu_ps(p.add(5))),
        )
    };
    // SAFETY: AVX2 by the caller (every intrinsic below).
    let (o, d) = unsafe {
        (
            _mm_set_ps(0.0, org[2], org[1], org[0]),
            _mm_set_ps(0.0, dir[2], dir[1], dir[0]),
        )
    };
    // SAFETY: as above.
    let (den, num, den_bound, num_bound) = unsafe { dot_products(v0, v1, v2, o, d) };
    // [`Plane::ray_t`](super::Plane)'s verdicts, in its order.
    let plane = den.abs() > den_bound;
    let on_plane = num.abs() <= num_bound;
    let q = num / den;
    let t = if on_plane { 0.0 } else { q };
    if !plane {
        return f32::NAN;
    }
    // SAFETY: as above.
    if unsafe { hit_inside_box(t, v0, v1, v2, o, d) } {
        return t as f32;
    }
    box_clamp(t, tri, org, dir)
}

/// `(n·d, n·a, PLANE_NOISE · m·|d|, PLANE_NOISE · m·|a|)` for the
/// vertices `v0, v1, v2`, origin `o` and direction `d` (lanes x, y, z):
/// `n = e1 × e2`, `m` its [`normal_magnitudes`](super::normal_magnitudes),
/// `a = v0 - o`, every sum `(x + y) + z`.
///
/// # Safety
/// The CPU must support AVX2.
#[inline(always)]
unsafe fn dot_products(
    v0: __m128,
    v1: __m128,
    v2: __m128,
    o: __m128,
    d: __m128,
) -> (f64, f64, f64, f64) {
    // SAFETY: AVX2 by the caller.
    unsafe {
        let (v0, v1, v2) = (
            _mm256_cvtps_pd(v0),
            _mm256_cvtps_pd(v1),
            _mm256_cvtps_pd(v2),
        );
        let (o, d) = (_mm256_cvtps_pd(o), _mm256_cvtps_pd(d));
        let e1 = _mm256_sub_pd(v1, v0);
        let e2 = _mm256_sub_pd(v2, v0);
        let a = _mm256_sub_pd(v0, o);
        // (y, z, x) and (z, x, y) of each edge.
        const YZX: i32 = 0b11_00_10_01;
        const ZXY: i32 = 0b11_01_00_10;
        // (e1y e2z, e1z e2x, e1x e2y) and (e1z e2y, e1x e2z, e1y e2x).
        let pr = _mm256_mul_pd(
            _mm256_permute4x64_pd::<YZX>(e1),
            _mm256_permute4x64_pd::<ZXY>(e2),
        );
        let qr = _mm256_mul_pd(
            _mm256_permute4x64_pd::<ZXY>(e1),
            _mm256_permute4x64_pd::<YZX>(e2),
        );
        let n = _mm256_sub_pd(pr, qr);
        let sign = _mm256_set1_pd(-0.0);
        let abs = |x| _mm256_andnot_pd(sign, x);
        let m = _mm256_add_pd(abs(pr), abs(qr));
        let (nd, na) = (_mm256_mul_pd(n, d), _mm256_mul_pd(n, a));
        let (md, ma) = (_mm256_mul_pd(m, abs(d)), _mm256_mul_pd(m, abs(a)));
        // Transposed to (nd, na, md, ma) per axis, then summed x + y + z.
        let (lo, hi) = (_mm256_unpacklo_pd(nd, na), _mm256_unpackhi_pd(nd, na));
        let (lo2, hi2) = (_mm256_unpacklo_pd(md, ma), _mm256_unpackhi_pd(md, ma));
        let x = _mm256_permute2f128_pd::<0x20>(lo, lo2);
        let y = _mm256_permute2f128_pd::<0x20>(hi, hi2);
        let z = _mm256_permute2f128_pd::<0x31>(lo, lo2);
        let sum = _mm256_add_pd(_mm256_add_pd(x, y), z);
        let dots = _mm256_castpd256_pd128(sum);
        let bounds = _mm_mul_pd(_mm_set1_pd(PLANE_NOISE), _mm256_extractf128_pd::<1>(sum));
        (
            _mm_cvtsd_f64(dots),
            _mm_cvtsd_f64(_mm_unpackhi_pd(dots, dots)),
            _mm_cvtsd_f64(bounds),
            _mm_cvtsd_f64(_mm_unpackhi_pd(bounds, bounds)),
        )
    }
}

/// [`hit_inside_box`](super::hit_inside_box) with the three axes in the
/// lanes of one register (the vertices, origin and direction as loaded
/// by [`plane_t`]).
///
/// # Safety
/// The CPU must support AVX2.
#[inline(always)]
unsafe fn hit_inside_box(t: f64, v0: __m128, v1: __m128, v2: __m128, o: __m128, d: __m128) -> bool {
    let t32 = t as f32;
    let normal = t.is_finite() & ((t == 0.0) | (t32.abs() >= f32::MIN_POSITIVE));
    // SAFETY: AVX2 by the caller.
    let inside = unsafe {
        // `minps`/`maxps` are the scalar code's `if a < b { a } else { b }`
        // and `if a > b { a } else { b }`, operands in its order.
        let lo = _mm_min_ps(_mm_min_ps(v0, v1), v2);
        let hi = _mm_max_ps(_mm_max_ps(v0, v1), v2);
        let sign = _mm_set1_ps(-0.0);
        let abs = |x| _mm_andnot_ps(sign, x);
        let k = _mm_set1_ps(BOX_INSIDE);
        let x = _mm_add_ps(o, _mm_mul_ps(_mm_set1_ps(t32), d));
        let mo = _mm_mul_ps(k, abs(o));
        let lo = _mm_sub_ps(lo, _mm_add_ps(_mm_mul_ps(k, abs(lo)), mo));
        let hi = _mm_add_ps(hi, _mm_add_ps(_mm_mul_ps(k, abs(hi)), mo));
        let inside = _mm_and_ps(_mm_cmpgt_ps(x, lo), _mm_cmplt_ps(x, hi));
        _mm_movemask_ps(inside) & 0b111 == 0b111
    };
    normal & inside
}
