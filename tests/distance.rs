//! Distance queries on meshes: the closest point equals brute force bit
//! for bit on random and adversarial geometry (points on vertices, edges
//! and faces, points equidistant from two triangles), its distance is
//! within the stated bound of an `f64` oracle, and the crossing count
//! behind `contains` equals brute force and counts a shared edge or vertex
//! once (closed boxes, nested shells, an open mesh).

mod common;

use common::{blob, shared_mesh};
use kdray::kernel::{
    closest_point_brute, crossings_brute, winding_crossings_brute, Triangle, TriangleTree,
};
use kdray::tools::builders::BuilderKind;
use kdray::tools::distance::{self, InsideRule};
use kdray::tools::winding;
use proptest::prelude::*;

/// A coordinate: mostly on a coarse grid (so planes, vertices and
/// distances coincide), sometimes raw.
fn coord() -> impl Strategy<Value = f32> {
    prop_oneof![
        4 => (-4i32..=4).prop_map(|i| i as f32),
        2 => (-8i32..=8).prop_map(|i| i as f32 * 0.5),
        1 => -5.0f32..5.0,
    ]
}

fn point() -> impl Strategy<Value = [f32; 3]> {
    [coord(), coord(), coord()]
}

/// General, axis-aligned and degenerate triangles.
fn triangle() -> impl Strategy<Value = Triangle> {
    prop_oneof![
        3 => [point(), point(), point()].prop_map(|v| Triangle { v }),
        3 => (0usize..3, coord(), point(), point(), point()).prop_map(|(a, c, mut p, mut q, mut r)| {
            p[a] = c;
            q[a] = c;
            r[a] = c;
            Triangle { v: [p, q, r] }
        }),
        1 => (point(), point()).prop_map(|(p, q)| Triangle {
            v: [p, q, std::array::from_fn(|a| (p[a] + q[a]) * 0.5)]
        }),
    ]
}

/// Query points on the mesh's vertices, edge midpoints and centroids, and
/// around it (grid points are often equidistant from several triangles).
fn queries(tris: &[Triangle], extra: &[[f32; 3]]) -> Vec<[f32; 3]> {
    let mut q = extra.to_vec();
    for t in tris.iter().take(20) {
        let [a, b, c] = t.v;
        q.extend([a, b, c]);
        q.push(std::array::from_fn(|i| (a[i] + b[i]) * 0.5));
        q.push(std::array::from_fn(|i| (a[i] + b[i] + c[i]) / 3.0));
    }
    q
}

/// Every builder's tree answers every query as brute force, bit for bit,
/// with and without a maximum distance.
fn assert_closest_matches_brute(tris: &[Triangle], qs: &[[f32; 3]]) {
    for kind in BuilderKind::ALL {
        let blob = blob(tris, kind);
        let tree = blob.tree().expect("built tree validates");
        for q in qs {
            for max in [f32::INFINITY, 1.5, 0.0] {
                let got = tree.closest_point_within(*q, max).map(|c| c.bits());
                let want = closest_point_brute(tris, *q, max).map(|c| c.bits());
                assert_eq!(got, want, "builder {}: {q:?} within {max}", kind.name());
                // From any first triangle: the same.
                let start = q[0].to_bits() % (tris.len() as u32 + 2);
                let from = tree.closest_point_from(*q, max, start).map(|c| c.bits());
                assert_eq!(from, want, "builder {}: {q:?} from {start}", kind.name());
            }
        }
        // The batch (in space order, each search from the previous answer)
        // answers each query as the kernel does alone.
        let mut batch = vec![None; qs.len()];
        distance::closest_points(&tree, qs, f32::INFINITY, &mut batch);
        for (q, b) in qs.iter().zip(&batch) {
            let want = closest_point_brute(tris, *q, f32::INFINITY).map(|c| c.bits());
            assert_eq!(
                b.map(|c| c.bits()),
                want,
                "builder {}: batch {q:?}",
                kind.name()
            );
        }
    }
}

/// Every builder's tree counts the crossings of every ray as brute force.
fn assert_crossings_match_brute(tris: &[Triangle], rays: &[([f32; 3], [f32; 3])]) {
    for kind in BuilderKind::ALL {
        let blob = blob(tris, kind);
        let tree = blob.tree().expect("built tree validates");
        for &(q, d) in rays {
            assert_eq!(
                tree.crossings(q, d),
                crossings_brute(tris, q, d),
                "builder {}: {q:?} along {d:?}",
                kind.name()
            );
            assert_eq!(
                tree.winding_crossings(q, d),
                winding_crossings_brute(tris, q, d),
                "builder {}: signed, {q:?} along {d:?}",
                kind.name()
            );
        }
    }
}

/// A direction: integer components (through grid vertices and edges) or raw.
fn dir() -> impl Strategy<Value = [f32; 3]> {
    let c = || prop_oneof![3 => (-2i32..=2).prop_map(|i| i as f32), 1 => -1.0f32..1.0];
    [c(), c(), c()]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]

    #[test]
    fn closest_point_equals_brute_force(
        tris in proptest::collection::vec(triangle(), 0..50),
        extra in proptest::collection::vec(point(), 1..30),
    ) {
        assert_closest_matches_brute(&tris, &queries(&tris, &extra));
    }

    #[test]
    fn crossings_equal_brute_force(
        tris in proptest::collection::vec(triangle(), 0..50),
        rays in proptest::collection::vec(
            (point(), dir()),
            1..30,
        ),
    ) {
        assert_crossings_match_brute(&tris, &rays);
    }
}

/// The 12 triangles of the box `[lo, hi]^3`, each face cut along a diagonal.
fn box_mesh(lo: f32, hi: f32) -> Vec<Triangle> {
    let c =
        |i: usize| -> [f32; 3] { std::array::from_fn(|a| if i >> a & 1 == 1 { hi } else { lo }) };
    // Each face as four corners in order around it.
    let faces = [
        [0, 2, 6, 4],
        [1, 3, 7, 5],
        [0, 1, 5, 4],
        [2, 3, 7, 6],
        [0, 1, 3, 2],
        [4, 5, 7, 6],
    ];
    let mut t = Vec::new();
    for f in faces {
        t.push(Triangle {
            v: [c(f[0]), c(f[1]), c(f[2])],
        });
        t.push(Triangle {
            v: [c(f[0]), c(f[2]), c(f[3])],
        });
    }
    t
}

/// Directions with components in {-1, 0, 1}: from grid points they run
/// exactly through the boxes' vertices, edges and face diagonals.
fn grid_dirs() -> Vec<[f32; 3]> {
    let mut d = Vec::new();
    for i in 0..27 {
        let v = [
            (i % 3) as f32 - 1.0,
            (i / 3 % 3) as f32 - 1.0,
            (i / 9) as f32 - 1.0,
        ];
        if v != [0.0; 3] {
            d.push(v);
        }
    }
    d
}

#[test]
fn rays_through_edges_and_vertices_cross_a_closed_box_once() {
    let tris = box_mesh(0.0, 4.0);
    let dirs = grid_dirs();
    let coords = [0.5, 1.0, 2.0, 3.0, 3.5];
    let mut rays = Vec::new();
    for &x in &coords {
        for &y in &coords {
            for &z in &coords {
                for &d in &dirs {
                    rays.push(([x, y, z], d));
                }
            }
        }
    }
    assert_crossings_match_brute(&tris, &rays);
    let tree_blob = blob(&tris, BuilderKind::default());
    let tree = tree_blob.tree().unwrap();
    for &(q, d) in &rays {
        assert_eq!(tree.crossings(q, d), 1, "{q:?} along {d:?}");
    }
    // From outside, rays that graze the box along an edge or through a
    // corner (silhouettes) cross it 0 or 2 times: parity is kept.
    for q in [
        [-1.0, -1.0, 2.0],
        [-1.0, 2.0, 2.0],
        [-1.0, -1.0, -1.0],
        [2.0, -1.0, -1.0],
    ] {
        for &d in &dirs {
            assert_eq!(tree.crossings(q, d) % 2, 0, "{q:?} along {d:?}");
        }
    }
}

#[test]
fn nested_shells_alternate_inside_and_outside() {
    let mut tris = box_mesh(0.0, 4.0);
    tris.extend(box_mesh(1.0, 3.0));
    let b = blob(&tris, BuilderKind::default());
    let tree = b.tree().unwrap();
    let coords = [0.5, 1.5, 2.0, 2.5, 3.5];
    for &x in &coords {
        for &y in &coords {
            for &z in &coords {
                let q = [x, y, z];
                let in_inner = q.iter().all(|&c| (1.5..=2.5).contains(&c));
                // Inside the outer box and outside the inner one: inside.
                assert_eq!(tree.contains(q), !in_inner, "{q:?}");
                assert_eq!(tree.contains_voting(q, 5), !in_inner, "{q:?}");
                for d in grid_dirs() {
                    let n = tree.crossings(q, d);
                    assert_eq!(n % 2 == 1, !in_inner, "{q:?} along {d:?}: {n}");
                }
            }
        }
    }
    assert!(!tree.contains([5.0, 2.0, 2.0]));
    assert!(!tree.contains([f32::NAN, 2.0, 2.0]));
}

#[test]
fn an_open_box_is_judged_by_the_vote() {
    // The box without one triangle of its top face: a hole.
    let mut tris = box_mesh(0.0, 4.0);
    tris.remove(11);
    let b = blob(&tris, BuilderKind::default());
    let tree = b.tree().unwrap();
    let mut parity_wrong = 0;
    let mut vote_wrong = 0;
    for i in 0..200 {
        let f = |k: u32| 0.25 + 3.5 * ((i * k % 97) as f32 / 97.0);
        let q = [f(13), f(29), f(53)];
        parity_wrong += usize::from(!tree.contains(q));
        vote_wrong += usize::from(!tree.contains_voting(q, 7));
    }
    // One ray in seven goes through the hole from some points; the
    // majority of seven never does from all of them here.
    assert!(
        parity_wrong > 0,
        "no ray went through the hole: the test tests nothing"
    );
    assert_eq!(vote_wrong, 0);
}

/// [`box_mesh`] with every normal pointing out.
fn outward_box(lo: f32, hi: f32) -> Vec<Triangle> {
    let mid = (lo + hi) / 2.0;
    box_mesh(lo, hi)
        .into_iter()
        .map(|t| {
            let [a, b, c] = t.v;
            let e = |p: [f32; 3], q: [f32; 3]| std::array::from_fn::<f32, 3, _>(|i| q[i] - p[i]);
            let (ab, ac) = (e(a, b), e(a, c));
            let n = [
                ab[1] * ac[2] - ab[2] * ac[1],
                ab[2] * ac[0] - ab[0] * ac[2],
                ab[0] * ac[1] - ab[1] * ac[0],
            ];
            let out: f32 = (0..3)
                .map(|i| n[i] * ((a[i] + b[i] + c[i]) / 3.0 - mid))
                .sum();
            if out < 0.0 {
                Triangle { v: [a, c, b] }
            } else {
                t
            }
        })
        .collect()
}

/// The winding number summed over every triangle, the oracle of the
/// winding rule.
fn winding_sum(tris: &[Triangle], q: [f32; 3]) -> f64 {
    tris.iter()
        .map(|t| winding::triangle_winding(t, q.map(f64::from)))
        .sum()
}

#[test]
fn the_winding_rule_is_the_winding_number_of_an_open_box() {
    // The box without one triangle of its top face (a hole), and without
    // its whole bottom face (a square hole of two triangles).
    let mut tris = outward_box(0.0, 4.0);
    tris.remove(11);
    tris.drain(4..6);
    let b = blob(&tris, BuilderKind::default());
    let tree = b.tree().unwrap();
    let caps = winding::WindingCaps::new(&tris);
    assert_eq!(
        caps.triangle_count(),
        3 + 4,
        "a triangular and a square hole"
    );
    let mut parity_wrong = 0;
    let mut checked = 0;
    for i in 0..400u32 {
        // Inside, around, and just beside the holes.
        let f = |k: u32| -1.0 + 6.0 * ((i * k % 101) as f32 / 101.0);
        let q = [f(13), f(29), f(53)];
        let w = winding_sum(&tris, q);
        let got = caps.winding_number(&tree, q);
        assert!((got - w).abs() < 1e-9, "{q:?}: {got} against {w}");
        if (w.abs() - 0.5).abs() > 1e-9 {
            checked += 1;
            assert_eq!(caps.contains(&tree, q), w.abs() > 0.5, "{q:?}: w {w}");
            assert_eq!(InsideRule::Winding.contains(&tree, q), w.abs() > 0.5);
            parity_wrong += usize::from(tree.contains(q) != (w.abs() > 0.5));
        }
    }
    assert!(checked > 300);
    assert!(
        parity_wrong > 0,
        "parity agreed everywhere: the test tests nothing"
    );
    // The batch: signed distances negative exactly where the rule says.
    let qs: Vec<[f32; 3]> = (0..50).map(|i| [0.05 + 0.1 * i as f32, 2.0, 3.9]).collect();
    let mut d = vec![0.0; qs.len()];
    distance::signed_distances(&tree, &qs, InsideRule::Winding, &mut d);
    for (q, d) in qs.iter().zip(&d) {
        assert_eq!(*d < 0.0, caps.contains(&tree, *q), "{q:?}");
    }
}

/// An open tube: the side of a cylinder of radius 1 about the z axis from
/// z = 0 to 2, `n` segments around, normals out; two holes of `n` edges.
fn open_tube(n: usize) -> Vec<Triangle> {
    let p = |i: usize, z: f32| {
        let a = std::f32::consts::TAU * (i % n) as f32 / n as f32;
        [a.cos(), a.sin(), z]
    };
    let mut tris = Vec::new();
    for i in 0..n {
        let (a0, a1, b0, b1) = (p(i, 0.0), p(i + 1, 0.0), p(i, 2.0), p(i + 1, 2.0));
        tris.push(Triangle { v: [a0, a1, b1] });
        tris.push(Triangle { v: [a0, b1, b0] });
    }
    tris
}

#[test]
fn the_winding_rule_sums_each_cap_group_once_near_large_holes() {
    // Holes of 64 edges: eight groups each, so points near a rim reach
    // the later tiers with some groups summed and others bounded.
    let tris = open_tube(64);
    let b = blob(&tris, BuilderKind::default());
    let tree = b.tree().unwrap();
    let caps = winding::WindingCaps::new(&tris);
    assert_eq!(caps.triangle_count(), 128);
    let mut checked = 0;
    let mut between = 0;
    for i in 0..3000u32 {
        let f = |k: u32, lo: f32, span: f32| lo + span * ((i * k % 997) as f32 / 997.0);
        let q = [f(31, -1.3, 2.6), f(57, -1.3, 2.6), f(101, -0.6, 3.2)];
        let w = winding_sum(&tris, q);
        if (w.abs() - 0.5).abs() > 1e-9 {
            checked += 1;
            between += usize::from(w.abs() > 0.05 && w.abs() < 0.95);
            assert_eq!(caps.contains(&tree, q), w.abs() > 0.5, "{q:?}: w {w}");
        }
    }
    assert!(checked > 2900 && between > 300, "{checked} {between}");
}

#[test]
fn a_closed_mesh_needs_no_caps_and_winds_once() {
    let tris = outward_box(0.0, 4.0);
    let b = blob(&tris, BuilderKind::default());
    let tree = b.tree().unwrap();
    let caps = winding::WindingCaps::new(&tris);
    assert_eq!(caps.triangle_count(), 0);
    // Off the surface (on it either answer is right): inside and outside,
    // near a face and a corner, where the winding rule's ray (towards the
    // nearer faces of the box) and parity's differ.
    for q in [
        [1.0, 2.0, 3.0],
        [3.999, 2.0, 2.0],
        [4.001, 2.0, 2.0],
        [5.0, 1.0, 1.0],
        [0.001, 0.001, 0.001],
        [-0.001, 0.0, 0.0],
    ] {
        let w = caps.winding_number(&tree, q);
        assert!((w - winding_sum(&tris, q)).abs() < 1e-9, "{q:?}: {w}");
        assert_eq!(caps.contains(&tree, q), tree.contains(q), "{q:?}");
        assert_eq!(caps.contains(&tree, q), w > 0.5, "{q:?}");
    }
    assert_eq!(caps.winding_number(&tree, [1.0, 2.0, 3.0]), 1.0);
    assert!(!caps.contains(&tree, [f32::NAN, 0.0, 0.0]));
}

/// The exact distance from `q` to `tri` in `f64`, by another route than the
/// kernel's: the projection onto the plane when it falls inside, else the
/// nearest of the three edges.
fn oracle_distance(q: [f64; 3], tri: &Triangle) -> f64 {
    let v = tri.v.map(|p| p.map(f64::from));
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let cross = |a: [f64; 3], b: [f64; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let seg = |p: [f64; 3], a: [f64; 3], b: [f64; 3]| {
        let e = sub(b, a);
        let l = dot(e, e);
        let s = if l > 0.0 {
            (dot(sub(p, a), e) / l).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let c = [a[0] + s * e[0], a[1] + s * e[1], a[2] + s * e[2]];
        dot(sub(p, c), sub(p, c)).sqrt()
    };
    let n = cross(sub(v[1], v[0]), sub(v[2], v[0]));
    let nn = dot(n, n);
    if nn > 0.0 {
        let h = dot(sub(q, v[0]), n) / nn;
        let p = [q[0] - h * n[0], q[1] - h * n[1], q[2] - h * n[2]];
        let inside = (0..3).all(|i| {
            let (a, b) = (v[i], v[(i + 1) % 3]);
            dot(cross(sub(b, a), sub(p, a)), n) >= 0.0
        });
        if inside {
            return h.abs() * nn.sqrt();
        }
    }
    seg(q, v[0], v[1])
        .min(seg(q, v[1], v[2]))
        .min(seg(q, v[2], v[0]))
}

/// The stated bound: `|sqrt(distance2) - d| <= 2^-40 (d + M)`.
fn assert_within_bound(tree: &TriangleTree<'_>, tris: &[Triangle], qs: &[[f32; 3]], name: &str) {
    let scale = tris
        .iter()
        .flat_map(|t| t.v.iter().flatten())
        .fold(0.0f64, |m, &c| m.max(f64::from(c).abs()));
    let mut worst = 0.0f64;
    for q in qs {
        let c = tree.closest_point(*q).expect("a mesh has a closest point");
        let q64 = q.map(f64::from);
        let d = tris
            .iter()
            .map(|t| oracle_distance(q64, t))
            .fold(f64::INFINITY, f64::min);
        let m = q64.iter().fold(scale, |m, c| m.max(c.abs()));
        let err = (c.distance2.sqrt() - d).abs();
        assert!(
            err <= (d + m) * 2f64.powi(-40),
            "{name} {q:?}: {} against {d}",
            c.distance2.sqrt()
        );
        worst = worst.max(err / (d + m));
    }
    eprintln!(
        "{name}: worst error {worst:e} of (d + M) over {} points",
        qs.len()
    );
}

#[test]
fn distances_are_within_the_bound_of_an_f64_oracle() {
    let tris = box_mesh(-1.0, 3.0);
    let b = blob(&tris, BuilderKind::default());
    let tree = b.tree().unwrap();
    let qs: Vec<[f32; 3]> = (0..500)
        .map(|i| std::array::from_fn(|a| ((i * (a + 7) * 37) % 101) as f32 / 101.0 * 6.0 - 2.0))
        .collect();
    assert_within_bound(&tree, &tris, &qs, "box");
    for name in ["stanford-bunny.obj", "fandisk.obj"] {
        let Some(path) = shared_mesh("distances_are_within_the_bound_of_an_f64_oracle", name)
        else {
            continue;
        };
        let tris = kdray::tools::mesh::load(&path).unwrap();
        let b = blob(&tris, BuilderKind::default());
        let tree = b.tree().unwrap();
        let bb = tree.bounds();
        let qs: Vec<[f32; 3]> = (0..200)
            .map(|i| {
                std::array::from_fn(|a| {
                    let f = ((i * (a + 3) * 61) % 211) as f32 / 211.0;
                    let w = bb.max[a] - bb.min[a];
                    bb.min[a] - 0.1 * w + 1.2 * w * f
                })
            })
            .collect();
        assert_within_bound(&tree, &tris, &qs, name);
        // And the tree is brute force on these and on the vertices.
        let mut on = qs.clone();
        on.extend(tris.iter().step_by(97).map(|t| t.v[1]));
        for q in &on {
            assert_eq!(
                tree.closest_point(*q).map(|c| c.bits()),
                closest_point_brute(&tris, *q, f32::INFINITY).map(|c| c.bits()),
                "{name} {q:?}"
            );
        }
    }
}

#[test]
fn points_equidistant_from_two_triangles_take_the_lower_index() {
    // Two parallel squares at z = 0 and z = 2, listed top first: every
    // point at z = 1 is equally near both.
    let mut tris = box_mesh(0.0, 2.0);
    tris.swap(0, 11);
    let b = blob(&tris, BuilderKind::default());
    let tree = b.tree().unwrap();
    for i in 0..50 {
        let q = [
            0.25 + (i % 7) as f32 * 0.25,
            0.25 + (i / 7) as f32 * 0.2,
            1.0,
        ];
        let got = tree.closest_point(q).unwrap();
        assert_eq!(
            got.bits(),
            closest_point_brute(&tris, q, f32::INFINITY).unwrap().bits()
        );
    }
}

#[test]
fn bad_queries_and_empty_trees_miss() {
    let b = blob(&[], BuilderKind::default());
    let tree = b.tree().unwrap();
    assert!(tree.closest_point([0.0; 3]).is_none());
    assert!(!tree.contains([0.0; 3]));
    let tris = box_mesh(0.0, 1.0);
    let b = blob(&tris, BuilderKind::default());
    let tree = b.tree().unwrap();
    for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        assert!(tree.closest_point([bad, 0.0, 0.0]).is_none());
        assert!(tree.closest_point_within([0.5; 3], bad).is_none() || bad == f32::INFINITY);
        assert!(!tree.contains([0.5, bad, 0.5]));
        assert_eq!(tree.crossings([0.5; 3], [bad, 1.0, 0.0]), 0);
    }
    assert!(tree.closest_point_within([0.5; 3], -1.0).is_none());
    assert_eq!(tree.crossings([0.5; 3], [0.0; 3]), 0);
}
