//! `kdray bench [SCENE...]`: every builder on every scene, one markdown
//! table: build time, tree quality (SAH cost under the builder's model and
//! under Wald & Havran's), size, the build's peak working memory, and
//! single-ray closest-hit speed for camera and random rays on the calling
//! thread (pin it: `taskset -c 0 kdray bench --threads 1`).
//!
//! A scene is an OBJ path or a generated scene: `stadium` (the built-in
//! teapot in a stadium with bleachers), `teapot-stadium:MESH` (MESH in the
//! 1000-wide box of `gen_stadium.py`), `needles` (long thin axis-aligned
//! triangles). Camera rays frame the detailed object.

use super::{check_image, check_threads, CmdResult, MeshArgs, MAX_PIXELS};
use kdray_kernel::{Hit, Ray};
use kdray_tools::blob::write_triangle_tree;
use kdray_tools::builders::{build_monitored, BuildMonitor, BuildParams, BuilderKind};
use kdray_tools::camera::{random_rays, Camera};
use kdray_tools::demo_scene::{bounds_of, in_stadium, needles, teapot_in_stadium, DemoScene};
use kdray_tools::stats::{tree_stats, CostModel};
use kdray_tools::trace::{trace_serial, PacketWidth, Query};
use std::path::Path;
use std::time::Instant;

/// Arguments of `kdray bench`.
#[derive(clap::Args, Debug)]
pub(crate) struct Args {
    /// Scenes: mesh paths (OBJ, PLY, glTF), `stadium`, `teapot-stadium:MESH`
    /// or `needles`.
    #[arg(required = true)]
    scenes: Vec<String>,
    /// Builders to run (comma-separated; default: all of them).
    #[arg(long, value_delimiter = ',')]
    builders: Vec<String>,
    /// Build threads (default: all cores). Tracing is single-threaded.
    #[arg(long)]
    threads: Option<usize>,
    /// Camera rays (a square image) and random rays per scene.
    #[arg(long, default_value_t = 262_144)]
    rays: usize,
    /// Builds timed per builder (the best is reported).
    #[arg(long, default_value_t = 3)]
    repeat: usize,
    #[command(flatten)]
    mesh_args: MeshArgs,
}

fn scene(
    spec: &str,
    mesh_args: MeshArgs,
) -> Result<(String, DemoScene), Box<dyn std::error::Error>> {
    if spec == "stadium" {
        return Ok(("built-in teapot-in-stadium".into(), teapot_in_stadium()));
    }
    if spec == "needles" {
        return Ok(("needles".into(), needles(20_000)));
    }
    if let Some(path) = spec.strip_prefix("teapot-stadium:") {
        let m = mesh_args.load(Path::new(path))?;
        return Ok((format!("{}-in-stadium", file_stem(path)), in_stadium(&m)));
    }
    if !Path::new(spec).exists() {
        return Err(format!(
            "{spec}: no such file, and not a generated scene (stadium, teapot-stadium:MESH, needles)"
        )
        .into());
    }
    let triangles = mesh_args.load(Path::new(spec))?;
    let focus = bounds_of(&triangles);
    Ok((file_stem(spec), DemoScene { triangles, focus }))
}

fn file_stem(p: &str) -> String {
    Path::new(p)
        .file_stem()
        .map_or(p.to_string(), |s| s.to_string_lossy().into_owned())
}

/// Mrays/s of closest hits on this thread, best of 3 passes.
fn mrays(tree: &kdray_kernel::TriangleTree<'_>, rays: &[Ray]) -> f64 {
    let mut hits = vec![Hit::MISS; rays.len()];
    let best = (0..3)
        .map(|_| {
            let t = Instant::now();
            trace_serial(
                tree,
                rays,
                &mut hits,
                Query::Closest,
                Some(PacketWidth::One),
            );
            t.elapsed().as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min);
    rays.len() as f64 / best / 1e6
}

pub(crate) fn run(a: &Args) -> CmdResult {
    let kinds = if a.builders.is_empty() {
        BuilderKind::ALL.to_vec()
    } else {
        a.builders
            .iter()
            .map(|n| BuilderKind::parse(n))
            .collect::<Result<Vec<_>, _>>()?
    };
    check_threads(a.threads)?;
    super::check_repeat("--repeat", a.repeat as u64)?;
    if a.rays as u64 > MAX_PIXELS {
        return Err(format!("--rays {} is more than {MAX_PIXELS}", a.rays).into());
    }
    let side = (a.rays as f64).sqrt() as u32;
    check_image(side, side, "--rays")?;
    let params = BuildParams {
        threads: a.threads,
        ..BuildParams::default()
    };
    // Every scene is loaded before the table starts: a bad one is an
    // error, not a header with nothing under it.
    let scenes = a
        .scenes
        .iter()
        .map(|spec| scene(spec, a.mesh_args))
        .collect::<Result<Vec<_>, _>>()?;
    say!(
        "| scene | tris | builder | build ms | SAH cost | SAH cost (W&H) | nodes | depth | refs/tri | bytes/tri | peak build B/tri | camera Mrays/s | random Mrays/s |"
    );
    say!("|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for (name, s) in &scenes {
        let tris = &s.triangles;
        let camera = Camera::framing(&s.focus).rays(side, side);
        let random = random_rays(&s.focus, a.rays, 7);
        for &kind in &kinds {
            let (mut best_ms, mut built, mut peak) = (f64::INFINITY, None, 0);
            for _ in 0..a.repeat {
                let monitor = BuildMonitor::new();
                let t = Instant::now();
                let b = build_monitored(tris, kind, &params, &monitor)?;
                best_ms = best_ms.min(t.elapsed().as_secs_f64() * 1e3);
                peak = monitor.peak_bytes();
                built = Some(b);
            }
            let built = built.ok_or("no build")?;
            let blob = write_triangle_tree(&built, tris)?;
            let tree = blob.tree()?;
            let st = tree_stats(&tree, CostModel::from_params(&params));
            let wh = tree_stats(&tree, CostModel::WALD_HAVRAN);
            say!(
                "| {name} | {} | {} | {best_ms:.1} | {:.2} | {:.1} | {} | {} | {:.2} | {:.1} | {:.0} | {:.2} | {:.2} |",
                tris.len(),
                kind.name(),
                st.sah_cost,
                wh.sah_cost,
                st.nodes,
                st.max_depth,
                st.refs_per_triangle,
                st.bytes_per_triangle,
                peak as f64 / tris.len().max(1) as f64,
                mrays(&tree, &camera),
                mrays(&tree, &random),
            );
        }
    }
    Ok(())
}
