//! Writes a generated level three ways, for the `## Scenes` figures in
//! docs/results.md: `cargo run --release -p kdray-tools --example level --
//! COPIES DIR` writes DIR/scene.kdt (the scene blob), DIR/flat.kdt (the
//! flattened tree) and DIR/flat.obj (the flattened triangles). With
//! `LEAF_SIZE EXTRA_DEPTH BINS` after them it writes only DIR/scene.kdt,
//! its top level built with those [`TopParams`] (to weigh a faster
//! rebuild against the rays' rate). With `moved FRAMES SPEED [DRIFT]`
//! after them it moves the instances for FRAMES frames
//! ([`moved_level`]) and writes DIR/kept.kdt, whose top level was kept
//! and updated every frame ([`TopLevel::update`], rebuilt past DRIFT,
//! default [`TopParams::DEFAULT`]'s), and DIR/moved.kdt, the same
//! instances under a top level built afresh: the rays a kept top level
//! costs, and the same answers.

use kdray_tools::blob::write_triangle_tree;
use kdray_tools::builders::{build, BuildParams, BuilderKind};
use kdray_tools::instances::{
    build_scene, build_top_level_with, flatten_scene, generated_level, moved_level, world_boxes,
    SceneParts, TopLevel, TopParams,
};
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let copies: usize = std::env::args().nth(1).map_or(Ok(1000), |a| a.parse())?;
    let dir = PathBuf::from(std::env::args().nth(2).unwrap_or_else(|| ".".into()));
    let size = (copies as f32).sqrt() * 4.0;
    let (meshes, instances) = generated_level(copies, size, 1);
    let mut parts = build_scene(
        &meshes,
        instances,
        BuilderKind::default(),
        &BuildParams::default(),
    )?;
    if std::env::args().nth(3).as_deref() == Some("moved") {
        let arg = |i: usize| std::env::args().nth(i).and_then(|a| a.parse::<f64>().ok());
        let frames = arg(4).map_or(100, |f| f as u32);
        let speed = arg(5).unwrap_or(0.02) as f32;
        let drift = arg(6).unwrap_or(TopParams::DEFAULT.drift);
        return write_moved(parts, &dir, frames, speed, drift);
    }
    let top: Vec<usize> = (3..6)
        .filter_map(|i| std::env::args().nth(i)?.parse().ok())
        .collect();
    if let [leaf_size, extra_depth, bins] = top[..] {
        let p = TopParams {
            leaf_size,
            extra_depth: extra_depth as u32,
            bins,
            ..TopParams::DEFAULT
        };
        let bounds: Vec<_> = parts.trees()?.iter().map(|t| t.bounds()).collect();
        parts.top = build_top_level_with(&world_boxes(&bounds, &parts.instances), &p);
        std::fs::write(dir.join("scene.kdt"), parts.write()?.as_bytes())?;
        println!("scene.kdt with {p:?}");
        return Ok(());
    }
    let scene = parts.write()?;
    std::fs::write(dir.join("scene.kdt"), scene.as_bytes())?;
    let flat = flatten_scene(&meshes, &parts.instances);
    let tree = build(&flat, BuilderKind::default(), &BuildParams::default())?;
    std::fs::write(
        dir.join("flat.kdt"),
        write_triangle_tree(&tree, &flat)?.as_bytes(),
    )?;
    std::fs::write(dir.join("flat.obj"), kdray_tools::mesh::obj_text(&flat))?;
    println!(
        "{} instances, {} flattened triangles: scene {} bytes, flattened tree {} bytes",
        parts.instances.len(),
        flat.len(),
        scene.as_bytes().len(),
        std::fs::metadata(dir.join("flat.kdt"))?.len()
    );
    Ok(())
}

/// The `moved` mode: `parts`' instances moved for `frames` frames, under
/// the kept top level (DIR/kept.kdt) and under a fresh one (DIR/moved.kdt).
fn write_moved(
    mut parts: SceneParts,
    dir: &std::path::Path,
    frames: u32,
    speed: f32,
    drift: f64,
) -> Result<(), Box<dyn std::error::Error>> {
    let bounds: Vec<_> = parts.trees()?.iter().map(|t| t.bounds()).collect();
    let start = parts.instances.clone();
    let p = TopParams {
        drift,
        ..TopParams::DEFAULT
    };
    let mut boxes = world_boxes(&bounds, &start);
    let mut kept = TopLevel::new(&boxes, &p);
    let mut rebuilds = 0;
    for f in 1..=frames {
        parts.instances = moved_level(&start, f, speed, 2);
        boxes = world_boxes(&bounds, &parts.instances);
        rebuilds += u32::from(kept.update(&boxes));
    }
    parts.top = kept.tree().clone();
    std::fs::write(dir.join("kept.kdt"), parts.write()?.as_bytes())?;
    parts.top = build_top_level_with(&boxes, &p);
    std::fs::write(dir.join("moved.kdt"), parts.write()?.as_bytes())?;
    println!("{frames} frames of {speed} per frame, drift {drift}: {rebuilds} rebuilds; kept.kdt, moved.kdt");
    Ok(())
}
