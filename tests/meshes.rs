//! Real meshes: every mesh in `../shared/meshes/` (when present) loads,
//! builds, round-trips through a blob file and agrees with brute force on
//! camera and random rays. Without the shared folder the same checks run
//! on the project's generated scenes, so a fresh clone tests the same ground.

mod common;

use common::{
    assert_matches_brute, assert_matches_f64, blob, meshes_are_the_shared_set, shared_mesh,
    shared_meshes,
};
use kdray::kernel::{Bounds, Ray, Triangle};
use kdray::tools::builders::BuilderKind;
use kdray::tools::camera::{random_rays, Camera};
use kdray::tools::{demo_scene, mesh};

fn bounds(tris: &[Triangle]) -> Bounds {
    tris.iter().fold(Bounds::EMPTY, |b, t| b.union(&t.bounds()))
}

/// Camera rays framing the mesh plus random rays through its box; fewer
/// for big meshes so brute force stays quick.
fn check_scene(name: &str, tris: &[Triangle], focus: &Bounds) {
    let side = if tris.len() > 100_000 { 24 } else { 40 };
    let mut rays = Camera::framing(focus).rays(side, side);
    rays.extend(random_rays(&bounds(tris), side as usize * 20, 5));
    eprintln!("{name}: {} triangles, {} rays", tris.len(), rays.len());
    assert_matches_brute(tris, &rays);
    check_against_f64(name, tris, focus);
}

/// Shadow rays as `gen_rays.py shadow` makes them: from points on the
/// surface (triangles picked evenly) towards a light above the scene, over
/// `[1e-4 diag / |L - o|, 0.999]`.
fn shadow_rays(tris: &[Triangle], n: usize) -> Vec<Ray> {
    let b = bounds(tris);
    let diag: f32 = (0..3)
        .map(|a| (b.max[a] - b.min[a]).powi(2))
        .sum::<f32>()
        .sqrt();
    let light: [f32; 3] =
        std::array::from_fn(|a| 0.5 * (b.min[a] + b.max[a]) + 2.0 * diag * [0.3, 1.0, 0.2][a]);
    (0..n)
        .map(|i| {
            let tri = &tris[i * tris.len() / n];
            let (u, v) = (0.25 + 0.5 * ((i * 7) % 13) as f32 / 13.0, 0.2);
            let (u, v) = (u * (1.0 - v), v);
            let o: [f32; 3] = std::array::from_fn(|a| {
                tri.v[0][a] + u * (tri.v[1][a] - tri.v[0][a]) + v * (tri.v[2][a] - tri.v[0][a])
            });
            let dir: [f32; 3] = std::array::from_fn(|a| light[a] - o[a]);
            let len = dir.iter().map(|c| c * c).sum::<f32>().sqrt();
            Ray {
                origin: o,
                tmin: 1e-4 * diag / len,
                dir,
                tmax: 0.999,
            }
        })
        .collect()
}

/// A sample of every ray set (camera, random, shadow) against the `f64`
/// reference over all triangles (`common::assert_matches_f64`).
fn check_against_f64(name: &str, tris: &[Triangle], focus: &Bounds) {
    let n = if tris.len() > 100_000 { 100 } else { 300 };
    let side = (n as f32).sqrt() as u32;
    let b = blob(tris, BuilderKind::default());
    let tree = b.tree().unwrap();
    let sets = [
        ("camera", Camera::framing(focus).rays(side, side)),
        ("random", random_rays(&bounds(tris), n, 16)),
        ("shadow", shadow_rays(tris, n)),
    ];
    for (set, rays) in sets {
        let hits = assert_matches_f64(&format!("{name} {set}"), tris, &tree, &rays, 1e-5);
        // The camera sees the scene; random rays through its box hit it.
        assert!(set == "shadow" || hits > 0, "{name} {set}: no ray hit");
    }
}

/// A plane of triangles (z = 0) with rays from points of the plane: the
/// case where the interpolated t missed a quarter of the rays.
fn planar_scene() -> (Vec<Triangle>, Vec<Ray>) {
    let mut tris = Vec::new();
    for j in 0..24 {
        for i in 0..24 {
            let (x, y) = (i as f32 * 0.75 - 9.0, j as f32 * 0.75 - 9.0);
            tris.push(Triangle {
                v: [[x, y, 0.0], [x + 0.75, y, 0.0], [x + 0.75, y + 0.75, 0.0]],
            });
            tris.push(Triangle {
                v: [[x, y, 0.0], [x + 0.75, y + 0.75, 0.0], [x, y + 0.75, 0.0]],
            });
        }
    }
    let mut rays = random_rays(&bounds(&tris), 600, 3);
    for r in &mut rays {
        r.origin[2] = 0.0;
    }
    (tris, rays)
}

#[test]
fn generated_scenes_match_brute_force() {
    let s = demo_scene::teapot_in_stadium();
    check_scene("teapot-in-stadium", &s.triangles, &s.focus);
    let (tris, rays) = planar_scene();
    assert_matches_brute(&tris, &rays);
    let b = blob(&tris, BuilderKind::default());
    let hits = assert_matches_f64("planar", &tris, &b.tree().unwrap(), &rays, 1e-5);
    assert_eq!(hits, rays.len(), "every ray starts on the plane");
}

#[test]
fn shared_meshes_load_build_and_match_brute_force() {
    let Some(dir) = shared_meshes("shared_meshes_load_build_and_match_brute_force") else {
        return;
    };
    let mut seen = 0;
    let mut entries: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .collect();
    entries.sort();
    for path in entries
        .iter()
        .filter(|p| p.extension().is_some_and(|e| e == "obj"))
    {
        let tris = mesh::load(path).unwrap_or_else(|e| panic!("{e}"));
        assert!(!tris.is_empty(), "{} has no triangles", path.display());
        check_scene(&path.display().to_string(), &tris, &bounds(&tris));
        seen += 1;
    }
    if meshes_are_the_shared_set() {
        assert!(seen >= 7, "expected the 7 shared meshes, found {seen}");
    } else {
        assert!(
            seen >= 1,
            "KDRAY_MESHES={} holds no .obj mesh",
            dir.display()
        );
    }
}

#[test]
fn triangle_counts_follow_the_fan_rule() {
    // From ../shared/meshes/README.md; a file not in the folder is skipped.
    for (file, count) in [
        ("cornell-box.obj", 36),
        ("teapot.obj", 6320),
        ("fandisk.obj", 12946),
        ("stanford-bunny.obj", 69451),
    ] {
        let Some(path) = shared_mesh("triangle_counts_follow_the_fan_rule", file) else {
            continue;
        };
        let tris = mesh::load(&path).unwrap();
        assert_eq!(tris.len(), count, "{file}");
    }
}

#[test]
fn blob_round_trips_through_a_file_and_builds_are_deterministic() {
    let s = demo_scene::teapot_in_stadium();
    let a = blob(&s.triangles, BuilderKind::default());
    let b = blob(&s.triangles, BuilderKind::default());
    assert_eq!(a.as_bytes(), b.as_bytes(), "same mesh, different bytes");
    let path = std::env::temp_dir().join(format!("kdray-roundtrip-{}.kdt", std::process::id()));
    std::fs::write(&path, a.as_bytes()).unwrap();
    let read = kdray::tools::blob::Blob::read(&path).unwrap();
    std::fs::remove_file(&path).unwrap();
    assert_eq!(read.as_bytes(), a.as_bytes());
    let (t1, t2) = (a.tree().unwrap(), read.tree().unwrap());
    for r in Camera::framing(&s.focus).rays(32, 32) {
        assert_eq!(t1.closest_hit(&r).bits(), t2.closest_hit(&r).bits());
    }
}
