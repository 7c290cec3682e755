//! The coordinate types a point tree holds (f32 and f64, sealed) and the
//! one distance expression the tree and brute force share.

use bytemuck::Pod;
use core::fmt::Debug;
use core::ops::{Mul, Sub};

mod sealed {
    pub trait Sealed {}
    impl Sealed for f32 {}
    impl Sealed for f64 {}
}

/// A point coordinate: `f32` or `f64` (sealed: the blob records which, by
/// its size in bytes).
pub trait Scalar:
    sealed::Sealed
    + Copy
    + Debug
    + Default
    + PartialEq
    + PartialOrd
    + Pod
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Send
    + Sync
    + 'static
{
    /// The type's name, for messages: `"f32"` or `"f64"`.
    const NAME: &'static str;
    /// Bytes per coordinate, the code a blob records: 4 or 8.
    const BYTES: u32;
    /// Zero.
    const ZERO: Self;
    /// Positive infinity.
    const INFINITY: Self;
    /// The exponent of the largest finite power of two: 127 for `f32`,
    /// 1023 for `f64`.
    const TOP_EXP: u32;

    /// `self + other` (IEEE, round to nearest).
    #[must_use]
    fn add(self, other: Self) -> Self;
    /// The larger of the two; the other one if either is NaN.
    #[must_use]
    fn max(self, other: Self) -> Self;
    /// The smaller of the two; the other one if either is NaN.
    #[must_use]
    fn min(self, other: Self) -> Self;
    /// Is this NaN?
    fn is_nan(self) -> bool;
    /// Is this neither NaN nor infinite?
    fn is_finite(self) -> bool;
    /// The value's bits, widened, for bitwise comparisons.
    fn bits(self) -> u64;
    /// The value as an f64 (exact for both types).
    fn to_f64(self) -> f64;
    /// The total order of `f32::total_cmp` / `f64::total_cmp`.
    fn total_cmp(&self, other: &Self) -> core::cmp::Ordering;
    /// The absolute value (NaN stays NaN).
    #[must_use]
    fn abs(self) -> Self;
    /// `2^e`, exactly, for `e <=` [`Scalar::TOP_EXP`] (clamped there).
    #[must_use]
    fn pow2(e: u32) -> Self;
}

macro_rules! scalar {
    ($t:ty, $bits:ty, $name:literal) => {
        impl Scalar for $t {
            const NAME: &'static str = $name;
            const BYTES: u32 = core::mem::size_of::<$t>() as u32;
            const ZERO: Self = 0.0;
            const INFINITY: Self = <$t>::INFINITY;
            const TOP_EXP: u32 = (<$t>::MAX_EXP - 1) as u32;
            #[inline(always)]
            fn add(self, other: Self) -> Self {
                self + other
            }
            #[inline(always)]
            fn max(self, other: Self) -> Self {
                <$t>::max(self, other)
            }
            #[inline(always)]
            fn min(self, other: Self) -> Self {
                <$t>::min(self, other)
            }
            #[inline(always)]
            fn is_nan(self) -> bool {
                <$t>::is_nan(self)
            }
            #[inline(always)]
            fn is_finite(self) -> bool {
                <$t>::is_finite(self)
            }
            #[inline(always)]
            fn bits(self) -> u64 {
                u64::from(self.to_bits())
            }
            #[inline(always)]
            fn to_f64(self) -> f64 {
                f64::from(self)
            }
            #[inline(always)]
            fn total_cmp(&self, other: &Self) -> core::cmp::Ordering {
                <$t>::total_cmp(self, other)
            }
            #[inline(always)]
            fn abs(self) -> Self {
                <$t>::abs(self)
            }
            #[inline(always)]
            fn pow2(e: u32) -> Self {
                // The biased exponent field, mantissa zero.
                let biased = e.min(Self::TOP_EXP) + Self::TOP_EXP;
                <$t>::from_bits(<$bits>::from(biased) << (<$t>::MANTISSA_DIGITS - 1))
            }
        }
    };
}
scalar!(f32, u32, "f32");
scalar!(f64, u64, "f64");

/// The squared distance between `p` and `q`: `d0*d0 + d1*d1 + ...` with
/// `d = p - q`, summed left to right in `S`. The one expression the tree
/// and brute force share, so their answers agree bit for bit (in 2-D and
/// 3-D exactly `dx*dx + dy*dy (+ dz*dz)`).
#[inline(always)]
#[must_use]
pub fn distance2<const D: usize, S: Scalar>(p: &[S; D], q: &[S; D]) -> S {
    sum_of_squares::<D, S>(core::array::from_fn(|a| p[a] - q[a]))
}

/// `d0*d0 + d1*d1 + ...`, left to right (the first term is not added to
/// zero: `0 + x` is not a no-op for IEEE, so the compiler would keep it).
#[inline(always)]
pub(crate) fn sum_of_squares<const D: usize, S: Scalar>(d: [S; D]) -> S {
    let mut s = match d.first() {
        Some(&d0) => d0 * d0,
        None => S::ZERO,
    };
    for &x in d.iter().skip(1) {
        s = s.add(x * x);
    }
    s
}

/// The squared distance from `q` to the nearest point of the box `b`
/// (`[min, max]`), by the expression of [`distance2`] on per-axis gaps:
/// each gap is at most the computed `|p - q|` of any point inside (IEEE
/// subtraction is monotone), so this is never above the computed distance
/// of a point in the box (module docs, "How a query prunes").
#[inline(always)]
pub(crate) fn box_distance2<const D: usize, S: Scalar>(b: &[[S; D]; 2], q: &[S; D]) -> S {
    let [min, max] = b;
    sum_of_squares::<D, S>(core::array::from_fn(|a| {
        larger(larger(min[a] - q[a], q[a] - max[a]), S::ZERO)
    }))
}

/// `a` if it is above `b`, else `b`: one compare and select, where
/// [`Scalar::max`]'s NaN rule costs three more instructions per call (the
/// query's bounds are not NaN on a validated tree; on an unvalidated one a
/// NaN bound only prunes wrongly, as the queries' docs allow).
#[inline(always)]
pub(crate) fn larger<S: Scalar>(a: S, b: S) -> S {
    if a > b {
        a
    } else {
        b
    }
}

/// `log2` of [`max_point_coord`]: `⌊(TOP_EXP − 2 − ⌈log2 D⌉) / 2⌋`, so 61
/// for 3-D `f32` points (60 up to 32-D, 59 up to 128-D) and 509 for 3-D
/// `f64` ones.
///
/// Why: with every coordinate of a point and a query within `±2^m`, a
/// coordinate difference is at most `2^(m+1)` (IEEE subtraction is monotone
/// and `2^(m+1)` is representable), its square at most `2^(2m+2)`, and the
/// sum of `D` squares, rounded monotonically too, at most
/// `2^(⌈log2 D⌉ + 2m + 2) <= 2^TOP_EXP`: finite. A box's gap to the query is
/// never above a difference of two in-range coordinates, so the pruning
/// bounds are finite as well, and no distance the queries compare is
/// `inf` (where two overflowed points would tie and the lower index win).
#[must_use]
pub const fn max_point_coord_log2<const D: usize, S: Scalar>() -> u32 {
    let ceil_log2_d = usize::BITS - D.saturating_sub(1).leading_zeros();
    (S::TOP_EXP - 2 - ceil_log2_d) / 2
}

/// The coordinate range of `D`-dimensional points of `S`: every point and
/// query coordinate must lie within `±` this, `2^`[`max_point_coord_log2`]
/// (`2^61` = 2.3e18 for 3-D `f32`), where no squared distance overflows.
/// The builders refuse points beyond it, a point blob whose root box
/// reaches beyond it is refused ([`crate::BlobError::PointsOutOfRange`]),
/// and a query beyond it gets the empty answer, as a NaN query does.
#[inline(always)]
#[must_use]
pub fn max_point_coord<const D: usize, S: Scalar>() -> S {
    S::pow2(max_point_coord_log2::<D, S>())
}

/// Is `q` a query the trees answer? Coordinates that are NaN or beyond
/// [`max_point_coord`] get an empty answer.
#[inline(always)]
pub(crate) fn query_is_valid<const D: usize, S: Scalar>(q: &[S; D]) -> bool {
    let limit = max_point_coord::<D, S>();
    // `<=` is false for NaN.
    q.iter().all(|c| c.abs() <= limit)
}
