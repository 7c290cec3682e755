//! Generated scenes for tests, benches and examples: a sphere, a torus
//! and a level of their transformed copies.

use crate::rng::Rng;
use kdray_kernel::{Instance, Triangle};

/// A rotation by `angle` about unit `axis`, scaled by `scale` per local
/// axis, then moved by `shift`: a 3×4 row-major transform.
#[must_use]
pub fn placement(axis: [f32; 3], angle: f32, scale: [f32; 3], shift: [f32; 3]) -> [f32; 12] {
    let r = glam::Mat3::from_axis_angle(glam::Vec3::from(axis).normalize_or(glam::Vec3::Y), angle)
        * glam::Mat3::from_diagonal(glam::Vec3::from(scale));
    let c = r.to_cols_array_2d();
    [
        c[0][0], c[1][0], c[2][0], shift[0], //
        c[0][1], c[1][1], c[2][1], shift[1], //
        c[0][2], c[1][2], c[2][2], shift[2],
    ]
}

/// A UV sphere of radius 1 about the origin: `rings` × `segments` quads.
#[must_use]
pub fn sphere(rings: usize, segments: usize) -> Vec<Triangle> {
    let p = |i: usize, j: usize| {
        let th = std::f32::consts::PI * i as f32 / rings as f32;
        let ph = std::f32::consts::TAU * j as f32 / segments as f32;
        [th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin()]
    };
    grid(rings, segments, p)
}

/// A torus of radii 1 and 0.3 about the y axis.
#[must_use]
pub fn torus(rings: usize, segments: usize) -> Vec<Triangle> {
    let p = |i: usize, j: usize| {
        let a = std::f32::consts::TAU * i as f32 / rings as f32;
        let b = std::f32::consts::TAU * j as f32 / segments as f32;
        let r = 1.0 + 0.3 * b.cos();
        [r * a.cos(), 0.3 * b.sin(), r * a.sin()]
    };
    grid(rings, segments, p)
}

fn grid(n: usize, m: usize, p: impl Fn(usize, usize) -> [f32; 3]) -> Vec<Triangle> {
    let mut out = Vec::with_capacity(2 * n * m);
    for i in 0..n {
        for j in 0..m {
            let (a, b, c, d) = (p(i, j), p(i + 1, j), p(i + 1, j + 1), p(i, j + 1));
            out.push(Triangle { v: [a, b, c] });
            out.push(Triangle { v: [a, c, d] });
        }
    }
    out
}

/// A generated level: `copies` transformed copies of a sphere and of a
/// torus (random rotations, scales from 0.3 to 2 per axis, every fifth
/// mirrored) over a `size` × `size` square, plus a floor (mesh 2, one
/// instance). Returns the meshes and the instances.
#[must_use]
pub fn generated_level(copies: usize, size: f32, seed: u64) -> (Vec<Vec<Triangle>>, Vec<Instance>) {
    let floor = vec![
        Triangle {
            v: [[-1.0, 0.0, -1.0], [1.0, 0.0, -1.0], [1.0, 0.0, 1.0]],
        },
        Triangle {
            v: [[-1.0, 0.0, -1.0], [1.0, 0.0, 1.0], [-1.0, 0.0, 1.0]],
        },
    ];
    let meshes = vec![sphere(24, 48), torus(48, 24), floor];
    let mut rng = Rng::new(seed);
    let mut instances = Vec::with_capacity(2 * copies + 1);
    for k in 0..2 * copies {
        let mut scale = [
            rng.range(0.3, 2.0),
            rng.range(0.3, 2.0),
            rng.range(0.3, 2.0),
        ];
        if k % 5 == 4 {
            scale[0] = -scale[0];
        }
        let shift = [
            rng.range(-size, size) * 0.5,
            rng.range(0.0, 2.0),
            rng.range(-size, size) * 0.5,
        ];
        let m = placement(
            rng.unit_vector(),
            rng.range(0.0, std::f32::consts::TAU),
            scale,
            shift,
        );
        if let Some(inst) = Instance::new((k % 2) as u32, m, k as u32, 1 << (k % 4)) {
            instances.push(inst);
        }
    }
    let half = size * 0.5 + 2.0;
    let floor_m = placement([0.0, 1.0, 0.0], 0.0, [half, 1.0, half], [0.0, 0.0, 0.0]);
    instances.extend(Instance::new(2, floor_m, u32::MAX, u32::MAX));
    (meshes, instances)
}

/// `instances` after `frames` frames of motion: each but the last (the
/// generated level's floor) moved by `speed` per frame along its own
/// horizontal direction (from `seed` and its index), nothing else changed.
#[must_use]
pub fn moved_level(instances: &[Instance], frames: u32, speed: f32, seed: u64) -> Vec<Instance> {
    let mut rng = Rng::new(seed);
    let last = instances.len().saturating_sub(1);
    instances
        .iter()
        .enumerate()
        .map(|(k, inst)| {
            let angle = rng.range(0.0, std::f32::consts::TAU);
            if k == last {
                return *inst;
            }
            let step = speed * frames as f32;
            let mut m = inst.to_world();
            m[3] += step * angle.cos();
            m[11] += step * angle.sin();
            Instance::new(inst.mesh(), m, inst.id(), inst.mask()).unwrap_or(*inst)
        })
        .collect()
}
