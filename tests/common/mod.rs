//! Helpers shared by the integration tests: scenes, rays, the oracle check.
#![allow(missing_docs)]
#![allow(dead_code)]

use kdray::kernel::{
    any_hit_brute, closest_hit_brute, first_hits_brute, Batch, Hit, Ray, Treelet, Triangle,
};
use kdray::tools::blob::{write_triangle_tree, Blob};
use kdray::tools::builders::{build, BuildParams, BuilderKind};
use kdray::tools::rng::Rng;
use std::path::PathBuf;

/// The real-mesh folder: `KDRAY_MESHES` when set (it must be a folder:
/// the user asked for it), else `../shared/meshes` when present. `None`
/// in a clone without it, after a line on stderr saying `test` was skipped
/// and which folder was missing.
pub(crate) fn shared_meshes(test: &str) -> Option<PathBuf> {
    if let Some(dir) = std::env::var_os("KDRAY_MESHES") {
        let dir = PathBuf::from(dir);
        assert!(
            dir.is_dir(),
            "KDRAY_MESHES={} is not a folder",
            dir.display()
        );
        return Some(dir);
    }
    let dir = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/meshes"));
    if dir.is_dir() {
        Some(dir)
    } else {
        eprintln!(
            "{test}: SKIPPED: {} not found (set KDRAY_MESHES=DIR to use another folder)",
            dir.display()
        );
        None
    }
}

/// Whether the real meshes are the shared folder's (whose files and counts
/// its README lists), not a folder of the user's own (`KDRAY_MESHES`).
pub(crate) fn meshes_are_the_shared_set() -> bool {
    std::env::var_os("KDRAY_MESHES").is_none()
}

/// The mesh `name` of the real-mesh folder, or `None` (with a "skipped"
/// line naming the file) when the folder or the file is not there.
pub(crate) fn shared_mesh(test: &str, name: &str) -> Option<PathBuf> {
    let p = shared_meshes(test)?.join(name);
    if p.is_file() {
        Some(p)
    } else {
        eprintln!("{test}: {name} SKIPPED: {} not found", p.display());
        None
    }
}

/// Builds `tris` with `kind` and returns the blob (validated by the caller via `tree()`).
pub(crate) fn blob(tris: &[Triangle], kind: BuilderKind) -> Blob {
    let built = build(tris, kind, &BuildParams::default()).expect("build");
    write_triangle_tree(&built, tris).unwrap()
}

/// Asserts every builder's tree answers every ray exactly as brute force:
/// closest hit bitwise, any hit the same boolean, the first hits bitwise.
pub(crate) fn assert_matches_brute(tris: &[Triangle], rays: &[Ray]) {
    // Brute force's answers once a ray: the closest hit, any hit and the
    // first hits (up to 256; fewer hits are brute force's complete list).
    let room = tris.len().clamp(1, 256);
    let want: Vec<(Hit, bool, Vec<Hit>)> = rays
        .iter()
        .map(|r| {
            let mut first = vec![Hit::MISS; room];
            let n = first_hits_brute(tris, r, &mut first);
            first.truncate(n);
            (closest_hit_brute(tris, r), any_hit_brute(tris, r), first)
        })
        .collect();
    for r in rays.iter().take(64) {
        assert_first_hits_sorted_once(tris, r);
    }
    let bits = |h: &[Hit]| h.iter().map(Hit::bits).collect::<Vec<_>>();
    for kind in BuilderKind::ALL {
        let blob = blob(tris, kind);
        let tree = blob.tree().expect("built tree validates");
        // The rays as a batch, through the treelets (7 planes a step) and
        // with the one-plane walk: scattered blocks walk in turns.
        let count = tree.treelet_count();
        let mut lines = vec![Treelet::default(); count];
        let with_lines = tree
            .treelets_into(&mut lines)
            .expect("room for every treelet");
        let mut batches = [vec![Hit::MISS; rays.len()], vec![Hit::MISS; rays.len()]];
        tree.closest_hits(rays, &mut batches[0], Batch::default());
        with_lines.closest_hits(rays, &mut batches[1], Batch::default());
        for scattered in &batches {
            for (i, ((r, (closest, ..)), got)) in rays.iter().zip(&want).zip(scattered).enumerate()
            {
                assert_eq!(
                    got.bits(),
                    closest.bits(),
                    "builder {}: ray {i} {r:?} in turns ({} treelets): {got:?} != brute {closest:?}",
                    kind.name(),
                    count
                );
            }
        }
        for (i, (r, (closest, any, first))) in rays.iter().zip(&want).enumerate() {
            let got = tree.closest_hit(r);
            assert_eq!(
                got.bits(),
                closest.bits(),
                "builder {}: ray {i} {r:?}: tree {got:?} != brute {closest:?}",
                kind.name()
            );
            assert_eq!(
                tree.any_hit(r),
                *any,
                "builder {}: any-hit of ray {i} {r:?}",
                kind.name()
            );
            assert_eq!(first.first().unwrap_or(&Hit::MISS).bits(), closest.bits());
            // The first hits in buffers of one (the closest hit), a few,
            // and brute force's: each the front of brute force's list.
            for k in [1, 3, room] {
                let mut got = vec![Hit::MISS; k];
                let n = tree.first_hits(r, &mut got);
                let m = first.len().min(k);
                assert_eq!(
                    bits(&got[..n]),
                    bits(&first[..m]),
                    "builder {}: first {k} hits of ray {i} {r:?}",
                    kind.name()
                );
            }
        }
    }
}

/// Brute force's first hits are every triangle's own hit (each tested
/// alone), sorted by `t` and then index.
fn assert_first_hits_sorted_once(tris: &[Triangle], r: &Ray) {
    let mut each: Vec<Hit> = tris
        .iter()
        .enumerate()
        .map(|(i, t)| Hit {
            prim: i as u32,
            ..closest_hit_brute(std::slice::from_ref(t), r)
        })
        .filter(|h| h.t.is_finite())
        .collect();
    each.sort_by(|a, b| a.t.total_cmp(&b.t).then(a.prim.cmp(&b.prim)));
    let mut got = vec![Hit::MISS; tris.len()];
    let n = first_hits_brute(tris, r, &mut got);
    let bits = |h: &[Hit]| h.iter().map(Hit::bits).collect::<Vec<_>>();
    assert_eq!(bits(&got[..n]), bits(&each), "{r:?}");
}

/// The `f64` reference for one triangle: Möller-Trumbore in `f64` on the
/// `f32` inputs (the oracle's test, `../shared/anchors/embree/brute_trace.c`),
/// for the whole line: `Some((t, [b0, b1, b2]))` where it meets the plane
/// (barycentrics of any sign), `None` for a line parallel to it.
pub(crate) fn line_hit(tri: &Triangle, ray: &Ray) -> Option<(f64, [f64; 3])> {
    let f = |p: [f32; 3]| p.map(f64::from);
    let [a, b, c] = tri.v.map(f);
    let (o, d) = (f(ray.origin), f(ray.dir));
    let (e1, e2) = (sub64(b, a), sub64(c, a));
    let p = cross64(d, e2);
    let det = dot64(e1, p);
    if det == 0.0 {
        return None;
    }
    let s = sub64(o, a);
    let u = dot64(s, p) / det;
    let q = cross64(s, e1);
    let v = dot64(d, q) / det;
    let t = dot64(e2, q) / det;
    Some((t, [1.0 - u - v, u, v]))
}

pub(crate) fn sub64(x: [f64; 3], y: [f64; 3]) -> [f64; 3] {
    [x[0] - y[0], x[1] - y[1], x[2] - y[2]]
}

pub(crate) fn cross64(x: [f64; 3], y: [f64; 3]) -> [f64; 3] {
    [
        x[1] * y[2] - x[2] * y[1],
        x[2] * y[0] - x[0] * y[2],
        x[0] * y[1] - x[1] * y[0],
    ]
}

pub(crate) fn dot64(x: [f64; 3], y: [f64; 3]) -> f64 {
    x[0] * y[0] + x[1] * y[1] + x[2] * y[2]
}

pub(crate) fn len64(x: [f64; 3]) -> f64 {
    dot64(x, x).sqrt()
}

/// The documented bound on `|t - t_exact|` (the kernel's triangle module):
/// `2^-24 |t| + 2^-47 |e1|₁ |e2|₁ (|v0 - o|₁ + |t| |d|₁) / |n·d|`, doubled
/// for the reference's own rounding.
pub(crate) fn t_bound(tri: &Triangle, ray: &Ray, t: f64) -> f64 {
    let f = |p: [f32; 3]| p.map(f64::from);
    let [a, b, c] = tri.v.map(f);
    let (o, d) = (f(ray.origin), f(ray.dir));
    let l1 = |x: [f64; 3]| x[0].abs() + x[1].abs() + x[2].abs();
    let (e1, e2) = (sub64(b, a), sub64(c, a));
    let nd = dot64(cross64(e1, e2), d).abs();
    let shape = l1(e1) * l1(e2) * (l1(sub64(a, o)) + t.abs() * l1(d)) / nd;
    2.0 * (t.abs() * 2f64.powi(-24) + shape * 2f64.powi(-47))
}

/// Holds kdray's closest hits against the `f64` reference over all
/// triangles, failing only where the reference decides against kdray:
/// kdray's triangle missed by the reference by more than `margin` in
/// barycentrics, kdray's `t` beyond the bound of the reference's, or a
/// triangle the reference hits with every barycentric above `margin`
/// nearer than kdray's hit (or when kdray misses). Returns how many rays
/// hit, so a caller can check the rays reached the geometry.
pub(crate) fn assert_matches_f64(
    name: &str,
    tris: &[Triangle],
    tree: &kdray::kernel::TriangleTree<'_>,
    rays: &[Ray],
    margin: f64,
) -> usize {
    let mut hits = 0;
    for (i, r) in rays.iter().enumerate() {
        let kd = tree.closest_hit(r);
        let kd_t = if kd.is_hit() {
            hits += 1;
            let tri = &tris[kd.prim as usize];
            let (t, b) = line_hit(tri, r).unwrap_or_else(|| {
                panic!("{name}: ray {i} {r:?}: {kd:?} hits a triangle the reference finds parallel")
            });
            let bound = t_bound(tri, r, t);
            assert!(
                b.iter().all(|&x| x >= -margin),
                "{name}: ray {i} {r:?}: kdray hits triangle {} the reference misses (barycentrics {b:?})",
                kd.prim
            );
            assert!(
                (f64::from(kd.t) - t).abs() <= bound,
                "{name}: ray {i} {r:?}: kdray t {} vs reference {t} (bound {bound:e})",
                kd.t
            );
            f64::from(kd.t) - bound
        } else {
            f64::INFINITY
        };
        for (j, tri) in tris.iter().enumerate() {
            let Some((t, b)) = line_hit(tri, r).filter(|_| j as u32 != kd.prim) else {
                continue;
            };
            let robust = b.iter().all(|&x| x > margin);
            let in_range = t >= f64::from(r.tmin) && t <= f64::from(r.tmax);
            if robust && in_range && t + t_bound(tri, r, t) < kd_t {
                panic!("{name}: ray {i} {r:?}: the reference hits triangle {j} at t = {t} (barycentrics {b:?}), kdray {kd:?}");
            }
        }
    }
    hits
}

/// `n` small triangles in a 10-unit cube; with `grid`, vertices snapped
/// to a 1/2-unit grid so many rays meet edges, vertices and split planes.
pub(crate) fn scene(rng: &mut Rng, n: usize, grid: bool) -> Vec<Triangle> {
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

/// A ray from a point in the 12-unit cube around the scenes of [`scene`],
/// in a random direction, unbounded.
pub(crate) fn random_ray(rng: &mut Rng) -> Ray {
    Ray {
        origin: std::array::from_fn(|_| rng.f32() * 12.0 - 1.0),
        tmin: 0.0,
        dir: std::array::from_fn(|_| rng.f32() - 0.5),
        tmax: f32::INFINITY,
    }
}

/// A ray with hostile components: NaN, ±0, ±inf, subnormals, origins on
/// grid planes (where splits of snapped scenes lie), rays along them.
pub(crate) fn adversarial_ray(rng: &mut Rng) -> Ray {
    let special = [
        0.0,
        -0.0,
        f32::NAN,
        f32::INFINITY,
        f32::NEG_INFINITY,
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
    r.tmin = rng.pick(&[0.0, -0.0, 0.0, 0.0, 1.0, -5.0, f32::NAN, f32::NEG_INFINITY]);
    r.tmax = rng.pick(&[f32::INFINITY, f32::INFINITY, 3.0, 0.0, f32::NAN, -1.0]);
    r
}
