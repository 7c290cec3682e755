//! Golden blobs: format version 3 keeps loading, embedded the way an
//! engine embeds it (`include_aligned!`), and answers exactly; versions 1
//! and 2 are refused with an error that says how to rebuild them.

use kdray::kernel::{closest_hit_brute, include_aligned, Aligned, BlobError, Ray, TriangleTree};
use kdray::tools::rng::Rng;

static CUBE_V1: &Aligned<[u8]> = include_aligned!("../kernel/golden/cube-v1.kdt");
static CUBE_V2: &Aligned<[u8]> = include_aligned!("../kernel/golden/cube-v2.kdt");
static CUBE_V3: &Aligned<[u8]> = include_aligned!("../kernel/golden/cube-v3.kdt");

fn rays() -> Vec<Ray> {
    let mut rng = Rng::new(9);
    (0..2000)
        .map(|_| Ray {
            origin: std::array::from_fn(|_| rng.range(0.01, 0.99)),
            tmin: 0.0,
            dir: rng.unit_vector(),
            tmax: f32::INFINITY,
        })
        .collect()
}

#[test]
fn v1_and_v2_blobs_are_refused_with_how_to_rebuild_them() {
    for (blob, version) in [(CUBE_V1, 1), (CUBE_V2, 2)] {
        for e in [
            TriangleTree::from_bytes(&blob.bytes).unwrap_err(),
            TriangleTree::from_bytes_unchecked(&blob.bytes).unwrap_err(),
        ] {
            assert_eq!(e, BlobError::OldVersion { found: version });
            assert!(e.to_string().contains("`kdray build`"), "{e}");
        }
    }
}

/// The version-3 cube is the version-2 one with the new version and
/// checksum: the same nodes, indices and triangles byte for byte.
#[test]
fn v3_differs_from_v2_only_in_version_and_checksum() {
    let (v2, v3) = (&CUBE_V2.bytes, &CUBE_V3.bytes);
    assert_eq!(v2.len(), v3.len());
    let differ: Vec<usize> = (0..v2.len()).filter(|&i| v2[i] != v3[i]).collect();
    assert!(
        differ.iter().all(|&i| i == 12 || (36..40).contains(&i)),
        "{differ:?}"
    );
}

#[test]
fn v3_blob_loads_in_place_and_answers_exactly() {
    assert_eq!(CUBE_V3.bytes.as_ptr() as usize % 64, 0, "a line per pair");
    let tree = TriangleTree::from_bytes(&CUBE_V3.bytes).expect("golden v3 blob loads");
    assert_eq!(tree.triangles().len(), 14);
    let mut hits = 0;
    for r in rays() {
        let want = closest_hit_brute(tree.triangles(), &r);
        assert_eq!(tree.closest_hit(&r).bits(), want.bits(), "{r:?}");
        hits += usize::from(want.is_hit());
    }
    // Every ray starts inside the closed cube: none may escape.
    assert_eq!(hits, 2000);
}

#[test]
fn unchecked_loading_gives_the_same_answers() {
    let checked = TriangleTree::from_bytes(&CUBE_V3.bytes).unwrap();
    let unchecked = TriangleTree::from_bytes_unchecked(&CUBE_V3.bytes).unwrap();
    for r in rays() {
        assert_eq!(
            checked.closest_hit(&r).bits(),
            unchecked.closest_hit(&r).bits()
        );
        assert_eq!(checked.any_hit(&r), unchecked.any_hit(&r));
    }
}
