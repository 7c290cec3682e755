//! Ray streams against single rays, bit for bit: every ray of a batch
//! walked as streams (`Streams::Always`) answers as `closest_hit` /
//! `any_hit`, on random and grid-snapped scenes of every builder, with
//! random, hostile, one-sign and one-origin rays, with scratch memory
//! enough and too little (streams that find no room go on as single
//! rays), and on the shared meshes' camera and random rays.

mod common;
use common::{adversarial_ray, random_ray, scene};

use kdray::kernel::{Batch, Hit, Ray, Streams, TriangleTree, STREAM_SCRATCH_WORDS};
use kdray::tools::blob::write_triangle_tree;
use kdray::tools::builders::{build, BuildParams, BuilderKind};
use kdray::tools::camera::{random_rays, Camera};
use kdray::tools::mesh;
use kdray::tools::rng::Rng;
use proptest::prelude::*;

/// Streams answer `rays` as single rays, closest and any hit, with
/// `words` of scratch; the number of rays that hit.
fn check(tree: &TriangleTree, rays: &[Ray], words: usize) -> usize {
    let mut scratch = vec![0u64; words];
    let mut hits = vec![Hit::OCCLUDED; rays.len()];
    tree.closest_hits(
        rays,
        &mut hits,
        Batch {
            scratch: &mut scratch,
            streams: Streams::Always,
            ..Batch::default()
        },
    );
    let mut occ = vec![false; rays.len()];
    tree.any_hits(
        rays,
        &mut occ,
        Batch {
            scratch: &mut scratch,
            streams: Streams::Always,
            ..Batch::default()
        },
    );
    let mut n = 0;
    for ((ray, h), o) in rays.iter().zip(&hits).zip(&occ) {
        let want = tree.closest_hit(ray);
        assert_eq!(h.bits(), want.bits(), "{ray:?} ({words} words)");
        assert_eq!(*o, tree.any_hit(ray), "{ray:?} ({words} words)");
        n += usize::from(want.is_hit());
    }
    n
}

#[test]
fn streams_equal_single_rays_on_generated_scenes() {
    let mut rng = Rng::new(51);
    for (round, grid) in [(0, false), (1, true), (2, false)] {
        let tris = scene(&mut rng, 300 + 400 * round, grid);
        for kind in BuilderKind::ALL {
            let built = build(&tris, kind, &BuildParams::default()).unwrap();
            let blob = write_triangle_tree(&built, &tris).unwrap();
            let tree = blob.tree().unwrap();
            let random: Vec<Ray> = (0..700).map(|_| random_ray(&mut rng)).collect();
            let hostile: Vec<Ray> = (0..300).map(|_| adversarial_ray(&mut rng)).collect();
            // One direction octant, and one origin: streams that stay together.
            let one_sign: Vec<Ray> = random
                .iter()
                .map(|r| Ray {
                    dir: r.dir.map(f32::abs),
                    ..*r
                })
                .collect();
            let fan: Vec<Ray> = one_sign
                .iter()
                .map(|r| Ray {
                    origin: [5.0, 5.0, -1.0],
                    ..*r
                })
                .collect();
            for rays in [&random, &hostile, &one_sign, &fan] {
                // Enough room; room for a few streams; none at all.
                for words in [STREAM_SCRATCH_WORDS, 600, 0] {
                    check(&tree, rays, words);
                }
            }
            assert!(check(&tree, &random, STREAM_SCRATCH_WORDS) > 100);
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]
    #[test]
    fn streams_equal_single_rays(seed in any::<u64>(), n in 1usize..200, grid in any::<bool>(), words in 0usize..4000) {
        let mut rng = Rng::new(seed);
        let tris = scene(&mut rng, n, grid);
        let built = build(&tris, BuilderKind::default(), &BuildParams::default()).unwrap();
        let blob = write_triangle_tree(&built, &tris).unwrap();
        let tree = blob.tree().unwrap();
        let rays: Vec<Ray> = (0..300)
            .map(|i| if i % 4 == 0 { adversarial_ray(&mut rng) } else { random_ray(&mut rng) })
            .collect();
        check(&tree, &rays, words);
    }
}

#[test]
fn streams_equal_single_rays_on_the_shared_meshes() {
    for name in ["stanford-bunny.obj", "teapot.obj", "sponza.obj"] {
        let Some(path) = common::shared_mesh("streams_on_shared_meshes", name) else {
            continue;
        };
        let tris = mesh::load(&path).unwrap();
        let blob = common::blob(&tris, BuilderKind::default());
        let tree = blob.tree().unwrap();
        let camera = Camera::framing(&tree.bounds()).rays(96, 96);
        let random = random_rays(&tree.bounds(), 9000, 7);
        assert!(check(&tree, &camera, STREAM_SCRATCH_WORDS) > 1000, "{name}");
        assert!(check(&tree, &random, STREAM_SCRATCH_WORDS) > 1000, "{name}");
    }
}
