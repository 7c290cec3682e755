//! A pinhole camera and the ray sets the CLI, tests and benches share.

use crate::rng::Rng;
use glam::Vec3;
use kdray_kernel::Bounds;
use kdray_kernel::Ray;
use kdray_kernel::MAX_COORD;

/// A pinhole camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Eye position.
    pub eye: Vec3,
    /// The point looked at.
    pub target: Vec3,
    /// Up direction.
    pub up: Vec3,
    /// Vertical field of view in degrees.
    pub fov_deg: f32,
}

impl Camera {
    /// A camera framing `focus` from the front-right-above, the whole box
    /// in view. The eye stays within `±`[`MAX_COORD`]: a ray whose origin
    /// lies beyond the kernel's range may miss every triangle (its edge
    /// functions overflow `f32`), so for a box near that range the eye
    /// comes closer and the field of view widens (up to
    /// [`Camera::WIDEST_FOV`] degrees) instead.
    #[must_use]
    pub fn framing(focus: &Bounds) -> Camera {
        let lo = Vec3::from(focus.min);
        let hi = Vec3::from(focus.max);
        let center = (lo + hi) * 0.5;
        let radius = ((hi - lo).length() * 0.5).max(1e-6);
        let fov_deg = 40.0f32;
        let dir = Vec3::new(0.55, 0.35, 1.0).normalize();
        let fits = radius * 1.05;
        let wanted = fits / (fov_deg.to_radians() * 0.5).sin();
        // The farthest along `dir` the eye may go on each axis, with a
        // margin for the rounding of `center + dir * dist`.
        let room = (0..3)
            .map(|a| (MAX_COORD * 0.99 - center[a].abs()) / dir[a].abs())
            .fold(f32::INFINITY, f32::min)
            .max(0.0);
        let dist = wanted.min(room);
        let fov_deg = if dist >= wanted {
            fov_deg
        } else {
            (2.0 * (fits / dist).min(1.0).asin().to_degrees()).min(Camera::WIDEST_FOV)
        };
        Camera {
            eye: center + dir * dist,
            target: center,
            up: Vec3::Y,
            fov_deg,
        }
    }

    /// The widest field of view [`Camera::framing`] opens, in degrees.
    pub const WIDEST_FOV: f32 = 150.0;

    /// The ray through the centre of pixel `(x, y)` of a `w` x `h` image
    /// (row 0 at the top).
    #[must_use]
    pub fn ray(&self, x: u32, y: u32, w: u32, h: u32) -> Ray {
        self.ray_at(x as f32 + 0.5, y as f32 + 0.5, w, h)
    }

    /// The ray through the point `(px, py)` of a `w` x `h` image, in
    /// pixels from its top left corner (`(x + 0.5, y + 0.5)` is pixel
    /// `(x, y)`'s centre): a supersampled picture's sub-pixel rays.
    #[must_use]
    pub fn ray_at(&self, px: f32, py: f32, w: u32, h: u32) -> Ray {
        let fwd = (self.target - self.eye).normalize_or(Vec3::NEG_Z);
        let right = fwd.cross(self.up).normalize_or(Vec3::X);
        let up = right.cross(fwd);
        let half = (self.fov_deg.to_radians() * 0.5).tan();
        let aspect = w as f32 / h.max(1) as f32;
        let sx = (px / w as f32 * 2.0 - 1.0) * half * aspect;
        let sy = (1.0 - py / h as f32 * 2.0) * half;
        Ray::new(self.eye, fwd + sx * right + sy * up)
    }

    /// All `w * h` rays, row by row.
    #[must_use]
    pub fn rays(&self, w: u32, h: u32) -> Vec<Ray> {
        self.ray_iter(w, h).collect()
    }

    /// The rays of [`Camera::rays`], one at a time (for a caller that
    /// reserves their room itself).
    pub fn ray_iter(&self, w: u32, h: u32) -> impl Iterator<Item = Ray> + '_ {
        (0..h).flat_map(move |y| (0..w).map(move |x| self.ray(x, y, w, h)))
    }
}

/// `n` rays with origins uniform in `bounds` and directions uniform on the
/// sphere (the incoherent case), from `seed`.
#[must_use]
pub fn random_rays(bounds: &Bounds, n: usize, seed: u64) -> Vec<Ray> {
    random_ray_iter(bounds, n, seed).collect()
}

/// The rays of [`random_rays`], one at a time.
pub fn random_ray_iter(bounds: &Bounds, n: usize, seed: u64) -> impl Iterator<Item = Ray> + '_ {
    let mut rng = Rng::new(seed);
    (0..n).map(move |_| {
        let o: [f32; 3] = std::array::from_fn(|a| rng.range(bounds.min[a], bounds.max[a]));
        Ray::new(Vec3::from(o), Vec3::from(rng.unit_vector()))
    })
}
