//! `kdray distance TREE POINTS -o OUT [--signed [--votes N | --winding]]
//! [--max-distance D] [--threads N]`: the closest point of a mesh to every
//! query point, with its distance (signed: negative inside), as a `.dist`
//! file (docs/formats.md).

use super::json::JsonObject;
use super::{plural, thread_pool, wrong_kind, CmdResult};
use kdray_tools::blob::{Blob, BlobKind};
use kdray_tools::distance::{distance_records, DistanceRecord, InsideRule};
use kdray_tools::{io, memory};
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `kdray distance`.
#[derive(clap::Args, Debug)]
pub(crate) struct Args {
    /// The triangle tree (.kdt, from `kdray build`).
    tree: PathBuf,
    /// The query points (.pts: 3 f32 coordinates per point, docs/points.md).
    points: PathBuf,
    /// Where to write the answers (.dist: 28 bytes per query, docs/formats.md).
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
    if let kind @ (BlobKind::Scene | BlobKind::Points) = blob.kind() {
        return Err(wrong_kind(&a.tree, kind, "distance", "a triangle tree").into());
    }
    let tree = blob
        .tree()
        .map_err(|e| format!("{}: invalid tree blob: {e}", a.tree.display()))?;
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
    let mut out = memory::filled(
        queries.len(),
        DistanceRecord::new(None, true),
        "distance records",
    )?;
    let t = Instant::now();
    pool.install(|| distance_records(&tree, &queries, max_distance, sign, &mut out));
    let seconds = t.elapsed().as_secs_f64();
    io::write_records(&a.output, &out)?;
    let qps = queries.len() as f64 / seconds.max(1e-12);
    let missed = out.iter().filter(|r| r.prim == kdray_kernel::MISS).count();
    if a.json {
        let j = JsonObject::default()
            .with("triangles", tree.triangles().len())
            .with("queries", queries.len())
            .with("beyond_max_distance", missed)
            .with("signed", sign.is_some())
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
            "{} queries against {} triangles on {} in {seconds:.3} s: {qps:.0} queries/s (excluding file I/O); {} beyond the maximum distance",
            queries.len(),
            tree.triangles().len(),
            plural(pool.current_num_threads(), "thread"),
            missed
        );
        say!("wrote {}", a.output.display());
    }
    Ok(())
}
