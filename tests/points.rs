//! Point trees against brute force (bit for bit, ties included) in every
//! dimension tested, f32 and f64, on the sets the issue names (uniform,
//! clustered, duplicate-heavy, all equal, on a line, on a plane), with
//! queries near and far outside; large k; and hostile point blobs.

use kdray::kernel::format::wire::{blob_checksum, CHECKSUM_OFFSET, HEADER_LEN};
use kdray::kernel::{
    distance2, knn_brute, max_point_coord, max_point_coord_log2, nearest_brute, within_brute,
    BlobError, Neighbour, PointTree, PointTreeN, Scalar, WriteError,
};
use kdray::tools::blob::{write_point_tree, Blob};
use kdray::tools::points::{build_points, knn_all, PointParams};
use kdray::tools::rng::Rng;
use proptest::prelude::*;

/// The test's coordinates, made from f64.
trait Coord: Scalar {
    fn of(x: f64) -> Self;
}
impl Coord for f32 {
    fn of(x: f64) -> Self {
        x as f32
    }
}
impl Coord for f64 {
    fn of(x: f64) -> Self {
        x
    }
}

/// A uniform f64 in [0, 1) with all 53 bits (f32 sets round it).
fn unit(r: &mut Rng) -> f64 {
    (r.next_u64() >> 11) as f64 / (1u64 << 53) as f64
}

/// The kinds of point set: uniform, clustered, duplicate-heavy (piles,
/// lattice), all on a line, all on a plane (2-D in D dimensions), all
/// equal.
const KINDS: usize = 6;

fn point_set<const D: usize, S: Coord>(kind: usize, n: usize, seed: u64) -> Vec<[S; D]> {
    let mut r = Rng::new(seed);
    let centres: Vec<[f64; D]> = (0..4)
        .map(|_| std::array::from_fn(|_| unit(&mut r)))
        .collect();
    let dir: [f64; D] = std::array::from_fn(|a| 1.0 / (a + 1) as f64);
    (0..n)
        .map(|i| {
            let p: [f64; D] = match kind {
                0 => std::array::from_fn(|_| unit(&mut r)),
                1 => {
                    let c = centres[i % centres.len()];
                    std::array::from_fn(|a| c[a] + 0.02 * unit(&mut r) - 0.01)
                }
                // A pile far larger than a leaf, a few repeated points, a lattice.
                2 => match r.next_u64() % 4 {
                    0 => [0.25; D],
                    1 => centres[(r.next_u64() % 4) as usize],
                    _ => std::array::from_fn(|_| (r.next_u64() % 4) as f64 / 4.0),
                },
                3 => {
                    let t = unit(&mut r);
                    dir.map(|d| t * d)
                }
                4 => {
                    let (u, v) = (unit(&mut r), unit(&mut r));
                    std::array::from_fn(|a| match a {
                        0 => u,
                        1 if D > 2 => v,
                        _ if a == D - 1 => 0.5 * u + 0.25 * v,
                        _ => 0.5,
                    })
                }
                _ => [0.5; D],
            };
            p.map(S::of)
        })
        .collect()
}

/// Queries near the set, on the set's points, and far outside it.
fn queries<const D: usize, S: Coord>(points: &[[S; D]], seed: u64) -> Vec<[S; D]> {
    let mut r = Rng::new(seed ^ 0x9E37);
    let mut q: Vec<[S; D]> = (0..30)
        .map(|_| std::array::from_fn(|_| S::of(1.4 * unit(&mut r) - 0.2)))
        .collect();
    q.extend(points.iter().step_by(points.len() / 8 + 1).copied());
    // Far outside, yet inside the coordinate range up to 16-D (2^60 =
    // 1.15e18; beyond it a query gets the empty answer, tested apart).
    let far = [1e6, -1e6, 3e5, -50.0, 1e18];
    q.push(std::array::from_fn(|a| S::of(far[a % far.len()])));
    q.push(std::array::from_fn(|a| {
        S::of(if a == 0 { -50.0 } else { 0.5 })
    }));
    q.push([S::of(-1e18); D]);
    q
}

fn bits<S: Scalar>(v: &[Neighbour<S>]) -> Vec<(u32, u64)> {
    v.iter().map(|n| n.bits()).collect()
}

fn check_all<const D: usize, S: Coord>(points: &[[S; D]], params: &PointParams, seed: u64) {
    let built = build_points(points, params).unwrap();
    let blob = write_point_tree(&built).unwrap();
    let tree: PointTreeN<D, S> = blob.point_tree().unwrap();
    let inf = S::INFINITY;
    for q in queries(points, seed) {
        assert_eq!(
            tree.nearest(q).map(Neighbour::bits),
            nearest_brute(points, q, inf).map(Neighbour::bits),
            "nearest {q:?}"
        );
        for k in [1, 3, 10, 40, 100] {
            let (mut a, mut b) = (vec![Neighbour::NONE; k], vec![Neighbour::NONE; k]);
            let na = tree.knn(q, &mut a);
            let nb = knn_brute(points, q, inf, &mut b);
            assert_eq!((na, bits(&a)), (nb, bits(&b)), "knn k={k} {q:?}");
        }
        let r2 = S::of(0.01);
        let (mut a, mut b) = (vec![Neighbour::NONE; 64], vec![Neighbour::NONE; 64]);
        let (ra, rb) = (
            tree.within(q, r2, &mut a),
            within_brute(points, q, r2, &mut b),
        );
        assert_eq!(ra, rb, "within {q:?}");
        if ra.is_ok() {
            assert_eq!(bits(&a), bits(&b), "within {q:?}");
        }
        // k = 1 takes the nearest point's accumulator: with a max distance too.
        for k in [1, 5] {
            let (mut a, mut b) = (vec![Neighbour::NONE; k], vec![Neighbour::NONE; k]);
            let na = tree.knn_within(q, S::of(0.02), &mut a);
            let nb = knn_brute(points, q, S::of(0.02), &mut b);
            assert_eq!((na, bits(&a)), (nb, bits(&b)), "knn_within k={k} {q:?}");
        }
    }
}

/// Every kind of set at D, for f32 and f64.
fn every_kind<const D: usize>(n: usize) {
    for kind in 0..KINDS {
        let params = PointParams {
            leaf_size: Some(8),
            parallel_min: 500,
            ..PointParams::default()
        };
        check_all(&point_set::<D, f32>(kind, n, 1 + kind as u64), &params, 2);
        check_all(&point_set::<D, f64>(kind, n, 1 + kind as u64), &params, 2);
    }
}

#[test]
fn brute_force_agreement_in_1_2_and_3_d() {
    every_kind::<1>(2000);
    every_kind::<2>(3000);
    every_kind::<3>(3000);
}

#[test]
fn brute_force_agreement_in_4_5_and_8_d() {
    every_kind::<4>(2000);
    every_kind::<5>(2000);
    every_kind::<8>(3000);
}

#[test]
fn brute_force_agreement_in_16_d() {
    every_kind::<16>(2000);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]
    #[test]
    fn tree_equals_brute_force(
        kind in 0..KINDS,
        n in 0usize..3000,
        seed in any::<u64>(),
        leaf_size in 1usize..80,
    ) {
        let params = PointParams { leaf_size: Some(leaf_size), parallel_min: 500, ..Default::default() };
        // Both builder stores: 3-D `f32` in place, 2-D `f32` and 8-D
        // `f64` through their keys.
        check_all(&point_set::<3, f32>(kind, n, seed), &params, seed);
        check_all(&point_set::<2, f32>(kind, n / 2, seed), &params, seed);
        check_all(&point_set::<8, f64>(kind, n / 3, seed), &params, seed);
    }
}

#[test]
fn every_kind_at_default_parameters() {
    for kind in 0..KINDS {
        check_all(
            &point_set::<3, f32>(kind, 20_000, 1),
            &PointParams::default(),
            2,
        );
    }
}

/// The k best by a full sort of every point: the oracle for the oracle's
/// heap at large k.
fn sorted_all<const D: usize, S: Scalar>(
    points: &[[S; D]],
    q: [S; D],
    k: usize,
) -> Vec<Neighbour<S>> {
    let mut all: Vec<Neighbour<S>> = points
        .iter()
        .enumerate()
        .map(|(i, p)| Neighbour {
            index: i as u32,
            d2: distance2(p, &q),
        })
        .collect();
    all.sort_by(|a, b| a.d2.total_cmp(&b.d2).then(a.index.cmp(&b.index)));
    all.truncate(k);
    all
}

#[test]
fn large_k_is_exact_with_the_tie_rule() {
    for kind in [0, 2, 5] {
        let points = point_set::<3, f32>(kind, 5000, 7);
        let built = build_points(&points, &PointParams::default()).unwrap();
        let tree = built.view().unwrap();
        for q in queries(&points, 8).into_iter().step_by(5) {
            // Each way the buffer is kept: sorted up to 128, the heap past
            // it.
            for k in [10, 32, 33, 128, 129, 500, 4999, 5000, 6000] {
                let (mut a, mut b) = (vec![Neighbour::NONE; k], vec![Neighbour::NONE; k]);
                let na = tree.knn(q, &mut a);
                let nb = knn_brute(&points, q, f32::INFINITY, &mut b);
                let want = sorted_all(&points, q, k);
                assert_eq!(na, want.len(), "k={k}");
                assert_eq!(bits(&a[..na]), bits(&want), "tree k={k} {q:?}");
                assert_eq!((nb, bits(&b)), (na, bits(&a)), "brute k={k} {q:?}");
            }
        }
    }
}

#[test]
fn large_k_is_fast() {
    // k = 50,000 of 100k points for 20 queries: about 1e10 shifts by sorted
    // insertion (many seconds), a fraction of a second with the heap.
    let points = point_set::<3, f32>(0, 100_000, 9);
    let built = build_points(&points, &PointParams::default()).unwrap();
    let tree = built.view().unwrap();
    let mut out = vec![Neighbour::NONE; 50_000];
    let t = std::time::Instant::now();
    for q in point_set::<3, f32>(0, 20, 10) {
        assert_eq!(tree.knn(q, &mut out), 50_000);
    }
    assert!(t.elapsed().as_secs_f64() < 3.0, "{:?}", t.elapsed());
}

#[test]
fn a_huge_pile_is_answered_by_index() {
    let mut points = vec![[0.5f32; 3]; 50_000];
    points.push([0.0; 3]);
    let tree_parts = build_points(&points, &PointParams::default()).unwrap();
    let tree = tree_parts.view().unwrap();
    let mut out = [Neighbour::NONE; 10];
    assert_eq!(tree.knn([0.5; 3], &mut out), 10);
    assert_eq!(out.map(|n| n.index), [0, 1, 2, 3, 4, 5, 6, 7, 8, 9]);
    assert_eq!(tree.nearest([0.1; 3]).unwrap().index, 50_000);
}

#[test]
fn knn_all_pads_with_none_and_matches_single_queries() {
    let points = point_set::<3, f32>(0, 5, 3);
    let built = build_points(&points, &PointParams::default()).unwrap();
    let tree = built.view().unwrap();
    let qs = queries(&points, 4);
    let mut out = vec![Neighbour::NONE; qs.len() * 7];
    knn_all(&tree, &qs, 7, &mut out);
    for (q, o) in qs.iter().zip(out.chunks(7)) {
        let mut b = [Neighbour::NONE; 7];
        knn_brute(&points, *q, f32::INFINITY, &mut b);
        assert_eq!(bits(o), bits(&b));
        assert_eq!(o[5], Neighbour::NONE);
    }
}

#[test]
fn nan_queries_are_empty_and_nan_points_are_refused() {
    let points = point_set::<3, f32>(0, 100, 5);
    let built = build_points(&points, &PointParams::default()).unwrap();
    let tree = built.view().unwrap();
    assert_eq!(tree.nearest([0.0, f32::NAN, 0.0]), None);
    let mut bad = points.clone();
    bad[42] = [1.0, f32::INFINITY, 0.0];
    let e = build_points(&bad, &PointParams::default()).unwrap_err();
    assert!(e.to_string().contains("point 42"), "{e}");
    assert!(e.to_string().contains("axis 1"), "{e}");
}

/// The case: points (1e20, 0, 0) and (4e20, 0, 0), query
/// (5e20, 0, 0): the squared distances overflow f32, both are inf, and the
/// lower index won at inf. Such points are now refused, naming the point.
#[test]
fn points_beyond_the_range_are_refused_naming_the_point() {
    assert_eq!(max_point_coord_log2::<3, f32>(), 61);
    assert_eq!(max_point_coord_log2::<16, f32>(), 60);
    assert_eq!(max_point_coord_log2::<64, f32>(), 59);
    assert_eq!(max_point_coord_log2::<128, f32>(), 59);
    assert_eq!(max_point_coord_log2::<129, f32>(), 58);
    assert_eq!(max_point_coord_log2::<3, f64>(), 509);
    assert_eq!(max_point_coord::<3, f32>(), 2f32.powi(61));
    assert_eq!(max_point_coord::<2, f64>(), 2f64.powi(510));
    let e = build_points(
        &[[1e20f32, 0.0, 0.0], [4e20, 0.0, 0.0]],
        &PointParams::default(),
    )
    .unwrap_err();
    let msg = e.to_string();
    assert!(
        msg.contains("point 0") && msg.contains("axis 0") && msg.contains("2^61"),
        "{msg}"
    );
    // The first coordinate past the bound is refused, the bound itself kept.
    let m = max_point_coord::<3, f32>();
    let past = f32::from_bits(m.to_bits() + 1);
    let e = build_points(&[[0.0; 3], [0.0, 0.0, -past]], &PointParams::default()).unwrap_err();
    assert!(
        e.to_string().contains("point 1") && e.to_string().contains("axis 2"),
        "{e}"
    );
    assert!(build_points(&[[0.0; 3], [0.0, 0.0, -m]], &PointParams::default()).is_ok());
}

/// At the bound, the largest squared distance in `D` dimensions is finite
/// (the derivation in `max_point_coord_log2`), and the tree equals brute
/// force: every corner of the box `[-M, M]^D` queried from every corner.
fn corners_stay_finite<const D: usize, S: Coord>() {
    let m = max_point_coord::<D, S>();
    let zero = S::of(0.0);
    let neg = zero - m;
    let corners: Vec<[S; D]> = (0..1usize << D.min(6))
        .map(|c| std::array::from_fn(|a| if a < 6 && c >> a & 1 == 1 { m } else { neg }))
        .collect();
    let tree_blob = write_point_tree(&build_points(&corners, &PointParams::default()).unwrap());
    let blob = tree_blob.unwrap();
    let tree = PointTreeN::<D, S>::from_bytes(blob.as_bytes()).unwrap();
    let k = corners.len();
    for q in &corners {
        let (mut got, mut want) = (vec![Neighbour::NONE; k], vec![Neighbour::NONE; k]);
        assert_eq!(tree.knn(*q, &mut got), k);
        knn_brute(&corners, *q, S::INFINITY, &mut want);
        assert_eq!(bits(&got), bits(&want), "{q:?}");
        assert!(got.iter().all(|n| n.d2.is_finite()), "{q:?}: {got:?}");
    }
}

#[test]
fn distances_at_the_range_bound_are_finite() {
    corners_stay_finite::<1, f32>();
    corners_stay_finite::<3, f32>();
    corners_stay_finite::<16, f32>();
    corners_stay_finite::<2, f64>();
    corners_stay_finite::<5, f64>();
}

/// A query beyond the range (or NaN) gets the documented empty answer from
/// every query and from brute force, never a neighbour at inf.
#[test]
fn queries_beyond_the_range_get_the_empty_answer() {
    let points = point_set::<3, f32>(0, 100, 5);
    let built = build_points(&points, &PointParams::default()).unwrap();
    let tree = built.view().unwrap();
    let m = max_point_coord::<3, f32>();
    for q in [
        [5e20f32, 0.0, 0.0],
        [0.0, -m * 2.0, 0.0],
        [0.0, 0.0, f32::NAN],
    ] {
        let mut out = [Neighbour::NONE; 3];
        assert_eq!(tree.knn(q, &mut out), 0, "{q:?}");
        assert_eq!(out, [Neighbour::NONE; 3]);
        assert_eq!(knn_brute(&points, q, f32::INFINITY, &mut out), 0);
        assert_eq!(tree.nearest(q), None);
        assert_eq!(nearest_brute(&points, q, f32::INFINITY), None);
        let mut n = 0;
        tree.for_each_within(q, f32::INFINITY, |_| n += 1);
        assert_eq!(n, 0);
    }
    // At the bound itself the answer is the brute force's, finite.
    let q = [m, -m, m];
    let mut out = [Neighbour::NONE; 2];
    assert_eq!(tree.knn(q, &mut out), 2);
    assert!(out.iter().all(|n| n.d2.is_finite()), "{out:?}");
}

/// A point blob whose root box reaches beyond the range is refused.
#[test]
fn a_point_blob_beyond_the_range_is_refused() {
    let points = point_set::<3, f32>(0, 100, 5);
    let mut built = build_points(&points, &PointParams::default()).unwrap();
    assert!(
        Blob::from_bytes(write_point_tree(&built).unwrap().as_bytes())
            .point_tree::<3, f32>()
            .is_ok()
    );
    built.bounds[0][1][1] = 2f32.powi(62);
    let blob = write_point_tree(&built).unwrap();
    let e = blob.point_tree::<3, f32>().unwrap_err();
    assert_eq!(e, BlobError::PointsOutOfRange { limit_log2: 61 });
    assert!(e.to_string().contains("2^61"), "{e}");
}

#[test]
fn a_blob_read_with_another_shape_is_refused_saying_which() {
    let points = point_set::<8, f64>(0, 300, 5);
    let blob = write_point_tree(&build_points(&points, &PointParams::default()).unwrap()).unwrap();
    assert!(blob.point_tree::<8, f64>().is_ok());
    let e = blob.point_tree::<8, f32>().unwrap_err();
    assert_eq!(
        e,
        BlobError::WrongScalar {
            expected: 4,
            found: 8
        }
    );
    assert_eq!(e.to_string(), "blob holds f64 coordinates, expected f32");
    let e = blob.point_tree::<3, f64>().unwrap_err();
    assert_eq!(
        e,
        BlobError::WrongDimension {
            expected: 3,
            found: 8
        }
    );
    assert!(e.to_string().contains("8-dimensional"), "{e}");
    // An f64 blob 4 bytes off its 8-byte alignment.
    let mut words = vec![0u32; blob.as_bytes().len() / 4 + 1];
    let bytes: &mut [u8] = bytemuck::cast_slice_mut(&mut words);
    let at = if (bytes.as_ptr() as usize).is_multiple_of(8) {
        4
    } else {
        0
    };
    let shifted = &mut bytes[at..at + blob.as_bytes().len()];
    shifted.copy_from_slice(blob.as_bytes());
    assert_eq!(
        PointTreeN::<8, f64>::from_bytes(shifted).unwrap_err(),
        BlobError::MisalignedScalar {
            align: 8,
            offset: 4
        }
    );
    // A triangle tree's loader and a point loader refuse each other's blobs.
    assert!(matches!(
        blob.tree(),
        Err(BlobError::WrongKind {
            expected: 1,
            found: 3
        })
    ));
}

#[test]
fn the_writer_refuses_a_short_buffer_and_round_trips() {
    let points = point_set::<2, f32>(1, 1000, 5);
    let built = build_points(&points, &PointParams::default()).unwrap();
    let view = built.view().unwrap();
    let len = view.blob_len().unwrap();
    let mut buf = vec![0u8; len - 1];
    assert_eq!(
        view.write_to(&mut buf),
        Err(WriteError::BufferTooSmall {
            need: len,
            have: len - 1
        })
    );
    let blob = write_point_tree(&built).unwrap();
    assert_eq!(blob.as_bytes().len(), len);
    let tree: PointTreeN<2> = blob.point_tree().unwrap();
    assert_eq!(tree.coords(), view.coords());
    for (at, &i) in tree.indices().iter().enumerate() {
        assert_eq!(tree.point(at), Some(points[i as usize]));
    }
    assert_eq!(tree.point(points.len()), None);
    assert_eq!(tree.node_bounds(), view.node_bounds());
    assert_eq!(tree.max_depth(), view.max_depth());
}

/// A valid blob with its body edited by `f`, checksum made valid again so
/// the structural checks are what refuse it.
fn edited(blob: &Blob, f: impl FnOnce(&mut [u8])) -> Blob {
    let mut bytes = blob.as_bytes().to_vec();
    f(&mut bytes[HEADER_LEN..]);
    resealed(bytes)
}

/// `bytes` with a checksum that matches them.
fn resealed(mut bytes: Vec<u8>) -> Blob {
    let sum = blob_checksum(&bytes);
    bytes[CHECKSUM_OFFSET..CHECKSUM_OFFSET + 4].copy_from_slice(&sum.to_le_bytes());
    Blob::from_bytes(&bytes)
}

fn sample_blob() -> (Blob, usize, usize) {
    let points = point_set::<3, f32>(0, 200, 9);
    let built = build_points(&points, &PointParams::default()).unwrap();
    (
        write_point_tree(&built).unwrap(),
        built.nodes.len(),
        points.len(),
    )
}

/// Where a 3-D f32 blob's sections start in its body (`points::blob`).
struct At {
    nodes: usize,
    points: usize,
    bounds: usize,
    indices: usize,
}

fn sections(nodes: usize, n: usize) -> At {
    let at_nodes = 8;
    let points = at_nodes + nodes * 8 + nodes * 4;
    let bounds = points + n * 12;
    At {
        nodes: at_nodes,
        points,
        bounds,
        indices: bounds + nodes * 24,
    }
}

#[test]
fn hostile_point_blobs_are_refused_with_the_right_error() {
    let (blob, nodes, n) = sample_blob();
    let ok: Result<PointTree, _> = blob.point_tree();
    assert!(ok.is_ok());
    let at = sections(nodes, n);
    let (points_at, bounds_at) = (at.points, at.bounds);
    // A point moved outside its leaf's box.
    let b = edited(&blob, |body| {
        body[points_at..points_at + 4].copy_from_slice(&1e9f32.to_le_bytes())
    });
    assert!(
        matches!(tree(&b), Err(BlobError::PointOutsideNode { .. })),
        "{:?}",
        tree(&b)
    );
    // A NaN point.
    let b = edited(&blob, |body| {
        body[points_at..points_at + 4].copy_from_slice(&f32::NAN.to_le_bytes())
    });
    assert!(matches!(tree(&b), Err(BlobError::PointOutsideNode { .. })));
    // A child's box sticking out of the root's.
    let b = edited(&blob, |body| {
        let at = bounds_at + 24 + 12;
        body[at..at + 4].copy_from_slice(&1e9f32.to_le_bytes());
    });
    assert!(
        matches!(tree(&b), Err(BlobError::BadNodeBounds { node: 1 })),
        "{:?}",
        tree(&b)
    );
    // An axis the points do not have.
    let b = edited(&blob, |body| {
        let at = at.nodes + 4;
        body[at..at + 4].copy_from_slice(&3u32.to_le_bytes());
    });
    assert!(
        matches!(
            tree(&b),
            Err(BlobError::AxisOutOfRange {
                node: 0,
                axis: 3,
                dim: 3
            })
        ),
        "{:?}",
        tree(&b)
    );
    // A blob whose shape record says 2-D: refused before its sections.
    let b = edited(&blob, |body| {
        body[..4].copy_from_slice(&2u32.to_le_bytes());
    });
    assert_eq!(
        tree(&b).unwrap_err(),
        BlobError::WrongDimension {
            expected: 3,
            found: 2
        }
    );
    // An index naming no point.
    let b = edited(&blob, |body| {
        let at = at.indices;
        body[at..at + 4].copy_from_slice(&u32::MAX.to_le_bytes());
    });
    assert!(matches!(
        tree(&b),
        Err(BlobError::PrimitiveOutOfRange { .. })
    ));
    // A leaf's indices out of order (the first two of the first leaf's run).
    let b = edited(&blob, |body| {
        let at = at.indices;
        let (x, y) = (body[at..at + 4].to_vec(), body[at + 4..at + 8].to_vec());
        body[at..at + 4].copy_from_slice(&y);
        body[at + 4..at + 8].copy_from_slice(&x);
    });
    assert!(matches!(tree(&b), Err(BlobError::LeafNotSorted { .. })));
    // Header bounds, which a point blob leaves zero.
    let mut bytes = blob.as_bytes().to_vec();
    bytes[40..44].copy_from_slice(&(-5.0f32).to_le_bytes());
    assert_eq!(tree(&resealed(bytes)).unwrap_err(), BlobError::BadBounds);
    // Truncated and trailing bytes.
    let bytes = blob.as_bytes();
    assert!(matches!(
        tree(&Blob::from_bytes(&bytes[..bytes.len() - 4])),
        Err(BlobError::Truncated {
            what: "point indices",
            ..
        })
    ));
    let mut long = bytes.to_vec();
    long.extend([0; 4]);
    assert!(matches!(
        tree(&Blob::from_bytes(&long)),
        Err(BlobError::TrailingBytes { .. })
    ));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]
    /// Any edit of any word of the body, checksum fixed up: refused with an
    /// error or accepted and queried, never a panic or a hang.
    #[test]
    fn edited_point_blobs_never_panic(word in 0usize..4096, value in any::<u32>(), q in prop::array::uniform3(-2.0f32..2.0)) {
        let (blob, _, _) = sample_blob();
        let words = (blob.as_bytes().len() - HEADER_LEN) / 4;
        let at = (word % words) * 4;
        let b = edited(&blob, |body| body[at..at + 4].copy_from_slice(&value.to_le_bytes()));
        if let Ok(tree) = tree(&b) {
            let mut out = [Neighbour::NONE; 8];
            tree.knn(q, &mut out);
            let _ = tree.nearest(q);
            let _ = tree.within(q, 0.5, &mut out);
        }
        // The unchecked loader must not panic either (and is only O(1)).
        if let Ok(tree) = PointTree::from_bytes_unchecked(b.as_bytes()) {
            let mut out = [Neighbour::NONE; 8];
            tree.knn(q, &mut out);
            let _ = tree.within(q, 0.5, &mut out);
        }
    }
}

/// The 3-D f32 view of a blob.
fn tree(b: &Blob) -> Result<PointTree<'_>, BlobError> {
    b.point_tree()
}
