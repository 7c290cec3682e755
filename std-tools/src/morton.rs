//! Morton (Z-order) codes: points close in space get close keys, so
//! sorting by the key gives rays in the order a renderer's pixel tiles
//! produce them (neighbouring origins one after the other), the order in
//! which a walk finds the nodes and triangles it needs still in cache.

use kdray_kernel::{Bounds, Ray};

/// Bits per axis of a key: three axes fit one `u64`.
const BITS: u32 = 21;

/// The Morton code of `p` on a `2^21`-cell grid over `bounds`: the
/// cell's x, y and z bits interleaved (x lowest). Points outside the box
/// are clamped onto it; a NaN coordinate counts as the box's minimum.
#[must_use]
pub fn morton_key(p: [f32; 3], bounds: &Bounds) -> u64 {
    let cells = f64::from((1u32 << BITS) - 1);
    let mut key = 0u64;
    for (a, &x) in p.iter().enumerate() {
        let (lo, hi) = (f64::from(bounds.min[a]), f64::from(bounds.max[a]));
        let unit = if hi > lo {
            (f64::from(x) - lo) / (hi - lo)
        } else {
            0.0
        };
        // `as` saturates and maps NaN to 0: every input gives a cell.
        let cell = (unit.clamp(0.0, 1.0) * cells) as u64;
        key |= spread(cell) << a;
    }
    key
}

/// `x`'s low 21 bits moved to every third bit.
fn spread(x: u64) -> u64 {
    let mut x = x & ((1 << BITS) - 1);
    x = (x | x << 32) & 0x001f_0000_0000_ffff;
    x = (x | x << 16) & 0x001f_0000_ff00_00ff;
    x = (x | x << 8) & 0x100f_00f0_0f00_f00f;
    x = (x | x << 4) & 0x10c3_0c30_c30c_30c3;
    x = (x | x << 2) & 0x1249_2492_4924_9249;
    x
}

/// Sorts `rays` by the Morton code of their origins over the box of all
/// finite origins; rays of equal code keep their order, and rays with a
/// non-finite origin go last, in their order.
pub fn sort_by_origin(rays: &mut [Ray]) {
    let finite = |r: &Ray| r.origin.iter().all(|c| c.is_finite());
    let bounds = rays
        .iter()
        .filter(|r| finite(r))
        .fold(Bounds::EMPTY, |b, r| {
            b.union(&Bounds {
                min: r.origin,
                max: r.origin,
            })
        });
    rays.sort_by_cached_key(|r| {
        if finite(r) {
            (false, morton_key(r.origin, &bounds))
        } else {
            (true, 0)
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_interleave_x_lowest_and_clamp() {
        let unit = Bounds {
            min: [0.0; 3],
            max: [1.0; 3],
        };
        assert_eq!(morton_key([0.0; 3], &unit), 0);
        assert_eq!(morton_key([1.0, 0.0, 0.0], &unit), spread(u64::MAX));
        assert_eq!(morton_key([0.0, 1.0, 0.0], &unit), spread(u64::MAX) << 1);
        assert_eq!(morton_key([1.0; 3], &unit), (1 << 63) - 1);
        assert_eq!(
            morton_key([-5.0, f32::NAN, 9.0], &unit),
            spread(u64::MAX) << 2
        );
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
        ];
        sort_by_origin(&mut rays);
        let xs: Vec<f32> = rays.iter().map(|r| r.origin[0]).collect();
        assert_eq!(&xs[..4], &[0.0, 0.1, 0.9, 1.0]);
        assert!(xs[4].is_nan());
    }
}
