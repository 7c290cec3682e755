//! Packet lanes against single rays, bit for bit, on SAH-built scenes:
//! random soups, grid-snapped scenes (hits on shared edges and split
//! planes), adversarial rays and camera-like coherent packets.

use glam::Vec3;
use kdray::kernel::{
    Batch, Hit, Packet, Packet16, Packet4, Packet8, PacketWidth, Ray, Triangle, TriangleTree, MISS,
};
use kdray::tools::blob::{write_triangle_tree, Blob};
use kdray::tools::builders::{build, BuildParams, BuilderKind};

use kdray::tools::rng::Rng;

mod common;
use common::{adversarial_ray, random_ray, scene};

// The lane-vs-single-ray check the fuzz targets use, shared rather than copied.
#[path = "../fuzz/src/checks.rs"]
#[allow(dead_code, unreachable_pub)]
mod checks;
use checks::assert_lanes;

fn blobs(tris: &[Triangle]) -> Vec<Blob> {
    BuilderKind::ALL
        .iter()
        .map(|&k| {
            write_triangle_tree(&build(tris, k, &BuildParams::default()).unwrap(), tris).unwrap()
        })
        .collect()
}

/// Gives every lane lane 0's direction signs, keeping the magnitudes:
/// packets with mixed signs go lane by lane, these walk together.
fn share_signs<const N: usize>(p: &Packet<N>) -> Packet<N> {
    let mut p = *p;
    for d in &mut p.dir {
        let sign = d[0];
        for x in d.iter_mut() {
            *x = x.copysign(sign);
        }
    }
    p
}

fn check_rays(tree: &TriangleTree, rays: &[Ray], rng: &mut Rng) -> usize {
    let mut hits = 0;
    for chunk in rays.chunks(8) {
        let mut p8 = Packet8::from_rays(chunk);
        // About one lane in eight inactive.
        for l in 0..8 {
            if rng.f32() < 0.12 {
                p8.valid[l] = false;
            }
        }
        let p4 = Packet4::from_rays(&chunk[..chunk.len().min(4)]);
        for (p8, p4) in [(p8, p4), (share_signs(&p8), share_signs(&p4))] {
            let h8 = tree.closest_hit_packet(&p8);
            hits += h8.iter().filter(|h| h.is_hit()).count();
            assert_lanes(tree, &p8, h8, tree.any_hit_packet(&p8));
            assert_lanes(
                tree,
                &p4,
                tree.closest_hit_packet(&p4),
                tree.any_hit_packet(&p4),
            );
        }
    }
    for chunk in rays.chunks(16) {
        let mut p16 = Packet16::from_rays(chunk);
        for l in 0..16 {
            if rng.f32() < 0.12 {
                p16.valid[l] = false;
            }
        }
        for p in [p16, share_signs(&p16)] {
            assert_lanes(
                tree,
                &p,
                tree.closest_hit_packet(&p),
                tree.any_hit_packet(&p),
            );
        }
    }
    hits
}

#[test]
fn random_scenes_random_rays() {
    let mut rng = Rng::new(1);
    let mut hits = 0;
    for (n, grid) in [
        (1, false),
        (30, true),
        (300, false),
        (2000, true),
        (3000, false),
    ] {
        let tris = scene(&mut rng, n, grid);
        for blob in blobs(&tris) {
            let tree = blob.tree().unwrap();
            let rays: Vec<Ray> = (0..8000).map(|_| random_ray(&mut rng)).collect();
            hits += check_rays(&tree, &rays, &mut rng);
        }
    }
    assert!(
        hits > 10_000,
        "only {hits} hits: the test checks too little"
    );
}

#[test]
fn adversarial_rays() {
    let mut rng = Rng::new(2);
    for (n, grid) in [(50, true), (1000, true), (1000, false)] {
        let tris = scene(&mut rng, n, grid);
        for blob in blobs(&tris) {
            let tree = blob.tree().unwrap();
            let rays: Vec<Ray> = (0..20000).map(|_| adversarial_ray(&mut rng)).collect();
            check_rays(&tree, &rays, &mut rng);
        }
    }
}

/// Packets from 4x2 pixel tiles of a pinhole camera: shared origin and
/// direction signs, except for tiles on the image's centre lines.
#[test]
fn camera_tiles_and_shadow_rays() {
    let mut rng = Rng::new(3);
    let tris = scene(&mut rng, 3000, true);
    let blob = &blobs(&tris)[0];
    let tree = blob.tree().unwrap();
    let eye = Vec3::new(5.0, 5.0, 25.0);
    let light = Vec3::new(12.0, 14.0, 3.0);
    let (w, h) = (128usize, 128usize);
    let mut hits = 0;
    for ty in (0..h).step_by(2) {
        for tx in (0..w).step_by(4) {
            let dirs: [Vec3; 8] = std::array::from_fn(|l| {
                let (x, y) = (tx + l % 4, ty + l / 4);
                Vec3::new(x as f32 / w as f32 - 0.5, y as f32 / h as f32 - 0.5, -1.0) * 0.5
            });
            let p = Packet8::from_vec3([eye; 8], dirs, 0.0, f32::INFINITY);
            let h8 = tree.closest_hit_packet(&p);
            assert_lanes(&tree, &p, h8, tree.any_hit_packet(&p));
            // Shadow rays from the hit points towards the light.
            let origins = std::array::from_fn(|l| Ray::new(eye, dirs[l]).at(h8[l].t.min(1e3)));
            let to_light = origins.map(|o| light - o);
            let s = Packet8::from_vec3(origins, to_light, 1e-3, 1.0);
            assert_lanes(
                &tree,
                &s,
                tree.closest_hit_packet(&s),
                tree.any_hit_packet(&s),
            );
            hits += h8.iter().filter(|h| h.is_hit()).count();
        }
        // 16 lanes: two 4x2 tiles side by side.
        for tx in (0..w).step_by(8) {
            let dirs: [Vec3; 16] = std::array::from_fn(|l| {
                let (x, y) = (tx + l % 4 + 4 * (l / 8), ty + l / 4 % 2);
                Vec3::new(x as f32 / w as f32 - 0.5, y as f32 / h as f32 - 0.5, -1.0) * 0.5
            });
            let p = Packet16::from_vec3([eye; 16], dirs, 0.0, f32::INFINITY);
            assert_lanes(
                &tree,
                &p,
                tree.closest_hit_packet(&p),
                tree.any_hit_packet(&p),
            );
        }
    }
    assert!(hits > 1000, "only {hits} camera hits");
}

#[test]
fn slice_entry_points_match_single_rays() {
    let mut rng = Rng::new(4);
    let tris = scene(&mut rng, 500, false);
    let blob = &blobs(&tris)[0];
    let tree = blob.tree().unwrap();
    let random: Vec<Ray> = (0..1003).map(|_| random_ray(&mut rng)).collect();
    // The same rays with shared direction signs: those packets walk
    // together (mixed-sign ones go ray by ray).
    let coherent: Vec<Ray> = random
        .iter()
        .map(|r| Ray {
            dir: r.dir.map(f32::abs),
            ..*r
        })
        .collect();
    // From one origin: the slices trace those in packets (scattered
    // origins go as single rays in turns over trees above 1 MiB).
    let b = tree.bounds();
    let centre = std::array::from_fn(|a| (b.min[a] + b.max[a]) / 2.0);
    let fan: Vec<Ray> = coherent
        .iter()
        .map(|r| Ray {
            origin: centre,
            ..*r
        })
        .collect();
    for rays in [random, coherent, fan] {
        let want: Vec<[u32; 4]> = rays.iter().map(|r| tree.closest_hit(r).bits()).collect();
        let want_any: Vec<bool> = rays.iter().map(|r| tree.any_hit(r)).collect();
        assert!(want_any.iter().filter(|&&a| a).count() > 100);
        for width in [
            PacketWidth::One,
            PacketWidth::Four,
            PacketWidth::Eight,
            PacketWidth::Sixteen,
        ] {
            let mut hits = vec![Hit::OCCLUDED; rays.len()];
            tree.closest_hits(
                &rays,
                &mut hits,
                Batch {
                    width: Some(width),
                    ..Batch::default()
                },
            );
            assert_eq!(
                hits.iter().map(Hit::bits).collect::<Vec<_>>(),
                want,
                "{width:?}"
            );
            let mut occ = vec![false; rays.len()];
            tree.any_hits(
                &rays,
                &mut occ,
                Batch {
                    width: Some(width),
                    ..Batch::default()
                },
            );
            assert_eq!(occ, want_any, "{width:?}");
        }
    }
}

/// A large batch of scattered shadow rays is traced in the Morton order
/// of its origins (`Order::Auto`) and answers as in its own order, each
/// answer in its ray's slot, at every width; camera-like rays (one
/// origin) and closest hits keep their order, unless `Order::Morton`
/// sorts them (closest hits by origin and direction), with the same
/// answers.
#[test]
fn batches_sorted_in_morton_order_answer_in_their_own_order() {
    use kdray::tools::trace::{trace_into, Order, Query};
    let mut rng = Rng::new(6);
    let tris = scene(&mut rng, 2000, false);
    let built = build(&tris, BuilderKind::default(), &BuildParams::default());
    let blob = write_triangle_tree(&built.unwrap(), &tris).unwrap();
    let tree = blob.tree().unwrap();
    let light = [30.0, 40.0, 20.0];
    let shadow: Vec<Ray> = (0..20_000)
        .map(|_| {
            let o: [f32; 3] = std::array::from_fn(|_| rng.f32() * 10.0);
            Ray {
                origin: o,
                tmin: 1e-4,
                dir: std::array::from_fn(|a| light[a] - o[a]),
                tmax: 1.0,
            }
        })
        .collect();
    let fan: Vec<Ray> = shadow
        .iter()
        .map(|r| Ray {
            origin: [5.0; 3],
            ..*r
        })
        .collect();
    assert!(Order::Auto.sorts(&tree, &shadow, Query::Any));
    assert!(!Order::Given.sorts(&tree, &shadow, Query::Any));
    assert!(!Order::Auto.sorts(&tree, &shadow, Query::Closest));
    assert!(!Order::Auto.sorts(&tree, &fan, Query::Any));
    assert!(!Order::Auto.sorts(&tree, &shadow[..10_000], Query::Any));
    let occluded: Vec<[u32; 4]> = shadow
        .iter()
        .map(|r| Hit::occlusion(tree.any_hit(r)).bits())
        .collect();
    let n = shadow.iter().filter(|r| tree.any_hit(r)).count();
    assert!(n > 2000 && n < 18_000, "{n} of 20,000 occluded");
    let traced = |rays: &[Ray], query: Query, width: Option<PacketWidth>, order: Order| {
        let mut hits = vec![Hit::MISS; rays.len()];
        trace_into(&tree, rays, &mut hits, query, width, order);
        hits.iter().map(Hit::bits).collect::<Vec<[u32; 4]>>()
    };
    for width in [None, Some(PacketWidth::One), Some(PacketWidth::Eight)] {
        for order in [Order::Auto, Order::Given, Order::Morton] {
            let got = traced(&shadow, Query::Any, width, order);
            assert!(got == occluded, "{width:?} {order:?}");
        }
        // The kernel's own entry point, with room for the sort and without.
        let want: Vec<bool> = shadow.iter().map(|r| tree.any_hit(r)).collect();
        for room in [2 * shadow.len(), 2 * shadow.len() - 1, 0] {
            let mut scratch = vec![0u64; room];
            let mut got = vec![false; shadow.len()];
            tree.any_hits(
                &shadow,
                &mut got,
                Batch {
                    width,
                    scratch: &mut scratch,
                    ..Batch::default()
                },
            );
            assert!(got == want, "{width:?} scratch {room}");
        }
    }
    // Closest hits, scattered in all directions:
    let random: Vec<Ray> = (0..20_000).map(|_| random_ray(&mut rng)).collect();
    // `Auto` sorts only any-hit batches; `Morton` any batch (closest
    // hits by origin and direction).
    assert!(!Order::Auto.sorts(&tree, &random, Query::Closest));
    assert!(Order::Auto.sorts(&tree, &random, Query::Any));
    assert!(Order::Morton.sorts(&tree, &random, Query::Closest));
    assert!(Order::Morton.sorts(&tree, &random[..10], Query::Any));
    assert!(!Order::Given.sorts(&tree, &random, Query::Closest));
    let want: Vec<[u32; 4]> = random.iter().map(|r| tree.closest_hit(r).bits()).collect();
    let hit = want.iter().filter(|h| h[1] != MISS).count();
    assert!(hit > 2000 && hit < 19_000, "{hit} of 20,000 hit");
    for width in [None, Some(PacketWidth::One), Some(PacketWidth::Eight)] {
        for order in [Order::Morton, Order::Given] {
            let got = traced(&random, Query::Closest, width, order);
            assert!(got == want, "{width:?} {order:?}");
        }
    }
}
