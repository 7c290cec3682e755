//! Every builder's trees answer exactly as brute force, bit for bit, on
//! random soups, adversarial scenes (axis-aligned and coplanar triangles,
//! triangles lying in split planes, rays along and starting on planes) and
//! real meshes; degenerate inputs build without panic; the tree is the same
//! for any thread count.

mod common;

use kdray::kernel::{any_hit_brute, closest_hit_brute, Ray, Triangle};
use kdray::tools::blob::write_triangle_tree;
use kdray::tools::builders::{build, BuildError, BuildParams, BuilderKind};

use kdray::tools::rng::Rng;

fn tri(v: [[f32; 3]; 3]) -> Triangle {
    Triangle { v }
}

/// Checks every builder against brute force on `rays`; returns the hits.
fn check_all(name: &str, tris: &[Triangle], rays: &[Ray]) -> usize {
    let mut hits = 0;
    for kind in BuilderKind::ALL {
        let built = build(tris, kind, &BuildParams::default()).unwrap();
        let blob = write_triangle_tree(&built, tris).unwrap();
        let tree = blob
            .tree()
            .unwrap_or_else(|e| panic!("{name}/{}: {e}", kind.name()));
        hits = 0;
        for r in rays {
            let (a, b) = (tree.closest_hit(r), closest_hit_brute(tris, r));
            assert_eq!(a.bits(), b.bits(), "{name}/{}: closest {r:?}", kind.name());
            assert_eq!(
                tree.any_hit(r),
                any_hit_brute(tris, r),
                "{name}/{}: any {r:?}",
                kind.name()
            );
            hits += usize::from(a.is_hit());
        }
    }
    hits
}

/// Rays between random points of the box `[lo, hi]^3`, plus rays from
/// grid points along the axes (on and parallel to planes).
fn rays(rng: &mut Rng, n: usize, lo: f32, hi: f32) -> Vec<Ray> {
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        let o: [f32; 3] = std::array::from_fn(|_| rng.range(lo, hi));
        let dir: [f32; 3] = match i % 4 {
            // Axis-parallel: along split planes.
            0 => {
                let mut d = [0.0; 3];
                d[rng.below(3)] = if rng.f32() < 0.5 { 1.0 } else { -1.0 };
                d
            }
            // Parallel to one axis plane.
            1 => {
                let mut d: [f32; 3] = std::array::from_fn(|_| rng.range(-1.0, 1.0));
                d[rng.below(3)] = 0.0;
                d
            }
            _ => std::array::from_fn(|_| rng.range(-1.0, 1.0)),
        };
        // Half of the origins snapped to the integer grid: on planes.
        let origin = if i % 2 == 0 { o.map(f32::round) } else { o };
        out.push(Ray {
            origin,
            tmin: if i % 8 == 3 { 0.5 } else { 0.0 },
            dir,
            tmax: if i % 8 == 5 { 3.0 } else { f32::INFINITY },
        });
    }
    out
}

#[test]
fn random_soups_match_brute_force() {
    let mut rng = Rng::new(11);
    for (n, size) in [(50, 0.5f32), (1500, 1.0), (3000, 4.0)] {
        let tris: Vec<Triangle> = (0..n)
            .map(|_| {
                let c: [f32; 3] = std::array::from_fn(|_| rng.range(0.0, 10.0));
                tri(std::array::from_fn(|_| {
                    std::array::from_fn(|a| c[a] + rng.range(-size, size))
                }))
            })
            .collect();
        let r = rays(&mut rng, 3000, -1.0, 11.0);
        let hits = check_all("soup", &tris, &r);
        assert!(hits > n / 10, "{n}: {hits}");
    }
}

/// Axis-aligned triangles on integer planes (where the SAH puts its split
/// planes), long thin ones, and coplanar stacks.
fn adversarial(rng: &mut Rng) -> Vec<Triangle> {
    let mut t = Vec::new();
    for _ in 0..1500 {
        let axis = rng.below(3);
        let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
        let plane = rng.below(9) as f32;
        let mut p = [[0.0f32; 3]; 3];
        let base: [f32; 2] = [rng.below(8) as f32, rng.below(8) as f32];
        let sizes = [1.0, 2.0, 8.0];
        let (du, dv) = (sizes[rng.below(3)], sizes[rng.below(3)]);
        let corners = [(0.0, 0.0), (du, 0.0), (0.0, dv)];
        for (k, (cu, cv)) in corners.into_iter().enumerate() {
            p[k][axis] = plane;
            p[k][u] = base[0] + cu;
            p[k][v] = base[1] + cv;
        }
        if rng.f32() < 0.2 {
            // Tilt one vertex off the plane.
            p[2][axis] += 1.0;
        }
        t.push(tri(p));
    }
    // Long thin axis-aligned needles across the whole scene.
    for i in 0..100 {
        let y = (i % 9) as f32;
        let z = (i / 9 % 9) as f32;
        t.push(tri([[0.0, y, z], [9.0, y, z], [9.0, y + 0.01, z]]));
    }
    t
}

#[test]
fn adversarial_scenes_match_brute_force() {
    let mut rng = Rng::new(5);
    let tris = adversarial(&mut rng);
    let r = rays(&mut rng, 6000, -0.5, 9.5);
    let hits = check_all("adversarial", &tris, &r);
    assert!(hits > 1000, "{hits}");
}

#[test]
fn coplanar_axis_plane_scene_matches_brute_force() {
    let mut rng = Rng::new(9);
    let tris: Vec<Triangle> = (0..800)
        .map(|_| {
            let c = [rng.range(0.0, 10.0), rng.range(0.0, 10.0)];
            tri(std::array::from_fn(|_| {
                [
                    c[0] + rng.range(-1.0, 1.0),
                    c[1] + rng.range(-1.0, 1.0),
                    2.0,
                ]
            }))
        })
        .collect();
    let mut r = rays(&mut rng, 3000, -1.0, 11.0);
    // Rays in the plane itself and rays starting on it.
    for i in 0..500 {
        let o = [rng.range(0.0, 10.0), rng.range(0.0, 10.0), 2.0];
        let d = if i % 2 == 0 {
            [rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), 0.0]
        } else {
            [
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
            ]
        };
        r.push(Ray {
            origin: o,
            tmin: 0.0,
            dir: d,
            tmax: f32::INFINITY,
        });
    }
    check_all("coplanar", &tris, &r);
}

#[test]
fn degenerate_inputs_build_and_answer_exactly() {
    let one = vec![tri([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])];
    let same = vec![one[0]; 300];
    let zero_area: Vec<Triangle> = (0..200)
        .map(|i| {
            let x = i as f32 * 0.05;
            match i % 3 {
                0 => tri([[x, 0.0, 0.0]; 3]),
                1 => tri([[x, 0.0, 0.0], [x, 1.0, 1.0], [x, 2.0, 2.0]]),
                _ => tri([[x, 0.0, 1.0], [x + 0.5, 0.5, 1.0], [x + 1.0, 1.0, 1.0]]),
            }
        })
        .collect();
    // Huge: coordinates up to 1e17, within MAX_COORD (2^60).
    let huge: Vec<Triangle> = (0..200)
        .map(|i| {
            let s = 1e15f32;
            let x = (i as f32 - 100.0) * s;
            tri([[x, -s, 0.0], [x + s, s, s], [x, s, -s]])
        })
        .collect();
    let tiny: Vec<Triangle> = (0..200)
        .map(|i| {
            let s = 1e-30f32;
            let x = i as f32 * s;
            tri([[x, 0.0, 0.0], [x + s, s, 0.0], [x, s, s]])
        })
        .collect();
    let mut rng = Rng::new(3);
    let scenes: [(&str, Vec<Triangle>, f32); 6] = [
        ("empty", Vec::new(), 1.0),
        ("one", one, 1.0),
        ("identical", same, 1.0),
        ("zero-area", zero_area, 10.0),
        ("huge", huge, 1e17),
        ("tiny", tiny, 1e-27),
    ];
    for (name, tris, scale) in scenes {
        let mut r = rays(&mut rng, 1500, -1.5, 1.5);
        for ray in &mut r {
            ray.origin = ray.origin.map(|c| c * scale);
        }
        check_all(name, &tris, &r);
    }
}

#[test]
fn non_finite_vertices_are_rejected_by_index() {
    let good = tri([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
    for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        let mut tris = vec![good; 5];
        tris[3].v[1][2] = bad;
        for kind in BuilderKind::ALL {
            let e = build(&tris, kind, &BuildParams::default()).unwrap_err();
            assert_eq!(e, BuildError::NonFinite { triangle: 3 });
            assert!(e.to_string().contains("triangle 3"));
        }
    }
}

/// A mesh of the real-mesh folder (`KDRAY_MESHES` or `../shared/meshes`),
/// or `None`, said on stderr, in a clone without it (the generated scenes
/// still run).
fn mesh(name: &str) -> Option<Vec<Triangle>> {
    let p = common::shared_mesh("builders", name)?;
    Some(kdray::tools::mesh::load(&p).unwrap_or_else(|e| panic!("{e}")))
}

#[test]
fn real_meshes_match_brute_force() {
    let mut rng = Rng::new(17);
    for name in ["teapot.obj", "fandisk.obj", "cornell-box.obj"] {
        let Some(tris) = mesh(name) else {
            continue;
        };
        let (mut lo, mut hi) = ([f32::MAX; 3], [f32::MIN; 3]);
        for p in tris.iter().flat_map(|t| t.v) {
            for a in 0..3 {
                lo[a] = lo[a].min(p[a]);
                hi[a] = hi[a].max(p[a]);
            }
        }
        let r: Vec<Ray> = (0..800)
            .map(|_| {
                let o: [f32; 3] = std::array::from_fn(|a| {
                    let e = hi[a] - lo[a];
                    rng.range(lo[a] - 0.2 * e, hi[a] + 0.2 * e)
                });
                let target: [f32; 3] = std::array::from_fn(|a| rng.range(lo[a], hi[a]));
                Ray {
                    origin: o,
                    tmin: 0.0,
                    dir: std::array::from_fn(|a| target[a] - o[a]),
                    tmax: f32::INFINITY,
                }
            })
            .collect();
        let hits = check_all(name, &tris, &r);
        assert!(hits > 100, "{name}: {hits}");
    }
}

#[test]
fn trees_are_identical_for_any_thread_count() {
    // The built-in scene (31k triangles) always, the bunny when present:
    // both are large enough for parallel subtrees, partitions and layout.
    let scenes = [
        Some(kdray::tools::demo_scene::teapot_in_stadium().triangles),
        mesh("stanford-bunny.obj"),
    ];
    for tris in scenes.iter().flatten() {
        for kind in BuilderKind::ALL {
            let with = |threads| {
                let p = BuildParams {
                    threads: Some(threads),
                    ..BuildParams::default()
                };
                build(tris, kind, &p).unwrap()
            };
            let one = with(1);
            assert_eq!(one, with(2), "{} on {} triangles", kind.name(), tris.len());
            assert_eq!(one, with(3), "{} on {} triangles", kind.name(), tris.len());
        }
    }
}
