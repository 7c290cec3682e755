//! `kdray info TREE`: validate a blob and report its statistics.

use super::build_points::{dispatch, Shape, ShapedCommand};
use super::json::JsonObject;
use super::report::{print_stats, stats_json};
use super::CmdResult;
use kdray_kernel::{PointShape, Scalar};
use kdray_tools::blob::{Blob, BlobKind};
use kdray_tools::builders::BuildParams;
use kdray_tools::stats::{tree_stats, CostModel};
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `kdray info`.
#[derive(clap::Args, Debug)]
pub(crate) struct Args {
    /// The tree blob.
    tree: PathBuf,
    /// Print one JSON object instead of the summary.
    #[arg(long)]
    json: bool,
}

pub(crate) fn run(a: &Args) -> CmdResult {
    let blob = match Blob::read(&a.tree) {
        Ok(b) => b,
        Err(e) => return fail(a, format!("{}: {e}", a.tree.display())),
    };
    if blob.kind() == BlobKind::Points {
        return point_info(a, &blob);
    }
    let t = Instant::now();
    if blob.kind() == BlobKind::Scene {
        let scene = match blob.scene() {
            Ok(s) => s,
            Err(e) => return fail(a, format!("{}: invalid scene blob: {e}", a.tree.display())),
        };
        let validate_ms = t.elapsed().as_secs_f64() * 1e3;
        let mesh_tris: Vec<usize> = (0..scene.mesh_count())
            .map(|m| scene.mesh(m).map_or(0, |t| t.triangles().len()))
            .collect();
        let flat: usize = scene
            .instances()
            .iter()
            .map(|i| mesh_tris.get(i.mesh() as usize).copied().unwrap_or(0))
            .sum();
        if a.json {
            let j = JsonObject::default()
                .with("tree", a.tree.display().to_string())
                .with("valid", true)
                .with("kind", "scene")
                .with("validate_ms", validate_ms)
                .with("bytes", blob.as_bytes().len())
                .with("instances", scene.instances().len())
                .with("meshes", scene.mesh_count())
                .with("mesh_triangles", mesh_tris.iter().sum::<usize>())
                .with("flattened_triangles", flat)
                .with("top_level_nodes", scene.nodes().len())
                .with("top_level_depth", scene.max_depth());
            say!("{}", j.finish());
        } else {
            say!(
                "{}: valid kdray scene (validated in {validate_ms:.1} ms)",
                a.tree.display()
            );
            say!("  bytes              {}", blob.as_bytes().len());
            say!("  instances          {}", scene.instances().len());
            say!(
                "  meshes             {} ({} triangles)",
                scene.mesh_count(),
                mesh_tris.iter().sum::<usize>()
            );
            say!("  flattened          {flat} triangles");
            say!(
                "  top level          {} nodes, depth {}",
                scene.nodes().len(),
                scene.max_depth()
            );
        }
        return Ok(());
    }
    let tree = match blob.tree() {
        Ok(t) => t,
        Err(e) => return fail(a, format!("{}: invalid tree blob: {e}", a.tree.display())),
    };
    let validate_ms = t.elapsed().as_secs_f64() * 1e3;
    let stats = tree_stats(&tree, CostModel::from_params(&BuildParams::default()));
    if a.json {
        let j = JsonObject::default()
            .with("tree", a.tree.display().to_string())
            .with("valid", true)
            .with("validate_ms", validate_ms);
        say!("{}", stats_json(j, &stats).finish());
    } else {
        say!(
            "{}: valid kdray triangle tree (validated in {validate_ms:.1} ms)",
            a.tree.display()
        );
        print_stats(&stats);
    }
    Ok(())
}

/// `kdray info` of a point blob: its shape picks the compiled D and scalar.
fn point_info(a: &Args, blob: &Blob) -> CmdResult {
    let shape = match PointShape::of_blob(blob.as_bytes()) {
        Ok(s) => s,
        Err(e) => return fail(a, format!("{}: invalid point blob: {e}", a.tree.display())),
    };
    let shape = Shape {
        dim: shape.dim as usize,
        f64: shape.scalar_bytes == 8,
    };
    dispatch(shape, &PointInfo { a, blob })
}

/// `kdray info` of a point blob of a known shape.
struct PointInfo<'a> {
    a: &'a Args,
    blob: &'a Blob,
}

impl ShapedCommand for PointInfo<'_> {
    fn run<const D: usize, S: Scalar>(&self) -> CmdResult {
        let a = self.a;
        let t = Instant::now();
        let tree = match self.blob.point_tree::<D, S>() {
            Ok(t) => t,
            Err(e) => return fail(a, format!("{}: invalid point blob: {e}", a.tree.display())),
        };
        let validate_ms = t.elapsed().as_secs_f64() * 1e3;
        let bytes = self.blob.as_bytes().len();
        if a.json {
            let j = JsonObject::default()
                .with("tree", a.tree.display().to_string())
                .with("valid", true)
                .with("kind", "points")
                .with("validate_ms", validate_ms)
                .with("points", tree.len())
                .with("dim", D)
                .with("scalar", S::NAME)
                .with("nodes", tree.nodes().len())
                .with("max_depth", tree.max_depth())
                .with("bytes", bytes);
            say!("{}", j.finish());
        } else {
            say!(
                "{}: valid kdray point tree (validated in {validate_ms:.1} ms)",
                a.tree.display()
            );
            say!("  points             {} ({D}-D {})", tree.len(), S::NAME);
            say!("  nodes              {}", tree.nodes().len());
            say!("  depth              max {}", tree.max_depth());
            say!("  size               {bytes} bytes");
        }
        Ok(())
    }
}

/// The error `message`, also as a JSON verdict on stdout under `--json`
/// (a script reading stdout learns it there, not only from stderr).
fn fail(a: &Args, message: String) -> CmdResult {
    if a.json {
        let j = JsonObject::default()
            .with("tree", a.tree.display().to_string())
            .with("valid", false)
            .with("error", &message);
        say!("{}", j.finish());
    }
    Err(message.into())
}
