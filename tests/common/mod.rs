//! Helpers shared by the integration tests: scenes, rays, the oracle check.
#![allow(missing_docs)]
#![allow(dead_code)]

use kdray::kernel::{any_hit_brute, closest_hit_brute, Ray, Triangle};
use kdray::tools::blob::{write_triangle_tree, Blob};
use kdray::tools::builders::{build, BuildParams, BuilderKind};
use std::path::PathBuf;

/// The shared meshes folder, if present (`KDRAY_MESHES` overrides).
pub(crate) fn shared_meshes() -> Option<PathBuf> {
    let dir = std::env::var_os("KDRAY_MESHES")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/meshes")));
    dir.is_dir().then_some(dir)
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
