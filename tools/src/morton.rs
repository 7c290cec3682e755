//! Rays in the Morton (Z-order) order of their origins (or of their
//! origins and directions): points close in space get close keys, so
//! sorting by the key gives rays in the order a renderer's pixel tiles
//! produce them (neighbouring origins one after the other), the order in
//! which a walk finds the nodes and triangles it needs still in cache. The
//! keys and the sort are the kernel's ([`MortonGrid`], [`sort_items`]);
//! here the keys are made on all cores.

use kdray_kernel::{item_index, sort_items, Bounds, MortonGrid, Ray, RayKey};
use rayon::prelude::*;

/// The rays' indices in the Morton order of their keys (`by`), over the
/// box of all finite origins, as the kernel's items (read each with
/// [`item_index`]): rays of equal key keep their order, rays with a
/// non-finite origin come last. ~20 ms for a batch of 1M rays on one core.
/// `None` past `u32::MAX` rays, whose indices an item cannot hold.
#[must_use]
pub fn ray_order(rays: &[Ray], by: RayKey) -> Option<Vec<u64>> {
    u32::try_from(rays.len()).ok()?;
    let grid = MortonGrid::over_rays(rays, by);
    let mut items: Vec<u64> = rays
        .par_iter()
        .enumerate()
        .map(|(i, r)| grid.item(r, i as u32))
        .collect();
    let mut spare = vec![0u64; items.len()];
    // `spare` is as long: the sort always runs.
    sort_items(&mut items, &mut spare);
    Some(items)
}

/// Sorts `rays` by their Morton codes ([`ray_order`] by `by`); past
/// `u32::MAX` rays they keep their order.
pub fn sort_by(rays: &mut [Ray], by: RayKey) {
    if let Some(order) = ray_order(rays, by) {
        let sorted: Vec<Ray> = order.iter().map(|&i| rays[item_index(i)]).collect();
        rays.copy_from_slice(&sorted);
    }
}

/// The points' indices in the Morton order of their positions over the
/// box `bounds` (points outside it clamped onto it), as the kernel's items
/// (read each with [`item_index`]): points of equal key keep their order,
/// points with a non-finite coordinate come last. `None` past `u32::MAX`
/// points.
#[must_use]
pub fn point_order(points: &[[f32; 3]], bounds: &Bounds) -> Option<Vec<u64>> {
    u32::try_from(points.len()).ok()?;
    let grid = MortonGrid::new(bounds);
    let mut items: Vec<u64> = points
        .par_iter()
        .enumerate()
        .map(|(i, &p)| u64::from(grid.key(p)) << 32 | i as u64)
        .collect();
    let mut spare = vec![0u64; items.len()];
    // `spare` is as long: the sort always runs.
    sort_items(&mut items, &mut spare);
    Some(items)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The rays' indices in the order of their keys.
    fn order(rays: &[Ray], by: RayKey) -> Vec<usize> {
        ray_order(rays, by)
            .unwrap()
            .into_iter()
            .map(item_index)
            .collect()
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
        // Equal keys keep their order: ray 2 before ray 5.
        assert_eq!(order(&rays, RayKey::Origin), [2, 5, 4, 3, 0, 1]);
        sort_by(&mut rays, RayKey::Origin);
        let xs: Vec<f32> = rays.iter().map(|r| r.origin[0]).collect();
        assert_eq!(&xs[..5], &[0.0, 0.0, 0.1, 0.9, 1.0]);
        assert_eq!(rays[1].tmax, 2.0);
        assert!(xs[5].is_nan());
    }

    #[test]
    fn sorting_by_direction_groups_near_directions_from_near_origins() {
        let ray = |o: [f32; 3], d: [f32; 3]| Ray::new(o.into(), d.into());
        let (here, there) = ([0.0; 3], [10.0, 10.0, 10.0]);
        let rays = [
            ray(here, [0.0, 0.0, 1.0]),
            ray(there, [0.0, 0.0, 1.0]),
            ray(here, [0.0, 0.0, -1.0]),
            ray(here, [0.0, 0.1, 1.0]),
            ray(here, [0.0, f32::INFINITY, 1.0]),
            ray(there, [0.0, 0.1, 5.0]),
            ray(here, [0.0, 0.0, -3.0]),
        ];
        // Towards -z from here (the same key whatever the length), then
        // towards +z from here, then from there; the infinite direction
        // last.
        assert_eq!(order(&rays, RayKey::OriginDirection), [2, 6, 0, 3, 1, 5, 4]);
        // By origin alone the directions from one origin keep their order.
        assert_eq!(order(&rays, RayKey::Origin), [0, 2, 3, 4, 6, 1, 5]);
    }
}
