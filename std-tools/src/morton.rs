//! Morton (Z-order) codes: points close in space get close keys, so
//! sorting by the key gives rays in the order a renderer's pixel tiles
//! produce them (neighbouring origins one after the other), the order in
//! which a walk finds the nodes and triangles it needs still in cache.

use kdray_kernel::{Bounds, Ray};
use rayon::prelude::*;

/// Bits per axis of a key: three axes in 30 bits, 2^30 cells, far more
/// than the rays of any batch, so that close origins share a cell only
/// when they are close indeed.
const BITS: u32 = 10;

/// The key of a ray whose origin is not finite: above every finite one.
const NOT_FINITE: u32 = 1 << (3 * BITS);

/// A grid of `2^10` cells a side over a box, for [`Grid::key`].
#[derive(Clone, Copy, Debug)]
pub struct Grid {
    lo: [f32; 3],
    /// Cells per unit on each axis (0 for a flat axis: one cell).
    scale: [f32; 3],
}

impl Grid {
    /// The grid over `bounds`.
    #[must_use]
    pub fn new(bounds: &Bounds) -> Grid {
        let cells = (1u32 << BITS) as f32;
        Grid {
            lo: bounds.min,
            scale: std::array::from_fn(|a| {
                let extent = bounds.max[a] - bounds.min[a];
                let s = cells / extent;
                if extent > 0.0 && s.is_finite() {
                    s
                } else {
                    0.0
                }
            }),
        }
    }

    /// The Morton code of `p`: its cell's x, y and z bits interleaved (x
    /// lowest), below `2^30`. Points outside the box are clamped onto it;
    /// a point with a non-finite coordinate gets `2^30`, after every other.
    #[must_use]
    pub fn key(&self, p: [f32; 3]) -> u32 {
        if !p.iter().all(|c| c.is_finite()) {
            return NOT_FINITE;
        }
        let mut key = 0;
        for (a, ((&x, &lo), &scale)) in p.iter().zip(&self.lo).zip(&self.scale).enumerate() {
            // `as` saturates: below the box is cell 0, beyond it is clamped.
            let cell = ((x - lo) * scale) as u32;
            key |= spread(cell.min((1 << BITS) - 1)) << a;
        }
        key
    }
}

/// `x`'s low 10 bits moved to every third bit.
fn spread(x: u32) -> u32 {
    let mut x = x & ((1 << BITS) - 1);
    x = (x | x << 16) & 0x0300_00ff;
    x = (x | x << 8) & 0x0300_f00f;
    x = (x | x << 4) & 0x030c_30c3;
    x = (x | x << 2) & 0x0924_9249;
    x
}

/// The rays' indices in the Morton order of their origins, over the box
/// of all finite origins, each in the low 32 bits of a `u64` (its key in
/// the high ones): rays of equal key keep their order, rays with a
/// non-finite origin come last. A stable radix sort on the keys (three
/// passes of 11 bits): ~20 ms for a batch of 1M rays on one core.
#[must_use]
pub fn origin_order(rays: &[Ray]) -> Vec<u64> {
    let finite = |r: &&Ray| r.origin.iter().all(|c| c.is_finite());
    let bounds = rays.iter().filter(finite).fold(Bounds::EMPTY, |b, r| {
        b.union(&Bounds {
            min: r.origin,
            max: r.origin,
        })
    });
    let grid = Grid::new(&bounds);
    // Key in the high word, index in the low word: sorted by key, the
    // index rides along.
    let mut items: Vec<u64> = rays
        .par_iter()
        .enumerate()
        .map(|(i, r)| u64::from(grid.key(r.origin)) << 32 | i as u64)
        .collect();
    let mut spare = vec![0u64; items.len()];
    for pass in 0..3 {
        let shift = 32 + 11 * pass;
        let digit = |x: u64| (x >> shift) as usize & 0x7ff;
        let mut start = [0usize; 0x800];
        for &x in &items {
            start[digit(x)] += 1;
        }
        let mut sum = 0;
        for s in &mut start {
            (*s, sum) = (sum, sum + *s);
        }
        for &x in &items {
            let d = digit(x);
            spare[start[d]] = x;
            start[d] += 1;
        }
        std::mem::swap(&mut items, &mut spare);
    }
    items
}

/// The ray index an [`origin_order`] item holds.
#[inline]
#[must_use]
pub fn index(item: u64) -> usize {
    item as u32 as usize
}

/// Sorts `rays` by the Morton code of their origins ([`origin_order`]).
pub fn sort_by_origin(rays: &mut [Ray]) {
    let order = origin_order(rays);
    let sorted: Vec<Ray> = order.iter().map(|&i| rays[index(i)]).collect();
    rays.copy_from_slice(&sorted);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_interleave_x_lowest_and_clamp() {
        let unit = Grid::new(&Bounds {
            min: [0.0; 3],
            max: [1.0; 3],
        });
        let all = spread(u32::MAX);
        assert_eq!(unit.key([0.0; 3]), 0);
        assert_eq!(unit.key([1.0, 0.0, 0.0]), all);
        assert_eq!(unit.key([0.0, 1.0, 0.0]), all << 1);
        assert_eq!(unit.key([1.0; 3]), (1 << 30) - 1);
        assert_eq!(unit.key([-5.0, 0.5, 9.0]), spread(512) << 1 | all << 2);
        assert_eq!(unit.key([0.0, f32::NAN, 0.0]), NOT_FINITE);
        // A flat box: every point in its one cell on that axis.
        let flat = Grid::new(&Bounds {
            min: [0.0; 3],
            max: [1.0, 0.0, 1.0],
        });
        assert_eq!(flat.key([0.0, 7.0, 0.0]), 0);
    }

    #[test]
    fn sorting_groups_near_origins_and_keeps_bad_rays_last() {
        let at = |x: f32, y: f32| Ray::new([x, y, 0.0].into(), [0.0, 0.0, 1.0].into());
        let mut rays = vec![
            at(1.0, 1.0),
            at(f32::NAN, 0.0),
            at(0.0, 0.0),
            at(0.9, 0.9),
            at(0.1, 0.0),
            at(0.0, 0.0),
        ];
        rays[5].tmax = 2.0;
        let order: Vec<usize> = origin_order(&rays).into_iter().map(index).collect();
        // Equal keys keep their order: ray 2 before ray 5.
        assert_eq!(order, [2, 5, 4, 3, 0, 1]);
        sort_by_origin(&mut rays);
        let xs: Vec<f32> = rays.iter().map(|r| r.origin[0]).collect();
        assert_eq!(&xs[..5], &[0.0, 0.0, 0.1, 0.9, 1.0]);
        assert_eq!(rays[1].tmax, 2.0);
        assert!(xs[5].is_nan());
    }

    #[test]
    fn the_radix_sort_orders_many_keys_stably() {
        // Keys that need every pass: a pseudo-random walk over the grid.
        let mut r = crate::rng::Rng::new(5);
        let rays: Vec<Ray> = (0..20_000)
            .map(|_| {
                let p = [r.f32() * 100.0, r.f32() * 3.0, r.f32()];
                Ray::new(p.into(), [1.0, 0.0, 0.0].into())
            })
            .collect();
        let order: Vec<usize> = origin_order(&rays).into_iter().map(index).collect();
        let mut want: Vec<usize> = (0..rays.len()).collect();
        let b = rays.iter().fold(Bounds::EMPTY, |b, r| {
            b.union(&Bounds {
                min: r.origin,
                max: r.origin,
            })
        });
        let grid = Grid::new(&b);
        want.sort_by_key(|&i| grid.key(rays[i].origin));
        assert_eq!(order, want);
    }
}
