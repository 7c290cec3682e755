//! A pinhole camera and the ray sets the CLI, tests and benches share.

use crate::rng::Rng;
use glam::Vec3;
use kdray_kernel::Bounds;
use kdray_kernel::Ray;
use kdray_kernel::TriangleTree;
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

    /// Rays [`Camera::encloses`] casts from the bounds' centre.
    pub const PROBES: u32 = 64;

    /// Whether a scene encloses the centre of its `bounds`, as a room or a
    /// courtyard does: of [`Camera::PROBES`] rays from the centre spread
    /// evenly over the sphere, at least 60% hit, and at least half of the
    /// hits see the front of their triangle (the side its winding makes
    /// the normal point to). The centre of a closed object's box (a bunny,
    /// a teapot) sees the backs of its triangles from inside the solid: not
    /// enclosed, framed from outside. `probe` traces one ray.
    #[must_use]
    pub fn encloses(bounds: &Bounds, probe: impl Fn(&Ray) -> Option<Probe>) -> bool {
        let centre = (Vec3::from(bounds.min) + Vec3::from(bounds.max)) * 0.5;
        let (mut hits, mut front) = (0, 0);
        for dir in sphere_directions(Camera::PROBES) {
            if let Some(p) = probe(&Ray::new(centre, dir)) {
                hits += 1;
                front += u32::from(p.front);
            }
        }
        hits * 10 >= Camera::PROBES * 6 && front * 2 >= hits
    }

    /// A camera inside a scene that encloses its bounds' centre: on the
    /// horizontal line through the centre along the box's longer side,
    /// looking at the farther wall (a wall rather than an open side),
    /// stepped back 80% of the free distance behind (out through an open
    /// side, as a Cornell box is seen), with a 75-degree field of view.
    /// The renderer puts its light above and to the left of the eye, as
    /// far as the target is ahead: the target is near enough that the
    /// light stays in the free space the probes found ahead, above and to
    /// the left.
    #[must_use]
    pub fn inside(bounds: &Bounds, probe: impl Fn(&Ray) -> Option<Probe>) -> Camera {
        let (lo, hi) = (Vec3::from(bounds.min), Vec3::from(bounds.max));
        let centre = (lo + hi) * 0.5;
        let size = (hi - lo).max(Vec3::splat(1e-6));
        // The free distance from `from` along `dir` (the box's size when
        // nothing is hit).
        let free =
            |from: Vec3, dir: Vec3| probe(&Ray::new(from, dir)).map_or(size.max_element(), |p| p.t);
        let axis = if size.x >= size.z { Vec3::X } else { Vec3::Z };
        // Towards a wall (not out of an open side), the farther one if both.
        let wall = |dir: Vec3| probe(&Ray::new(centre, dir)).map(|p| p.t);
        let dir = match (wall(axis), wall(-axis)) {
            (Some(ahead), Some(behind)) if ahead < behind => -axis,
            (None, Some(_)) => -axis,
            _ => axis,
        };
        let eye = centre - dir * (0.8 * free(centre, -dir));
        let left = Vec3::Y.cross(dir);
        let reach = [
            free(eye, dir),
            free(eye, Vec3::Y) / 0.9,
            free(eye, left) / 0.6,
        ]
        .into_iter()
        .fold(f32::INFINITY, f32::min);
        Camera {
            eye,
            target: eye + dir * (0.5 * reach).max(1e-6),
            up: Vec3::Y,
            fov_deg: 75.0,
        }
    }

    /// The camera `placement` asks for over `bounds`: [`Camera::framing`]
    /// from outside, or [`Camera::inside`] (for [`Placement::Auto`], when
    /// [`Camera::encloses`] says the scene encloses the centre).
    #[must_use]
    pub fn placed(
        bounds: &Bounds,
        placement: Placement,
        probe: impl Fn(&Ray) -> Option<Probe>,
    ) -> Camera {
        let inside = match placement {
            Placement::Outside => false,
            Placement::Inside => true,
            Placement::Auto => Camera::encloses(bounds, &probe),
        };
        if inside {
            Camera::inside(bounds, probe)
        } else {
            Camera::framing(bounds)
        }
    }

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

/// Where a camera stands when no eye is given.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Placement {
    /// Inside when the scene encloses its bounds' centre
    /// ([`Camera::encloses`]), else outside.
    #[default]
    Auto,
    /// Outside, framing the whole box ([`Camera::framing`]).
    Outside,
    /// Inside ([`Camera::inside`]).
    Inside,
}

/// What a probe ray of [`Camera::encloses`] and [`Camera::inside`] met.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Probe {
    /// The closest hit's distance along the ray.
    pub t: f32,
    /// Whether the ray met the front of the triangle (its normal, by the
    /// corners' winding, points back along the ray).
    pub front: bool,
}

/// The closest hit of `ray` in `tree`, as a [`Probe`].
#[must_use]
pub fn probe_tree(tree: &TriangleTree<'_>, ray: &Ray) -> Option<Probe> {
    let hit = tree.closest_hit(ray);
    let tri = tree
        .triangles()
        .get(hit.prim as usize)
        .filter(|_| hit.is_hit())?;
    let [a, b, c] = tri.v.map(Vec3::from);
    let n = (b - a).cross(c - a);
    Some(Probe {
        t: hit.t,
        front: n.dot(Vec3::from(ray.dir)) < 0.0,
    })
}

/// `n` directions spread evenly over the unit sphere (a Fibonacci
/// lattice: heights evenly spaced, turned by the golden angle).
fn sphere_directions(n: u32) -> impl Iterator<Item = Vec3> {
    let golden = std::f32::consts::PI * (3.0 - 5.0f32.sqrt());
    (0..n).map(move |k| {
        let y = 1.0 - (k as f32 + 0.5) * 2.0 / n as f32;
        let r = (1.0 - y * y).max(0.0).sqrt();
        let phi = k as f32 * golden;
        Vec3::new(r * phi.cos(), y, r * phi.sin())
    })
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
