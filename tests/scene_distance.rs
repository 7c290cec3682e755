//! The closest point of a scene: the walk over instances equals the brute
//! force over every instance and triangle bit for bit (rotations, uniform
//! scales, mirrors, masks), its world distance is the flattened mesh's,
//! and a non-uniform scale is refused.

use kdray::kernel::{closest_point_brute, Instance, NotSimilar, Scene, Triangle};
use kdray::tools::builders::{BuildParams, BuilderKind};
use kdray::tools::instances::{build_scene, flatten_scene, placement, sphere, torus, SceneParts};

fn meshes() -> Vec<Vec<Triangle>> {
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

/// Copies of the three meshes, rotated, uniformly scaled (one mirrored),
/// some overlapping; masks 1 and 2.
fn similar_instances() -> Vec<Instance> {
    let mut out = Vec::new();
    for i in 0..12u32 {
        let f = i as f32;
        let s = 0.5 + 0.25 * (i % 4) as f32;
        let mirror = if i == 5 { -s } else { s };
        let m = placement(
            [0.3, 1.0, 0.2 * f],
            0.7 * f,
            [mirror, s, s],
            [
                (i % 4) as f32 * 1.5 - 2.0,
                (i / 4) as f32 * 1.7 - 1.5,
                0.3 * f,
            ],
        );
        out.push(Instance::new(i % 3, m, 100 + i, 1 << (i % 2)).unwrap());
    }
    out
}

/// Query points on a grid through and around the scene, and on vertices.
fn queries(meshes: &[Vec<Triangle>], insts: &[Instance]) -> Vec<[f32; 3]> {
    let mut q = Vec::new();
    for x in -6..=6 {
        for y in -5..=5 {
            for z in -3..=6 {
                q.push([x as f32 * 0.61, y as f32 * 0.53, z as f32 * 0.7]);
            }
        }
    }
    for (k, inst) in insts.iter().enumerate() {
        // A vertex of the instance in world space: distance about 0.
        let mesh = &meshes[inst.mesh() as usize];
        let v = mesh[k % mesh.len()].v[k % 3];
        q.push(inst.world_point(v));
    }
    q
}

#[test]
fn scene_closest_point_equals_brute_force_bit_for_bit() {
    let meshes = meshes();
    let insts = similar_instances();
    let p = parts(&meshes, insts.clone());
    let trees = p.trees().unwrap();
    let scene: Scene<'_> = p.scene(&trees).unwrap();
    let world = flatten_scene(&meshes, &insts);
    let mut answered = 0;
    for q in queries(&meshes, &insts) {
        for mask in [u32::MAX, 1, 2, 0] {
            let got = scene.closest_point(q, mask).unwrap();
            let want = scene.closest_point_brute(q, mask).unwrap();
            assert_eq!(
                got.map(|c| c.bits()),
                want.map(|c| c.bits()),
                "{q:?} mask {mask}"
            );
            if mask == 0 {
                assert!(got.is_none());
            }
            if mask == u32::MAX {
                // The world distance is the flattened mesh's, up to the
                // rounding of the transforms.
                let c = got.unwrap();
                answered += 1;
                let flat = closest_point_brute(&world, q, f32::INFINITY).unwrap();
                let (a, b) = (c.distance2.sqrt(), flat.distance2.sqrt());
                assert!(
                    (a - b).abs() <= 1e-5 * (1.0 + a),
                    "{q:?}: {a} against flattened {b}"
                );
                let d = (0..3)
                    .map(|k| (f64::from(c.point[k]) - f64::from(q[k])).powi(2))
                    .sum::<f64>()
                    .sqrt();
                assert!(
                    (d - a).abs() <= 1e-5 * (1.0 + a),
                    "{q:?}: point at {d}, reported {a}"
                );
            }
        }
    }
    assert!(answered > 1000);
    assert_eq!(
        scene.closest_point([f32::NAN, 0.0, 0.0], u32::MAX),
        Ok(None)
    );
}

#[test]
fn an_unevenly_scaled_instance_is_refused() {
    let meshes = meshes();
    let mut insts = similar_instances();
    let squashed = placement([0.0, 1.0, 0.0], 0.4, [1.0, 0.25, 1.0], [0.0, 0.0, 9.0]);
    insts.push(Instance::new(0, squashed, 7, 4).unwrap());
    let p = parts(&meshes, insts);
    let trees = p.trees().unwrap();
    let scene = p.scene(&trees).unwrap();
    let not_similar = NotSimilar { instance: 12 };
    let refused = Err(not_similar);
    assert_eq!(scene.closest_point([0.0; 3], u32::MAX), refused);
    assert_eq!(scene.closest_point_brute([0.0; 3], u32::MAX), refused);
    assert!(not_similar.to_string().contains("instance 12"));
    // Not selected by the mask: answered.
    let c = scene.closest_point([0.0; 3], 3).unwrap().unwrap();
    assert_eq!(Ok(Some(c)), scene.closest_point_brute([0.0; 3], 3));
}

/// Many small instances on a jittered grid (rotated, uniformly scaled,
/// some mirrored), some stacked exactly on another (ties between
/// instances), and one mesh whose coordinates lie far from its origin.
fn crowded() -> (Vec<Vec<Triangle>>, Vec<Instance>) {
    let far: Vec<Triangle> = sphere(4, 6)
        .into_iter()
        .map(|t| Triangle {
            v: t.v.map(|p| [p[0] + 1000.0, p[1] - 500.0, p[2] + 250.0]),
        })
        .collect();
    let meshes = vec![sphere(4, 6), torus(6, 4), far];
    let mut out = Vec::new();
    let mut seed = 0x9e37_79b9u32;
    let mut next = || {
        seed ^= seed << 13;
        seed ^= seed >> 17;
        seed ^= seed << 5;
        f64::from(seed) as f32 / 4_294_967_296.0
    };
    for k in 0..600u32 {
        let s = 0.2 + 0.3 * next();
        let mirror = if k % 7 == 3 { -s } else { s };
        let shift = [
            (k % 25) as f32 * 1.1 + next() * 0.3,
            (k / 25) as f32 * 0.9 + next() * 0.3,
            next() * 2.0 - 1.0,
        ];
        let mesh = k % 3;
        let shift = if mesh == 2 {
            // Back near the others: the mesh's far offset undone.
            [
                shift[0] - 1000.0 * s,
                shift[1] + 500.0 * s,
                shift[2] - 250.0 * s,
            ]
        } else {
            shift
        };
        let m = placement(
            [next() - 0.5, next() - 0.5, 0.7],
            next() * 6.0,
            [mirror, s, s],
            shift,
        );
        let inst = Instance::new(mesh, m, k, 1 << (k % 3)).unwrap();
        out.push(inst);
        if k % 50 == 7 {
            // The same instance again: every answer a tie, the lower wins.
            out.push(inst);
        }
    }
    (meshes, out)
}

#[test]
fn the_walk_over_many_instances_equals_brute_force_with_ties_and_limits() {
    let (meshes, insts) = crowded();
    let p = parts(&meshes, insts.clone());
    let trees = p.trees().unwrap();
    let scene = p.scene(&trees).unwrap();
    let mut tied = 0;
    let mut checked = 0;
    let mut queries: Vec<[f32; 3]> = Vec::new();
    for x in -4..32 {
        for y in -3..30 {
            queries.push([
                x as f32 * 0.87,
                y as f32 * 0.81,
                ((x * y) % 5) as f32 * 0.4 - 1.0,
            ]);
        }
    }
    for (k, inst) in insts.iter().enumerate().step_by(5) {
        let mesh = &meshes[inst.mesh() as usize];
        queries.push(inst.world_point(mesh[k % mesh.len()].v[k % 3]));
    }
    queries.push([1e6, -1e6, 3e5]);
    for (n, &q) in queries.iter().enumerate() {
        let mask = [u32::MAX, 1, 6, 4][n % 4];
        let want = scene.closest_point_brute(q, mask).unwrap();
        let got = scene.closest_point(q, mask).unwrap();
        assert_eq!(
            got.map(|c| c.bits()),
            want.map(|c| c.bits()),
            "{q:?} mask {mask}"
        );
        let w = want.unwrap();
        checked += 1;
        if insts
            .get(w.instance as usize + 1)
            .is_some_and(|next| *next == insts[w.instance as usize])
        {
            tied += 1;
        }
        // Within a limit: the answer when it lies that close, else none.
        let d = w.distance2.sqrt() as f32;
        for max in [0.0, d * 0.5, d, d * 1.01, f32::INFINITY] {
            let within = scene.closest_point_within(q, mask, max).unwrap();
            let keep = w.distance2 <= f64::from(max) * f64::from(max);
            assert_eq!(
                within.map(|c| c.bits()),
                keep.then(|| w.bits()),
                "{q:?} within {max}"
            );
        }
    }
    assert!(checked > 1000 && tied > 0, "{checked} checked, {tied} ties");
}

#[test]
fn bad_queries_and_limits_get_defined_answers() {
    let (meshes, insts) = crowded();
    let p = parts(&meshes, insts);
    let trees = p.trees().unwrap();
    let scene = p.scene(&trees).unwrap();
    for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        assert_eq!(scene.closest_point([1.0, bad, 0.0], u32::MAX), Ok(None));
        assert_eq!(
            scene.closest_point_brute([1.0, bad, 0.0], u32::MAX),
            Ok(None)
        );
    }
    for max in [f32::NAN, -1.0, -0.0 - f32::MIN_POSITIVE] {
        assert_eq!(
            scene.closest_point_within([1.0; 3], u32::MAX, max),
            Ok(None)
        );
    }
    assert!(scene.closest_point_within([1.0; 3], u32::MAX, -0.0).is_ok());
    // An empty scene: nothing to be near.
    let empty = parts(&meshes, Vec::new());
    let trees = empty.trees().unwrap();
    let none = empty.scene(&trees).unwrap();
    assert_eq!(none.closest_point([0.0; 3], u32::MAX), Ok(None));
    assert_eq!(none.closest_point_brute([0.0; 3], u32::MAX), Ok(None));
}
