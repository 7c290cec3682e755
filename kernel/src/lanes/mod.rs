//! The few lane operations the packet and leaf code needs, over `wide`'s
//! `f32x4`, `f32x8` and `f32x16`, so one generic walk serves every width.
//!
//! Only exact IEEE operations are exposed: `+ - * /` (true division, never
//! `recip`), `abs`, comparisons, and the scalar walk's `min`/`max`
//! selects ([`Span`]: `rhs` where it is smaller/larger, else `self`, so a
//! NaN `rhs` keeps `self`). No fused multiply-add: each lane rounds
//! exactly where the scalar code does. Masks are lane vectors with all
//! bits set or clear, as `wide` returns them, combined with `&` and `|`;
//! control flow reads them as bitmasks (bit `l` = lane `l`), one per
//! decision.

mod dispatch;
mod span;
#[cfg(target_arch = "x86_64")]
mod x86;

pub(crate) use dispatch::{dispatch, Job, Level};
pub(crate) use span::Span;

use crate::geometry::Ray;
use core::ops::{BitAnd, BitOr, Div, Mul};

/// The arithmetic the triangle test's `t` window shares between `f32` and
/// lane vectors (one generic body, the same operations in one order).
pub(crate) trait Real: Span + Mul<Output = Self> + Div<Output = Self> {
    /// `x` (in every lane).
    fn splat(x: f32) -> Self;
    /// `|x|` (in every lane; the sign bit cleared, as `f32::abs`).
    fn abs(self) -> Self;
}

impl Real for f32 {
    #[inline(always)]
    fn splat(x: f32) -> f32 {
        x
    }
    #[inline(always)]
    fn abs(self) -> f32 {
        f32::abs(self)
    }
}
use wide::{f32x16, f32x4, f32x8, i32x16, i32x4, i32x8};

/// A vector of `N` `f32` lanes.
/// `splat` and `abs` come from [`Real`].
pub(crate) trait Lanes<const N: usize>:
    Real + BitAnd<Output = Self> + BitOr<Output = Self>
{
    fn from_array(a: [f32; N]) -> Self;
    fn to_array(self) -> [f32; N];
    /// Lane `l`, read in place (NaN for `l >= N`).
    fn lane(&self, l: usize) -> f32;
    /// `N` rays (zero rays past the end of `rays`) as the columns
    /// `[origin x, y, z, tmin, dir x, y, z, tmax]`: a transpose in
    /// registers, not `N` scalar stores reloaded as vectors.
    fn columns(rays: &[Ray]) -> [Self; 8];
    /// Four columns as `N` rows of 4 floats (a transpose in registers):
    /// `[t, prim, u, v]` lanes into hit records.
    fn records(cols: [Self; 4]) -> [[f32; 4]; N];
    /// Lanes where `self < rhs`, as a bitmask.
    fn lt(self, rhs: Self) -> u32;
    /// Lanes where `self > rhs`, as a bitmask.
    fn gt(self, rhs: Self) -> u32;
    /// Lanes where `self <= rhs`, as a bitmask.
    fn le(self, rhs: Self) -> u32;
    /// Lanes where `self < rhs`, as a lane mask (combine masks with `&`
    /// and `|`, then take one [`Lanes::bits`]).
    fn lt_mask(self, rhs: Self) -> Self;
    /// Lanes where `self > rhs`, as a lane mask.
    fn gt_mask(self, rhs: Self) -> Self;
    /// Lanes where `self <= rhs`, as a lane mask.
    fn le_mask(self, rhs: Self) -> Self;
    /// Lanes where `self >= rhs`, as a lane mask.
    fn ge_mask(self, rhs: Self) -> Self;
    /// Lanes where `self == rhs`, as a lane mask.
    fn eq_mask(self, rhs: Self) -> Self;
    /// Each lane's sign bit, as a bitmask: for a lane mask, its lanes.
    fn bits(self) -> u32;
    /// `if_true` where `mask` (a lane mask from [`Lanes::mask`]) is set.
    fn select(mask: Self, if_true: Self, if_false: Self) -> Self;
    /// The lane mask of a bitmask.
    fn mask(bits: u32) -> Self;
    /// Up to `N` records of nine floats (a triangle's three vertices),
    /// `items[at[l]]` in lane `l` wherever `at[l]` is in range and not
    /// `skip`, as nine vectors (float `f` of every record in vector `f`),
    /// with the bitmask of those lanes (the others hold anything).
    #[inline(always)]
    fn nine_rows(items: &[[f32; 9]], at: &[u32], skip: u32) -> ([Self; 9], u32) {
        let mut rows = [[0.0f32; N]; 9];
        let mut live = 0u32;
        for (l, &p) in at.iter().enumerate() {
            let Some(item) = items.get(p as usize).filter(|_| p != skip) else {
                continue;
            };
            // `at` holds at most N: `l % N` is `l`, and proves it.
            let l = l % N;
            live |= 1 << l;
            for (row, &x) in rows.iter_mut().zip(item) {
                row[l] = x;
            }
        }
        (rows.map(Self::from_array), live)
    }
    /// Whether values of this type exist only in code run after AVX2 was
    /// detected (the AVX2 and AVX-512 levels' types), so that code
    /// generic over it may use AVX2 (the triangle's `plane_t`).
    const AVX2: bool = false;
}

macro_rules! impl_lanes {
    ($v:ident, $i:ty, $n:literal, $columns:ident, $records:ident) => {
        /// The scalar `Span`'s selects lane by lane: `rhs` where it is
        /// smaller (larger), else `self`, so a NaN `rhs` keeps `self`. One
        /// `vminps`/`vmaxps` with the operands swapped (it returns its
        /// second operand unless the first is smaller/larger), not
        /// `wide`'s NaN-fixing three-instruction `min`/`max`.
        impl Span for $v {
            #[inline(always)]
            fn min(self, rhs: Self) -> Self {
                rhs.fast_min(self)
            }
            #[inline(always)]
            fn max(self, rhs: Self) -> Self {
                rhs.fast_max(self)
            }
        }

        impl Real for $v {
            #[inline(always)]
            fn splat(x: f32) -> Self {
                <$v>::splat(x)
            }
            #[inline(always)]
            fn abs(self) -> Self {
                <$v>::abs(self)
            }
        }

        impl Lanes<$n> for $v {
            #[inline(always)]
            fn from_array(a: [f32; $n]) -> Self {
                <$v>::new(a)
            }
            #[inline(always)]
            fn to_array(self) -> [f32; $n] {
                <$v>::to_array(self)
            }
            #[inline(always)]
            fn lane(&self, l: usize) -> f32 {
                self.as_array().get(l).copied().unwrap_or(f32::NAN)
            }
            #[inline(always)]
            fn columns(rays: &[Ray]) -> [Self; 8] {
                $columns(rays)
            }
            #[inline(always)]
            fn records(cols: [Self; 4]) -> [[f32; 4]; $n] {
                $records(cols)
            }
            #[inline(always)]
            fn lt(self, rhs: Self) -> u32 {
                self.simd_lt(rhs).to_bitmask()
            }
            #[inline(always)]
            fn gt(self, rhs: Self) -> u32 {
                self.simd_gt(rhs).to_bitmask()
            }
            #[inline(always)]
            fn le(self, rhs: Self) -> u32 {
                self.simd_le(rhs).to_bitmask()
            }
            #[inline(always)]
            fn lt_mask(self, rhs: Self) -> Self {
                self.simd_lt(rhs)
            }
            #[inline(always)]
            fn gt_mask(self, rhs: Self) -> Self {
                self.simd_gt(rhs)
            }
            #[inline(always)]
            fn le_mask(self, rhs: Self) -> Self {
                self.simd_le(rhs)
            }
            #[inline(always)]
            fn ge_mask(self, rhs: Self) -> Self {
                self.simd_ge(rhs)
            }
            #[inline(always)]
            fn eq_mask(self, rhs: Self) -> Self {
                self.simd_eq(rhs)
            }
            #[inline(always)]
            fn bits(self) -> u32 {
                self.to_bitmask()
            }
            #[inline(always)]
            fn select(mask: Self, if_true: Self, if_false: Self) -> Self {
                mask.select(if_true, if_false)
            }
            #[inline(always)]
            fn mask(bits: u32) -> Self {
                // Lane l tests bit l of a splat: three instructions.
                let bit = <$i>::new(core::array::from_fn(|l| 1 << l));
                let bits = <$i>::splat(bits as i32) & bit;
                bytemuck::cast(bits.simd_eq(bit))
            }
        }
    };
}

/// Hints the cache to fetch the line holding `p` (any address: a hint
/// reads nothing the program sees and never faults). A no-op off x86-64
/// and under Miri.
#[inline(always)]
pub(crate) fn prefetch<T>(p: *const T) {
    #[cfg(all(target_arch = "x86_64", not(miri)))]
    // SAFETY: a prefetch only hints the cache: it reads nothing the
    // program sees and never faults, for any address.
    unsafe {
        use core::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        _mm_prefetch::<_MM_HINT_T0>(p.cast());
    }
    #[cfg(not(all(target_arch = "x86_64", not(miri))))]
    let _ = p;
}

/// Ray `l` of `rays` as its 8 floats (zeros past the end).
#[inline(always)]
fn ray_floats(rays: &[Ray], l: usize) -> [f32; 8] {
    rays.get(l).map_or([0.0; 8], |r| bytemuck::cast(*r))
}

/// [`Lanes::columns`] for 8 lanes: a ray is 8 floats, so an 8x8 transpose.
#[inline(always)]
fn columns8(rays: &[Ray]) -> [f32x8; 8] {
    f32x8::transpose(core::array::from_fn(|l| f32x8::new(ray_floats(rays, l))))
}

/// [`Lanes::columns`] for 4 lanes: two 4x4 transposes (origin and tmin,
/// dir and tmax).
#[inline(always)]
fn columns4(rays: &[Ray]) -> [f32x4; 8] {
    let half = |h: usize| {
        f32x4::transpose(core::array::from_fn(|l| {
            let [a, b]: [[f32; 4]; 2] = bytemuck::cast(ray_floats(rays, l));
            f32x4::new(if h == 0 { a } else { b })
        }))
    };
    let ([ox, oy, oz, tmin], [dx, dy, dz, tmax]) = (half(0), half(1));
    [ox, oy, oz, tmin, dx, dy, dz, tmax]
}

/// [`Lanes::records`] for 4 lanes: one 4x4 transpose.
#[inline(always)]
fn records4(cols: [f32x4; 4]) -> [[f32; 4]; 4] {
    f32x4::transpose(cols).map(f32x4::to_array)
}

/// [`Lanes::records`] for 8 lanes: 4x4 transposes of the low and the
/// high halves.
#[inline(always)]
fn records8(cols: [f32x8; 4]) -> [[f32; 4]; 8] {
    let halves: [[[f32; 4]; 2]; 4] = cols.map(|c| bytemuck::cast(c.to_array()));
    let half = |h: usize| records4(halves.map(|c| f32x4::new(c[h])));
    bytemuck::cast([half(0), half(1)])
}

/// [`Lanes::columns`] for 16 lanes: two 8x8 transposes, joined.
#[inline(always)]
fn columns16(rays: &[Ray]) -> [f32x16; 8] {
    let (lo, hi) = rays.split_at(rays.len().min(8));
    let (a, b) = (columns8(lo), columns8(hi));
    core::array::from_fn(|c| {
        let halves: [f32; 16] = bytemuck::cast([a[c].to_array(), b[c].to_array()]);
        f32x16::new(halves)
    })
}

/// [`Lanes::records`] for 16 lanes: [`records8`] of the two halves.
#[inline(always)]
fn records16(cols: [f32x16; 4]) -> [[f32; 4]; 16] {
    let halves: [[[f32; 8]; 2]; 4] = cols.map(|c| bytemuck::cast(c.to_array()));
    let half = |h: usize| records8(halves.map(|c| f32x8::new(c[h])));
    bytemuck::cast([half(0), half(1)])
}

impl_lanes!(f32x4, i32x4, 4, columns4, records4);
impl_lanes!(f32x8, i32x8, 8, columns8, records8);
impl_lanes!(f32x16, i32x16, 16, columns16, records16);

#[cfg(test)]
mod tests {
    use super::*;

    const SPECIAL: [f32; 8] = [
        f32::NAN,
        f32::INFINITY,
        f32::NEG_INFINITY,
        -0.0,
        0.0,
        f32::MAX,
        f32::MIN_POSITIVE / 4.0,
        -1.5,
    ];

    fn check<V: Lanes<8>>() {
        // Every pair of special values, lane by lane, against the scalar op.
        for a in SPECIAL {
            let va = V::splat(a);
            let vb = V::from_array(SPECIAL);
            // Bits, with every NaN alike: NaN payloads may differ between
            // a const-folded scalar op and the hardware, and no NaN ever
            // reaches a hit record (it fails the `t` range test).
            let canon = |x: f32| if x.is_nan() { u32::MAX } else { x.to_bits() };
            let r = |v: V| v.to_array().map(canon);
            let s = |f: fn(f32, f32) -> f32| SPECIAL.map(|b| canon(f(a, b)));
            assert_eq!(r(va + vb), s(|x, y| x + y));
            assert_eq!(r(va - vb), s(|x, y| x - y));
            assert_eq!(r(va * vb), s(|x, y| x * y));
            assert_eq!(r(va / vb), s(|x, y| x / y));
            let bits = |f: fn(f32, f32) -> bool| {
                (0..8).fold(0, |m, l| m | (u32::from(f(a, SPECIAL[l])) << l))
            };
            assert_eq!(va.lt(vb), bits(|x, y| x < y));
            assert_eq!(va.gt(vb), bits(|x, y| x > y));
            assert_eq!(va.le(vb), bits(|x, y| x <= y));
            assert_eq!(va.ge_mask(vb).bits(), bits(|x, y| x >= y));
            assert_eq!(va.eq_mask(vb).bits(), bits(|x, y| x == y));
            assert_eq!(va.lt_mask(vb).bits(), va.lt(vb));
            assert_eq!(va.gt_mask(vb).bits(), va.gt(vb));
            assert_eq!(va.le_mask(vb).bits(), va.le(vb));
            // `|x| < inf`, the lanes' finiteness test.
            let inf = V::splat(f32::INFINITY);
            assert_eq!(vb.abs().lt_mask(inf).bits(), bits(|_, y| y.is_finite()));
            // min/max are the scalar walk's selects, bit for bit (signed
            // zeros and NaNs included).
            let raw = |v: V| v.to_array().map(f32::to_bits);
            let scalar = |f: fn(f32, f32) -> f32| SPECIAL.map(|b| f(a, b).to_bits());
            assert_eq!(raw(Span::min(va, vb)), scalar(<f32 as Span>::min));
            assert_eq!(raw(Span::max(va, vb)), scalar(<f32 as Span>::max));
        }
        let m = V::mask(0b1010_0110);
        let pick = V::select(m, V::splat(1.0), V::splat(2.0)).to_array();
        assert_eq!(pick, [2.0, 1.0, 1.0, 2.0, 2.0, 1.0, 2.0, 1.0]);
    }

    /// Rays `l = 0..n`, field `f` of ray `l` = `10 l + f`, as columns.
    fn columns_of<V: Lanes<N>, const N: usize>(n: usize) -> [[f32; N]; 8] {
        let rays: [Ray; N] = core::array::from_fn(|l| {
            bytemuck::cast(core::array::from_fn::<f32, 8, _>(|f| (10 * l + f) as f32))
        });
        V::columns(&rays[..n]).map(V::to_array)
    }

    #[test]
    fn columns_transpose_rays_and_zero_missing_lanes() {
        fn check<V: Lanes<N>, const N: usize>() {
            for n in 0..=N {
                let cols = columns_of::<V, N>(n);
                for (f, col) in cols.iter().enumerate() {
                    for (l, &x) in col.iter().enumerate() {
                        let want = if l < n { (10 * l + f) as f32 } else { 0.0 };
                        assert_eq!(x, want, "{N} lanes, {n} rays, field {f}, lane {l}");
                    }
                }
            }
        }
        check::<f32x4, 4>();
        check::<f32x8, 8>();
    }

    #[test]
    fn records_transpose_four_columns_bit_for_bit() {
        fn check<V: Lanes<N>, const N: usize>() {
            // Column c, lane l holds 10 l + c; column 1 a NaN with a payload
            // (a `MISS` index), which must arrive as the same bits.
            let cols: [V; 4] = core::array::from_fn(|c| {
                V::from_array(core::array::from_fn(|l| match c {
                    1 => f32::from_bits(u32::MAX - l as u32),
                    _ => (10 * l + c) as f32,
                }))
            });
            for (l, row) in V::records(cols).iter().enumerate() {
                let want = [
                    (10 * l) as f32,
                    f32::from_bits(u32::MAX - l as u32),
                    (10 * l + 2) as f32,
                    (10 * l + 3) as f32,
                ];
                assert_eq!(
                    row.map(f32::to_bits),
                    want.map(f32::to_bits),
                    "{N} lanes, lane {l}"
                );
            }
        }
        check::<f32x4, 4>();
        check::<f32x8, 8>();
    }

    #[test]
    fn nine_rows_gather_the_live_records_at_every_level() {
        /// `L`'s eight-lane `nine_rows`, as arrays.
        struct Rows<'a> {
            items: &'a [[f32; 9]],
            at: &'a [u32],
            skip: u32,
        }
        impl Job for Rows<'_> {
            type Out = ([[f32; 8]; 9], u32);
            #[inline(always)]
            fn run<L: Level>(self) -> Self::Out {
                let (rows, live) = L::X8::nine_rows(self.items, self.at, self.skip);
                (rows.map(Lanes::to_array), live)
            }
        }
        // Record i, float f = 100 i + f; record 3 holds a NaN with a payload
        // and a -0, which must arrive as the same bits.
        let mut items: [[f32; 9]; 12] =
            core::array::from_fn(|i| core::array::from_fn(|f| (100 * i + f) as f32));
        items[3][8] = f32::from_bits(0x7FC0_1234);
        items[3][0] = -0.0;
        let lists: [&[u32]; 6] = [
            &[],
            &[3],
            &[0, 11, 5],
            &[7, 99, 3, 3, 2, 1, 0, 8],
            &[11, 10, 9, 8, 7, 6, 5],
            &[u32::MAX, 4, 6],
        ];
        let _level = crate::cpu::tests::LEVEL.lock();
        let detected = crate::cpu::detected_isa();
        for level in crate::cpu::Isa::ALL.into_iter().filter(|&l| l <= detected) {
            crate::cpu::set_isa(level).unwrap();
            for at in lists {
                for skip in [u32::MAX, 3, 5] {
                    let (rows, live) = dispatch(Rows {
                        items: &items,
                        at,
                        skip,
                    });
                    let mut want = 0;
                    for (l, &p) in at.iter().enumerate() {
                        let Some(item) = items.get(p as usize).filter(|_| p != skip) else {
                            continue;
                        };
                        want |= 1 << l;
                        for (f, row) in rows.iter().enumerate() {
                            assert_eq!(row[l].to_bits(), item[f].to_bits(), "{level:?} {at:?}");
                        }
                    }
                    assert_eq!(live, want, "{level:?} {at:?} skip {skip}");
                }
            }
        }
        crate::cpu::set_isa(detected).unwrap();
    }

    #[test]
    fn lanes_match_scalar_ops_bitwise() {
        check::<f32x8>();
        // The 4-wide type through two halves.
        let lo = f32x4::new([1.0, -0.0, f32::NAN, 3.0]);
        assert_eq!(lo.lt(f32x4::splat(2.0)), 0b0011);
    }
}
