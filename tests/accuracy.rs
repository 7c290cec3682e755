//! Accurate hits: `t` against an `f64` reference on random and adversarial
//! triangles (huge, tiny, slivers, nearly parallel to the ray, far from
//! the origin, axis-aligned); rays that start on a triangle hit it at
//! `t = 0`; rays spawned from a hit never hit the surface they leave;
//! closed meshes stay watertight from inside through every vertex and
//! edge; the coordinate range is refused by the builders.

mod common;

use common::{assert_matches_brute, blob, cross64, len64, line_hit, sub64, t_bound};
use kdray::kernel::{
    any_hit_brute, closest_hit_brute, Hit, Ray, SurfacePoint, Triangle, MAX_COORD,
};
use kdray::tools::builders::{build, BuildError, BuildParams, BuilderKind};
use proptest::prelude::*;

/// The reference's hit of the triangle itself (barycentrics all >= 0).
fn reference(tri: &Triangle, ray: &Ray) -> Option<(f64, f64, f64)> {
    line_hit(tri, ray)
        .filter(|(_, b)| b.iter().all(|&x| x >= 0.0))
        .map(|(t, b)| (t, b[1], b[2]))
}

/// A line ray: every `t`, so the reference's and kdray's `t` compare
/// wherever both hit.
fn line(origin: [f32; 3], dir: [f32; 3]) -> Ray {
    Ray {
        origin,
        tmin: f32::NEG_INFINITY,
        dir,
        tmax: f32::INFINITY,
    }
}

/// Checks kdray's `t` against the reference for `ray`, and that a ray the
/// reference hits well inside the triangle (barycentrics at least 1e-3
/// from an edge) is not missed.
fn check_t(tri: &Triangle, ray: &Ray) -> Result<(), TestCaseError> {
    let got = closest_hit_brute(std::slice::from_ref(tri), ray);
    let Some((t, b1, b2)) = reference(tri, ray) else {
        return Ok(());
    };
    // Well inside: farther from every edge than 2^-16 of the coordinates'
    // magnitude (the f32 projection's rounding is 2^-22 of it).
    let [a, b, c] = tri.v.map(|p| p.map(f64::from));
    let n = cross64(sub64(b, a), sub64(c, a));
    let longest = [sub64(b, a), sub64(c, b), sub64(a, c)]
        .iter()
        .map(|e| len64(*e))
        .fold(0.0, f64::max);
    let height = len64(n) / longest;
    let mag = tri
        .v
        .iter()
        .flatten()
        .chain(&ray.origin)
        .map(|x| f64::from(x.abs()))
        .fold(0.0, f64::max);
    let inside = b1.min(b2).min(1.0 - b1 - b2) * height > mag * 2f64.powi(-16);
    let in_range = t >= f64::from(ray.tmin) && t <= f64::from(ray.tmax);
    let bound = t_bound(tri, ray, t);
    if got.is_hit() {
        let err = (f64::from(got.t) - t).abs();
        prop_assert!(
            err <= bound,
            "t {} vs f64 {t}: error {err:e} above the bound {bound:e}; {tri:?} {ray:?}",
            got.t
        );
    } else if inside && in_range && bound < 1e-3 * t.abs().max(1e-30) && t.abs() < 1e30 {
        prop_assert!(
            false,
            "missed a well-conditioned hit at t = {t}: {tri:?} {ray:?}"
        );
    }
    Ok(())
}

/// A point of `tri` by barycentrics `(b1, b2)` in `f32`.
fn at(tri: &Triangle, b1: f32, b2: f32) -> [f32; 3] {
    let [a, b, c] = tri.v;
    std::array::from_fn(|i| a[i] + b1 * (b[i] - a[i]) + b2 * (c[i] - a[i]))
}

fn unit(d: [f32; 3]) -> [f32; 3] {
    let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    if l > 0.0 {
        d.map(|c| c / l)
    } else {
        [0.0, 0.0, 1.0]
    }
}

fn vec3(r: f32) -> impl Strategy<Value = [f32; 3]> {
    [-r..r, -r..r, -r..r]
}

/// Triangles of every awkward kind, scaled by `10^scale` and moved by an
/// offset (far from the origin).
fn adversarial() -> impl Strategy<Value = Triangle> {
    let shape = prop_oneof![
        // General position.
        [vec3(1.0), vec3(1.0), vec3(1.0)].prop_map(|v| Triangle { v }),
        // A sliver: the third vertex within 1e-4 of the first edge.
        (vec3(1.0), vec3(1.0), 0.0f32..1.0, vec3(1e-4)).prop_map(|(a, b, s, e)| {
            let c = std::array::from_fn(|i| a[i] + s * (b[i] - a[i]) + e[i]);
            Triangle { v: [a, b, c] }
        }),
        // Axis-aligned: in a plane x, y or z = const.
        (0usize..3, -1.0f32..1.0, [vec3(1.0), vec3(1.0), vec3(1.0)]).prop_map(|(k, c, mut v)| {
            for p in &mut v {
                p[k] = c;
            }
            Triangle { v }
        }),
    ];
    (shape, -12i32..12, vec3(1.0), 0i32..13).prop_map(|(t, scale, off, far)| {
        let s = 10f32.powi(scale);
        let off = off.map(|c| c * 10f32.powi(far));
        Triangle {
            v: t.v.map(|p| std::array::from_fn(|i| p[i] * s + off[i])),
        }
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 4000, ..ProptestConfig::default() })]

    /// Rays aimed at a point of the triangle (inside or just outside) from
    /// a distance from 1e-3 to 1e3 times its size, some nearly parallel to
    /// its plane: `t` within the bound of the `f64` reference.
    #[test]
    fn t_is_within_the_bound_of_an_f64_reference(
        tri in adversarial(),
        (b1, b2) in (-0.1f32..1.1, -0.1f32..1.1),
        dir in vec3(1.0),
        grazing in 0.0f32..1.0,
        dist in -3i32..4,
    ) {
        let target = at(&tri, b1, b2);
        let [a, b, c] = tri.v;
        let size = (0..3).map(|i| (b[i] - a[i]).abs().max((c[i] - a[i]).abs())).fold(0.0, f32::max);
        // Towards the plane, or mixed with an in-plane direction (grazing).
        let n = tri.normal();
        let d = unit(std::array::from_fn(|i| dir[i] * grazing + unit(n)[i] * (1.0 - grazing)));
        let back = size * 10f32.powi(dist);
        let origin = std::array::from_fn(|i| target[i] - back * d[i]);
        check_t(&tri, &line(origin, d))?;
        // Also the ray over [0, inf] only: the same t where it hits.
        let r = Ray { tmin: 0.0, ..line(origin, d) };
        check_t(&tri, &r)?;
    }

    /// A ray starting on a triangle (a vertex, or any point of an
    /// axis-aligned triangle) with `tmin <= 0` hits it at `t = 0`.
    #[test]
    fn rays_from_points_on_triangles_hit_at_zero(
        mut tri in adversarial(),
        plane in 0usize..3,
        (b1, b2) in (0.05f32..0.45, 0.05f32..0.45),
        dir in vec3(1.0),
        vertex in 0usize..4,
        tmin in prop_oneof![Just(0.0f32), Just(-0.0f32), -1.0f32..0.0],
    ) {
        let d = unit(dir);
        if vertex == 3 {
            // An interior point: of a triangle put in an axis plane.
            let c = tri.v[0][plane];
            for p in &mut tri.v {
                p[plane] = c;
            }
        }
        let origin = match tri.v.get(vertex) {
            Some(&v) => v,
            None => at(&tri, b1, b2),
        };
        // A point of the plane exactly: a vertex, or an interior point of
        // a triangle in an axis plane (the coordinate is the same).
        let n = tri.normal();
        let axis_plane = n.iter().filter(|&&c| c == 0.0).count() == 2;
        if !(vertex < 3 || axis_plane) {
            return Ok(());
        }
        let [a, b, c] = tri.v;
        let e1: [f32; 3] = std::array::from_fn(|i| b[i] - a[i]);
        let e2: [f32; 3] = std::array::from_fn(|i| c[i] - a[i]);
        let nd: f32 = (0..3).map(|i| n[i] * d[i]).sum();
        let scale = (0..3).map(|i| e1[i].abs() + e2[i].abs()).sum::<f32>();
        // Not grazing (there, the 2-D projection is a sliver and an edge
        // may round either way), and a real triangle.
        let ln = (0..3).map(|i| n[i] * n[i]).sum::<f32>().sqrt();
        if !(ln > 1e-6 * scale * scale && nd.abs() > 0.1 * ln) {
            return Ok(());
        }
        // An interior point computed in f32 stays inside only where the
        // triangle spans many ulps of its coordinates.
        let mag = tri.v.iter().flatten().fold(0.0f32, |m, x| m.max(x.abs()));
        if !(vertex < 3 || ln.sqrt() > mag * 1e-3) {
            return Ok(());
        }
        let ray = Ray { origin, tmin, dir: d, tmax: f32::INFINITY };
        let h = closest_hit_brute(std::slice::from_ref(&tri), &ray);
        prop_assert!(h.is_hit() && h.t == 0.0, "{h:?} for {tri:?} {ray:?}");
        prop_assert!(any_hit_brute(std::slice::from_ref(&tri), &ray));
    }

    /// Any hit says yes exactly when closest hit finds a triangle, on
    /// scenes with degenerate and nearly degenerate triangles.
    #[test]
    fn any_hit_agrees_with_closest_hit(
        tris in proptest::collection::vec(adversarial(), 1..8),
        origin in vec3(2.0),
        dir in vec3(1.0),
        (tmin, tmax) in prop_oneof![Just((0.0f32, f32::INFINITY)), Just((f32::NEG_INFINITY, f32::INFINITY)), (-2.0f32..2.0, 0.0f32..4.0)],
    ) {
        let ray = Ray { origin, tmin, dir, tmax };
        let h = closest_hit_brute(&tris, &ray);
        prop_assert_eq!(any_hit_brute(&tris, &ray), h.is_hit(), "{:?}", h);
    }
}

/// The 20 triangles of an icosahedron of radius `r` about `c`: a closed,
/// convex mesh, outward winding.
fn icosahedron(c: [f32; 3], r: f32) -> Vec<Triangle> {
    let p = (1.0 + 5f32.sqrt()) / 2.0;
    let v = [
        [-1.0, p, 0.0],
        [1.0, p, 0.0],
        [-1.0, -p, 0.0],
        [1.0, -p, 0.0],
        [0.0, -1.0, p],
        [0.0, 1.0, p],
        [0.0, -1.0, -p],
        [0.0, 1.0, -p],
        [p, 0.0, -1.0],
        [p, 0.0, 1.0],
        [-p, 0.0, -1.0],
        [-p, 0.0, 1.0],
    ]
    .map(|q: [f32; 3]| {
        let l = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]).sqrt();
        std::array::from_fn(|i| c[i] + r * q[i] / l)
    });
    let f = [
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    f.iter()
        .map(|t: &[usize; 3]| Triangle { v: t.map(|i| v[i]) })
        .collect()
}

/// The 12 triangles of the box `lo..hi`: closed, axis-aligned faces.
fn cuboid(lo: [f32; 3], hi: [f32; 3]) -> Vec<Triangle> {
    let c = |i: usize| {
        [
            if i & 1 == 0 { lo[0] } else { hi[0] },
            if i & 2 == 0 { lo[1] } else { hi[1] },
            if i & 4 == 0 { lo[2] } else { hi[2] },
        ]
    };
    let quads = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    quads
        .iter()
        .flat_map(|q| {
            [
                Triangle {
                    v: [c(q[0]), c(q[1]), c(q[2])],
                },
                Triangle {
                    v: [c(q[0]), c(q[2]), c(q[3])],
                },
            ]
        })
        .collect()
}

/// Closed convex meshes at many scales and distances from the origin.
fn closed_meshes() -> Vec<Vec<Triangle>> {
    let mut out = Vec::new();
    for (scale, far) in [
        (1.0f32, 0.0f32),
        (1e-6, 0.0),
        (1e6, 0.0),
        (1.0, 1e6),
        (1e-3, 1e3),
        (1e12, 1e13),
    ] {
        let c = [far, -0.5 * far, 0.25 * far];
        out.push(icosahedron(c, scale));
        let lo = c.map(|x| x - 0.7 * scale);
        let hi = [c[0] + 0.3 * scale, c[1] + 1.1 * scale, c[2] + 0.5 * scale];
        out.push(cuboid(lo, hi));
    }
    out
}

/// A small deterministic generator (xorshift) for the mesh tests.
struct Rng(u64);
impl Rng {
    fn f(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
    fn dir(&mut self) -> [f32; 3] {
        unit([self.f() - 0.5, self.f() - 0.5, self.f() - 0.5])
    }
}

/// The bounding box of `mesh`'s vertices.
fn mesh_box(mesh: &[Triangle]) -> ([f32; 3], [f32; 3]) {
    let pts = || mesh.iter().flat_map(|t| t.v);
    let lo = pts().fold([f32::MAX; 3], |m, p| {
        std::array::from_fn(|i| m[i].min(p[i]))
    });
    let hi = pts().fold([f32::MIN; 3], |m, p| {
        std::array::from_fn(|i| m[i].max(p[i]))
    });
    (lo, hi)
}

#[test]
fn spawned_rays_never_hit_the_surface_they_leave() {
    let mut rng = Rng(0x1234_5678_9abc_def1);
    for mesh in closed_meshes() {
        let tree_blob = blob(&mesh, BuilderKind::default());
        let tree = tree_blob.tree().unwrap();
        let (lo, hi) = mesh_box(&mesh);
        let centre: [f32; 3] = std::array::from_fn(|i| 0.5 * (lo[i] + hi[i]));
        let size = (0..3).map(|i| hi[i] - lo[i]).fold(0.0, f32::max);
        let mut spawned = 0;
        for _ in 0..2000 {
            // From outside towards a point inside.
            let d = rng.dir();
            let origin = std::array::from_fn(|i| centre[i] - 3.0 * size * d[i]);
            let aim: [f32; 3] = std::array::from_fn(|i| centre[i] + 0.3 * size * (rng.f() - 0.5));
            let ray = Ray {
                origin,
                tmin: 0.0,
                dir: std::array::from_fn(|i| aim[i] - origin[i]),
                tmax: f32::INFINITY,
            };
            let h = tree.closest_hit(&ray);
            assert!(h.is_hit(), "{ray:?} missed a closed mesh");
            let tri = &mesh[h.prim as usize];
            let sp = SurfacePoint::new(tri, &h);
            let n = sp.normal;
            // Outward (the side the ray came from): a convex mesh is left
            // for good; inward: the far side, never the triangle left.
            for _ in 0..4 {
                let mut w = rng.dir();
                let wn: f32 = (0..3).map(|i| w[i] * n[i]).sum();
                let outward = wn * (0..3).map(|i| ray.dir[i] * n[i]).sum::<f32>() < 0.0;
                let r = sp.spawn(w, f32::INFINITY);
                let again = tree.closest_hit(&r);
                // Inward rays from a point at an edge may start past the
                // neighbouring face (the point is off by its error) and
                // miss, or hit that neighbour at t = 0: only the triangle
                // left is ruled out.
                if outward {
                    assert!(
                        !again.is_hit(),
                        "spawned outward from {h:?} on {tri:?}: {again:?}, ray {r:?}"
                    );
                } else {
                    assert!(
                        again.prim != h.prim,
                        "spawned inward from {h:?} on {tri:?}: {again:?}, ray {r:?}"
                    );
                }
                // A ray along the surface (in its plane) leaves it too.
                for (a, b) in w.iter_mut().zip(n) {
                    *a -= wn * b;
                }
                let r = sp.spawn(w, f32::INFINITY);
                let again = tree.closest_hit(&r);
                assert!(
                    !again.is_hit() || again.prim != h.prim,
                    "along the surface: {again:?}"
                );
                // To a light outside: never its own triangle.
                let light = std::array::from_fn(|i| centre[i] + 5.0 * size * n[i]);
                let r = sp.spawn_to(light);
                let again = tree.closest_hit(&r);
                assert!(
                    !again.is_hit() || again.prim != h.prim,
                    "to the light: {again:?}"
                );
                spawned += 3;
            }
        }
        assert!(spawned > 0);
    }
}

#[test]
fn closed_meshes_are_watertight_from_inside_through_every_vertex_and_edge() {
    let mut rng = Rng(0x0dd_ba11);
    for mesh in closed_meshes() {
        let tree_blob = blob(&mesh, BuilderKind::default());
        let tree = tree_blob.tree().unwrap();
        let (lo, hi) = mesh_box(&mesh);
        let mut rays = Vec::new();
        for _ in 0..6 {
            let inside: [f32; 3] = std::array::from_fn(|i| {
                let s = 0.35 + 0.3 * rng.f();
                lo[i] + s * (hi[i] - lo[i])
            });
            for tri in &mesh {
                for k in 0..3 {
                    let (p, q) = (tri.v[k], tri.v[(k + 1) % 3]);
                    for s in [0.0f32, 0.125, 0.25, 1.0 / 3.0, 0.5, 0.9] {
                        let aim: [f32; 3] = std::array::from_fn(|i| p[i] + s * (q[i] - p[i]));
                        rays.push(Ray {
                            origin: inside,
                            tmin: 0.0,
                            dir: std::array::from_fn(|i| aim[i] - inside[i]),
                            tmax: f32::INFINITY,
                        });
                    }
                }
            }
        }
        for r in &rays {
            let h = tree.closest_hit(r);
            assert!(h.is_hit(), "leaked from inside: {r:?}");
            assert!(tree.any_hit(r));
        }
        assert_matches_brute(&mesh, &rays);
    }
}

#[test]
fn a_huge_tetrahedron_is_hit() {
    // Size 1e13: the f32 estimate of t overflowed in the old test and
    // every ray missed.
    let s = 1e13f32;
    let v = [[0.0, 0.0, 0.0], [s, 0.0, 0.0], [0.0, s, 0.0], [0.0, 0.0, s]];
    let tris: Vec<Triangle> = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]
        .iter()
        .map(|f: &[usize; 3]| Triangle { v: f.map(|i| v[i]) })
        .collect();
    let tree_blob = blob(&tris, BuilderKind::default());
    let tree = tree_blob.tree().unwrap();
    let ray = Ray {
        origin: [0.2 * s, 0.2 * s, -3.0 * s],
        tmin: 0.0,
        dir: [0.0, 0.0, 1.0],
        tmax: f32::INFINITY,
    };
    let h = tree.closest_hit(&ray);
    assert_eq!((h.prim, h.t), (0, 3.0 * s));
    assert!(tree.any_hit(&ray));
}

#[test]
fn builders_refuse_coordinates_beyond_the_range() {
    let big = MAX_COORD * 2.0;
    let tris = [
        Triangle {
            v: [[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        },
        Triangle {
            v: [[0.0; 3], [1.0, 0.0, 0.0], [0.0, -big, 0.0]],
        },
    ];
    for kind in BuilderKind::ALL {
        let e = build(&tris, kind, &BuildParams::default()).unwrap_err();
        assert_eq!(
            e,
            BuildError::OutOfRange {
                triangle: 1,
                coordinate: -big
            }
        );
        let msg = e.to_string();
        assert!(
            msg.contains("triangle 1") && msg.contains("1.1529215e18"),
            "{msg}"
        );
    }
    // At the limit itself: built.
    let edge = [Triangle {
        v: [
            [MAX_COORD, 0.0, 0.0],
            [0.0, -MAX_COORD, 0.0],
            [0.0, 0.0, 1.0],
        ],
    }];
    assert!(build(&edge, BuilderKind::default(), &BuildParams::default()).is_ok());
}

#[test]
fn stadium_floor_diagonal_gets_the_f64_t() {
    // Two 1000-unit triangles of a floor, hit near their shared diagonal
    // 1.5 units from the origin: the interpolated t was 1.4e-5 off.
    let floor = [
        Triangle {
            v: [
                [-500.0, 0.0, -500.0],
                [500.0, 0.0, -500.0],
                [500.0, 0.0, 500.0],
            ],
        },
        Triangle {
            v: [
                [-500.0, 0.0, -500.0],
                [500.0, 0.0, 500.0],
                [-500.0, 0.0, 500.0],
            ],
        },
    ];
    let mut rng = Rng(7);
    for _ in 0..2000 {
        let o = [rng.f() - 0.5, 0.2 + rng.f(), rng.f() - 0.5];
        let d = unit([rng.f() - 0.5, -0.2 - rng.f(), rng.f() - 0.5]);
        let ray = Ray {
            origin: o,
            tmin: 0.0,
            dir: d,
            tmax: f32::INFINITY,
        };
        let h = closest_hit_brute(&floor, &ray);
        let want = -f64::from(o[1]) / f64::from(d[1]);
        assert!(h.is_hit());
        let err = (f64::from(h.t) - want).abs() / want;
        assert!(err <= 2f64.powi(-23), "{h:?} vs {want}: {err:e}");
    }
}

#[test]
fn planar_scene_rays_from_the_plane_hit_at_zero() {
    // A grid of triangles in z = 0 and rays from points of the plane in
    // every direction, over [0, inf]: each hits at t = 0 (the old test
    // missed a quarter of them).
    let mut tris = Vec::new();
    for j in 0..16 {
        for i in 0..16 {
            let (x, y) = (i as f32 - 8.0, j as f32 - 8.0);
            tris.push(Triangle {
                v: [[x, y, 0.0], [x + 1.0, y, 0.0], [x + 1.0, y + 1.0, 0.0]],
            });
            tris.push(Triangle {
                v: [[x, y, 0.0], [x + 1.0, y + 1.0, 0.0], [x, y + 1.0, 0.0]],
            });
        }
    }
    let tree_blob = blob(&tris, BuilderKind::default());
    let tree = tree_blob.tree().unwrap();
    let mut rng = Rng(99);
    let mut rays = Vec::new();
    for _ in 0..4000 {
        let o = [15.0 * (rng.f() - 0.5), 15.0 * (rng.f() - 0.5), 0.0];
        let mut d = rng.dir();
        if d[2] == 0.0 {
            d[2] = 0.5;
        }
        let ray = Ray {
            origin: o,
            tmin: 0.0,
            dir: d,
            tmax: f32::INFINITY,
        };
        let h = tree.closest_hit(&ray);
        assert!(h.is_hit() && h.t == 0.0, "{ray:?}: {h:?}");
        rays.push(ray);
    }
    assert_matches_brute(&tris, &rays);
}

#[test]
fn a_spawned_shadow_ray_reaches_its_light() {
    let tri = Triangle {
        v: [[-1e3, 0.0, -1e3], [1e3, 0.0, -1e3], [0.0, 0.0, 1e3]],
    };
    let hit = Hit {
        t: 1.0,
        prim: 0,
        u: 0.3,
        v: 0.2,
    };
    let sp = SurfacePoint::new(&tri, &hit);
    let r = sp.spawn_to([0.0, 10.0, 0.0]);
    assert!(r.origin[1] > 0.0, "{r:?}");
    assert!(!any_hit_brute(&[tri], &r));
    let end = r.at(1.0);
    assert!((end.y - 10.0).abs() < 1e-5, "{end}");
}
