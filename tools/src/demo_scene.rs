//! The built-in scene: a teapot in a stadium. The Utah teapot
//! ([`crate::teapot`], 30,800 triangles) stands on the floor of a hollow
//! stadium sixty times its size, with long thin axis-aligned bleachers:
//! the case the lecture says k-d trees handle and octrees do not.
//! Generated, so the project needs no mesh file to run.

use kdray_kernel::Bounds;
use kdray_kernel::Triangle;

/// The scene's triangles and the box around its detailed object.
#[derive(Clone, Debug)]
pub struct DemoScene {
    /// All triangles: the detailed object first, then the stadium.
    pub triangles: Vec<Triangle>,
    /// The bounds of the detailed object (what a camera should frame).
    pub focus: Bounds,
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

/// Grid steps a side of each of the teapot's patches in the built-in scene.
pub const TEAPOT_SEGMENTS: u32 = 22;

/// The built-in teapot-in-a-stadium scene (deterministic): the teapot at
/// half the table's size (3.26 long, 1.575 high), standing on the floor
/// at the stadium's centre.
#[must_use]
pub fn teapot_in_stadium() -> DemoScene {
    // Halving is exact in f32: the seams stay shared bit for bit.
    let mut triangles: Vec<Triangle> = crate::teapot::teapot(TEAPOT_SEGMENTS)
        .into_iter()
        .map(|t| Triangle {
            v: t.v.map(|p| p.map(|c| c * 0.5)),
        })
        .collect();
    let focus = bounds_of(&triangles);
    let s = 100.0;
    // The stadium: floor, four walls and a ceiling, sixty teapots wide.
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_built_in_scene_is_the_teapot_in_the_stadium() {
        let s = teapot_in_stadium();
        // 32 patches of 22 x 22 quads less the 8 x 22 without area; the
        // stadium's 12 and the bleachers' 40 steps of 8.
        let teapot = 32 * 22 * 22 * 2 - 8 * 22;
        assert_eq!(teapot, 30_800);
        assert_eq!(s.triangles.len(), teapot + 12 + 40 * 8);
        assert_eq!(s.focus, bounds_of(&s.triangles[..teapot]));
        // Half the table's teapot, standing on the floor at the centre.
        assert_eq!((s.focus.min[1], s.focus.max[1]), (0.0, 1.575));
        assert!(s.focus.min[0] >= -1.5 && s.focus.max[0] <= 1.7625);
        assert!(s.focus.min[2] >= -1.0 && s.focus.max[2] <= 1.0);
        let all = bounds_of(&s.triangles);
        assert_eq!((all.min, all.max), ([-100.0, 0.0, -100.0], [100.0; 3]));
        // Deterministic: the same bits on every call.
        let again = teapot_in_stadium();
        assert!(s
            .triangles
            .iter()
            .zip(&again.triangles)
            .all(|(a, b)| a.v == b.v));
    }
}
