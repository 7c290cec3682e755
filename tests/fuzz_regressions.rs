//! The fuzz targets' properties (`fuzz/src/checks.rs`, included as is)
//! replayed under plain `cargo test`: every committed seed, and every
//! crash the fuzzers found, as a named test (files in
//! `fuzz/regressions/TARGET/`).

#[path = "../fuzz/src/checks.rs"]
#[allow(dead_code, unreachable_pub)]
mod checks;

use std::path::Path;

fn replay_dir(dir: &str, check: fn(&[u8])) -> usize {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join(dir);
    let mut n = 0;
    for entry in std::fs::read_dir(&root).unwrap_or_else(|e| panic!("{}: {e}", root.display())) {
        let path = entry.unwrap().path();
        let data = std::fs::read(&path).unwrap();
        eprintln!("replaying {}", path.display());
        check(&data);
        n += 1;
    }
    n
}

#[test]
fn seed_corpora_replay() {
    assert!(replay_dir("fuzz/corpus/blob", checks::blob) >= 3);
    assert!(replay_dir("fuzz/corpus/packet_vs_single", checks::packet_vs_single) >= 3);
    assert!(replay_dir("fuzz/corpus/tree_vs_brute", checks::tree_vs_brute) >= 3);
    assert!(replay_dir("fuzz/corpus/scene_blob", checks::scene_blob) >= 2);
    assert!(replay_dir("fuzz/corpus/point_blob", checks::point_blob) >= 3);
    assert!(replay_dir("fuzz/corpus/deforming", checks::deforming) >= 3);
    assert!(replay_dir("fuzz/corpus/distance", checks::distance) >= 4);
}

/// The raw-blob seeds of the `blob` target carry the whole-blob checksum
/// (`wire::blob_checksum`), so the fuzzer starts from blobs that pass the
/// checksum and reach structural validation, and these two load as trees.
#[test]
fn blob_seeds_pass_the_checksum() {
    use kdray::kernel::TriangleTree;
    for name in ["one_leaf", "split_x"] {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("fuzz/corpus/blob")
            .join(name);
        let data = std::fs::read(&path).unwrap();
        // Byte 0 even: the rest is the blob, as is.
        assert_eq!(data[0] & 1, 0, "{name}: not a raw-blob seed");
        let blob = kdray::tools::blob::Blob::from_bytes(&data[1..]);
        if let Err(e) = TriangleTree::from_bytes(blob.as_bytes()) {
            panic!("{name}: {e}");
        }
    }
}

/// Found by `tree_vs_brute` (150 s run): 12 triangles, two of them
/// reaching z = 4.26e37; the ray from (-3.75, 3.75, 9) hits triangle 5 at
/// t = -0.0 (accepted: -0.0 >= tmin = 0.0) by brute force, the SAH tree
/// misses. The f32 edge products had overflowed: the hit was bogus. Fixed
/// in the triangle test (an infinite determinant is no hit).
#[test]
fn tree_vs_brute_sah_misses_t_neg_zero_hit_on_huge_triangle() {
    checks::tree_vs_brute(include_bytes!(
        "../fuzz/regressions/tree_vs_brute/sah_misses_t_neg_zero_hit_on_huge_triangle"
    ));
}

/// Found by `tree_vs_brute` in a CI run: one triangle, a ray starting on
/// the scene box's z = 0 face with direction z = -1e-45 (subnormal). 1/d
/// overflowed to -inf and the slab test computed 0 * -inf = NaN, clipping
/// the ray away; brute force hits. Such slabs are now treated as parallel.
#[test]
fn tree_vs_brute_subnormal_direction_origin_on_box_face() {
    checks::tree_vs_brute(include_bytes!(
        "../fuzz/regressions/tree_vs_brute/subnormal_direction_origin_on_box_face"
    ));
}

/// Found by `tree_vs_brute` (60 s run on the packets2 branch): the ray
/// starts on an edge of the scene box (y = z = -8, the bounds' minimum)
/// with a subnormal y direction (-1e-45, so 1/dir = -inf). The slab test
/// computed 0 * -inf = NaN for the y = -8 plane, kept only the other end
/// (-inf) and rejected the ray; brute force hits triangle 4, whose edge
/// the origin lies on, at t = 2.3e-9. The same fault as the test above
/// (found the same day on main); fixed there (such slabs are parallel).
#[test]
fn tree_vs_brute_sah_misses_hit_at_origin_on_box_edge_subnormal_dir() {
    checks::tree_vs_brute(include_bytes!(
        "../fuzz/regressions/tree_vs_brute/sah_misses_hit_at_origin_on_edge_subnormal_dir"
    ));
}

/// Found by `tree_vs_brute` in a CI run: 12 triangles, one a sliver
/// reaching y = 7.6e11; the ray from (-10, -10, -10), outside the scene
/// and heading away from it. The f32 edge test passes the sliver by
/// rounding, and the plane's `t` snapped the origin onto its plane: brute
/// force hit at t = 0, outside the scene, where the tree's walk never
/// goes. The plane's `t` is now kept within the triangle's own extent
/// along the ray, so both miss.
#[test]
fn tree_vs_brute_sah_hit_at_t0_outside_the_scene_on_huge_sliver() {
    checks::tree_vs_brute(include_bytes!(
        "../fuzz/regressions/tree_vs_brute/sah_hit_at_t0_outside_the_scene_on_huge_sliver"
    ));
}

/// Found by `tree_vs_brute` in a CI run: the same fault off the ray's
/// dominant axis (a sliver reaching x = 6e12; the origin inside the
/// sliver's extent along y, the dominant axis, but below its z range).
/// The plane's `t` is kept within the ray's interval through the
/// triangle's whole box, on every axis.
#[test]
fn tree_vs_brute_sah_hit_at_t0_off_the_dominant_axis_on_huge_sliver() {
    checks::tree_vs_brute(include_bytes!(
        "../fuzz/regressions/tree_vs_brute/sah_hit_at_t0_off_the_dominant_axis_on_huge_sliver"
    ));
}

/// Found by `tree_vs_brute` in a CI run: a triangle reaching y = 2.0e14;
/// the ray from y = -10, outside the scene (y from -8) and heading away.
/// The plane's `t` was kept within the triangle's box widened by a margin
/// relative to the box's whole span (7.7e8 here), which took in the
/// origin: brute force hit at t = 0, where the tree's walk never goes.
/// The walk now clips rays to the scene box widened by twice that margin
/// of the scene's extent.
#[test]
fn tree_vs_brute_sah_hit_at_t0_outside_the_scene_in_a_huge_triangles_margin() {
    checks::tree_vs_brute(include_bytes!(
        "../fuzz/regressions/tree_vs_brute/sah_hit_at_t0_outside_the_scene_in_a_huge_triangles_margin"
    ));
}

/// Found by `tree_vs_brute` in a CI run: a sliver whose long edges (8e17
/// and 1.4e17) run along z and y, lying in the plane x = -5.25; the ray
/// from (3.5, 8.75, 9.5) meets it at t = 0.875. The plane's numerator was
/// taken for zero (an origin on the plane) by a bound that paired the long
/// edges' product with the origin's distance along z, so `t` snapped to 0
/// and the box clamp moved it to 0.325, while the `f32` window put it at
/// 0.875 and rejected it once brute force's `tmax` was below: the tree,
/// testing it first, reported it. The zero threshold is now bounded per
/// component of the normal.
#[test]
fn tree_vs_brute_sah_hits_sliver_snapped_onto_the_origin_plane() {
    checks::tree_vs_brute(include_bytes!(
        "../fuzz/regressions/tree_vs_brute/sah_hits_sliver_snapped_onto_the_origin_plane"
    ));
}

/// Found by `tree_vs_brute` in a soak run: triangle 5 runs from z = 6.25
/// to z = 2.1e9, and its `f32` edge test passes a ray at z = 2.4, 3.8
/// units beyond the short end (the vertices' own `f32` step at 2.1e9 is
/// 128). The box clamp's margin on each face is `2^-18 (|lo| + |hi| +
/// |o|)`, 8,192 units here, so brute force takes the hit at t = 0.18; the
/// fast builder listed the triangle only in cells overlapping its box,
/// which the ray meets behind its origin, and the tree missed. It now
/// lists each triangle by `Triangle::hit_bounds`. (Tried: a margin of
/// each face's own magnitude, which fixed this input and broke
/// `tree_vs_brute_subnormal_direction_origin_on_box_face` and
/// `scene_blob_subnormal_extent_slack_loses_lower_triangle`.)
#[test]
fn tree_vs_brute_fast_misses_hit_beyond_the_short_end_of_a_huge_sliver() {
    checks::tree_vs_brute(include_bytes!(
        "../fuzz/regressions/tree_vs_brute/fast_misses_hit_beyond_the_short_end_of_a_huge_sliver"
    ));
}

/// Found by `scene_blob` in a CI run: a ray with a direction near
/// `f32::MAX` along y, so its extent through an instance's mesh in `t` is
/// subnormal and the relative slack was a few subnormal steps; the mesh
/// walk missed triangle 0, which brute force hits at the same `t = 2^-128`
/// as triangle 2. The slack now has a floor (`SLACK_FLOOR`).
#[test]
fn scene_blob_subnormal_extent_slack_loses_lower_triangle() {
    checks::scene_blob(include_bytes!(
        "../fuzz/regressions/scene_blob/subnormal_extent_slack_loses_lower_triangle"
    ));
}

/// Found by `scene_blob` in a CI run: one byte of the seed scene's
/// top-level nodes overwritten (a split plane's sign and exponent, byte
/// 91) and the checksum resealed, so instance 0 is no longer in the cell
/// the ray (-1e-45, 1.2e-38, 0.75) + t (-10, -10, -10) meets it in: a
/// well-formed blob whose tree disagrees with its instances. It loads
/// and its queries run without a panic; the walk answers for the tree it
/// was given, which only the unedited scene is held to (`checks::scene_blob`).
#[test]
fn scene_blob_resealed_split_plane_edit_runs() {
    checks::scene_blob(include_bytes!(
        "../fuzz/regressions/scene_blob/resealed_split_plane_edit"
    ));
}

/// Found by `packet_vs_single` (a debug assertion): the walk deferred the
/// `f64` `t` of a hit whose window had rounded to `[-0, 0]` (heights of
/// 1e-38 times a shear of 1e-34: the estimate and the slack underflowed),
/// and `plane_t` gave `-1e-45`, outside it. The window now has an
/// absolute floor on `t` itself (`WINDOW_UNDERFLOW`).
#[test]
fn packet_vs_single_sure_window_underflows_to_zero_width() {
    checks::packet_vs_single(include_bytes!(
        "../fuzz/regressions/packet_vs_single/sure_window_underflows_to_zero_width"
    ));
}

/// Found by `scene_blob` in a CI run: in instance 0's space the ray runs
/// down the sphere's axis through its pole, from y = 2e34 with a direction
/// of (-2e-13, -2e38, 0). Its shear `dx / dy` underflows to 0, so the
/// `f32` test sees it pass exactly through the pole vertex and takes
/// every triangle of the fan at the same `t`, triangle 0 first; the walk
/// sees it at x = -2e-17 and the SAH tree listed triangle 0 (x >= 0) only
/// in cells with x >= 0, so it answered triangle 2. The clipping builders
/// now list each triangle by its hit box and clip with the triangle
/// test's margin, as `fast` does.
#[test]
fn scene_blob_ray_through_a_pole_loses_the_lower_triangle() {
    checks::scene_blob(include_bytes!(
        "../fuzz/regressions/scene_blob/ray_through_a_pole_loses_the_lower_triangle"
    ));
}
