//! What the benches share: the scenes they trace.

use kdray::kernel::{Bounds, Ray, Triangle};
use kdray::tools::blob::{write_triangle_tree, Blob};
use kdray::tools::builders::{build, BuildParams, BuilderKind};
use kdray::tools::io::read_records;
use kdray::tools::{demo_scene, mesh};
use std::path::PathBuf;

/// The built-in teapot-in-a-stadium scene, then each of `meshes` from
/// `../shared/meshes` (`NAME.obj`) that loads, a message for each that
/// does not; each with the box a camera frames.
pub(crate) fn scenes(meshes: &[&str]) -> Vec<(String, Vec<Triangle>, Bounds)> {
    let s = demo_scene::teapot_in_stadium();
    let mut out = vec![("teapot-stadium".to_string(), s.triangles, s.focus)];
    for name in meshes {
        let path = PathBuf::from(format!(
            "{}/../shared/meshes/{name}.obj",
            env!("CARGO_MANIFEST_DIR")
        ));
        match mesh::load(&path) {
            Ok(t) => {
                let b = t.iter().fold(Bounds::EMPTY, |b, x| b.union(&x.bounds()));
                out.push((name.to_string(), t, b));
            }
            Err(e) => eprintln!("{name} skipped: {e}"),
        }
    }
    out
}

/// The default build of `tris` as a blob, kept as `NAME.kdt` in the folder
/// `KDRAY_BENCH_CACHE` when set (a build under callgrind takes minutes).
#[allow(dead_code)] // not every bench keeps its trees
pub(crate) fn tree_blob(name: &str, tris: &[Triangle]) -> Blob {
    let cached = std::env::var("KDRAY_BENCH_CACHE")
        .ok()
        .map(|d| PathBuf::from(d).join(format!("{name}.kdt")));
    if let Some(Ok(b)) = cached.as_deref().map(Blob::read) {
        return b;
    }
    let built = build(tris, BuilderKind::default(), &BuildParams::default()).unwrap();
    let b = write_triangle_tree(&built, tris).expect("the bench tree fits a blob");
    if let Some(p) = &cached {
        std::fs::write(p, b.as_bytes()).expect("the cache folder is writable");
    }
    b
}

/// The Embree anchor's ray file `rays-NAME/FILE.rays` in the folder named
/// by `KDRAY_BENCH_RAYS` (`anchors/embree/rays.sh` writes them), `None`
/// when it is unset or has no such file (the scenes made here).
#[allow(dead_code)] // not every bench reads the anchor's rays
pub(crate) fn anchor_rays(name: &str, file: &str) -> Option<Vec<Ray>> {
    let dir = std::env::var("KDRAY_BENCH_RAYS").ok()?;
    let at = PathBuf::from(dir).join(format!("rays-{name}/{file}.rays"));
    if !at.exists() {
        eprintln!(
            "{}: no such file, {name} takes rays made here",
            at.display()
        );
        return None;
    }
    Some(read_records::<Ray>(&at, "rays").expect("a ray file"))
}
