//! The built-in scene: a teapot in a stadium. A detailed torus knot (the
//! "teapot", ~33k triangles) stands on the floor of a hollow stadium a
//! hundred times its size, with long thin axis-aligned bleachers: the case
//! the lecture says k-d trees handle and octrees do not. Generated, so the
//! project needs no mesh file to run.

use kdray_kernel::Bounds;
use kdray_kernel::Triangle;
use std::f32::consts::TAU;

/// The scene's triangles and the box around its detailed object.
#[derive(Clone, Debug)]
pub struct DemoScene {
    /// All triangles: the knot first, then the stadium.
    pub triangles: Vec<Triangle>,
    /// The bounds of the knot (what a camera should frame).
    pub focus: Bounds,
}

/// The knot's path: a (2, 3) torus knot of major radius 1.
fn knot(t: f32) -> glam::Vec3 {
    let (p, q) = (2.0, 3.0);
    let r = 1.0 + 0.4 * (q * t).cos();
    glam::Vec3::new(
        r * (p * t).cos(),
        0.4 * (q * t).sin() + 0.8,
        r * (p * t).sin(),
    )
}

/// A tube of radius `radius` around the knot, `segments` x `sides` quads.
fn tube(segments: usize, sides: usize, radius: f32) -> Vec<Triangle> {
    let ring = |i: usize| {
        let t = i as f32 / segments as f32 * TAU;
        let c = knot(t);
        let tangent = (knot(t + 1e-3) - knot(t - 1e-3)).normalize();
        let n = tangent.cross(glam::Vec3::Y).normalize();
        let b = tangent.cross(n);
        (0..sides)
            .map(|j| {
                let a = j as f32 / sides as f32 * TAU;
                (c + radius * (a.cos() * n + a.sin() * b)).to_array()
            })
            .collect::<Vec<_>>()
    };
    let rings: Vec<_> = (0..segments).map(ring).collect();
    let mut tris = Vec::with_capacity(segments * sides * 2);
    for i in 0..segments {
        let (r0, r1) = (&rings[i], &rings[(i + 1) % segments]);
        for j in 0..sides {
            let k = (j + 1) % sides;
            tris.push(Triangle {
                v: [r0[j], r1[j], r1[k]],
            });
            tris.push(Triangle {
                v: [r0[j], r1[k], r0[k]],
            });
        }
    }
    tris
}

/// The two triangles of an axis-aligned rectangle with corners `a` and `b`
/// (equal in one coordinate).
fn rect(a: [f32; 3], b: [f32; 3]) -> [Triangle; 2] {
    let flat = (0..3).find(|&i| a[i] == b[i]).unwrap_or(1);
    let (u, v) = ((flat + 1) % 3, (flat + 2) % 3);
    let corner = |cu: f32, cv: f32| {
        let mut p = a;
        p[u] = cu;
        p[v] = cv;
        p
    };
    let (p0, p1, p2, p3) = (
        corner(a[u], a[v]),
        corner(b[u], a[v]),
        corner(b[u], b[v]),
        corner(a[u], b[v]),
    );
    [Triangle { v: [p0, p1, p2] }, Triangle { v: [p0, p2, p3] }]
}

/// The bounding box of `triangles`.
#[must_use]
pub fn bounds_of(triangles: &[Triangle]) -> Bounds {
    triangles
        .iter()
        .fold(Bounds::EMPTY, |b, t| b.union(&t.bounds()))
}

/// A closed box on the floor `y = 0`: `2 * half` wide in x and z, `height`
/// tall (floor, ceiling, four walls; 12 triangles).
fn closed_box(half: f32, height: f32) -> Vec<Triangle> {
    let (s, h) = (half, height);
    [
        rect([-s, 0.0, -s], [s, 0.0, s]),
        rect([-s, h, -s], [s, h, s]),
        rect([-s, 0.0, -s], [-s, h, s]),
        rect([s, 0.0, -s], [s, h, s]),
        rect([-s, 0.0, -s], [s, h, -s]),
        rect([-s, 0.0, s], [s, h, s]),
    ]
    .concat()
}

/// The built-in teapot-in-a-stadium scene (deterministic).
#[must_use]
pub fn teapot_in_stadium() -> DemoScene {
    let mut triangles = tube(1024, 16, 0.18);
    let focus = bounds_of(&triangles);
    let s = 100.0;
    // The stadium: floor, four walls and a ceiling, a hundred knots wide.
    triangles.extend(closed_box(s, s));
    // Bleachers: long, thin, axis-aligned steps along two sides.
    for step in 0..40 {
        let h = 1.0 + step as f32;
        let d = s - 2.0 * step as f32;
        triangles.extend(rect([-s, h, d - 2.0], [s, h, d]));
        triangles.extend(rect([-s, h - 1.0, d - 2.0], [s, h, d - 2.0]));
        triangles.extend(rect([d - 2.0, h, -s], [d, h, s]));
        triangles.extend(rect([d - 2.0, h - 1.0, -s], [d - 2.0, h, s]));
    }
    DemoScene { triangles, focus }
}

/// `mesh` scaled to a largest extent of 1, standing at the centre of a
/// closed box 1000 wide and 200 high (12 triangles after the mesh's): the
/// teapot-in-a-stadium of `anchors/embree/gen_stadium.py`, focus = the mesh.
#[must_use]
pub fn in_stadium(mesh: &[Triangle]) -> DemoScene {
    let b = bounds_of(mesh);
    let extent = (0..3).fold(0.0f32, |m, a| m.max(b.max[a] - b.min[a]));
    let scale = 1.0 / extent.max(f32::MIN_POSITIVE);
    let centre = [
        (b.min[0] + b.max[0]) * 0.5,
        b.min[1],
        (b.min[2] + b.max[2]) * 0.5,
    ];
    let lift = [0.0, 0.2, 0.0];
    let mut triangles: Vec<Triangle> = mesh
        .iter()
        .map(|t| Triangle {
            v: t.v
                .map(|p| std::array::from_fn(|a| (p[a] - centre[a]) * scale + lift[a])),
        })
        .collect();
    let focus = bounds_of(&triangles);
    triangles.extend(closed_box(500.0, 200.0));
    DemoScene { triangles, focus }
}

/// `n` long, thin, axis-aligned triangles ("needles", 50 long and 0.05
/// wide) along all three axes through a 100-unit cube, their ends and
/// planes on a grid: every box edge is a candidate split plane and most
/// triangles straddle most planes. Deterministic.
#[must_use]
pub fn needles(n: usize) -> DemoScene {
    let mut rng = crate::rng::Rng::new(42);
    let triangles: Vec<Triangle> = (0..n)
        .map(|i| {
            let axis = i % 3;
            let (u, w) = ((axis + 1) % 3, (axis + 2) % 3);
            let start = (rng.f32() * 50.0).floor();
            let (pu, pw) = ((rng.f32() * 100.0).floor(), (rng.f32() * 100.0).floor());
            let mut v = [[0.0f32; 3]; 3];
            for (k, p) in v.iter_mut().enumerate() {
                p[axis] = if k == 0 { start } else { start + 50.0 };
                p[u] = pu + if k == 2 { 0.05 } else { 0.0 };
                p[w] = pw;
            }
            Triangle { v }
        })
        .collect();
    let focus = bounds_of(&triangles);
    DemoScene { triangles, focus }
}
