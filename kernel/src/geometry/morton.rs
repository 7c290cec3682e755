//! Morton (Z-order) codes of ray origins and a batch of rays sorted by
//! them, in the caller's memory: points close in space get close keys, so
//! rays in key order are neighbours one after the other, and their walks
//! read the cells, nodes and triangles the previous ray left in cache.

use super::{Bounds, Ray};

/// Bits per axis of a key: three axes in 30 bits, 2^30 cells, far more
/// than the rays of any batch.
const BITS: u32 = 10;

/// The key of a point with a non-finite coordinate: after every other.
const NOT_FINITE: u32 = 1 << (3 * BITS);

/// A grid of `2^10` cells a side over a box, for [`MortonGrid::key`].
#[derive(Clone, Copy, Debug)]
pub struct MortonGrid {
    lo: [f32; 3],
    /// Cells per unit on each axis (0 for a flat axis: one cell).
    scale: [f32; 3],
}

impl MortonGrid {
    /// The grid over `bounds`.
    #[must_use]
    pub fn new(bounds: &Bounds) -> MortonGrid {
        let cells = (1u32 << BITS) as f32;
        let scale = |a: usize| {
            let extent = bounds.max[a] - bounds.min[a];
            let s = cells / extent;
            if extent > 0.0 && s.is_finite() {
                s
            } else {
                0.0
            }
        };
        MortonGrid {
            lo: bounds.min,
            scale: [scale(0), scale(1), scale(2)],
        }
    }

    /// The grid over the finite origins of `rays`.
    #[must_use]
    pub fn over_origins(rays: &[Ray]) -> MortonGrid {
        let finite = |r: &&Ray| r.origin.iter().all(|c| c.is_finite());
        let bounds = rays.iter().filter(finite).fold(Bounds::EMPTY, |b, r| {
            b.union(&Bounds {
                min: r.origin,
                max: r.origin,
            })
        });
        MortonGrid::new(&bounds)
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

    /// A ray's item for [`sort_items`]: its origin's key in the high word,
    /// its index `i` in the low one.
    #[must_use]
    pub fn item(&self, ray: &Ray, i: u32) -> u64 {
        u64::from(self.key(ray.origin)) << 32 | u64::from(i)
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

/// Sorts [`MortonGrid::item`]s by key, stably (equal keys keep their
/// order), in place: a radix sort in four passes of 8 bits between
/// `items` and `spare`. `false`, and nothing moved, when `spare` is
/// shorter than `items`.
pub fn sort_items(items: &mut [u64], spare: &mut [u64]) -> bool {
    let Some(spare) = spare.get_mut(..items.len()) else {
        return false;
    };
    let (mut from, mut to) = (items, spare);
    // An even number of passes: the last one writes `items`.
    for pass in 0..4 {
        let shift = 32 + 8 * pass;
        let digit = |x: u64| (x >> shift) as u8 as usize;
        let mut start = [0usize; 256];
        for &x in from.iter() {
            if let Some(s) = start.get_mut(digit(x)) {
                *s += 1;
            }
        }
        let mut sum = 0;
        for s in &mut start {
            (*s, sum) = (sum, sum + *s);
        }
        for &x in from.iter() {
            if let Some(s) = start.get_mut(digit(x)) {
                if let Some(slot) = to.get_mut(*s) {
                    *slot = x;
                }
                *s += 1;
            }
        }
        core::mem::swap(&mut from, &mut to);
    }
    true
}

/// The ray index an item holds.
#[inline]
#[must_use]
pub fn item_index(item: u64) -> usize {
    item as u32 as usize
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_interleave_x_lowest_and_clamp() {
        let unit = MortonGrid::new(&Bounds {
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
        let flat = MortonGrid::new(&Bounds {
            min: [0.0; 3],
            max: [1.0, 0.0, 1.0],
        });
        assert_eq!(flat.key([0.0, 7.0, 0.0]), 0);
    }

    #[test]
    fn the_radix_sort_orders_keys_stably() {
        // Keys in every digit of the four passes, many equal ones.
        let mut rng = crate::test_rng::Rng(0x2545_F491_4F6C_DD1D);
        let items: [u64; 3000] = core::array::from_fn(|i| {
            let key = (rng.f() * (1u32 << 31) as f32) as u64 & 0x7fff_f000;
            key << 32 | i as u64
        });
        let (mut sorted, mut spare) = (items, [0u64; 3000]);
        assert!(sort_items(&mut sorted, &mut spare));
        for w in sorted.windows(2) {
            let (x, y) = (w[0] >> 32, w[1] >> 32);
            assert!(x < y || (x == y && w[0] < w[1]), "{:x} {:x}", w[0], w[1]);
        }
        let mut seen = [false; 3000];
        for &x in &sorted {
            seen[item_index(x)] = true;
        }
        assert!(seen.iter().all(|&s| s));
        // Too little room: nothing moves.
        let mut again = items;
        assert!(!sort_items(&mut again, &mut [0u64; 2]));
        assert_eq!(again, items);
    }
}
