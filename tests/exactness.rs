//! Tree == brute force, bit for bit, on random and adversarial geometry:
//! random soups; axis-aligned and coplanar triangles snapped to a grid so
//! they lie exactly in split planes; zero-area triangles; rays along split
//! planes, starting on them, with zero, negative-zero, NaN and infinite
//! components, and with inverted or negative intervals.

mod common;

use common::assert_matches_brute;
use kdray::kernel::{
    any_hit_brute, closest_hit_brute, first_hits_brute, Hit, Ray, ShallowTree, Triangle,
};
use kdray::tools::blob::write_triangle_tree;
use kdray::tools::builders::{build, BuildParams, BuilderKind};
use proptest::prelude::*;

/// A coordinate: mostly on a coarse grid (so planes coincide), sometimes raw.
fn coord() -> impl Strategy<Value = f32> {
    prop_oneof![
        4 => (-4i32..=4).prop_map(|i| i as f32),
        2 => (-8i32..=8).prop_map(|i| i as f32 * 0.5),
        1 => -5.0f32..5.0,
    ]
}

fn point() -> impl Strategy<Value = [f32; 3]> {
    [coord(), coord(), coord()]
}

/// Triangles of every awkward kind.
fn triangle() -> impl Strategy<Value = Triangle> {
    prop_oneof![
        // General position.
        3 => [point(), point(), point()].prop_map(|v| Triangle { v }),
        // Axis-aligned: all three vertices share one coordinate (lies in a plane
        // a builder may well choose as a split).
        3 => (0usize..3, coord(), point(), point(), point()).prop_map(|(a, c, mut p, mut q, mut r)| {
            p[a] = c;
            q[a] = c;
            r[a] = c;
            Triangle { v: [p, q, r] }
        }),
        // Degenerate: a repeated vertex or collinear points.
        1 => (point(), point()).prop_map(|(p, q)| Triangle {
            v: [p, q, std::array::from_fn(|a| (p[a] + q[a]) * 0.5)]
        }),
    ]
}

/// A direction component: often exactly 0 or -0, sometimes tiny.
fn dir_component() -> impl Strategy<Value = f32> {
    prop_oneof![
        3 => -1.0f32..1.0,
        1 => Just(0.0f32),
        1 => Just(-0.0f32),
        1 => (-2i32..=2).prop_map(|i| i as f32),
        1 => Just(1e-30f32),
    ]
}

fn ray() -> impl Strategy<Value = Ray> {
    let interval = prop_oneof![
        6 => Just((0.0f32, f32::INFINITY)),
        1 => (-10.0f32..10.0, -10.0f32..10.0),
        1 => Just((f32::NEG_INFINITY, f32::INFINITY)),
        1 => (0.0f32..3.0).prop_map(|t| (t, t)),
    ];
    (
        point(),
        [dir_component(), dir_component(), dir_component()],
        interval,
    )
        .prop_map(|(origin, dir, (tmin, tmax))| Ray {
            origin,
            tmin,
            dir,
            tmax,
        })
}

/// Rays that break the rules: NaN anywhere, infinite components.
fn hostile_ray() -> impl Strategy<Value = Ray> {
    let special = prop_oneof![
        Just(f32::NAN),
        Just(f32::INFINITY),
        Just(f32::NEG_INFINITY),
        Just(0.0f32),
        Just(-0.0f32),
        Just(f32::MIN_POSITIVE / 4.0),
        -3.0f32..3.0,
    ];
    proptest::collection::vec(special, 8).prop_map(|c| Ray {
        origin: [c[0], c[1], c[2]],
        tmin: c[3],
        dir: [c[4], c[5], c[6]],
        tmax: c[7],
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 1000, ..ProptestConfig::default() })]

    #[test]
    fn adversarial_scenes_match_brute_force(
        tris in proptest::collection::vec(triangle(), 0..60),
        rays in proptest::collection::vec(ray(), 1..40),
    ) {
        assert_matches_brute(&tris, &rays);
    }

    #[test]
    fn hostile_rays_never_panic_and_match_brute_force(
        tris in proptest::collection::vec(triangle(), 1..30),
        rays in proptest::collection::vec(hostile_ray(), 1..30),
    ) {
        assert_matches_brute(&tris, &rays);
    }
}

/// Rays aimed at grid points: through shared vertices and edges of the
/// axis-aligned triangles, and exactly along the split planes between them.
#[test]
fn grid_rays_through_planes_edges_and_vertices() {
    assert_matches_brute(&lattice(), &lattice_rays());
}

/// A tree built to a depth limit, walked by a [`ShallowTree`] of exactly
/// that depth (one stack entry per level), answers as brute force (closest,
/// any and first hits); a
/// stack one level shallower is refused.
#[test]
fn shallow_tree_of_the_tree_depth_matches_brute_force() {
    let tris = lattice();
    let params = BuildParams {
        max_depth: Some(6),
        ..BuildParams::default()
    };
    let built = build(&tris, BuilderKind::Sah, &params).unwrap();
    let blob = write_triangle_tree(&built, &tris).unwrap();
    let tree = blob.tree().unwrap();
    assert_eq!(
        tree.max_depth(),
        6,
        "the limit must bind, or the stack is not tight"
    );
    let err = ShallowTree::<5>::new(tree).unwrap_err();
    assert!(err.to_string().contains("6 levels deep"), "{err}");
    let shallow = ShallowTree::<6>::new(tree).unwrap();
    let mut hits = 0;
    for (i, r) in lattice_rays().iter().enumerate() {
        let want = closest_hit_brute(&tris, r);
        hits += usize::from(want.is_hit());
        assert_eq!(shallow.closest_hit(r).bits(), want.bits(), "ray {i} {r:?}");
        assert_eq!(shallow.any_hit(r), any_hit_brute(&tris, r), "ray {i} {r:?}");
        let (mut got, mut want) = ([Hit::MISS; 8], [Hit::MISS; 8]);
        let n = shallow.first_hits(r, &mut got);
        assert_eq!(n, first_hits_brute(&tris, r, &mut want), "ray {i} {r:?}");
        assert_eq!(
            got.map(|h| h.bits()),
            want.map(|h| h.bits()),
            "ray {i} {r:?}"
        );
    }
    assert!(hits > 500, "{hits} hits: too few to see a lost far cell");
}

/// A 4x4x4 lattice of unit squares in the three axis planes.
fn lattice() -> Vec<Triangle> {
    let mut tris = Vec::new();
    for i in 0..4 {
        for j in 0..4 {
            for k in 0..4 {
                let (x, y, z) = (i as f32, j as f32, k as f32);
                tris.push(Triangle {
                    v: [[x, y, z], [x + 1.0, y, z], [x + 1.0, y + 1.0, z]],
                });
                tris.push(Triangle {
                    v: [[x, y, z], [x + 1.0, y + 1.0, z], [x, y + 1.0, z]],
                });
                tris.push(Triangle {
                    v: [[x, y, z], [x, y + 1.0, z], [x, y + 1.0, z + 1.0]],
                });
                tris.push(Triangle {
                    v: [[x, y, z], [x, y, z + 1.0], [x + 1.0, y, z + 1.0]],
                });
            }
        }
    }
    tris
}

/// Rays from three sides of the lattice through its grid points, along
/// the axes and diagonals.
fn lattice_rays() -> Vec<Ray> {
    let mut rays = Vec::new();
    for i in 0..=8 {
        for j in 0..=8 {
            let (a, b) = (i as f32 * 0.5, j as f32 * 0.5);
            for dir in [
                [0.0, 0.0, 1.0],
                [0.0, 0.0, -1.0],
                [1.0, 0.0, 0.0],
                [0.0, -0.0, 1.0],
                [1.0, 1.0, 1.0],
                [-1.0, 0.5, 0.25],
            ] {
                rays.push(Ray {
                    origin: [a, b, -1.0],
                    tmin: 0.0,
                    dir,
                    tmax: f32::INFINITY,
                });
                rays.push(Ray {
                    origin: [a, b, 2.0],
                    tmin: 0.0,
                    dir,
                    tmax: f32::INFINITY,
                });
                rays.push(Ray {
                    origin: [-1.0, a, b],
                    tmin: 0.0,
                    dir,
                    tmax: 7.0,
                });
            }
        }
    }
    rays
}

/// Found by `hostile_rays_never_panic_and_match_brute_force` in a CI run
/// (shrunk): triangles lying in the x = 0 and y = 0 planes (two collapsed to a
/// point), a ray from a subnormal y on that plane, over t in [-inf, 0].
#[test]
fn ray_from_plane_of_flat_triangles_over_negative_t() {
    let t = |v: [[f32; 3]; 3]| Triangle { v };
    let tris = [
        t([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 1.0, 0.0]]),
        t([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]]),
        t([[0.0, 0.0, 0.0], [0.0, 4.0, 0.0], [0.0, -4.0, 0.0]]),
        t([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]]),
        t([[0.0, 0.0, 0.0], [3.0, 0.0, -2.0], [0.0, 0.0, 2.5]]),
    ];
    let ray = Ray {
        origin: [0.0, 2.938736e-39, 0.0],
        tmin: f32::NEG_INFINITY,
        dir: [-2.5473, 2.938736e-39, 1.3442075],
        tmax: 0.0,
    };
    assert_matches_brute(&tris, &[ray]);
}

/// The any-hit walk goes back to front: down a stack of 16 walls, the
/// occluder it finds (and remembers) is one of the last walls before
/// `tmax`, and it tests only their leaf (front to back it finds one of
/// the first walls). Every wall it skips would have been an answer too,
/// so the answer is brute force's either way.
#[test]
fn any_hit_walks_from_the_far_end() {
    let tris: Vec<Triangle> = (0..16)
        .flat_map(|k| {
            let z = k as f32;
            [
                Triangle {
                    v: [[0.0, 0.0, z], [4.0, 0.0, z], [4.0, 4.0, z]],
                },
                Triangle {
                    v: [[0.0, 0.0, z], [4.0, 4.0, z], [0.0, 4.0, z]],
                },
            ]
        })
        .collect();
    let built = build(&tris, BuilderKind::Sah, &BuildParams::default()).unwrap();
    let blob = write_triangle_tree(&built, &tris).unwrap();
    let tree = blob.tree().unwrap();
    for (tmax, wall) in [(100.0, 15), (10.7, 10), (3.7, 3)] {
        for dir in [[0.0, 0.0, 1.0], [0.01, 0.02, 1.0]] {
            let ray = Ray {
                origin: [1.0, 3.0, -0.5],
                tmin: 0.0,
                dir,
                tmax,
            };
            let mut last = kdray::kernel::MISS;
            assert!(tree.any_hit_remembering(&ray, &mut last));
            // A leaf may hold two walls, tested in index order.
            assert!(
                (wall - 1..=wall).contains(&(last / 2)),
                "tmax {tmax}, dir {dir:?}: triangle {last}"
            );
            let (hit, counts) = tree.counting().any_hit(&ray);
            assert!(hit && any_hit_brute(&tris, &ray));
            assert!(counts.triangles <= 4, "{counts:?}");
        }
    }
}
