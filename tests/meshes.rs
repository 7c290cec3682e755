//! Real meshes: every mesh in `../shared/meshes/` (when present) loads,
//! builds, round-trips through a blob file and agrees with brute force on
//! camera and random rays. Without the shared folder the same checks run
//! on the project's generated scenes, so a fresh clone tests the same ground.

mod common;

use common::{assert_matches_brute, blob, meshes_are_the_shared_set, shared_mesh, shared_meshes};
use kdray::kernel::Bounds;
use kdray::kernel::Triangle;
use kdray::tools::builders::BuilderKind;
use kdray::tools::camera::{random_rays, Camera};
use kdray::tools::{mesh, scene};

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
}

#[test]
fn generated_scenes_match_brute_force() {
    let s = scene::teapot_in_stadium();
    check_scene("teapot-in-stadium", &s.triangles, &s.focus);
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
    let s = scene::teapot_in_stadium();
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
