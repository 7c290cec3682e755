//! The coordinate ranges end to end: `kdray knn` refuses queries the
//! kernel would answer with nothing, `kdray build --instances` refuses a
//! placement a flat build refuses, and a scene near the range is rendered,
//! not left as background.

mod common;

use common::{kdray, stderr};
use kdray_kernel::{PacketWidth, Triangle, MAX_COORD};
use kdray_tools::blob::write_triangle_tree;
use kdray_tools::builders::{build, BuildParams, BuilderKind};
use kdray_tools::camera::Camera;
use kdray_tools::render::{render, RenderParams, TreeTracer, BACKGROUND};
use std::path::PathBuf;

fn tmp(name: &str) -> PathBuf {
    common::tmp_in("ranges", name)
}

fn pts(name: &str, points: &[[f32; 3]]) -> String {
    let path = tmp(name);
    let bytes: Vec<u8> = points
        .iter()
        .flatten()
        .flat_map(|c| c.to_le_bytes())
        .collect();
    std::fs::write(&path, bytes).unwrap();
    path.display().to_string()
}

#[test]
fn knn_refuses_nan_and_out_of_range_queries_and_points() {
    let points = pts("p.pts", &[[1.0, 0.0, 0.0], [4.0, 0.0, 0.0]]);
    let out = tmp("out.knn").display().to_string();
    for (name, q, says) in [
        ("nan.pts", [0.0, f32::NAN, 0.0], "non-finite"),
        ("far.pts", [5e20, 0.0, 0.0], "beyond the range"),
    ] {
        let queries = pts(name, &[[1.0, 1.0, 1.0], q]);
        let o = kdray(&["knn", &points, &queries, "-k", "1", "-o", &out]);
        let e = stderr(&o);
        assert!(!o.status.success(), "{name} accepted");
        assert!(
            e.contains(name) && e.contains("query") && e.contains("point 1"),
            "{e}"
        );
        assert!(e.contains(says), "{e}");
    }
    // The issue's points: the squared distances overflowed f32 and point 0
    // came back at inf.
    let far = pts("far-points.pts", &[[1e20, 0.0, 0.0], [4e20, 0.0, 0.0]]);
    let queries = pts("q.pts", &[[1.0, 0.0, 0.0]]);
    let o = kdray(&["knn", &far, &queries, "-k", "1", "-o", &out]);
    let e = stderr(&o);
    assert!(!o.status.success());
    assert!(
        e.contains("far-points.pts: point 0 has coordinate 1.0000000"),
        "{e}"
    );
    assert!(e.contains("axis 0") && e.contains("2^61"), "{e}");
}

/// The two-quad glTF of the C API's tests with its second node scaled by
/// `scale`.
fn scaled_gltf(name: &str, scale: f32) -> String {
    let json = format!(
        r#"{{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": [0, 1]}}], "nodes": [{{"mesh": 0, "translation": [0, 0, 5]}}, {{"mesh": 0, "scale": [{scale:e}, {scale:e}, {scale:e}]}}], "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}, "indices": 1}}]}}], "buffers": [{{"byteLength": 60, "uri": "data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAACAPwAAgD8AAAAAAAAAAAAAgD8AAAAAAAABAAIAAAACAAMA"}}], "bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": 48}}, {{"buffer": 0, "byteOffset": 48, "byteLength": 12}}], "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}}, {{"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"}}]}}"#
    );
    let path = tmp(name);
    std::fs::write(&path, json).unwrap();
    path.display().to_string()
}

#[test]
fn instances_are_held_to_the_flat_builds_range() {
    let huge = scaled_gltf("huge.gltf", 1e30);
    let out = tmp("huge.kdt").display().to_string();
    let flat = kdray(&["build", &huge, "-o", &out]);
    assert!(!flat.status.success());
    assert!(stderr(&flat).contains("MAX_COORD"), "{}", stderr(&flat));
    let inst = kdray(&["build", &huge, "-o", &out, "--instances"]);
    let e = stderr(&inst);
    assert!(
        !inst.status.success(),
        "--instances accepted a node scale of 1e30"
    );
    assert!(e.contains("instance 1") && e.contains("MAX_COORD"), "{e}");
    // In range, both builds work.
    let fine = scaled_gltf("fine.gltf", 1e6);
    assert!(kdray(&["build", &fine, "-o", &out, "--instances"])
        .status
        .success());
}

/// A mesh whose coordinates reach 2^59: the framing camera's eye, three
/// radii out, would sit beyond the kernel's range, where rays may miss
/// everything; it is kept inside, so the picture shows the mesh.
#[test]
fn a_mesh_near_the_range_is_framed_from_inside_it() {
    let s = MAX_COORD / 2.0;
    let f = |a: [f32; 3], b: [f32; 3], c: [f32; 3]| Triangle { v: [a, b, c] };
    let tris = vec![
        f([0.0; 3], [s, 0.0, 0.0], [s, s, 0.0]),
        f([0.0; 3], [s, s, 0.0], [0.0, s, 0.0]),
        f([0.0; 3], [s, 0.0, 0.0], [0.0, 0.0, s]),
    ];
    let built = build(&tris, BuilderKind::default(), &BuildParams::default()).unwrap();
    let blob = write_triangle_tree(&built, &tris).unwrap();
    let tree = blob.tree().unwrap();
    let camera = Camera::framing(&tree.bounds());
    assert!(
        camera.eye.to_array().iter().all(|c| c.abs() <= MAX_COORD),
        "{camera:?}"
    );
    let tracer = TreeTracer {
        tree: &tree,
        width: PacketWidth::One,
    };
    let img = render(&tracer, &RenderParams::new(camera, 48, 36), &|| {});
    let hit = img.pixels.iter().filter(|&&p| p != BACKGROUND).count();
    assert!(
        hit > 48 * 36 / 10,
        "{hit} of {} pixels show the mesh",
        48 * 36
    );
}
