//! The interval rule of the walk, for one ray and for lanes.

/// The slack rule's interval arithmetic, written once for a single ray
/// (`f32`) and for packet lanes (one `f32` per lane): intervals are kept
/// pre-widened, `[lo, hi] = [t0 - s, t1 + s]`, so the visit tests compare
/// `t_split` as computed (`t_split < lo`: near child skipped,
/// `t_split > hi`: far child skipped) and each new end moves by `2s`.
pub(crate) trait Span:
    Copy + core::ops::Add<Output = Self> + core::ops::Sub<Output = Self>
{
    /// The smaller of the two; a NaN `rhs` keeps `self` (`self` is never NaN).
    fn min(self, rhs: Self) -> Self;
    /// The larger of the two; a NaN `rhs` keeps `self` (`self` is never NaN).
    fn max(self, rhs: Self) -> Self;

    /// The near child's interval end: its cell ends at the plane.
    #[inline(always)]
    fn near_hi(self, t_split: Self, s2: Self) -> Self {
        self.min(t_split + s2)
    }

    /// The far child's interval start: its cell starts at the plane.
    #[inline(always)]
    fn far_lo(self, t_split: Self, s2: Self) -> Self {
        self.max(t_split - s2)
    }

    /// Cells whose `lo` lies beyond this (the best hit `self` plus the
    /// slack, widened by the slack) cannot hold a better hit.
    #[inline(always)]
    fn cutoff(self, s2: Self) -> Self {
        self + s2
    }
}

/// Plain selects: the walk's `lo` and `hi` are never NaN and a NaN `rhs`
/// keeps them, which is all of `f32::min`/`max`'s NaN rule the walk needs
/// (those spend three instructions on the rest).
impl Span for f32 {
    #[inline(always)]
    fn min(self, rhs: f32) -> f32 {
        if rhs < self {
            rhs
        } else {
            self
        }
    }
    #[inline(always)]
    fn max(self, rhs: f32) -> f32 {
        if rhs > self {
            rhs
        } else {
            self
        }
    }
}
