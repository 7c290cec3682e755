//! Geometry the rest of the kernel speaks: rays and hits, axes, boxes.

mod axis;
mod bounds;
mod morton;
mod ray;
mod ulp;

pub use axis::Axis;
pub use bounds::Bounds;
pub use morton::{item_index, sort_items, MortonGrid, RayKey};
pub use ray::{ray_is_valid, Hit, Ray, MISS, OCCLUDED};
pub(crate) use ulp::{next_down, next_up};
