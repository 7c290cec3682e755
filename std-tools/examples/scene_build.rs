//! Times the top-level rebuild of a generated level, one thread:
//! `taskset -c 0 cargo run --release -p kdray-tools --example scene_build -- 10000`.

use kdray_tools::builders::{build, BuildParams, BuilderKind};
use kdray_tools::instances::{build_top_level, generated_level, world_boxes};
use std::time::Instant;

fn main() {
    let n: usize = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(10_000);
    let (meshes, instances) = generated_level(n / 2, (n as f32).sqrt() * 2.0, 1);
    let bounds: Vec<_> = meshes
        .iter()
        .map(|m| {
            build(m, BuilderKind::default(), &BuildParams::default())
                .unwrap()
                .bounds
        })
        .collect();
    let mut best_boxes = f64::INFINITY;
    let mut best_top = f64::INFINITY;
    let mut nodes = 0;
    for _ in 0..50 {
        let t = Instant::now();
        let boxes = world_boxes(&bounds, &instances);
        let t_boxes = t.elapsed().as_secs_f64();
        let top = build_top_level(&boxes);
        let t_all = t.elapsed().as_secs_f64();
        best_boxes = best_boxes.min(t_boxes);
        best_top = best_top.min(t_all - t_boxes);
        nodes = top.nodes.len();
    }
    println!(
        "{} instances: world boxes {:.3} ms, top level {:.3} ms ({nodes} nodes), best of 50",
        instances.len(),
        best_boxes * 1e3,
        best_top * 1e3
    );
}
