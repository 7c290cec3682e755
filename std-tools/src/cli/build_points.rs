//! `kdray build-points POINTS -o TREE`: build a point tree and write it as
//! a kind-2 blob (for firmware: load it with `PointTree::from_bytes`).

use super::json::JsonObject;
use super::CmdResult;
use kdray_tools::blob::write_point_tree;
use kdray_tools::io;
use kdray_tools::points::{build_points, PointParams};
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `kdray build-points`.
#[derive(clap::Args, Debug)]
pub(crate) struct Args {
    /// The points (.pts: 12-byte records, docs/formats.md).
    points: PathBuf,
    /// Where to write the tree blob.
    #[arg(short, long)]
    output: PathBuf,
    /// Points per leaf (the lecture's m).
    #[arg(long, default_value_t = PointParams::default().leaf_size)]
    leaf_size: usize,
    /// Print one JSON object instead of the summary.
    #[arg(long)]
    json: bool,
}

pub(crate) fn run(a: &Args) -> CmdResult {
    io::check_output(&a.output)?;
    if a.leaf_size == 0 {
        return Err("--leaf-size must be at least 1".into());
    }
    let points: Vec<[f32; 3]> = io::read_records(&a.points, "point")?;
    let params = PointParams {
        leaf_size: a.leaf_size,
        ..PointParams::default()
    };
    let t = Instant::now();
    let built =
        build_points(&points, &params).map_err(|e| format!("{}: {e}", a.points.display()))?;
    let build_ms = t.elapsed().as_secs_f64() * 1e3;
    let blob = write_point_tree(&built);
    blob.point_tree()
        .map_err(|e| format!("internal error: the built tree does not validate: {e}"))?;
    io::write_bytes(&a.output, blob.as_bytes())?;
    if a.json {
        let j = JsonObject::default()
            .num("points", points.len() as f64)
            .num("nodes", built.nodes.len() as f64)
            .num("max_depth", f64::from(built.max_depth))
            .num("bytes", blob.as_bytes().len() as f64)
            .num("build_ms", build_ms)
            .str(
                "timing",
                "build_ms excludes reading the points and writing the blob",
            );
        say!("{}", j.finish());
    } else {
        say!(
            "built {} points -> {}: {} nodes, depth {}, {} bytes, {build_ms:.1} ms (excluding file I/O)",
            points.len(),
            a.output.display(),
            built.nodes.len(),
            built.max_depth,
            blob.as_bytes().len()
        );
    }
    Ok(())
}
