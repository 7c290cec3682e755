//! `kdray distance TREE POINTS -o OUT [--signed [--votes N | --winding]]
//! [--max-distance D] [--threads N]`: the closest point of a mesh to every
//! query point, with its distance (signed: negative inside), as a `.dist`
//! file (docs/formats.md). On a scene blob (`kdray build --instances`):
//! over every instance, each record naming its instance (32 bytes).

use super::json::JsonObject;
use super::{plural, thread_pool, wrong_kind, CmdResult};
use kdray_tools::blob::{Blob, BlobKind};
use kdray_tools::distance::{
    distance_records, scene_distance_records, DistanceRecord, InsideRule, SceneDistanceRecord,
};
use kdray_tools::{io, memory};
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `kdray distance`.
#[derive(clap::Args, Debug)]
pub(crate) struct Args {
    /// The triangle tree (.kdt, from `kdray build`) or scene (from
    /// `kdray build --instances`).
    tree: PathBuf,
    /// The query points (.pts: 3 f32 coordinates per point, docs/points.md).
    points: PathBuf,
    /// Where to write the answers (.dist: 28 bytes per query, 32 with the
    /// instance for a scene; docs/formats.md).
    #[arg(short, long)]
    output: PathBuf,
    /// Sign the distances: negative inside the mesh (by the parity of a
    /// ray's crossings, the majority of --votes rays, or --winding).
    #[arg(long)]
    signed: bool,
    /// With --signed: inside by the majority of this many rays (1 to 7),
    /// for open or self-intersecting meshes.
    #[arg(long, requires = "signed", conflicts_with = "winding")]
    votes: Option<u32>,
    /// With --signed: inside where the generalized winding number exceeds
    /// one half (open meshes: the holes are closed by caps).
    #[arg(long, requires = "signed")]
    winding: bool,
    /// Only triangles within this distance count; beyond it a query gets
    /// no point (triangle 0xFFFFFFFF, distance +inf).
    #[arg(long)]
    max_distance: Option<f32>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Print one JSON object instead of the summary.
    #[arg(long)]
    json: bool,
}

pub(crate) fn run(a: &Args) -> CmdResult {
    io::check_output_apart(&a.output, &[&a.tree, &a.points])?;
    let max_distance = a.max_distance.unwrap_or(f32::INFINITY);
    if max_distance.is_nan() || max_distance < 0.0 {
        return Err(format!("--max-distance {max_distance} must be a number >= 0").into());
    }
    let sign = match (a.signed, a.votes) {
        (false, _) => None,
        (true, None) if a.winding => Some(InsideRule::Winding),
        (true, None) => Some(InsideRule::Parity),
        (true, Some(n @ 1..=7)) => Some(InsideRule::Vote(n)),
        (true, Some(n)) => return Err(format!("--votes {n} must be 1 to 7").into()),
    };
    let pool = thread_pool(a.threads)?;
    let blob = Blob::read(&a.tree).map_err(|e| format!("{}: {e}", a.tree.display()))?;
    if blob.kind() == BlobKind::Points {
        return Err(wrong_kind(
            &a.tree,
            BlobKind::Points,
            "distance",
            "a triangle tree or a scene",
        )
        .into());
    }
    let queries: Vec<[f32; 3]> = io::read_records(&a.points, "3-D f32 point")?;
    if let Some(i) = queries
        .iter()
        .position(|q| !q.iter().all(|c| c.is_finite()))
    {
        return Err(format!(
            "{}: point {i} is {:?}: every coordinate must be finite",
            a.points.display(),
            queries[i]
        )
        .into());
    }
    if blob.kind() == BlobKind::Scene {
        if sign.is_some() {
            return Err(format!(
                "{}: --signed on a scene is not offered (each crossing of the sign's ray is not yet counted once per instance): build the scene's mesh file without --instances to sign",
                a.tree.display()
            )
            .into());
        }
        return scene_distance(a, &pool, &blob, &queries, max_distance);
    }
    let tree = blob
        .tree()
        .map_err(|e| format!("{}: invalid tree blob: {e}", a.tree.display()))?;
    let mut out = memory::filled(
        queries.len(),
        DistanceRecord::new(None, true),
        "distance records",
    )?;
    let t = Instant::now();
    pool.install(|| distance_records(&tree, &queries, max_distance, sign, &mut out));
    let seconds = t.elapsed().as_secs_f64();
    io::write_records(&a.output, &out)?;
    let missed = out.iter().filter(|r| r.prim == kdray_kernel::MISS).count();
    let size = ("triangle", tree.triangles().len());
    summary(
        a,
        &pool,
        queries.len(),
        seconds,
        missed,
        size,
        sign.is_some(),
    );
    Ok(())
}

/// `kdray distance` on a scene blob: every instance, unsigned.
fn scene_distance(
    a: &Args,
    pool: &rayon::ThreadPool,
    blob: &Blob,
    queries: &[[f32; 3]],
    max_distance: f32,
) -> CmdResult {
    let scene = blob
        .scene()
        .map_err(|e| format!("{}: invalid scene blob: {e}", a.tree.display()))?;
    let mut out = memory::filled(
        queries.len(),
        SceneDistanceRecord::new(None, true),
        "distance records",
    )?;
    let t = Instant::now();
    pool.install(|| scene_distance_records(&scene, queries, u32::MAX, max_distance, &mut out))
        .map_err(|e| format!("{}: {e}", a.tree.display()))?;
    let seconds = t.elapsed().as_secs_f64();
    io::write_records(&a.output, &out)?;
    let missed = out
        .iter()
        .filter(|r| r.instance == kdray_kernel::MISS)
        .count();
    let size = ("instance", scene.instances().len());
    summary(a, pool, queries.len(), seconds, missed, size, false);
    Ok(())
}

/// Prints the run's summary (or its JSON object) and the output's name;
/// `size` counts what was searched (`"triangle"` or `"instance"`).
fn summary(
    a: &Args,
    pool: &rayon::ThreadPool,
    queries: usize,
    seconds: f64,
    missed: usize,
    size: (&str, usize),
    signed: bool,
) {
    let qps = queries as f64 / seconds.max(1e-12);
    if a.json {
        let j = JsonObject::default()
            .with(&format!("{}s", size.0), size.1)
            .with("queries", queries)
            .with("beyond_max_distance", missed)
            .with("signed", signed)
            .with("threads", pool.current_num_threads())
            .with("seconds", seconds)
            .with("queries_per_s", qps)
            .with(
                "timing",
                "seconds exclude reading the files and writing the output",
            );
        say!("{}", j.finish());
    } else {
        say!(
            "{queries} queries against {} on {} in {seconds:.3} s: {qps:.0} queries/s (excluding file I/O); {missed} beyond the maximum distance",
            plural(size.1, size.0),
            plural(pool.current_num_threads(), "thread"),
        );
        say!("wrote {}", a.output.display());
    }
}
