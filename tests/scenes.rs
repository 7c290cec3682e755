//! Scenes: the top-level walk equals the brute force over all instances
//! bit for bit (random instances with rotations, scales, mirrors and
//! masks), packets equal single rays, scene blobs round-trip and
//! malformed ones are refused with typed errors, and a generated level
//! agrees with its flattened tree.

use kdray::kernel::{Instance, Packet8, Ray, Scene, SceneError, SceneHit, Triangle, TriangleTree};
use kdray::tools::builders::{build, BuildParams, BuilderKind, BuiltTree};
use kdray::tools::instances::{
    build_scene, build_top_level, first_hits_scene, flatten_scene, flattened_offsets,
    generated_level, mesh_bounds, moved_level, placement, sphere, torus, world_boxes, SceneParts,
    TopLevel, TopParams,
};
use proptest::prelude::*;

/// Each mesh's tree, by the default builder.
fn build_all(meshes: &[Vec<Triangle>]) -> Vec<BuiltTree> {
    meshes
        .iter()
        .map(|m| build(m, BuilderKind::default(), &BuildParams::default()).unwrap())
        .collect()
}

/// The kernel's views of `trees` over their `meshes`.
fn views_of<'a>(trees: &'a [BuiltTree], meshes: &'a [Vec<Triangle>]) -> Vec<TriangleTree<'a>> {
    trees
        .iter()
        .zip(meshes)
        .map(|(t, m)| TriangleTree::from_parts(&t.nodes, &t.prims, m, t.bounds).unwrap())
        .collect()
}

fn small_meshes() -> Vec<Vec<Triangle>> {
    let tri = Triangle {
        v: [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
    };
    vec![sphere(6, 8), torus(8, 6), vec![tri, tri]]
}

fn parts(meshes: &[Vec<Triangle>], instances: Vec<Instance>) -> SceneParts {
    build_scene(
        meshes,
        instances,
        BuilderKind::default(),
        &BuildParams::default(),
    )
    .unwrap()
}

fn check(scene: &Scene<'_>, ray: &Ray, mask: u32) -> bool {
    let want = scene.closest_hit_brute(ray, mask);
    let got = scene.closest_hit(ray, mask);
    assert_eq!(got.bits(), want.bits(), "{ray:?} mask {mask:#x}");
    assert_eq!(
        scene.any_hit(ray, mask),
        scene.any_hit_brute(ray, mask),
        "{ray:?}"
    );
    // The first hits in buffers of one (the closest hit) and of eight
    // (two instances of the same mesh overlapping, the same triangle in
    // both, at equal t: ordered by instance).
    for k in [1, 8] {
        let (mut got, mut brute) = (vec![SceneHit::MISS; k], vec![SceneHit::MISS; k]);
        let n = scene.first_hits(ray, mask, &mut got);
        assert_eq!(n, scene.first_hits_brute(ray, mask, &mut brute), "{ray:?}");
        let bits = |h: &[SceneHit]| h.iter().map(SceneHit::bits).collect::<Vec<_>>();
        assert_eq!(
            bits(&got),
            bits(&brute),
            "first {k} hits of {ray:?} mask {mask:#x}"
        );
        assert_eq!(got[0].bits(), want.bits(), "the first hit is the closest");
        let rank = |h: &SceneHit| (h.t, h.instance, h.prim);
        assert!(
            got[..n].windows(2).all(|w| rank(&w[0]) < rank(&w[1])),
            "sorted by t, instance, triangle, each once: {got:?}"
        );
    }
    want.is_hit()
}

fn instance_strategy() -> impl Strategy<Value = Instance> {
    (
        0u32..3,
        prop::array::uniform3(-1.0f32..1.0),
        0.0f32..7.0,
        prop::array::uniform3(0.2f32..2.5),
        prop::array::uniform3(-6.0f32..6.0),
        any::<bool>(),
        0u32..16,
    )
        .prop_filter_map(
            "singular",
            |(mesh, axis, angle, mut scale, shift, mirror, mask)| {
                if mirror {
                    scale[1] = -scale[1];
                }
                let m = placement(axis, angle, scale, shift);
                Instance::new(mesh, m, mesh * 100, mask)
            },
        )
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    #[test]
    fn scene_equals_brute_force_bit_for_bit(
        instances in prop::collection::vec(instance_strategy(), 1..40),
        rays in prop::collection::vec(
            (prop::array::uniform3(-9.0f32..9.0), prop::array::uniform3(-1.0f32..1.0), 0u32..16),
            64,
        ),
    ) {
        let meshes = small_meshes();
        let p = parts(&meshes, instances);
        let trees = p.trees().unwrap();
        let scene = p.scene(&trees).unwrap();
        let blob = p.write().unwrap();
        let from_blob = blob.scene().unwrap();
        let mut packet_rays = Vec::new();
        for (o, d, mask) in rays {
            let ray = Ray { origin: o, tmin: 0.0, dir: d, tmax: f32::INFINITY };
            check(&scene, &ray, mask);
            assert_eq!(from_blob.closest_hit(&ray, mask).bits(), scene.closest_hit(&ray, mask).bits());
            // Aimed at an instance's centre: a hit is likely.
            let inst = &p.instances[(o[0].abs() * 10.0) as usize % p.instances.len()];
            let c = inst.to_world();
            let aim = [c[3] - o[0], c[7] - o[1], c[11] - o[2]];
            let aimed = Ray { origin: o, tmin: 0.0, dir: aim, tmax: f32::INFINITY };
            check(&scene, &aimed, u32::MAX);
            packet_rays.push(aimed);
        }
        for chunk in packet_rays.chunks(8) {
            let packet = Packet8::from_rays(chunk);
            let hits = scene.closest_hit_packet(&packet, u32::MAX);
            let any = scene.any_hit_packet(&packet, 0b101);
            for (l, ray) in chunk.iter().enumerate() {
                assert_eq!(hits[l].bits(), scene.closest_hit(ray, u32::MAX).bits());
                assert_eq!(any[l], scene.any_hit(ray, 0b101));
            }
        }
    }
}

#[test]
fn coincident_copies_tie_to_the_lower_instance() {
    // Three identical copies: every hit is a tie in t, won by instance 0;
    // mask out instance 0 and instance 1 wins.
    let m = placement([0.0, 1.0, 0.0], 0.5, [1.0, 1.0, 1.0], [0.0, 0.0, 0.0]);
    let insts = (0..3)
        .map(|k| Instance::new(0, m, k, 1 << k).unwrap())
        .collect::<Vec<_>>();
    let p = parts(&[sphere(8, 8)], insts);
    let trees = p.trees().unwrap();
    let scene = p.scene(&trees).unwrap();
    let ray = Ray {
        origin: [0.1, 0.2, -5.0],
        tmin: 0.0,
        dir: [0.0, 0.0, 1.0],
        tmax: f32::INFINITY,
    };
    assert_eq!(scene.closest_hit(&ray, u32::MAX).instance, 0);
    assert_eq!(scene.closest_hit(&ray, 0b110).instance, 1);
    assert!(!scene.any_hit(&ray, 0b1000));
    assert_eq!(scene.closest_hit(&ray, 0), SceneHit::MISS);
    check(&scene, &ray, 0b110);
    // Every copy's entry and exit: at each t the lower instance first.
    let mut first = [SceneHit::MISS; 8];
    assert_eq!(scene.first_hits(&ray, 0b111, &mut first), 6);
    assert_eq!(first.map(|h| h.instance)[..6], [0, 1, 2, 0, 1, 2]);
    assert!(first[0].t == first[2].t && first[2].t < first[3].t);
}

#[test]
fn malformed_scene_blobs_are_refused_with_what_is_wrong() {
    let meshes = small_meshes();
    let insts = (0..5)
        .map(|k| {
            let m = placement(
                [1.0, 0.0, 0.0],
                k as f32,
                [1.0, 1.0, 1.0],
                [k as f32 * 3.0, 0.0, 0.0],
            );
            Instance::new(k % 3, m, k, 1).unwrap()
        })
        .collect::<Vec<_>>();
    let p = parts(&meshes, insts);
    let good = p.write().unwrap();
    let bytes = good.as_bytes().to_vec();
    assert!(Scene::from_bytes(&bytes).is_ok());
    // A mesh tree blob is not a scene, and a scene is not a mesh tree.
    let mesh = p.meshes[0].as_bytes();
    assert!(matches!(Scene::from_bytes(mesh), Err(SceneError::Blob(_))));
    let e = TriangleTree::from_bytes(&bytes).unwrap_err();
    assert!(e.to_string().contains("scene"), "{e}");
    // Every flipped byte and every truncation: an error, never a panic.
    for at in (0..bytes.len()).step_by(7) {
        let mut bad = bytes.clone();
        bad[at] ^= 0x10;
        assert!(Scene::from_bytes(&bad).is_err(), "byte {at}");
    }
    for len in (0..bytes.len()).step_by(13) {
        assert!(Scene::from_bytes(&bytes[..len]).is_err(), "length {len}");
    }
    // Damage behind a valid checksum: each check names its problem.
    let reseal = |mut b: Vec<u8>| {
        let sum = kdray::kernel::format::wire::blob_checksum(&b);
        b[36..40].copy_from_slice(&sum.to_le_bytes());
        kdray::tools::blob::Blob::from_bytes(&b)
    };
    let inst_at = 64 + 8 * p.top.nodes.len() + 4 * p.top.prims.len();
    let mut b = bytes.clone();
    b[inst_at..inst_at + 4].copy_from_slice(&9u32.to_le_bytes());
    assert_eq!(
        reseal(b).scene().unwrap_err(),
        SceneError::MeshOutOfRange {
            instance: 0,
            mesh: 9,
            meshes: 3
        }
    );
    let mut b = bytes.clone();
    b[inst_at + 112 + 16 + 4] ^= 1; // instance 1's transform, inverse unchanged
    assert_eq!(
        reseal(b).scene().unwrap_err(),
        SceneError::BadInverse { instance: 1 }
    );
    let mut b = bytes.clone();
    b[inst_at + 12] = 1;
    assert_eq!(
        reseal(b).scene().unwrap_err(),
        SceneError::Reserved { instance: 0 }
    );
    let mut b = bytes.clone();
    b[40..44].copy_from_slice(&1000.0f32.to_le_bytes()); // bounds min x beyond every instance
    assert!(matches!(
        reseal(b).scene().unwrap_err(),
        SceneError::InstanceOutsideBounds { .. } | SceneError::Blob(_)
    ));
    let table_at = inst_at + 112 * 5 + 4;
    let mut b = bytes.clone();
    b[table_at..table_at + 4].copy_from_slice(&0u32.to_le_bytes());
    assert!(matches!(
        reseal(b).scene().unwrap_err(),
        SceneError::MeshPlacement { mesh: 0, .. }
    ));
    let mesh_at = u32::from_le_bytes(bytes[table_at..table_at + 4].try_into().unwrap()) as usize;
    let mut b = bytes.clone();
    b[mesh_at + 100] ^= 1;
    assert!(matches!(
        reseal(b).scene().unwrap_err(),
        SceneError::Mesh { mesh: 0, .. }
    ));
}

#[test]
fn a_generated_level_agrees_with_its_flattened_tree() {
    let (meshes, instances) = generated_level(60, 40.0, 7);
    let p = parts(&meshes, instances);
    let trees = p.trees().unwrap();
    let scene = p.scene(&trees).unwrap();
    let flat = flatten_scene(&meshes, &p.instances);
    let flat_tree = build(&flat, BuilderKind::default(), &BuildParams::default()).unwrap();
    let flat_view =
        TriangleTree::from_parts(&flat_tree.nodes, &flat_tree.prims, &flat, flat_tree.bounds)
            .unwrap();
    let sizes: Vec<usize> = meshes.iter().map(Vec::len).collect();
    let offsets = flattened_offsets(&sizes, &p.instances);
    let mut rng = kdray::tools::rng::Rng::new(3);
    let (mut agree, mut hits, mut same_prim) = (0, 0, 0);
    let n = 3000;
    for _ in 0..n {
        let o = [
            rng.range(-25.0, 25.0),
            rng.range(0.5, 6.0),
            rng.range(-25.0, 25.0),
        ];
        let d = [
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 0.2),
            rng.range(-1.0, 1.0),
        ];
        let ray = Ray {
            origin: o,
            tmin: 0.0,
            dir: d,
            tmax: f32::INFINITY,
        };
        let s = scene.closest_hit(&ray, u32::MAX);
        let f = flat_view.closest_hit(&ray);
        agree += usize::from(s.is_hit() == f.is_hit());
        hits += usize::from(s.is_hit());
        if s.is_hit() && f.is_hit() {
            let prim = offsets[s.instance as usize] + u64::from(s.prim);
            same_prim += usize::from(prim == u64::from(f.prim));
            assert!(
                (s.t - f.t).abs() <= 1e-3 * s.t.max(1.0),
                "{ray:?}: {s:?} vs {f:?}"
            );
        }
    }
    // Hit/miss differs only where a ray grazes an edge and the two
    // roundings of the transform fall on either side.
    assert!(hits > n / 2, "only {hits} hits");
    assert!(agree >= n - n / 500, "{agree} of {n} agree");
    assert!(
        same_prim >= hits - hits / 100,
        "{same_prim} of {hits} on the same triangle"
    );
    // The scene blob is far smaller than the flattened tree.
    let blob = p.write().unwrap();
    let flat_blob = kdray::tools::blob::write_triangle_tree(&flat_tree, &flat).unwrap();
    assert!(blob.as_bytes().len() * 20 < flat_blob.as_bytes().len());
}

#[test]
fn the_top_level_is_rebuilt_from_moved_instances() {
    let meshes = small_meshes();
    let bounds = mesh_bounds(&meshes).unwrap();
    let (_, mut instances) = generated_level(50, 30.0, 1);
    for frame in 0..3 {
        for (k, inst) in instances.iter_mut().enumerate().take(20) {
            let m = placement(
                [0.0, 1.0, 0.0],
                frame as f32,
                [1.0; 3],
                [k as f32, frame as f32, 0.0],
            );
            *inst = Instance::new(inst.mesh(), m, inst.id(), inst.mask()).unwrap();
        }
        let top = build_top_level(&world_boxes(&bounds, &instances));
        let trees = build_all(&meshes);
        let views = views_of(&trees, &meshes);
        let scene =
            Scene::from_parts(&views, &instances, &top.nodes, &top.prims, top.bounds).unwrap();
        for k in 0..20 {
            let ray = Ray {
                origin: [k as f32 + 0.01, frame as f32 + 0.02, -10.0],
                tmin: 0.0,
                dir: [0.0, 0.0, 1.0],
                tmax: f32::INFINITY,
            };
            assert!(
                check(&scene, &ray, u32::MAX),
                "instance {k} moved out of reach"
            );
        }
    }
}

#[test]
fn a_kept_top_level_refilled_over_moving_instances_equals_brute_force() {
    let meshes = small_meshes();
    let bounds = mesh_bounds(&meshes).unwrap();
    let trees = build_all(&meshes);
    let views = views_of(&trees, &meshes);
    let (_, start) = generated_level(60, 20.0, 3);
    let mut kept = TopLevel::new(&world_boxes(&bounds, &start), &TopParams::DEFAULT);
    let mut rebuilt = 0;
    let mut rng = kdray::tools::rng::Rng::new(4);
    for frame in 1..12 {
        // Fast enough that some frames drift past the rebuild factor.
        let instances = moved_level(&start, frame, 0.4, 8);
        rebuilt += u32::from(kept.update(&world_boxes(&bounds, &instances)));
        let top = kept.tree();
        let scene =
            Scene::from_parts(&views, &instances, &top.nodes, &top.prims, top.bounds).unwrap();
        let mut hits = 0;
        for k in 0..200 {
            let inst = &instances[k % instances.len()];
            let c = inst.to_world();
            let o = [
                rng.range(-15.0, 15.0),
                rng.range(-2.0, 6.0),
                rng.range(-15.0, 15.0),
            ];
            let ray = Ray {
                origin: o,
                tmin: 0.0,
                dir: [c[3] - o[0], c[7] - o[1], c[11] - o[2]],
                tmax: f32::INFINITY,
            };
            hits += usize::from(check(&scene, &ray, u32::MAX));
        }
        assert!(
            hits > 100,
            "frame {frame}: rays aimed at instances hit: {hits}"
        );
    }
    assert!(
        (1..11).contains(&rebuilt),
        "some frames refilled, some rebuilt: {rebuilt}"
    );
}

/// Standard base64 with padding.
fn base64(bytes: &[u8]) -> String {
    const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for c in bytes.chunks(3) {
        let n = (u32::from(c[0]) << 16)
            | (u32::from(*c.get(1).unwrap_or(&0)) << 8)
            | u32::from(*c.get(2).unwrap_or(&0));
        for k in 0..4 {
            if k <= c.len() {
                out.push(A[(n >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// A glTF file of one quad mesh used by two nodes (one the child of a
/// moved, scaled parent without a mesh), in the temporary folder.
fn three_node_gltf() -> std::path::PathBuf {
    let mut bin = Vec::new();
    for p in [
        [0.0f32, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
    ] {
        for c in p {
            bin.extend_from_slice(&c.to_le_bytes());
        }
    }
    for i in [0u16, 1, 2, 0, 2, 3] {
        bin.extend_from_slice(&i.to_le_bytes());
    }
    let uri = base64(&bin);
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,
        "scenes":[{{"nodes":[0,1]}}],
        "nodes":[{{"mesh":0,"translation":[0,0,5]}},
                 {{"translation":[3,0,0],"scale":[2,2,2],"children":[2]}},
                 {{"mesh":0,"rotation":[0,0,0.7071068,0.7071068]}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1}}]}}],
        "buffers":[{{"byteLength":60,"uri":"data:application/octet-stream;base64,{uri}"}}],
        "bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":48}},{{"buffer":0,"byteOffset":48,"byteLength":12}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}},
                     {{"bufferView":1,"componentType":5123,"count":6,"type":"SCALAR"}}]}}"#
    );
    let path = std::env::temp_dir().join(format!("kdray-scenes-{}.gltf", std::process::id()));
    std::fs::write(&path, json).unwrap();
    path
}

#[test]
fn gltf_instances_number_triangles_as_the_flattened_load_does() {
    use kdray::tools::mesh::{load_gltf, load_gltf_instanced, LoadOptions};
    let path = three_node_gltf();
    let flat = load_gltf(&path).unwrap();
    let g = load_gltf_instanced(&path, &LoadOptions::default(), &mut Vec::new()).unwrap();
    std::fs::remove_file(&path).unwrap();
    assert_eq!((g.meshes.len(), g.instances.len(), flat.len()), (1, 2, 4));
    assert_eq!(g.instances.iter().map(|i| i.2).collect::<Vec<_>>(), [0, 2]);
    let instances: Vec<Instance> = g
        .instances
        .iter()
        .map(|&(mesh, m, node)| Instance::new(mesh, m, node, u32::MAX).unwrap())
        .collect();
    let ours = flatten_scene(&g.meshes, &instances);
    for (a, b) in ours.iter().zip(&flat) {
        for (p, q) in a.v.iter().zip(&b.v) {
            for (x, y) in p.iter().zip(q) {
                assert!((x - y).abs() < 1e-5, "{a:?} vs {b:?}");
            }
        }
    }
    // A ray through the child node's quad (x in [1, 3], y in [0, 2] at
    // z = 0: rotated a quarter turn, scaled by 2, moved to x = 3) hits
    // flattened triangle 2 or 3, as the flattened tree numbers it.
    let p = parts(&g.meshes, instances);
    let trees = p.trees().unwrap();
    let scene = p.scene(&trees).unwrap();
    let ray = Ray {
        origin: [2.5, 0.5, -1.0],
        tmin: 0.0,
        dir: [0.0, 0.0, 1.0],
        tmax: f32::INFINITY,
    };
    let hit = scene.closest_hit(&ray, u32::MAX);
    assert_eq!(hit.instance, 1);
    let sizes = [g.meshes[0].len()];
    let flat_prim = flattened_offsets(&sizes, &p.instances)[1] + u64::from(hit.prim);
    let want = kdray::kernel::closest_hit_brute(&flat, &ray);
    assert_eq!(flat_prim, u64::from(want.prim));
}

/// `kdray trace --first-hits` over a scene: each ray's first hits, numbered
/// in the flattened order, are the flattened triangles' brute-force first
/// hits (the same triangles in the same order; `t` may differ by the two
/// roundings of the transform, so it is compared loosely).
#[test]
fn scene_first_hits_number_triangles_in_the_flattened_order() {
    let meshes = small_meshes();
    let insts: Vec<Instance> = (0..6)
        .map(|k| {
            let m = placement(
                [0.0, 1.0, 0.0],
                k as f32,
                [1.0; 3],
                [k as f32 * 0.7, 0.0, 0.0],
            );
            Instance::new(k % 2, m, k, u32::MAX).unwrap()
        })
        .collect();
    let p = parts(&meshes, insts);
    let trees = p.trees().unwrap();
    let scene = p.scene(&trees).unwrap();
    let flat = flatten_scene(&meshes, &p.instances);
    let sizes: Vec<usize> = meshes.iter().map(Vec::len).collect();
    let offsets = flattened_offsets(&sizes, &p.instances);
    let rays: Vec<Ray> = (0..40)
        .map(|i| Ray {
            origin: [-3.0, 0.1 * (i % 7) as f32 - 0.3, 0.05 * i as f32 - 1.0],
            tmin: 0.0,
            dir: [1.0, 0.01 * i as f32, 0.02],
            tmax: f32::INFINITY,
        })
        .collect();
    let k = 5;
    let mut hits = vec![kdray::kernel::Hit::MISS; rays.len() * k];
    let total = first_hits_scene(&scene, &offsets, &rays, &mut hits, k);
    let mut seen = 0;
    for (r, got) in rays.iter().zip(hits.chunks(k)) {
        let mut want = [kdray::kernel::Hit::MISS; 5];
        let n = kdray::kernel::first_hits_brute(&flat, r, &mut want);
        seen += n;
        for (g, w) in got.iter().zip(&want) {
            assert_eq!(g.prim, w.prim, "{r:?}: {got:?} against {want:?}");
            assert!(
                g.t == w.t || (g.t - w.t).abs() <= 1e-5 * w.t.abs(),
                "{g:?} {w:?}"
            );
        }
    }
    assert_eq!(total, seen);
    assert!(seen > 40, "{seen} hits: too few to see the order");
}

/// A node scale of 1e30 on an in-range mesh: the flat build of the same
/// triangles refuses them (beyond `MAX_COORD`), so the scene builder
/// refuses the instance and the kernel refuses a scene that holds it.
#[test]
fn instances_beyond_the_coordinate_range_are_refused() {
    use kdray::tools::instances::SceneBuildError;
    let meshes = small_meshes();
    let fine = Instance::new(0, placement([0.0, 0.0, 1.0], 0.0, [1.0; 3], [0.0; 3]), 0, 1).unwrap();
    let huge = Instance::new(
        1,
        placement([0.0, 0.0, 1.0], 0.0, [1e30; 3], [0.0; 3]),
        1,
        1,
    )
    .unwrap();
    let flat = flatten_scene(&meshes, &[huge]);
    assert!(build(&flat, BuilderKind::default(), &BuildParams::default()).is_err());
    let e = build_scene(
        &meshes,
        vec![fine, huge],
        BuilderKind::default(),
        &BuildParams::default(),
    )
    .unwrap_err();
    assert!(
        matches!(e, SceneBuildError::OutOfRange { instance: 1, .. }),
        "{e}"
    );
    assert!(e.to_string().contains("MAX_COORD"), "{e}");
    // Assembled by hand around the builder: the kernel refuses it too.
    let trees = build_all(&meshes);
    let views = views_of(&trees, &meshes);
    let instances = [fine, huge];
    let boxes = world_boxes(&mesh_bounds(&meshes).unwrap(), &instances);
    let top = build_top_level(&boxes);
    let e = Scene::from_parts(&views, &instances, &top.nodes, &top.prims, top.bounds).unwrap_err();
    assert_eq!(e, SceneError::InstanceOutOfRange { instance: 1 });
}
