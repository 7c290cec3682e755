//! Hostile blobs: truncated, bit-flipped and hand-crafted bad trees are
//! refused with the right error, never a panic; whatever is accepted can
//! be traced without a panic or an endless loop.

use kdray::kernel::format::wire::{blob_checksum, CHECKSUM_OFFSET};
use kdray::kernel::{Axis, BlobError, Bounds, Node, Ray, Triangle, TriangleTree, MAX_DEPTH};
use kdray::tools::blob::{write_triangle_tree, Blob};
use kdray::tools::builders::{BuildParams, BuiltTree};
use kdray::tools::rng::Rng;

fn tris() -> Vec<Triangle> {
    let mut rng = Rng::new(7);
    (0..40)
        .map(|_| Triangle {
            v: std::array::from_fn(|_| std::array::from_fn(|_| rng.range(0.0, 4.0))),
        })
        .collect()
}

fn good_blob() -> (Blob, Vec<Triangle>) {
    let t = tris();
    let built =
        kdray::tools::builders::build(&t, Default::default(), &BuildParams::default()).unwrap();
    (write_triangle_tree(&built, &t).unwrap(), t)
}

/// A blob with the given nodes and primitive runs over [`tris`], checksum right.
fn crafted(nodes: Vec<Node>, prims: Vec<u32>, max_depth: u32) -> Blob {
    let t = tris();
    let tree = BuiltTree {
        nodes,
        prims,
        bounds: Bounds {
            min: [0.0; 3],
            max: [4.0; 3],
        },
        max_depth,
    };
    write_triangle_tree(&tree, &t).unwrap()
}

fn err(blob: &Blob) -> BlobError {
    blob.tree().expect_err("hostile blob accepted")
}

fn leaf(count: u32, word: u32) -> Node {
    Node::leaf(count, word).unwrap()
}

/// Node 1 of every triangle tree: the padding before the first pair.
const PAD: Node = Node::EMPTY_LEAF;

fn split(child: u32) -> Node {
    Node::interior(Axis::X, 2.0, child).unwrap()
}

/// Re-seals a mutated blob's checksum so the structural checks are reached.
fn reseal(bytes: &mut [u8]) {
    let sum = blob_checksum(bytes);
    bytes[CHECKSUM_OFFSET..CHECKSUM_OFFSET + 4].copy_from_slice(&sum.to_le_bytes());
}

fn trace_some(tree: &TriangleTree<'_>) {
    let mut rng = Rng::new(3);
    for _ in 0..50 {
        let o: [f32; 3] = std::array::from_fn(|_| rng.range(-1.0, 5.0));
        let r = Ray {
            origin: o,
            tmin: 0.0,
            dir: rng.unit_vector(),
            tmax: f32::INFINITY,
        };
        let _ = tree.closest_hit(&r);
        let _ = tree.any_hit(&r);
    }
}

#[test]
fn every_truncation_is_refused() {
    let (blob, _) = good_blob();
    let bytes = blob.as_bytes();
    for len in 0..bytes.len() {
        let e = err(&Blob::from_bytes(&bytes[..len]));
        assert!(
            matches!(
                e,
                BlobError::Truncated { .. } | BlobError::TrailingBytes { .. }
            ),
            "length {len}: {e}"
        );
    }
    assert!(Blob::from_bytes(bytes).tree().is_ok());
}

#[test]
fn trailing_bytes_are_refused() {
    let (blob, _) = good_blob();
    let mut bytes = blob.as_bytes().to_vec();
    bytes.extend_from_slice(&[0; 4]);
    assert!(matches!(
        err(&Blob::from_bytes(&bytes)),
        BlobError::TrailingBytes { .. }
    ));
}

#[test]
fn every_bit_flip_is_refused_or_harmless() {
    let (blob, _) = good_blob();
    let bytes = blob.as_bytes();
    for bit in 0..bytes.len() * 8 {
        let mut b = bytes.to_vec();
        b[bit / 8] ^= 1 << (bit % 8);
        // Body flips break the checksum; header flips break a header check
        // (a flip in the stored checksum itself is a checksum error too).
        let flipped = Blob::from_bytes(&b);
        match flipped.tree() {
            Err(_) => {}
            Ok(t) => panic!(
                "bit {bit} flipped and the blob still validates ({} nodes)",
                t.nodes().len()
            ),
        }
        // With the checksum resealed, structural validation must still
        // never panic, and any accepted tree must trace safely.
        reseal(&mut b);
        if let Ok(t) = Blob::from_bytes(&b).tree() {
            trace_some(&t);
        }
    }
}

/// The bunny pattern: the sign bits of two vertex coordinates
/// flipped. A word-wise FNV-1a checksum let any two sign flips cancel (the
/// multiply by an odd prime keeps bit 31 to itself); CRC-32C refuses every
/// pair.
#[test]
fn two_flipped_sign_bits_are_refused() {
    let (blob, t) = good_blob();
    let bytes = blob.as_bytes();
    // The triangles are the last section: 9 coordinates of 4 bytes each.
    let start = bytes.len() - t.len() * 36;
    let signs: Vec<usize> = (start..bytes.len()).step_by(4).map(|w| w + 3).collect();
    for (n, &a) in signs.iter().enumerate() {
        for &b in &signs[n + 1..] {
            let mut m = bytes.to_vec();
            m[a] ^= 0x80;
            m[b] ^= 0x80;
            match Blob::from_bytes(&m).tree() {
                Err(BlobError::Checksum { .. }) => {}
                other => panic!("sign bits at bytes {a} and {b}: {other:?}"),
            }
        }
    }
}

/// Flips `k` distinct random bits of `bytes`.
fn flip_bits(rng: &mut Rng, bytes: &[u8], k: usize) -> (Vec<u8>, Vec<usize>) {
    let mut m = bytes.to_vec();
    let mut bits = Vec::with_capacity(k);
    while bits.len() < k {
        let bit = rng.below(bytes.len() * 8);
        if !bits.contains(&bit) {
            bits.push(bit);
            m[bit / 8] ^= 1 << (bit % 8);
        }
    }
    (m, bits)
}

/// Random k-bit flips, k = 1..8, no checksum resealed: every flip of up to
/// 3 bits is refused (CRC-32C's Hamming distance); more may in principle
/// validate (a 2^-32 chance), and then must still trace without a panic.
#[test]
fn random_multi_bit_flips_are_refused() {
    let (blob, _) = good_blob();
    let mut rng = Rng::new(21);
    for k in 1..=8 {
        for _ in 0..2000 {
            let (m, bits) = flip_bits(&mut rng, blob.as_bytes(), k);
            match Blob::from_bytes(&m).tree() {
                Err(_) => {}
                Ok(t) if k > 3 => trace_some(&t),
                Ok(_) => panic!("bits {bits:?} flipped and the blob still validates"),
            }
        }
    }
}

/// The same for a point tree and a scene blob, whose checksum is the
/// same function over the same header field.
#[test]
fn random_multi_bit_flips_in_point_and_scene_blobs_are_refused() {
    use kdray::kernel::{PointTree, Scene};
    let mut rng = Rng::new(22);
    let points: Vec<[f32; 3]> = (0..60)
        .map(|_| std::array::from_fn(|_| rng.range(-2.0, 2.0)))
        .collect();
    let built = kdray::tools::points::build_points(&points, &Default::default()).unwrap();
    let point_blob = kdray::tools::blob::write_point_tree(&built).unwrap();
    let (mesh, instances) = kdray::tools::instances::generated_level(3, 4.0, 5);
    let scene_blob = kdray::tools::instances::build_scene(
        &mesh,
        instances,
        Default::default(),
        &BuildParams::default(),
    )
    .unwrap()
    .write()
    .unwrap();
    assert!(PointTree::from_bytes(point_blob.as_bytes()).is_ok());
    assert!(Scene::from_bytes(scene_blob.as_bytes()).is_ok());
    for k in 1..=8 {
        for _ in 0..300 {
            let (m, bits) = flip_bits(&mut rng, point_blob.as_bytes(), k);
            let m = Blob::from_bytes(&m);
            if let Ok(t) = PointTree::from_bytes(m.as_bytes()) {
                assert!(k > 3, "point blob, bits {bits:?} flipped and it validates");
                let _ = t.knn([0.0; 3], &mut [kdray::kernel::Neighbour::NONE; 4]);
            }
            let (m, bits) = flip_bits(&mut rng, scene_blob.as_bytes(), k);
            let m = Blob::from_bytes(&m);
            if let Ok(s) = Scene::from_bytes(m.as_bytes()) {
                assert!(k > 3, "scene blob, bits {bits:?} flipped and it validates");
                let ray = Ray {
                    origin: [0.0; 3],
                    tmin: 0.0,
                    dir: [1.0, 0.5, 0.25],
                    tmax: f32::INFINITY,
                };
                let _ = s.closest_hit(&ray, !0);
            }
        }
    }
}

#[test]
fn header_fields_are_checked() {
    let (blob, _) = good_blob();
    let base = blob.as_bytes().to_vec();
    let with = |off: usize, v: u32| {
        let mut b = base.clone();
        b[off..off + 4].copy_from_slice(&v.to_le_bytes());
        Blob::from_bytes(&b)
    };
    let mut bad_magic = base.clone();
    bad_magic[0] = b'K';
    assert_eq!(err(&Blob::from_bytes(&bad_magic)), BlobError::BadMagic);
    assert_eq!(
        err(&with(8, 0xFFFE_0000)),
        BlobError::BadEndianness { found: 0xFFFE_0000 }
    );
    for old in [1, 2] {
        assert_eq!(err(&with(12, old)), BlobError::OldVersion { found: old });
        let msg = err(&with(12, old)).to_string();
        assert!(
            msg.contains("older kdray") && msg.contains("`kdray build`"),
            "{msg}"
        );
    }
    for future in [0, 4] {
        assert_eq!(
            err(&with(12, future)),
            BlobError::UnsupportedVersion { found: future }
        );
    }
    assert_eq!(
        err(&with(16, 2)),
        BlobError::WrongKind {
            expected: 1,
            found: 2
        }
    );
    assert!(matches!(
        err(&with(24, u32::MAX)),
        BlobError::Truncated { what: "nodes", .. }
    ));
    assert!(matches!(
        err(&with(32, u32::MAX)),
        BlobError::Truncated {
            what: "triangles",
            ..
        }
    ));
    assert!(matches!(err(&with(36, 0)), BlobError::Checksum { .. }));
}

#[test]
fn misaligned_input_is_refused_not_copied() {
    let (blob, _) = good_blob();
    let mut buf = vec![0u32; blob.as_bytes().len() / 4 + 1];
    let bytes: &mut [u8] = bytemuck::cast_slice_mut(&mut buf);
    bytes[1..1 + blob.as_bytes().len()].copy_from_slice(blob.as_bytes());
    let e = TriangleTree::from_bytes(&bytes[1..1 + blob.as_bytes().len()]).unwrap_err();
    assert_eq!(e, BlobError::Misaligned { offset: 1 });
}

#[test]
fn an_empty_or_short_blob_is_truncated_wherever_it_lies() {
    // An empty slice's address is a dangling 1: the error is its length,
    // not its alignment, for every kind of blob.
    let truncated = |have| BlobError::Truncated {
        what: "header",
        need: 64,
        have,
    };
    let empty: &[u8] = &[];
    assert_eq!(TriangleTree::from_bytes(empty).unwrap_err(), truncated(0));
    assert_eq!(
        kdray::kernel::PointTreeN::<3, f64>::from_bytes(empty).unwrap_err(),
        truncated(0)
    );
    assert_eq!(
        kdray::kernel::Scene::from_bytes(empty).unwrap_err(),
        kdray::kernel::SceneError::Blob(truncated(0))
    );
    let words = [0u32; 4];
    let bytes: &[u8] = bytemuck::cast_slice(&words);
    assert_eq!(
        TriangleTree::from_bytes(&bytes[1..]).unwrap_err(),
        truncated(15)
    );
}

#[test]
fn crafted_structures_get_the_right_error() {
    // A cycle: the root's children point back at the root.
    assert_eq!(
        err(&crafted(
            vec![split(0), PAD, leaf(0, 0), leaf(0, 0)],
            vec![],
            1
        )),
        BlobError::BadChild {
            node: 0,
            child: 0,
            expected: 2
        }
    );
    // A child out of range.
    assert!(matches!(
        err(&crafted(vec![split(2), PAD], vec![], 1)),
        BlobError::BadChild { node: 0, .. }
    ));
    // Two parents sharing one pair (a DAG that could blow up a walk).
    assert!(matches!(
        err(&crafted(
            vec![split(2), PAD, split(4), split(4), leaf(0, 0), leaf(0, 0)],
            vec![],
            2
        )),
        BlobError::BadChild { node: 3, .. }
    ));
    // A pair in the wrong place: the root's pair must be at node 2.
    assert!(matches!(
        err(&crafted(vec![split(1), PAD, leaf(0, 0)], vec![], 1)),
        BlobError::BadChild {
            node: 0,
            child: 1,
            expected: 2
        }
    ));
    // The padding node is not the empty leaf.
    assert!(matches!(
        err(&crafted(
            vec![split(2), leaf(1, 0), leaf(0, 0), leaf(0, 0)],
            vec![],
            1
        )),
        BlobError::BadPadding { .. }
    ));
    // Unreachable nodes after a leaf root.
    assert_eq!(
        err(&crafted(
            vec![leaf(0, 0), PAD, leaf(0, 0), leaf(0, 0)],
            vec![],
            0
        )),
        BlobError::UnreachableNodes {
            reached: 2,
            total: 4
        }
    );
    // A NaN split.
    assert_eq!(
        err(&crafted(
            vec![
                Node::interior(Axis::Y, f32::NAN, 2).unwrap(),
                PAD,
                leaf(0, 0),
                leaf(0, 0)
            ],
            vec![],
            1
        )),
        BlobError::NonFiniteSplit { node: 0 }
    );
    // A leaf run past the index array, and a primitive past the triangles.
    assert_eq!(
        err(&crafted(vec![leaf(3, 1), PAD], vec![0, 1, 2], 0)),
        BlobError::LeafRangeOutOfBounds {
            node: 0,
            offset: 1,
            count: 3
        }
    );
    assert_eq!(
        err(&crafted(vec![leaf(1, 40), PAD], vec![], 0)),
        BlobError::PrimitiveOutOfRange { at: 0, prim: 40 }
    );
    assert_eq!(
        err(&crafted(vec![leaf(2, 0), PAD], vec![0, 99], 0)),
        BlobError::PrimitiveOutOfRange { at: 1, prim: 99 }
    );
    // No nodes at all.
    assert_eq!(err(&crafted(vec![], vec![], 0)), BlobError::NoNodes);
    // A header that lies about the depth.
    assert_eq!(
        err(&crafted(
            vec![split(2), PAD, leaf(0, 0), leaf(0, 0)],
            vec![],
            5
        )),
        BlobError::BadHeaderField {
            what: "max_depth",
            found: 5
        }
    );
}

#[test]
fn depth_over_the_traversal_stack_is_refused() {
    // A chain: each interior node's below child is the next interior node.
    let depth = MAX_DEPTH + 1;
    // Node 0 is the root, node 1 padding; the treelet order places the
    // chain's pairs one after another: (2,3), (4,5), ... with below = even.
    let mut layout = vec![split(2), PAD];
    for k in 0..depth {
        let below = if k + 1 < depth {
            split(2 * k + 4)
        } else {
            leaf(0, 0)
        };
        layout.push(below);
        layout.push(leaf(0, 0));
    }
    let e = err(&crafted(layout, vec![], depth));
    assert!(
        matches!(e, BlobError::TooDeep { max: MAX_DEPTH, .. }),
        "{e}"
    );
}

#[test]
fn triangles_outside_the_bounds_are_refused() {
    let t = tris();
    let tree = BuiltTree {
        nodes: vec![leaf(0, 0), PAD],
        prims: vec![],
        bounds: Bounds {
            min: [0.0; 3],
            max: [1.0; 3],
        },
        max_depth: 0,
    };
    let e = err(&write_triangle_tree(&tree, &t).unwrap());
    assert!(matches!(e, BlobError::ItemOutsideBounds { .. }), "{e}");
    let tree = BuiltTree {
        bounds: Bounds {
            min: [0.0; 3],
            max: [f32::NAN; 3],
        },
        ..tree
    };
    assert_eq!(
        err(&write_triangle_tree(&tree, &t).unwrap()),
        BlobError::BadBounds
    );
}

#[test]
fn random_garbage_and_resealed_mutations_never_panic() {
    let (blob, _) = good_blob();
    let mut rng = Rng::new(11);
    for round in 0..3000 {
        let mut b = blob.as_bytes().to_vec();
        for _ in 0..1 + round % 8 {
            let i = (rng.next_u64() as usize) % b.len();
            b[i] = rng.next_u64() as u8;
        }
        reseal(&mut b);
        if let Ok(t) = Blob::from_bytes(&b).tree() {
            trace_some(&t);
        }
    }
}

#[test]
fn errors_read_like_sentences() {
    let msg = BlobError::LeafRangeOutOfBounds {
        node: 7,
        offset: 3,
        count: 9,
    }
    .to_string();
    assert_eq!(
        msg,
        "leaf 7 names primitives 3..3+9, outside the primitive-index array"
    );
}
