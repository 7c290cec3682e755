//! Ray streams against single rays, bit for bit: every ray of a batch
//! walked as streams (`Streams::Always`) answers as `closest_hit` /
//! `any_hit`, on random and grid-snapped scenes of every builder, with
//! random, hostile, one-sign and one-origin rays, with scratch memory
//! enough and too little (streams that find no room go on as single
//! rays), and on the shared meshes' camera and random rays.

mod common;

use kdray::kernel::{Batch, Hit, Ray, Streams, Triangle, TriangleTree, STREAM_SCRATCH_WORDS};
use kdray::tools::blob::write_triangle_tree;
use kdray::tools::builders::{build, BuildParams, BuilderKind};
use kdray::tools::camera::{random_rays, Camera};
use kdray::tools::mesh;
use kdray::tools::rng::Rng;
use proptest::prelude::*;

/// `n` small triangles in a 10-unit cube; with `grid`, vertices snapped
/// to a 1/2-unit grid (hits on shared edges, vertices and split planes).
fn scene(rng: &mut Rng, n: usize, grid: bool) -> Vec<Triangle> {
    let snap = |x: f32| if grid { (x * 2.0).round() / 2.0 } else { x };
    (0..n)
        .map(|_| {
            let c = [rng.f32() * 10.0, rng.f32() * 10.0, rng.f32() * 10.0];
            Triangle {
                v: std::array::from_fn(|_| {
                    std::array::from_fn(|a| snap(c[a] + 2.0 * rng.f32() - 1.0))
                }),
            }
        })
        .collect()
}

fn random_ray(rng: &mut Rng) -> Ray {
    Ray {
        origin: std::array::from_fn(|_| rng.f32() * 12.0 - 1.0),
        tmin: 0.0,
        dir: std::array::from_fn(|_| rng.f32() - 0.5),
        tmax: f32::INFINITY,
    }
}

/// NaN, ±0, ±inf, subnormals, origins on grid planes, odd intervals.
fn hostile_ray(rng: &mut Rng) -> Ray {
    let special = [
        0.0,
        -0.0,
        f32::NAN,
        f32::INFINITY,
        1e-42,
        -1e-42,
        f32::MIN_POSITIVE,
        1e30,
    ];
    let mut r = random_ray(rng);
    for a in 0..3 {
        match (rng.f32() * 10.0) as u32 {
            0 => r.origin[a] = rng.pick(&special),
            1 => r.dir[a] = rng.pick(&special),
            2..=3 => r.origin[a] = (r.origin[a] * 2.0).round() / 2.0,
            4 => r.dir[a] = 0.0,
            _ => {}
        }
    }
    r.tmin = rng.pick(&[0.0, -0.0, 0.0, 1.0, -5.0, f32::NAN]);
    r.tmax = rng.pick(&[f32::INFINITY, f32::INFINITY, 3.0, 0.0, f32::NAN, -1.0]);
    r
}

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
            let hostile: Vec<Ray> = (0..300).map(|_| hostile_ray(&mut rng)).collect();
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
            .map(|i| if i % 4 == 0 { hostile_ray(&mut rng) } else { random_ray(&mut rng) })
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
