//! `kdray build-points POINTS -o TREE [--dim D] [--f64]`: build a point
//! tree and write it as a point blob (for firmware: load it with
//! `PointTreeN::<D, S>::from_bytes`). Also the point shape both point
//! commands take, and the one dispatch from it to a compiled D.

use super::json::JsonObject;
use super::CmdResult;
use kdray_kernel::Scalar;
use kdray_tools::blob::write_point_tree;
use kdray_tools::io;
use kdray_tools::points::{build_points, PointParams};
use std::path::PathBuf;
use std::time::Instant;

/// The largest `--dim` the tools are compiled for.
pub(crate) const MAX_DIM: usize = 16;

/// The shape of the points in a `.pts` file: D coordinates per point, f32
/// (default) or f64, little-endian, no header.
#[derive(clap::Args, Debug, Clone, Copy)]
pub(crate) struct Shape {
    /// Coordinates per point, 1 to 16.
    #[arg(long, default_value_t = 3)]
    pub(crate) dim: usize,
    /// Coordinates are f64 (default f32).
    #[arg(long)]
    pub(crate) f64: bool,
}

impl Shape {
    /// What one record holds, for messages ("3-D f32 point").
    pub(crate) fn describe(self) -> String {
        let name = if self.f64 { "f64" } else { "f32" };
        format!("{}-D {name} point", self.dim)
    }
}

/// A command generic over the point shape.
pub(crate) trait ShapedCommand {
    /// Runs the command for D-dimensional points of `S`.
    fn run<const D: usize, S: Scalar>(&self) -> CmdResult;
}

/// Runs `cmd` at the compiled D and scalar type `shape` names.
pub(crate) fn dispatch(shape: Shape, cmd: &impl ShapedCommand) -> CmdResult {
    macro_rules! dims {
        ($($d:literal)*) => {
            match (shape.dim, shape.f64) {
                $(($d, false) => cmd.run::<$d, f32>(),
                  ($d, true) => cmd.run::<$d, f64>(),)*
                (d, _) => Err(format!("--dim {d} is not supported: use 1 to {MAX_DIM}").into()),
            }
        };
    }
    dims!(1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16)
}

/// Arguments of `kdray build-points`.
#[derive(clap::Args, Debug)]
pub(crate) struct Args {
    /// The points (.pts: D coordinates per point, docs/points.md).
    points: PathBuf,
    /// Where to write the tree blob.
    #[arg(short, long)]
    output: PathBuf,
    #[command(flatten)]
    shape: Shape,
    /// The most points a leaf holds (default 32 below 8-D, 64 from 8-D
    /// on): larger leaves make a smaller tree and test more points a query.
    #[arg(long)]
    leaf_size: Option<usize>,
    /// Print one JSON object instead of the summary.
    #[arg(long)]
    json: bool,
}

pub(crate) fn run(a: &Args) -> CmdResult {
    io::check_output_apart(&a.output, &[&a.points])?;
    if a.leaf_size == Some(0) {
        return Err("--leaf-size must be at least 1".into());
    }
    dispatch(a.shape, a)
}

impl ShapedCommand for Args {
    fn run<const D: usize, S: Scalar>(&self) -> CmdResult {
        let a = self;
        let points: Vec<[S; D]> = io::read_records(&a.points, &a.shape.describe())?;
        let params = PointParams {
            leaf_size: a.leaf_size,
            ..PointParams::default()
        };
        let t = Instant::now();
        let built =
            build_points(&points, &params).map_err(|e| format!("{}: {e}", a.points.display()))?;
        let build_ms = t.elapsed().as_secs_f64() * 1e3;
        let blob = write_point_tree(&built)
            .map_err(|e| format!("internal error: the built tree does not validate: {e}"))?;
        io::write_bytes(&a.output, blob.as_bytes())?;
        if a.json {
            let j = JsonObject::default()
                .with("points", points.len())
                .with("dim", D)
                .with("scalar", S::NAME)
                .with("nodes", built.nodes.len())
                .with("max_depth", built.max_depth)
                .with("bytes", blob.as_bytes().len())
                .with("build_ms", build_ms)
                .with(
                    "timing",
                    "build_ms excludes reading the points and writing the blob",
                );
            say!("{}", j.finish());
        } else {
            say!(
                "built {} {D}-D {} points -> {}: {} nodes, depth {}, {} bytes, {build_ms:.1} ms (excluding file I/O)",
                points.len(),
                S::NAME,
                a.output.display(),
                built.nodes.len(),
                built.max_depth,
                blob.as_bytes().len()
            );
        }
        Ok(())
    }
}
