//! Morton (Z-order) codes of rays and a batch of rays sorted by them, in
//! the caller's memory: points close in space get close keys, so rays in
//! key order are neighbours one after the other, and their walks read the
//! cells, nodes and triangles the previous ray left in cache. Two keys:
//! the origin alone (shadow rays towards one light, whose direction
//! follows from the origin), or the origin and the direction (bounce rays,
//! which leave nearby points in all directions).

use super::{Bounds, Ray};

/// Bits per axis of a key: three axes in 30 bits, 2^30 cells, far more
/// than the rays of any batch.
const BITS: u32 = 10;

/// The key of a point with a non-finite coordinate: after every other.
const NOT_FINITE: u32 = 1 << (3 * BITS);

/// Origin bits per axis of a key with the direction ([`RayKey::OriginDirection`]).
const ORIGIN_BITS: u32 = 6;
/// Direction bits per axis of such a key: 6 + 6 + 6 + 4 + 4 + 4 = 30 bits.
const DIRECTION_BITS: u32 = 4;

/// What a ray's key orders by.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RayKey {
    /// The origin, 10 bits an axis: rays from nearby points one after the
    /// other (shadow rays towards a light: their directions follow from
    /// their origins).
    Origin,
    /// The origin, 6 bits an axis, and the direction, 4 bits an axis,
    /// interleaved from the top: rays from nearby points in nearby
    /// directions one after the other (bounce rays, random rays).
    OriginDirection,
}

/// A grid of cells over a box of origins, for [`MortonGrid::key`] and
/// [`MortonGrid::item`].
#[derive(Clone, Copy, Debug)]
pub struct MortonGrid {
    lo: [f32; 3],
    /// Cells per unit on each axis (0 for a flat axis: one cell).
    scale: [f32; 3],
    /// What [`MortonGrid::item`] keys a ray by.
    by: RayKey,
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
            by: RayKey::Origin,
        }
    }

    /// The grid over the finite origins of `rays`, keying each ray by `by`.
    #[must_use]
    pub fn over_rays(rays: &[Ray], by: RayKey) -> MortonGrid {
        MortonGrid {
            by,
            ..MortonGrid::over_origins(rays)
        }
    }

    /// The grid over the finite origins of `rays`, keying each ray by its
    /// origin ([`RayKey::Origin`]).
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

    /// The key of a ray by its origin (6 bits an axis) and its direction
    /// (4 bits an axis, over `[-1, 1]` after dividing by the largest
    /// component's magnitude: a cube around the origin), below `2^30`: the
    /// origin's two top bits of each axis, then rounds of one bit of each
    /// origin and direction axis. A ray with a non-finite origin or
    /// direction gets `2^30`, after every other.
    #[must_use]
    pub fn ray_key(&self, ray: &Ray) -> u32 {
        let (o, d) = (ray.origin, ray.dir);
        if !o.iter().chain(&d).all(|c| c.is_finite()) {
            return NOT_FINITE;
        }
        let big = d[0].abs().max(d[1].abs()).max(d[2].abs());
        // A zero direction (an invalid ray) falls in the middle cell.
        let half = (1u32 << DIRECTION_BITS) as f32 / 2.0;
        let to_cube = if big > 0.0 { half / big } else { 0.0 };
        let (mut top, mut low) = (0, 0);
        for a in 0..3 {
            let cell = ((o[a] - self.lo[a]) * self.scale[a]) as u32 >> (BITS - ORIGIN_BITS);
            let cell = cell.min((1 << ORIGIN_BITS) - 1);
            let dir = ((d[a] * to_cube + half) as u32).min((1 << DIRECTION_BITS) - 1);
            // Round bit k: origin x, y, z at 6k + 5, 4, 3; direction x,
            // y, z at 6k + 2, 1, 0.
            top |= spread(cell >> DIRECTION_BITS) << (2 - a);
            low |= spread_six(cell) << (5 - a) | spread_six(dir) << (2 - a);
        }
        top << (6 * DIRECTION_BITS) | low
    }

    /// A ray's item for [`sort_items`]: its key (by the grid's [`RayKey`])
    /// in the high word, its index `i` in the low one.
    #[must_use]
    pub fn item(&self, ray: &Ray, i: u32) -> u64 {
        let key = match self.by {
            RayKey::Origin => self.key(ray.origin),
            RayKey::OriginDirection => self.ray_key(ray),
        };
        u64::from(key) << 32 | u64::from(i)
    }
}

/// `x`'s low 4 bits moved to every sixth bit.
fn spread_six(x: u32) -> u32 {
    (x & 1) | (x & 2) << 5 | (x & 4) << 10 | (x & 8) << 15
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
    fn ray_keys_put_the_origin_above_the_direction() {
        let grid = MortonGrid::new(&Bounds {
            min: [0.0; 3],
            max: [1.0; 3],
        });
        let key = |o: [f32; 3], d: [f32; 3]| grid.ray_key(&Ray::new(o.into(), d.into()));
        // The lowest origin cell towards -x, -y, -z (a corner of the cube
        // of directions): every bit clear; the highest towards +x, +y, +z:
        // every one of the 30 bits set.
        assert_eq!(key([0.0; 3], [-1.0; 3]), 0);
        assert_eq!(key([1.0; 3], [1.0; 3]), (1 << 30) - 1);
        // Lengths do not matter, only the direction.
        assert_eq!(
            key([0.5; 3], [0.0, 2.0, 4.0]),
            key([0.5; 3], [0.0, 0.5, 1.0])
        );
        // The origin's top bits decide before any direction bit: the top
        // 6 bits are the origin's two highest bits of each axis.
        let (low, high) = (
            key([0.49, 0.0, 0.0], [1.0; 3]),
            key([0.5, 0.0, 0.0], [-1.0; 3]),
        );
        assert!(low < high);
        assert_eq!(high >> 24, 0b100_000);
        // Round bit k: origin x at 6k + 5, direction z at 6k + 0.
        assert_eq!(key([0.0; 3], [-1.0, -1.0, 1.0]), spread_six(15));
        assert_eq!(key([1.0 / 64.0, 0.0, 0.0], [-1.0; 3]), 1 << 5);
        // A zero direction (an invalid ray) lies in the middle cell;
        // anything non-finite after every other key.
        assert_eq!(key([0.0; 3], [0.0; 3]), spread_six(8) * 0b111);
        assert_eq!(key([0.0; 3], [f32::NAN, 0.0, 1.0]), NOT_FINITE);
        assert_eq!(key([f32::INFINITY, 0.0, 0.0], [1.0; 3]), NOT_FINITE);
        // Hostile finite values (huge, tiny, negative, subnormal, signed
        // zeros, outside the grid) stay below 2^30.
        let odd = [
            0.0,
            -0.0,
            1e-45,
            -1e-45,
            1e-30,
            -3.0,
            0.5,
            7.0,
            1e30,
            -f32::MAX,
            f32::MAX,
        ];
        for (&a, &b) in odd.iter().zip(odd.iter().rev()) {
            for &c in &odd {
                assert!(key([a, b, c], [c, a, b]) < 1 << 30, "{a} {b} {c}");
                assert!(key([c, c, a], [b, b, c]) < 1 << 30, "{a} {b} {c}");
            }
        }
        // The grid's `RayKey` picks the item's key.
        let ray = Ray::new([0.5; 3].into(), [1.0, 0.0, 0.0].into());
        let by = MortonGrid::over_rays(&[ray], RayKey::OriginDirection);
        assert_eq!(by.item(&ray, 7), u64::from(by.ray_key(&ray)) << 32 | 7);
        let by = MortonGrid::over_rays(&[ray], RayKey::Origin);
        assert_eq!(by.item(&ray, 7), u64::from(by.key(ray.origin)) << 32 | 7);
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
