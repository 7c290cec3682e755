//! Times the top-level rebuild of a generated level, one thread:
//! `taskset -c 0 cargo run --release -p kdray-tools --example scene_build -- 10000`
//! (then, to try other parameters: intersection cost, bins, leaf size,
//! extra depth).

use kdray_tools::builders::CostModel;
use kdray_tools::instances::{
    build_top_level_with, generated_level, mesh_bounds, world_boxes, TopParams,
};
use std::time::Instant;

fn main() {
    let arg = |i: usize| std::env::args().nth(i).and_then(|a| a.parse::<f64>().ok());
    let n = arg(1).map_or(10_000, |x| x as usize);
    let d = TopParams::DEFAULT;
    let p = TopParams {
        cost: CostModel {
            intersection: arg(2).unwrap_or(d.cost.intersection),
            ..d.cost
        },
        bins: arg(3).map_or(d.bins, |x| x as usize),
        leaf_size: arg(4).map_or(d.leaf_size, |x| x as usize),
        extra_depth: arg(5).map_or(d.extra_depth, |x| x as u32),
        ..d
    };
    let (meshes, instances) = generated_level(n / 2, (n as f32).sqrt() * 2.0, 1);
    let bounds = mesh_bounds(&meshes).expect("the generated meshes build");
    let (mut best_boxes, mut best_top) = (f64::INFINITY, f64::INFINITY);
    let mut top = None;
    for _ in 0..50 {
        let t = Instant::now();
        let boxes = world_boxes(&bounds, &instances);
        let t_boxes = t.elapsed().as_secs_f64();
        let tree = build_top_level_with(&boxes, &p);
        let t_all = t.elapsed().as_secs_f64();
        best_boxes = best_boxes.min(t_boxes);
        best_top = best_top.min(t_all - t_boxes);
        top = Some(tree);
    }
    let top = top.expect("built");
    let cost = kdray_tools::stats::sah_cost(&top.nodes, &top.bounds, p.cost);
    let (nodes, refs) = (top.nodes.len(), top.prims.len());
    // FNV-1a over the laid-out tree: equal prints, the same tree.
    let print = format!("{:?}{:?}", top.nodes, top.prims)
        .bytes()
        .fold(0xcbf2_9ce4_8422_2325, |h, b| {
            (h ^ u64::from(b)).wrapping_mul(0x100_0000_01b3)
        });
    println!(
        "{} instances: world boxes {:.3} ms, top level {:.3} ms ({nodes} nodes, {refs} listed, SAH cost {cost:.2}, print {print:016x}), best of 50, {p:?}",
        instances.len(),
        best_boxes * 1e3,
        best_top * 1e3
    );
}
