//! `kdray knn POINTS QUERIES -k K -o OUT [--dim D] [--f64]`: build a point
//! tree, answer the k nearest neighbours of every query, write a `.knn`
//! file.

use super::build_points::{dispatch, Shape, ShapedCommand};
use super::json::JsonObject;
use super::{plural, thread_pool, CmdResult};
use kdray_kernel::{Neighbour, Scalar};
use kdray_tools::points::{build_points, check_point, knn_all, PointParams};
use kdray_tools::{io, memory};
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `kdray knn`.
#[derive(clap::Args, Debug)]
pub(crate) struct Args {
    /// The points (.pts: D coordinates per point, docs/points.md).
    points: PathBuf,
    /// The query points (.pts, the same shape).
    queries: PathBuf,
    #[command(flatten)]
    shape: Shape,
    /// How many neighbours per query.
    #[arg(short, default_value_t = 1)]
    k: usize,
    /// Where to write the neighbours (.knn: k records per query, u32
    /// index then the squared distance as f32, or f64 with --f64).
    #[arg(short, long)]
    output: PathBuf,
    /// The most points a leaf holds (default 32 below 8-D, 64 from 8-D
    /// on): larger leaves make a smaller tree and test more points a query.
    #[arg(long)]
    leaf_size: Option<usize>,
    /// Build and answer this many times; timings are the best pass.
    #[arg(long, default_value_t = 1)]
    reps: usize,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Print one JSON object instead of the summary.
    #[arg(long)]
    json: bool,
}

pub(crate) fn run(a: &Args) -> CmdResult {
    io::check_output_apart(&a.output, &[&a.points, &a.queries])?;
    if a.k == 0 || a.leaf_size == Some(0) {
        return Err("-k and --leaf-size must be at least 1".into());
    }
    super::check_repeat("--reps", a.reps as u64)?;
    dispatch(a.shape, a)
}

/// The `.knn` records: per neighbour its index, then its squared distance,
/// both little-endian.
fn knn_bytes<S: Scalar>(out: &[Neighbour<S>]) -> Result<Vec<u8>, memory::OutOfMemory> {
    let size = out.len().saturating_mul(4 + S::BYTES as usize);
    let mut bytes = memory::with_capacity(size, "bytes of the .knn file")?;
    for n in out {
        bytes.extend_from_slice(&n.index.to_le_bytes());
        bytes.extend_from_slice(bytemuck::bytes_of(&n.d2));
    }
    Ok(bytes)
}

impl ShapedCommand for Args {
    fn run<const D: usize, S: Scalar>(&self) -> CmdResult {
        run_shaped::<D, S>(self)
    }
}

fn run_shaped<const D: usize, S: Scalar>(a: &Args) -> CmdResult {
    let pool = thread_pool(a.threads)?;
    let what = a.shape.describe();
    let points: Vec<[S; D]> = io::read_records(&a.points, &what)?;
    let queries: Vec<[S; D]> = io::read_records(&a.queries, &what)?;
    // The kernel answers nothing for such a query; say which one it is.
    for (i, q) in queries.iter().enumerate() {
        check_point(i, q).map_err(|e| format!("{}: as a query, {e}", a.queries.display()))?;
    }
    // Every query has k neighbours only when k <= n: a larger k would only
    // pad each query's records (and ask for k slots per query).
    if a.k > points.len() {
        return Err(format!(
            "-k {} is more than the {} points of {}",
            a.k,
            points.len(),
            a.points.display()
        )
        .into());
    }
    let params = PointParams {
        leaf_size: a.leaf_size,
        ..PointParams::default()
    };
    let len = queries
        .len()
        .checked_mul(a.k)
        .ok_or("queries times k overflows")?;
    let mut out = memory::filled(len, Neighbour::NONE, "neighbour records (queries x k)")?;
    let (mut build_s, mut query_s) = (f64::INFINITY, f64::INFINITY);
    pool.install(|| -> Result<(), String> {
        for _ in 0..a.reps {
            let t = Instant::now();
            let built = build_points(&points, &params)
                .map_err(|e| format!("{}: {e}", a.points.display()))?;
            build_s = build_s.min(t.elapsed().as_secs_f64());
            let tree = built
                .view()
                .map_err(|e| format!("internal error: the built tree does not validate: {e}"))?;
            let t = Instant::now();
            knn_all(&tree, &queries, a.k, &mut out);
            query_s = query_s.min(t.elapsed().as_secs_f64());
        }
        Ok(())
    })?;
    io::write_bytes(&a.output, &knn_bytes(&out)?)?;
    let qps = queries.len() as f64 / query_s.max(1e-12);
    if a.json {
        let j = JsonObject::default()
            .with("points", points.len())
            .with("queries", queries.len())
            .with("k", a.k)
            .with("dim", D)
            .with("scalar", S::NAME)
            .with("threads", pool.current_num_threads())
            .with("leaf_size", params.leaf_size_for(D))
            .with("reps", a.reps)
            .with("build_ms", build_s * 1e3)
            .with("seconds", query_s)
            .with("queries_per_s", qps)
            .with(
                "timing",
                "build_ms and seconds exclude reading the point files and writing the output; best of reps",
            );
        say!("{}", j.finish());
    } else {
        say!(
            "built {} points in {:.1} ms; {} queries, k = {}, on {} in {query_s:.3} s: {:.0} queries/s (excluding file I/O)",
            points.len(),
            build_s * 1e3,
            queries.len(),
            a.k,
            plural(pool.current_num_threads(), "thread"),
            qps
        );
        say!("wrote {}", a.output.display());
    }
    Ok(())
}
