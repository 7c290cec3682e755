//! Lanes against single rays, bitwise, on a small hand-built tree whose
//! splits cut all three axes (every leaf lists every triangle, so the
//! tree is trivially exact and only the walk is under test).

use super::*;
use crate::blob::Node;
use crate::geometry::{Axis, Bounds};
use crate::triangle::Triangle;
use crate::triangle_tree::batch::{scattered, widest, AnyHit, ClosestHit, Plan};
use crate::triangle_tree::walk_choice::{Trial, Walk, CLOCK};
use crate::triangle_tree::Batch;

use crate::test_rng::Rng;

const SPLITS: [(Axis, f32); 3] = [(Axis::X, 0.5), (Axis::Z, 0.25), (Axis::Y, 0.5)];

fn scene(rng: &mut Rng) -> ([Node; 8], [u32; 64], [Triangle; 16]) {
    // Triangles on a coarse grid (shared edges and vertices, hits on
    // split planes) plus a few random ones.
    let mut tris = [Triangle { v: [[0.0; 3]; 3] }; 16];
    for (i, t) in tris.iter_mut().enumerate() {
        let g = |r: &mut Rng| (r.f() * 4.0).floor() / 4.0;
        let raw = i % 4 == 3;
        *t = Triangle {
            v: core::array::from_fn(|_| {
                core::array::from_fn(|_| if raw { rng.f() } else { g(rng) })
            }),
        };
    }
    let mut prims = [0u32; 64];
    for (i, p) in prims.iter_mut().enumerate() {
        *p = (i % 16) as u32;
    }
    let i = |a, s, c| Node::interior(a, s, c).unwrap();
    let leaf = |k: u32| Node::leaf(16, 16 * k).unwrap();
    let nodes = [
        i(SPLITS[0].0, SPLITS[0].1, 2),
        Node::EMPTY_LEAF,
        i(SPLITS[1].0, SPLITS[1].1, 4),
        i(SPLITS[2].0, SPLITS[2].1, 6),
        leaf(0),
        leaf(1),
        leaf(2),
        leaf(3),
    ];
    (nodes, prims, tris)
}

const BOUNDS: Bounds = Bounds {
    min: [0.0; 3],
    max: [1.0; 3],
};

fn component(rng: &mut Rng, special: bool) -> f32 {
    let specials = [
        0.0,
        -0.0,
        0.5,
        0.25,
        f32::NAN,
        f32::INFINITY,
        f32::NEG_INFINITY,
        1e-40,
        -1e-40,
        f32::MIN_POSITIVE,
        1.0,
        -1.0,
    ];
    if special {
        rng.pick(&specials)
    } else {
        rng.f() * 2.0 - 0.5
    }
}

fn random_ray(rng: &mut Rng, adversarial: bool) -> Ray {
    let s = |r: &mut Rng| adversarial && r.f() < 0.3;
    let mut ray = Ray {
        origin: core::array::from_fn(|_| {
            let sp = s(rng);
            component(rng, sp)
        }),
        tmin: 0.0,
        dir: core::array::from_fn(|_| {
            let sp = s(rng);
            component(rng, sp) - 0.25
        }),
        tmax: f32::INFINITY,
    };
    if adversarial {
        ray.tmin = rng.pick(&[0.0, -0.0, -1.0, 0.5, f32::NAN, f32::NEG_INFINITY]);
        ray.tmax = rng.pick(&[f32::INFINITY, 1.0, 0.0, 2.5, f32::NAN]);
        // Origins on split planes and rays along them.
        if rng.f() < 0.3 {
            let (a, sp) = rng.pick(&SPLITS);
            ray.origin[a.index()] = sp;
            if rng.f() < 0.5 {
                ray.dir[a.index()] = rng.pick(&[0.0, -0.0]);
            }
        }
    }
    ray
}

fn check_packet<const N: usize>(
    tree: &TriangleTree,
    packet: &Packet<N>,
    closest: [Hit; N],
    any: [bool; N],
) {
    for l in 0..N {
        let ray = packet.ray(l);
        let (want, want_any) = if packet.valid[l] {
            (tree.closest_hit(&ray), tree.any_hit(&ray))
        } else {
            (Hit::MISS, false)
        };
        assert_eq!(closest[l].bits(), want.bits(), "lane {l} of {packet:?}");
        assert_eq!(any[l], want_any, "any-hit lane {l} of {packet:?}");
    }
}

#[test]
fn lanes_equal_single_rays_bitwise() {
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    let mut hits = 0;
    for _ in 0..40 {
        let (nodes, prims, tris) = scene(&mut rng);
        let tree = TriangleTree::from_parts(&nodes, &prims, &tris, BOUNDS).unwrap();
        for i in 0..400 {
            let adversarial = i % 2 == 1;
            let mut p16 = Packet16::EMPTY;
            let mut p8 = Packet8::EMPTY;
            let mut p4 = Packet4::EMPTY;
            for l in 0..16 {
                let ray = random_ray(&mut rng, adversarial);
                // Some lanes stay inactive (with a ray that would hit).
                if !adversarial || rng.f() < 0.8 {
                    p16.set_ray(l, &ray);
                    p8.set_ray(l, &ray);
                    p4.set_ray(l % 4, &ray);
                } else {
                    p16.origin[0][l] = 0.25;
                    p16.dir[2][l] = -1.0;
                    if l < 8 {
                        p8.origin[0][l] = 0.25;
                        p8.dir[2][l] = -1.0;
                    }
                }
            }
            check_packet(
                &tree,
                &p16,
                tree.closest_hit_packet(&p16),
                tree.any_hit_packet(&p16),
            );
            let h8 = tree.closest_hit_packet(&p8);
            hits += h8.iter().filter(|h| h.is_hit()).count();
            check_packet(&tree, &p8, h8, tree.any_hit_packet(&p8));
            check_packet(
                &tree,
                &p4,
                tree.closest_hit_packet(&p4),
                tree.any_hit_packet(&p4),
            );
        }
    }
    // The test must exercise hits, not only misses.
    assert!(hits > 5_000, "only {hits} hits");
}

#[test]
fn coherent_packets_with_shared_signs() {
    let mut rng = Rng(7);
    let (nodes, prims, tris) = scene(&mut rng);
    let tree = TriangleTree::from_parts(&nodes, &prims, &tris, BOUNDS).unwrap();
    let eye = Vec3::new(0.5, 0.4, 2.0);
    for ty in 0..32 {
        for tx in 0..16 {
            let dirs = core::array::from_fn(|l| {
                let (x, y) = (tx * 4 + l % 4, ty * 2 + l / 4);
                Vec3::new(x as f32 / 64.0 - 0.5, y as f32 / 64.0 - 0.5, -1.0)
            });
            let p = Packet8::from_vec3([eye; 8], dirs, 0.0, f32::INFINITY);
            check_packet(
                &tree,
                &p,
                tree.closest_hit_packet(&p),
                tree.any_hit_packet(&p),
            );
            // Two such tiles side by side in 16 lanes.
            let dirs16 = core::array::from_fn(|l| {
                let (x, y) = (tx * 4 + l % 4 + 64 * (l / 8), ty * 2 + l / 4 % 2);
                Vec3::new(x as f32 / 128.0 - 0.5, y as f32 / 64.0 - 0.5, -1.0)
            });
            let p = Packet16::from_vec3([eye; 16], dirs16, 0.0, f32::INFINITY);
            check_packet(
                &tree,
                &p,
                tree.closest_hit_packet(&p),
                tree.any_hit_packet(&p),
            );
        }
    }
}

#[test]
fn slices_trace_every_ray_and_stop_at_the_shorter() {
    let mut rng = Rng(99);
    let (nodes, prims, tris) = scene(&mut rng);
    let tree = TriangleTree::from_parts(&nodes, &prims, &tris, BOUNDS).unwrap();
    let rays: [Ray; 21] = core::array::from_fn(|_| random_ray(&mut rng, false));
    for width in [
        PacketWidth::One,
        PacketWidth::Four,
        PacketWidth::Eight,
        PacketWidth::Sixteen,
    ] {
        let mut hits = [Hit::OCCLUDED; 22];
        tree.closest_hits(
            &rays,
            &mut hits,
            Batch {
                width: Some(width),
                ..Batch::default()
            },
        );
        let mut occ = [true; 20];
        tree.any_hits(
            &rays,
            &mut occ,
            Batch {
                width: Some(width),
                ..Batch::default()
            },
        );
        for (i, r) in rays.iter().enumerate() {
            assert_eq!(hits[i].bits(), tree.closest_hit(r).bits());
            if let Some(&o) = occ.get(i) {
                assert_eq!(o, tree.any_hit(r));
            }
        }
        assert_eq!(
            hits[21].bits(),
            Hit::OCCLUDED.bits(),
            "written past the rays"
        );
    }
}

/// Every answer of every entry point, at the level in use: packets of
/// 4, 8 and 16 (closest and any), the slices at every width, single rays.
fn answers(tree: &TriangleTree, rays: &[Ray]) -> ([u32; 4], [[u32; 4]; 2], u32) {
    let mut sum = [0u32; 4];
    let mut fold = |h: &Hit| {
        for (s, b) in sum.iter_mut().zip(h.bits()) {
            *s = s.wrapping_mul(31).wrapping_add(b);
        }
    };
    let mut any = 0u32;
    let mut fold_any = |o: bool| any = any.wrapping_mul(3).wrapping_add(u32::from(o));
    for chunk in rays.chunks(16) {
        let (p4, p8, p16) = (
            Packet4::from_rays(chunk),
            Packet8::from_rays(chunk),
            Packet16::from_rays(chunk),
        );
        tree.closest_hit_packet(&p4).iter().for_each(&mut fold);
        tree.closest_hit_packet(&p8).iter().for_each(&mut fold);
        tree.closest_hit_packet(&p16).iter().for_each(&mut fold);
        tree.any_hit_packet(&p4).into_iter().for_each(&mut fold_any);
        tree.any_hit_packet(&p8).into_iter().for_each(&mut fold_any);
        tree.any_hit_packet(&p16)
            .into_iter()
            .for_each(&mut fold_any);
        for r in chunk {
            fold(&tree.closest_hit(r));
            fold_any(tree.any_hit(r));
        }
    }
    let mut slices = [[0u32; 4]; 2];
    let mut hits = [Hit::MISS; 64];
    let mut occ = [false; 64];
    for width in [PacketWidth::Four, PacketWidth::Eight, PacketWidth::Sixteen] {
        for chunk in rays.chunks(64) {
            tree.closest_hits(
                chunk,
                &mut hits,
                Batch {
                    width: Some(width),
                    ..Batch::default()
                },
            );
            tree.any_hits(
                chunk,
                &mut occ,
                Batch {
                    width: Some(width),
                    ..Batch::default()
                },
            );
            for (h, &o) in hits.iter().zip(&occ).take(chunk.len()) {
                for (s, b) in slices[0].iter_mut().zip(h.bits()) {
                    *s = s.wrapping_mul(31).wrapping_add(b);
                }
                slices[1][0] = slices[1][0].wrapping_mul(3).wrapping_add(u32::from(o));
            }
        }
    }
    (sum, slices, any)
}

/// Rays of both kinds (coherent fans, which walk together, and
/// adversarial ones) for comparing levels.
fn level_rays(rng: &mut Rng, n: usize) -> impl Iterator<Item = Ray> + '_ {
    (0..n).map(move |i| {
        if i % 64 < 32 {
            let (x, y) = ((i % 8) as f32 / 16.0, (i / 8 % 4) as f32 / 16.0);
            Ray::new(Vec3::new(0.5, 0.4, 2.0), Vec3::new(x - 0.3, y - 0.2, -1.0))
        } else {
            random_ray(rng, i % 2 == 1)
        }
    })
}

#[test]
fn every_level_answers_alike() {
    let _level = crate::cpu::tests::LEVEL.lock();
    let mut rng = Rng(0xC0FF_EE00);
    let detected = crate::cpu::detected_isa();
    let mut levels = 0;
    for _ in 0..8 {
        let (nodes, prims, tris) = scene(&mut rng);
        let tree = TriangleTree::from_parts(&nodes, &prims, &tris, BOUNDS).unwrap();
        let mut rays = [Ray::new(Vec3::ZERO, Vec3::Z); 1024];
        for (r, new) in rays.iter_mut().zip(level_rays(&mut rng, 1024)) {
            *r = new;
        }
        crate::cpu::set_isa(crate::cpu::Isa::Baseline).unwrap();
        let want = answers(&tree, &rays);
        for level in crate::cpu::Isa::ALL.into_iter().filter(|&l| l <= detected) {
            crate::cpu::set_isa(level).unwrap();
            assert_eq!(crate::cpu::isa(), level);
            assert_eq!(answers(&tree, &rays), want, "{level:?}");
            levels += 1;
        }
    }
    crate::cpu::set_isa(detected).unwrap();
    assert!(levels >= 8);
}

/// The dispatch path as Miri runs it (the portable level: Miri does not
/// model `cpuid`): the entry points through `dispatch`, against single
/// rays, and a forced level above the detected one refused.
#[test]
fn dispatch_runs_the_detected_level() {
    let mut rng = Rng(5);
    let (nodes, prims, tris) = scene(&mut rng);
    let tree = TriangleTree::from_parts(&nodes, &prims, &tris, BOUNDS).unwrap();
    let rays: [Ray; 24] = core::array::from_fn(|i| level_rays(&mut rng, 64).nth(i * 2).unwrap());
    let mut hits = [Hit::MISS; 24];
    tree.closest_hits(
        &rays,
        &mut hits,
        Batch {
            width: Some(PacketWidth::Eight),
            ..Batch::default()
        },
    );
    for (r, h) in rays.iter().zip(&hits) {
        assert_eq!(h.bits(), tree.closest_hit(r).bits());
    }
    let p = Packet16::from_rays(&rays);
    check_packet(
        &tree,
        &p,
        tree.closest_hit_packet(&p),
        tree.any_hit_packet(&p),
    );
    if cfg!(miri) {
        assert_eq!(crate::cpu::detected_isa(), crate::cpu::Isa::Baseline);
        assert!(crate::cpu::set_isa(crate::cpu::Isa::Avx2).is_err());
    }
}

#[test]
fn rays_in_turns_equal_single_rays_bitwise() {
    // More rays than slots and than a block, adversarial ones among them
    // (invalid rays and rays missing the box refill their slot at once).
    let mut rng = Rng(7);
    let (nodes, prims, tris) = scene(&mut rng);
    let tree = TriangleTree::from_parts(&nodes, &prims, &tris, BOUNDS).unwrap();
    let rays: [Ray; 301] = core::array::from_fn(|i| random_ray(&mut rng, i % 3 == 0));
    assert!(
        scattered(&rays, &BOUNDS),
        "the slices would not walk these in turns"
    );
    let mut hits = [Hit::OCCLUDED; 301];
    tree.closest_hits_in_turns(&rays, &mut hits);
    for (i, r) in rays.iter().enumerate() {
        assert_eq!(hits[i].bits(), tree.closest_hit(r).bits(), "ray {i}: {r:?}");
    }
    let closest = hits.iter().filter(|h| h.is_hit()).count();
    assert!(closest > 0, "no ray hit");
    // Fewer answers than rays: the first `hits.len()` rays are answered.
    let mut fewer = [Hit::OCCLUDED; 300];
    tree.closest_hits_in_turns(&rays, &mut fewer);
    assert!(fewer.iter().zip(&hits).all(|(a, b)| a.bits() == b.bits()));
    // One origin: not scattered.
    let fan = rays.map(|r| Ray {
        origin: [0.5; 3],
        ..r
    });
    assert!(!scattered(&fan, &BOUNDS));
}

#[test]
fn batches_sort_blocks_into_kinds_time_them_and_every_walk_answers_alike() {
    let mut rng = Rng(11);
    let (nodes, prims, tris) = scene(&mut rng);
    let tree = TriangleTree::from_parts(&nodes, &prims, &tris, BOUNDS).unwrap();
    // Three blocks (the last partial) scattered, and the same rays from
    // one origin.
    let random: [Ray; 700] = core::array::from_fn(|i| random_ray(&mut rng, i % 5 == 0));
    let fan = random.map(|r| Ray {
        origin: [0.5, 0.5, 0.6],
        ..r
    });
    assert!(scattered(&random[..256], &BOUNDS) && !scattered(&fan[..256], &BOUNDS));
    let mut hits = [Hit::OCCLUDED; 700];
    let mut occ = [false; 700];
    for rays in [&random, &fan] {
        // Each kind's first and second walk, and timed.
        for trial in [Trial::First, Trial::Second, Trial::Timed] {
            let batch = || Batch {
                trial,
                ..Batch::default()
            };
            tree.closest_hits(rays, &mut hits, batch());
            tree.any_hits(rays, &mut occ, batch());
            for (i, r) in rays.iter().enumerate() {
                assert_eq!(
                    hits[i].bits(),
                    tree.closest_hit(r).bits(),
                    "{trial:?} {r:?}"
                );
                assert_eq!(occ[i], tree.any_hit(r), "{trial:?} {r:?}");
            }
        }
    }
    // The candidates: coherent blocks packets or single rays; scattered
    // ones single rays or (closest hit, x86-64) rays in turns, else packets.
    let packets = Walk::Packets(widest());
    let mut plan = Plan::new::<ClosestHit>(&Batch::default());
    let any = Plan::new::<AnyHit>(&Batch::default());
    assert_eq!(plan.coherent.walks, [packets, Walk::Single]);
    assert_eq!(any.coherent.walks, [packets, Walk::Single]);
    let in_turns = if cfg!(target_arch = "x86_64") {
        Walk::InTurns
    } else {
        packets
    };
    assert_eq!(plan.scattered.walks, [Walk::Single, in_turns]);
    assert_eq!(any.scattered.walks, [Walk::Single, packets]);
    // Each kind's blocks timed apart: three blocks, three trials.
    let round = if CLOCK { 3 } else { 0 };
    tree.slice_with::<ClosestHit>(&mut plan, &random, &mut hits);
    assert_eq!((plan.scattered.trials, plan.coherent.trials), (round, 0));
    tree.slice_with::<ClosestHit>(&mut plan, &fan, &mut hits);
    assert_eq!(
        (plan.scattered.trials, plan.coherent.trials),
        (round, round)
    );
    for (i, r) in fan.iter().enumerate() {
        assert_eq!(hits[i].bits(), tree.closest_hit(r).bits(), "{r:?}");
    }
}
