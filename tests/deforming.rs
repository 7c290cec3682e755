//! Deforming meshes: a tree kept over frames of moving triangles
//! (`DeformingMesh`) answers every ray as brute force over that frame's
//! triangles does, bit for bit, closest and any hit, whether a frame
//! refilled the kept planes or rebuilt; a bad frame is refused and the
//! tree kept.

use kdray::kernel::{any_hit_brute, closest_hit_brute, glam::Vec3, Ray, Triangle};
use kdray::tools::builders::{BuildError, BuildParams};
use kdray::tools::deforming::DeformingMesh;
use kdray::tools::instances::{sphere, torus};
use kdray::tools::rng::Rng;
use proptest::prelude::*;

/// `rest` under a wave along x travelling up y, of `amplitude` at `frame`.
fn waved(rest: &[Triangle], frame: u32, amplitude: f32) -> Vec<Triangle> {
    rest.iter()
        .map(|t| Triangle {
            v: t.v
                .map(|[x, y, z]| [x + amplitude * (0.4 * frame as f32 + 3.0 * y).sin(), y, z]),
        })
        .collect()
}

/// Rays from a sphere of radius 3 through random points of the unit cube,
/// some grazing, some from inside.
fn rays(r: &mut Rng, n: usize) -> Vec<Ray> {
    (0..n)
        .map(|i| {
            let p = Vec3::new(r.range(-1.2, 1.2), r.range(-1.2, 1.2), r.range(-1.2, 1.2));
            let o = if i % 4 == 0 {
                Vec3::new(r.range(-0.5, 0.5), r.range(-0.5, 0.5), r.range(-0.5, 0.5))
            } else {
                Vec3::new(r.range(-1.0, 1.0), r.range(-1.0, 1.0), r.range(-1.0, 1.0))
                    .normalize_or_zero()
                    * 3.0
            };
            Ray::new(o, p - o)
        })
        .collect()
}

/// Runs `frames` frames of the wave over `rest` and checks each frame's
/// tree against brute force; returns how many frames rebuilt.
fn run(rest: &[Triangle], frames: u32, amplitude: f32) -> u32 {
    let mut mesh = DeformingMesh::new(rest, &BuildParams::default(), DeformingMesh::DRIFT).unwrap();
    let mut r = Rng::new(u64::from(frames));
    let mut rebuilds = 0;
    for f in 1..=frames {
        let tris = waved(rest, f, amplitude);
        rebuilds += u32::from(mesh.update(&tris).unwrap());
        let tree = mesh.view(&tris).unwrap();
        for ray in rays(&mut r, 300) {
            assert_eq!(
                tree.closest_hit(&ray).bits(),
                closest_hit_brute(&tris, &ray).bits(),
                "frame {f}: {ray:?}"
            );
            assert_eq!(
                tree.any_hit(&ray),
                any_hit_brute(&tris, &ray),
                "frame {f}: {ray:?}"
            );
        }
    }
    rebuilds
}

#[test]
fn small_motions_keep_the_planes_and_match_brute_force() {
    // 0.002 a frame against triangles ~0.2 across: few cross a plane,
    // and the cost stays within the drift.
    assert_eq!(run(&sphere(16, 32), 12, 0.02), 0);
}

#[test]
fn large_motions_rebuild_and_match_brute_force() {
    // A wave of a third of the mesh: the kept planes drift, frames rebuild.
    assert!(run(&torus(24, 16), 12, 0.3) > 0);
}

#[test]
fn a_frame_with_a_bad_triangle_is_refused_and_the_tree_kept() {
    let rest = sphere(8, 12);
    let mut mesh =
        DeformingMesh::new(&rest, &BuildParams::default(), DeformingMesh::DRIFT).unwrap();
    let mut bad = waved(&rest, 1, 0.05);
    bad[7].v[1][2] = f32::NAN;
    assert_eq!(
        mesh.update(&bad),
        Err(BuildError::NonFinite { triangle: 7 })
    );
    let tree = mesh.view(&rest).unwrap();
    let ray = Ray::new(Vec3::new(0.0, 0.0, -3.0), Vec3::Z);
    assert_eq!(
        tree.closest_hit(&ray).bits(),
        closest_hit_brute(&rest, &ray).bits()
    );
    // Another count of triangles is refused by the view, not traced.
    assert!(mesh.view(&rest[..10]).is_err());
    let more = [rest.as_slice(), &rest[..1]].concat();
    assert!(mesh.view(&more).is_err());
}

/// A random triangle soup within `[-1, 1]^3`: small, large, slivers.
fn soup() -> impl Strategy<Value = Vec<Triangle>> {
    let c = -1.0f32..1.0;
    let v = [c.clone(), c.clone(), c];
    let tri = (v.clone(), v.clone(), v, 0.0f32..1.0).prop_map(|(a, b, c, s)| {
        // Shrink towards the first vertex: from the whole box to a speck.
        let s = s * s;
        let p = |w: [f32; 3]| core::array::from_fn(|i| a[i] + (w[i] - a[i]) * s);
        Triangle { v: [a, p(b), p(c)] }
    });
    prop::collection::vec(tri, 0..80)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    /// Every triangle moving on its own, frame after frame: each frame's
    /// tree answers as brute force over that frame's triangles.
    #[test]
    fn random_motions_match_brute_force(rest in soup(), speed in 0.0f32..0.2, seed in 0u64..1000) {
        let mut mesh = DeformingMesh::new(&rest, &BuildParams::default(), DeformingMesh::DRIFT).unwrap();
        let mut r = Rng::new(seed);
        let mut tris = rest;
        for f in 0..6 {
            for t in &mut tris {
                let d = [r.range(-speed, speed), r.range(-speed, speed), r.range(-speed, speed)];
                for p in &mut t.v {
                    for a in 0..3 {
                        p[a] += d[a] + r.range(-0.1, 0.1) * speed;
                    }
                }
            }
            mesh.update(&tris).unwrap();
            let tree = mesh.view(&tris).unwrap();
            for ray in rays(&mut r, 60) {
                prop_assert_eq!(tree.closest_hit(&ray).bits(), closest_hit_brute(&tris, &ray).bits(), "frame {}: {:?}", f, ray);
                prop_assert_eq!(tree.any_hit(&ray), any_hit_brute(&tris, &ray), "frame {}: {:?}", f, ray);
            }
        }
    }
}
