//! Writes a generated level three ways, for the `## Scenes` figures in
//! docs/results.md: `cargo run --release -p kdray-tools --example level --
//! COPIES DIR` writes DIR/scene.kdt (the scene blob), DIR/flat.kdt (the
//! flattened tree) and DIR/flat.obj (the flattened triangles). With
//! `LEAF_SIZE EXTRA_DEPTH BINS` after them it writes only DIR/scene.kdt,
//! its top level built with those [`TopParams`] (to weigh a faster
//! rebuild against the rays' rate).

use kdray_tools::blob::write_triangle_tree;
use kdray_tools::builders::{build, BuildParams, BuilderKind};
use kdray_tools::instances::{
    build_scene, build_top_level_with, flatten_scene, generated_level, world_boxes, TopParams,
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
