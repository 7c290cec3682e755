//! Times a deforming mesh's per-frame tree, one thread: `taskset -c 0
//! cargo run --release -p kdray-tools --example mesh_deform -- MESH.obj
//! [FRAMES] [AMPLITUDE] [PERIOD]` (defaults 100 frames, a wave of 1% of
//! the mesh's extent, 60 frames a period). Each frame moves every vertex
//! along x by a wave travelling up y; the tree is built afresh with
//! `fast` (the mesh's kernel view, validated, included), then, in a
//! second pass over the same frames, kept and updated
//! ([`DeformingMesh::update`]) and viewed ([`DeformingMesh::view`]).
//! Prints the times (best, mean, worst), the rebuilds, the
//! SAH cost of both trees at the last frame, and traces 65,536 rays into
//! the last frame with both trees (their rates; the hits must be equal).

use kdray_kernel::glam::Vec3;
use kdray_kernel::{Bounds, Ray, Triangle, TriangleTree};
use kdray_tools::builders::{build, BuildParams, BuilderKind, CostModel};
use kdray_tools::deforming::DeformingMesh;
use kdray_tools::rng::Rng;
use kdray_tools::stats::sah_cost;
use std::time::Instant;

#[path = "support/stat.rs"]
mod stat;
use stat::Stat;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let path = args
        .get(1)
        .expect("usage: mesh_deform MESH.obj [FRAMES] [AMPLITUDE] [PERIOD]");
    let arg = |i: usize| args.get(i).and_then(|a| a.parse::<f64>().ok());
    let frames = arg(2).map_or(100, |x| x as u32);
    let amplitude = arg(3).unwrap_or(0.01) as f32;
    let period = arg(4).unwrap_or(60.0) as f32;
    let rest = kdray_tools::mesh::load(std::path::Path::new(path)).expect("the mesh loads");
    let Bounds { min: lo, max: hi } = rest.iter().fold(Bounds::EMPTY, |u, t| u.union(&t.bounds()));
    let extent = (0..3).fold(0.0f32, |m, a| m.max(hi[a] - lo[a]));
    // A wave along x travelling up y: one wavelength over the mesh's height.
    let frame = |f: u32| -> Vec<Triangle> {
        let phase = std::f32::consts::TAU * f as f32 / period;
        rest.iter()
            .map(|t| Triangle {
                v: t.v.map(|[x, y, z]| {
                    let k = std::f32::consts::TAU * (y - lo[1]) / extent;
                    [x + amplitude * extent * (phase + k).sin(), y, z]
                }),
            })
            .collect()
    };
    let params = BuildParams {
        threads: Some(1),
        ..BuildParams::default()
    };
    // The rebuilds and the updates run in two passes over the same frames.
    let (mut build_t, mut update_t, mut view_t) =
        (Stat::default(), Stat::default(), Stat::default());
    let mut fresh = None;
    for f in 1..=frames {
        let tris = frame(f);
        let t = Instant::now();
        let tree = build(&tris, BuilderKind::Fast, &params).expect("the frame builds");
        TriangleTree::from_parts(&tree.nodes, &tree.prims, &tris, tree.bounds).expect("valid");
        build_t.add(t.elapsed().as_secs_f64());
        fresh = Some((tree, tris));
    }
    let mut kept = DeformingMesh::new(&rest, &params, DeformingMesh::DRIFT).expect("it builds");
    let mut rebuilds = 0;
    let mut last = rest.clone();
    for f in 1..=frames {
        let tris = frame(f);
        let t = Instant::now();
        rebuilds += u32::from(kept.update(&tris).expect("the frame updates"));
        update_t.add(t.elapsed().as_secs_f64());
        let t = Instant::now();
        kept.view(&tris).expect("valid");
        view_t.add(t.elapsed().as_secs_f64());
        last = tris;
    }
    let (fresh, tris) = fresh.expect("one frame at least");
    let cost = CostModel::from_params(&params);
    println!(
        "{} triangles, {frames} frames, wave {amplitude} x extent, period {period}: rebuild and view {build_t}, kept: update {update_t} ({rebuilds} rebuilds), view {view_t}; last frame SAH cost rebuilt {:.2}, kept {:.2}",
        rest.len(),
        sah_cost(&fresh.nodes, &fresh.bounds, cost),
        sah_cost(&kept.tree().nodes, &kept.tree().bounds, cost),
    );
    // Both trees of the last frame against each other: rays from a sphere
    // around the mesh through random points of its box.
    let a = TriangleTree::from_parts(&fresh.nodes, &fresh.prims, &tris, fresh.bounds).expect("ok");
    let b = kept.view(&last).expect("valid");
    let mut r = Rng::new(7);
    let centre = Vec3::from_array(std::array::from_fn(|i| (lo[i] + hi[i]) / 2.0));
    let rays: Vec<Ray> = (0..65_536)
        .map(|_| {
            let o = centre
                + Vec3::new(r.range(-1.0, 1.0), r.range(-1.0, 1.0), r.range(-1.0, 1.0))
                    .normalize_or_zero()
                    * extent;
            let p = Vec3::from_array(std::array::from_fn(|i| r.range(lo[i], hi[i])));
            Ray::new(o, p - o)
        })
        .collect();
    // The two trees' passes interleaved, best of seven each.
    let pass = |t: &TriangleTree<'_>, best: &mut f64| -> Vec<kdray_kernel::Hit> {
        let s = Instant::now();
        let hits = rays.iter().map(|ray| t.closest_hit(ray)).collect();
        *best = best.min(s.elapsed().as_secs_f64());
        hits
    };
    let (mut best_a, mut best_b) = (f64::INFINITY, f64::INFINITY);
    let (mut x, mut y) = (Vec::new(), Vec::new());
    for _ in 0..7 {
        x = pass(&a, &mut best_a);
        y = pass(&b, &mut best_b);
    }
    let rate = |best: f64| rays.len() as f64 / best / 1e6;
    let (rate_a, rate_b) = (rate(best_a), rate(best_b));
    for ((x, y), ray) in x.iter().zip(&y).zip(&rays) {
        assert_eq!(x.bits(), y.bits(), "the kept tree's hit differs: {ray:?}");
    }
    let hits = x.iter().filter(|h| h.is_hit()).count();
    println!(
        "65536 rays into the last frame: {hits} hits, the same in both trees; rebuilt {rate_a:.2} Mrays/s, kept {rate_b:.2} Mrays/s"
    );
}
