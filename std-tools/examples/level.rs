//! Writes a generated level three ways, for the `## Scenes` figures in
//! docs/results.md: `cargo run --release -p kdray-tools --example level --
//! COPIES DIR` writes DIR/scene.kdt (the scene blob), DIR/flat.kdt (the
//! flattened tree) and DIR/flat.obj (the flattened triangles).

use kdray_tools::blob::write_triangle_tree;
use kdray_tools::builders::{build, BuildParams, BuilderKind};
use kdray_tools::instances::{build_scene, flatten_scene, generated_level};
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let copies: usize = std::env::args().nth(1).map_or(Ok(1000), |a| a.parse())?;
    let dir = PathBuf::from(std::env::args().nth(2).unwrap_or_else(|| ".".into()));
    let size = (copies as f32).sqrt() * 4.0;
    let (meshes, instances) = generated_level(copies, size, 1);
    let parts = build_scene(
        &meshes,
        instances,
        BuilderKind::default(),
        &BuildParams::default(),
    )?;
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
