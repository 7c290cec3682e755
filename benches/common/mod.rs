//! What the benches share: the scenes they trace.

use kdray::kernel::{Bounds, Triangle};
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
