//! Helpers shared by the integration tests: scenes, rays, the oracle check.
#![allow(missing_docs)]
#![allow(dead_code)]

use kdray::kernel::{any_hit_brute, closest_hit_brute, Ray, Triangle};
use kdray::tools::blob::{write_triangle_tree, Blob};
use kdray::tools::builders::{build, BuildParams, BuilderKind};
use std::path::PathBuf;

/// The real-mesh folder: `KDRAY_MESHES` when set (it must be a folder:
/// the user asked for it), else `../shared/meshes` when present. `None`
/// in a clone without it, after a line on stderr saying `test` was skipped
/// and which folder was missing.
pub(crate) fn shared_meshes(test: &str) -> Option<PathBuf> {
    if let Some(dir) = std::env::var_os("KDRAY_MESHES") {
        let dir = PathBuf::from(dir);
        assert!(
            dir.is_dir(),
            "KDRAY_MESHES={} is not a folder",
            dir.display()
        );
        return Some(dir);
    }
    let dir = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/meshes"));
    if dir.is_dir() {
        Some(dir)
    } else {
        eprintln!(
            "{test}: SKIPPED: {} not found (set KDRAY_MESHES=DIR to use another folder)",
            dir.display()
        );
        None
    }
}

/// Whether the real meshes are the shared folder's (whose files and counts
/// its README lists), not a folder of the user's own (`KDRAY_MESHES`).
pub(crate) fn meshes_are_the_shared_set() -> bool {
    std::env::var_os("KDRAY_MESHES").is_none()
}

/// The mesh `name` of the real-mesh folder, or `None` (with a "skipped"
/// line naming the file) when the folder or the file is not there.
pub(crate) fn shared_mesh(test: &str, name: &str) -> Option<PathBuf> {
    let p = shared_meshes(test)?.join(name);
    if p.is_file() {
        Some(p)
    } else {
        eprintln!("{test}: {name} SKIPPED: {} not found", p.display());
        None
    }
}

/// Builds `tris` with `kind` and returns the blob (validated by the caller via `tree()`).
pub(crate) fn blob(tris: &[Triangle], kind: BuilderKind) -> Blob {
    let built = build(tris, kind, &BuildParams::default()).expect("build");
    write_triangle_tree(&built, tris).unwrap()
}

/// Asserts every builder's tree answers every ray exactly as brute force:
/// closest hit bitwise, any hit the same boolean.
pub(crate) fn assert_matches_brute(tris: &[Triangle], rays: &[Ray]) {
    for kind in BuilderKind::ALL {
        let blob = blob(tris, kind);
        let tree = blob.tree().expect("built tree validates");
        for (i, r) in rays.iter().enumerate() {
            let want = closest_hit_brute(tris, r);
            let got = tree.closest_hit(r);
            assert_eq!(
                got.bits(),
                want.bits(),
                "builder {}: ray {i} {r:?}: tree {got:?} != brute {want:?}",
                kind.name()
            );
            assert_eq!(
                tree.any_hit(r),
                any_hit_brute(tris, r),
                "builder {}: any-hit of ray {i} {r:?}",
                kind.name()
            );
        }
    }
}
