//! `kdray trace TREE RAYS -o HITS`: trace a ray file, write a hit file.

use super::json::JsonObject;
use super::{thread_pool, CmdResult};
use kdray_kernel::{Hit, Ray};
use kdray_tools::blob::Blob;
use kdray_tools::io;
use kdray_tools::trace::{trace_into, Query};
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `kdray trace`.
#[derive(clap::Args, Debug)]
pub(crate) struct Args {
    /// The tree blob.
    tree: PathBuf,
    /// The ray file (32-byte records, formats/RAYS.md).
    rays: PathBuf,
    /// Where to write the hit file (16-byte records).
    #[arg(short, long)]
    output: PathBuf,
    /// Occlusion only: occluded rays get t = -inf, triangle 0xFFFFFFFE.
    #[arg(long)]
    any_hit: bool,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Print one JSON object instead of the summary.
    #[arg(long)]
    json: bool,
}

pub(crate) fn run(a: &Args) -> CmdResult {
    let pool = thread_pool(a.threads)?;
    let blob = Blob::read(&a.tree).map_err(|e| format!("{}: {e}", a.tree.display()))?;
    let tree = blob
        .tree()
        .map_err(|e| format!("{}: invalid tree blob: {e}", a.tree.display()))?;
    let rays: Vec<Ray> = io::read_records(&a.rays, "ray")?;
    let mut hits = vec![Hit::MISS; rays.len()];
    let query = if a.any_hit {
        Query::Any
    } else {
        Query::Closest
    };
    let t = Instant::now();
    pool.install(|| trace_into(&tree, &rays, &mut hits, query));
    let seconds = t.elapsed().as_secs_f64();
    io::write_records(&a.output, &hits)?;
    let hit_count = hits.iter().filter(|h| h.prim != kdray_kernel::MISS).count();
    let mrays = rays.len() as f64 / seconds.max(1e-12) / 1e6;
    if a.json {
        let j = JsonObject::default()
            .num("rays", rays.len() as f64)
            .num("hits", hit_count as f64)
            .num("threads", pool.current_num_threads() as f64)
            .str("query", if a.any_hit { "any" } else { "closest" })
            .num("seconds", seconds)
            .num("mrays_per_s", mrays)
            .str(
                "timing",
                "seconds excludes reading the tree and rays and writing the hits",
            );
        println!("{}", j.finish());
    } else {
        println!(
            "traced {} rays ({} {}) on {} threads in {seconds:.3} s: {mrays:.2} Mrays/s (excluding file I/O)",
            rays.len(),
            hit_count,
            if a.any_hit { "occluded" } else { "hit" },
            pool.current_num_threads()
        );
        println!("wrote {}", a.output.display());
    }
    Ok(())
}
