//! Times the per-frame top level of a generated level whose instances
//! move, one thread: `taskset -c 0 cargo run --release -p kdray-tools
//! --example scene_move -- 10000 FRAMES SPEED` (defaults 200 frames of
//! 0.02 units per frame, instances about 2 units across). Each frame the
//! moved instances' world boxes are computed (timed apart) and the top
//! level rebuilt ([`build_top_level_with`]); then, in a second pass over
//! the same frames, the kept one updated ([`TopLevel::update`]); prints
//! both times (best, mean, worst), the rebuilds, and the SAH cost of both
//! trees at the last frame.

use kdray_tools::instances::{
    build_top_level_with, generated_level, mesh_bounds, moved_level, world_boxes, TopLevel,
    TopParams,
};
use std::time::Instant;

#[path = "support/stat.rs"]
mod stat;
use stat::Stat;

fn main() {
    let arg = |i: usize| std::env::args().nth(i).and_then(|a| a.parse::<f64>().ok());
    let n = arg(1).map_or(10_000, |x| x as usize);
    let frames = arg(2).map_or(200, |x| x as u32);
    let speed = arg(3).unwrap_or(0.02) as f32;
    let p = TopParams {
        drift: arg(4).unwrap_or(TopParams::DEFAULT.drift),
        ..TopParams::DEFAULT
    };
    let (meshes, instances) = generated_level(n / 2, (n as f32).sqrt() * 2.0, 1);
    let bounds = mesh_bounds(&meshes).expect("the generated meshes build");
    // The rebuilds and the kept tree's updates run in two passes over the
    // same frames, so neither finds the caches as the other left them.
    let (mut boxes_t, mut build_t, mut update_t) =
        (Stat::default(), Stat::default(), Stat::default());
    let frame_boxes = |f: u32| world_boxes(&bounds, &moved_level(&instances, f, speed, 2));
    let mut fresh = None;
    for f in 1..=frames {
        let boxes = frame_boxes(f);
        let t = Instant::now();
        fresh = Some(build_top_level_with(&boxes, &p));
        build_t.add(t.elapsed().as_secs_f64());
    }
    let mut kept = TopLevel::new(&world_boxes(&bounds, &instances), &p);
    let mut rebuilds = 0;
    for f in 1..=frames {
        let moved = moved_level(&instances, f, speed, 2);
        let t = Instant::now();
        let boxes = world_boxes(&bounds, &moved);
        boxes_t.add(t.elapsed().as_secs_f64());
        let t = Instant::now();
        rebuilds += u32::from(kept.update(&boxes));
        update_t.add(t.elapsed().as_secs_f64());
    }
    let fresh = fresh.expect("one frame at least");
    let cost = |t: &kdray_tools::builders::BuiltTree| {
        kdray_tools::stats::sah_cost(&t.nodes, &t.bounds, p.cost)
    };
    println!(
        "{} instances, {frames} frames of {speed} per frame: world boxes {}, rebuild {}, kept and updated {} ({rebuilds} rebuilds); last frame SAH cost rebuilt {:.2}, kept {:.2} ({} listed)",
        instances.len(),
        boxes_t,
        build_t,
        update_t,
        cost(&fresh),
        cost(kept.tree()),
        listed(kept.tree()),
    );
}

/// How many instance references the leaves of `t` hold (its `prims` may
/// also hold room for runs to grow).
fn listed(t: &kdray_tools::builders::BuiltTree) -> u32 {
    t.nodes
        .iter()
        .map(|n| match n.kind() {
            kdray_kernel::NodeKind::Leaf { count, .. } => count,
            kdray_kernel::NodeKind::Interior { .. } => 0,
        })
        .sum()
}
