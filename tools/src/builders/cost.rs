//! The surface area heuristic's cost model: what a split plane costs a ray
//! that enters the cell, against making the cell a leaf.
//!
//! ```text
//! leaf  = C_isect * N
//! split = lambda * (C_trav + C_isect * (SA(below)/SA(cell) * N(below)
//!                                      + SA(above)/SA(cell) * N(above)))
//! lambda = empty_factor when one side is empty (an empty cell is cut off), else 1
//! ```
//!
//! The builders weigh candidate planes with it and the statistics weigh
//! finished trees with it, so a tree's cost and its builder's choices are
//! measured in the same units.

use kdray_kernel::Bounds;

/// The constants of the cost model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CostModel {
    /// Cost of one traversal step (C_trav).
    pub traversal: f64,
    /// Cost of one ray/triangle test (C_isect).
    pub intersection: f64,
    /// Factor applied to a split with an empty side (lambda; 1 = no bonus).
    pub empty_factor: f64,
}

impl CostModel {
    /// Wald & Havran 2006's published constants (traversal 15,
    /// intersection 20, empty cells 0.8), for comparing with their figures.
    pub const WALD_HAVRAN: CostModel = CostModel {
        traversal: 15.0,
        intersection: 20.0,
        empty_factor: 0.8,
    };

    /// The model a build with `p` uses.
    #[must_use]
    pub fn from_params(p: &super::BuildParams) -> CostModel {
        CostModel {
            traversal: f64::from(p.traversal_cost),
            intersection: f64::from(p.intersection_cost),
            empty_factor: 1.0 - f64::from(p.empty_bonus),
        }
    }

    /// The cost of a leaf of `n` triangles. Linear, though the walk tests
    /// a leaf of 3 to 8 triangles in one pass of eight lanes. Tried: a
    /// lane-aware leaf, `C_isect * (base + per8 * ceil(n / 8))` from 3
    /// triangles on (base 0-2, per8 2-6): the bunny's trees had 21-56% of
    /// the nodes, yet camera rays visited 21.2-23.4 nodes instead of 24.5
    /// while testing 10-19 triangles instead of 6.2, and ran at
    /// 0.82-0.98x (random and shadow rays level, 8-wide tiles 0.88-1.0x).
    #[inline]
    #[must_use]
    pub fn leaf(&self, n: usize) -> f64 {
        self.intersection * n as f64
    }

    /// The cost of an interior node whose children cost `below` and `above`
    /// (per ray entering them) and cover the fractions `p_below`, `p_above`
    /// of the cell's surface area; `empty` when a side holds no triangle.
    #[inline]
    #[must_use]
    pub fn interior(&self, p_below: f64, below: f64, p_above: f64, above: f64, empty: bool) -> f64 {
        let lambda = if empty { self.empty_factor } else { 1.0 };
        lambda * (self.traversal + p_below * below + p_above * above)
    }

    /// The cost of splitting with `n_below` and `n_above` triangles on each
    /// side, the children taken as leaves.
    #[inline]
    #[must_use]
    pub fn split(&self, p_below: f64, n_below: usize, p_above: f64, n_above: usize) -> f64 {
        self.split_counts(p_below, n_below as f64, p_above, n_above as f64)
    }

    /// [`CostModel::split`] with the counts as `f64`, without branches,
    /// for loops that price many planes at once.
    #[inline]
    #[must_use]
    pub(super) fn split_counts(
        &self,
        p_below: f64,
        n_below: f64,
        p_above: f64,
        n_above: f64,
    ) -> f64 {
        let empty = n_below == 0.0 || n_above == 0.0;
        let lambda = if empty { self.empty_factor } else { 1.0 };
        lambda
            * (self.traversal
                + p_below * (self.intersection * n_below)
                + p_above * (self.intersection * n_above))
    }
}

impl CostModel {
    /// The cost of splitting with `n_below` and `n_above` triangles on
    /// each side and `planar` ones lying in the plane, these put on the
    /// cheaper side (below on a tie): (cost, planar triangles go below).
    #[inline]
    #[must_use]
    pub(super) fn split_planar(
        &self,
        p_below: f64,
        n_below: usize,
        p_above: f64,
        n_above: usize,
        planar: usize,
    ) -> (f64, bool) {
        let below = self.split(p_below, n_below + planar, p_above, n_above);
        if planar == 0 {
            return (below, true);
        }
        let above = self.split(p_below, n_below, p_above, n_above + planar);
        if below <= above {
            (below, true)
        } else {
            (above, false)
        }
    }
}

/// The least of `prices` (never NaN), `+inf` for none: in eight running
/// minimums, then across them. One dependent chain of 16-64 `f64::min`s,
/// each with its NaN fix-up, cost the small cells 3% of the bunny's build;
/// the binned pricing reduces its candidates the same way.
#[inline]
pub(super) fn least_price(prices: &[f64]) -> f64 {
    let lesser = |a: f64, b: f64| if b < a { b } else { a };
    let mut mins = [f64::INFINITY; 8];
    let chunks = prices.chunks_exact(8);
    let rest = chunks
        .remainder()
        .iter()
        .fold(f64::INFINITY, |a, &b| lesser(a, b));
    for chunk in chunks {
        for (m, &c) in mins.iter_mut().zip(chunk) {
            *m = lesser(*m, c);
        }
    }
    mins.iter().fold(rest, |a, &b| lesser(a, b))
}

/// The surface areas of a cell's two halves as fractions of the cell's,
/// for planes along one axis, without building the boxes.
#[derive(Clone, Copy, Debug)]
pub(super) struct AreaRatios {
    lo: f64,
    /// 2 * (sum of the other two extents) / SA(cell).
    per_length: f64,
    /// 2 * (product of the other two extents) / SA(cell).
    cap: f64,
    hi: f64,
}

impl AreaRatios {
    /// For planes along `axis` of `cell`; `None` when the cell has no area.
    pub(super) fn new(cell: &Bounds, axis: usize) -> Option<AreaRatios> {
        Self::with_area(cell, axis, cell.area())
    }

    /// [`AreaRatios::new`] given the cell's area (computed once for the
    /// three axes).
    pub(super) fn with_area(cell: &Bounds, axis: usize, area: f64) -> Option<AreaRatios> {
        if area <= 0.0 {
            return None;
        }
        let d = |a: usize| f64::from(cell.max[a]) - f64::from(cell.min[a]);
        let (u, v) = (d((axis + 1) % 3), d((axis + 2) % 3));
        Some(AreaRatios {
            lo: f64::from(cell.min[axis]),
            per_length: 2.0 * (u + v) / area,
            cap: 2.0 * u * v / area,
            hi: f64::from(cell.max[axis]),
        })
    }

    /// (SA(below), SA(above)) / SA(cell) for the plane at `pos`.
    #[inline]
    pub(super) fn at(&self, pos: f32) -> (f64, f64) {
        let p = f64::from(pos);
        (
            self.cap + self.per_length * (p - self.lo),
            self.cap + self.per_length * (self.hi - p),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::least_price;

    #[test]
    fn least_price_is_the_minimum_at_every_length() {
        // Lengths around the chunks of eight, the least in every place.
        for n in 0..26 {
            for at in 0..n {
                let prices: Vec<f64> = (0..n)
                    .map(|i| if i == at { 0.5 } else { 1.0 + i as f64 })
                    .collect();
                assert_eq!(least_price(&prices), 0.5, "length {n}, least at {at}");
            }
        }
        assert_eq!(least_price(&[]), f64::INFINITY);
        assert_eq!(least_price(&[f64::INFINITY; 9]), f64::INFINITY);
    }
}
