//! `kdray build MESH -o TREE`: load, build, write, report.

use super::json::JsonObject;
use super::progress::with_bar;
use super::report::{print_stats, stats_json};
use super::{check_threads, CmdResult, MeshArgs};
use kdray_kernel::Instance;
use kdray_tools::blob::write_triangle_tree;
use kdray_tools::builders::{build_monitored, BuildMonitor, BuildParams, BuilderKind};
use kdray_tools::instances::build_scene;
use kdray_tools::io;
use kdray_tools::stats::{tree_stats, CostModel};
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `kdray build`.
#[derive(clap::Args, Debug)]
pub(crate) struct Args {
    /// The mesh (.obj, .ply, .gltf, .glb).
    mesh: PathBuf,
    /// Where to write the tree blob.
    #[arg(short, long)]
    output: PathBuf,
    /// The builder: sah (default), sweep, binned, fast, median or middle.
    #[arg(long, default_value = "sah")]
    builder: String,
    /// Build threads (default: all cores); the tree is the same for any count.
    #[arg(long)]
    threads: Option<usize>,
    /// Cost of a traversal step in the SAH (default: BuildParams' 1.0).
    #[arg(long, allow_negative_numbers = true)]
    traversal_cost: Option<f32>,
    /// Cost of a triangle test in the SAH (default: BuildParams' 0.5).
    #[arg(long, allow_negative_numbers = true)]
    intersection_cost: Option<f32>,
    /// Fraction of cost forgiven for an empty side (default: BuildParams' 0.2).
    #[arg(long, allow_negative_numbers = true)]
    empty_bonus: Option<f32>,
    /// Deepest leaf (default 8 + 1.3 log2 n, at most 64; a larger value is
    /// refused).
    #[arg(long)]
    max_depth: Option<u32>,
    /// Print one JSON object instead of the summary.
    #[arg(long)]
    json: bool,
    /// Keep a glTF's mesh references as instances: write a scene blob (a
    /// tree per mesh, an instance per node with a mesh, a top-level tree)
    /// instead of flattening every node's mesh into one tree.
    #[arg(long)]
    instances: bool,
    #[command(flatten)]
    mesh_args: MeshArgs,
}

pub(crate) fn run(a: &Args) -> CmdResult {
    // Every argument is checked before the mesh is read and built.
    super::check_apart_from_mesh(&a.output, &a.mesh)?;
    let kind = BuilderKind::parse(&a.builder)?;
    check_threads(a.threads)?;
    let d = BuildParams::default();
    let params = BuildParams {
        threads: a.threads,
        traversal_cost: a.traversal_cost.unwrap_or(d.traversal_cost),
        intersection_cost: a.intersection_cost.unwrap_or(d.intersection_cost),
        empty_bonus: a.empty_bonus.unwrap_or(d.empty_bonus),
        max_depth: a.max_depth.or(d.max_depth),
        ..d
    };
    params.check(|field| format!("--{}", field.replace('_', "-")))?;
    if a.instances {
        return build_instanced(a, kind, &params);
    }
    let t = Instant::now();
    let tris = a.mesh_args.load(&a.mesh)?;
    let load_ms = t.elapsed().as_secs_f64() * 1e3;
    let monitor = BuildMonitor::new();
    let t = Instant::now();
    let built = with_bar(&monitor, || build_monitored(&tris, kind, &params, &monitor))
        .map_err(|e| format!("{}: {e}", a.mesh.display()))?;
    let build_ms = t.elapsed().as_secs_f64() * 1e3;
    let blob = write_triangle_tree(&built, &tris)?;
    let tree = blob
        .tree()
        .map_err(|e| format!("internal error: the built tree does not validate: {e}"))?;
    let stats = tree_stats(&tree, CostModel::from_params(&params));
    io::write_bytes(&a.output, blob.as_bytes())?;
    if a.json {
        let j = JsonObject::default()
            .with("mesh", a.mesh.display().to_string())
            .with("output", a.output.display().to_string())
            .with("builder", kind.name())
            .with("load_ms", load_ms)
            .with("build_ms", build_ms)
            .with(
                "peak_build_bytes_per_triangle",
                monitor.peak_bytes() as f64 / tris.len().max(1) as f64,
            )
            .with(
                "timing",
                "build_ms excludes reading and parsing the mesh and writing the blob",
            );
        say!("{}", stats_json(j, &stats).finish());
    } else {
        say!("built {} -> {}", a.mesh.display(), a.output.display());
        say!("  load               {load_ms:.1} ms");
        say!(
            "  build              {build_ms:.1} ms ({} builder)",
            kind.name()
        );
        print_stats(&stats);
    }
    Ok(())
}

/// `kdray build --instances`: a scene blob from a glTF file.
fn build_instanced(a: &Args, kind: BuilderKind, params: &BuildParams) -> CmdResult {
    let t = Instant::now();
    let g = a.mesh_args.load_instanced(&a.mesh)?;
    let load_ms = t.elapsed().as_secs_f64() * 1e3;
    let t = Instant::now();
    let mut instances = Vec::with_capacity(g.instances.len());
    for &(mesh, m, node) in &g.instances {
        let inst = Instance::new(mesh, m, node, u32::MAX).ok_or_else(|| {
            format!(
                "{}: node {node}: its transform is singular or not finite",
                a.mesh.display()
            )
        })?;
        instances.push(inst);
    }
    let parts = build_scene(&g.meshes, instances, kind, params)
        .map_err(|e| format!("{}: {e}", a.mesh.display()))?;
    let build_ms = t.elapsed().as_secs_f64() * 1e3;
    let blob = parts.write()?;
    blob.scene()
        .map_err(|e| format!("internal error: the built scene does not validate: {e}"))?;
    io::write_bytes(&a.output, blob.as_bytes())?;
    let tris: usize = g.meshes.iter().map(Vec::len).sum();
    if a.json {
        let j = JsonObject::default()
            .with("mesh", a.mesh.display().to_string())
            .with("output", a.output.display().to_string())
            .with("kind", "scene")
            .with("load_ms", load_ms)
            .with("build_ms", build_ms)
            .with("meshes", g.meshes.len())
            .with("mesh_triangles", tris)
            .with("instances", parts.instances.len())
            .with("bytes", blob.as_bytes().len());
        say!("{}", j.finish());
    } else {
        say!(
            "built {} -> {} (scene)",
            a.mesh.display(),
            a.output.display()
        );
        say!("  load               {load_ms:.1} ms");
        say!(
            "  build              {build_ms:.1} ms ({} builder per mesh)",
            kind.name()
        );
        say!("  meshes             {} ({tris} triangles)", g.meshes.len());
        say!("  instances          {}", parts.instances.len());
        say!("  bytes              {}", blob.as_bytes().len());
    }
    Ok(())
}
