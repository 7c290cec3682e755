//! Argument parsing and dispatch: one file per subcommand.

/// `println!` that never panics: a closed stdout (`kdray ... | head`) is
/// not an error worth a panic, and a report line is all that is lost.
macro_rules! say {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout(), $($arg)*);
    }};
}

mod bench;
mod build_points;
mod build_tree;
mod demo;
mod distance;
mod export_obj;
mod info;
mod json;
mod knn;
mod progress;
mod rays;
mod render;
mod report;
#[cfg(unix)]
#[allow(unsafe_code)] // one query of a signal's action, with its SAFETY argument
mod signals;
mod sort_rays;
mod trace;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// kdray: build k-d trees over meshes and point sets, then trace rays and
/// answer nearest-neighbour queries against them. With no command, runs
/// the built-in demo.
#[derive(Parser, Debug)]
#[command(name = "kdray", version, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Build a tree from a mesh and write it as a blob.
    Build(build_tree::Args),
    /// Validate a tree blob and print its statistics.
    Info(info::Args),
    /// Trace a ray file against a tree, writing a hit file.
    Trace(trace::Args),
    /// Build a point tree and write it as a blob.
    BuildPoints(build_points::Args),
    /// Answer the k nearest points of every query in a file.
    Knn(knn::Args),
    /// The closest point of a mesh to every point in a file, with its
    /// distance (signed with --signed: negative inside).
    Distance(distance::Args),
    /// Make a ray file: camera rays (row order or packet tiles), random
    /// rays or shadow rays.
    Rays(rays::Args),
    /// Reorder a ray file by the Morton code of the origins, as an
    /// engine's pixel order gives its shadow and bounce rays.
    SortRays(sort_rays::Args),
    /// Render a mesh or tree to PNG: shaded, or a traversal-cost heatmap.
    Render(render::Args),
    /// Build and trace the built-in teapot-in-a-stadium scene (the default).
    Demo(demo::Args),
    /// Compare the builders: build time, tree quality and trace speed.
    Bench(bench::Args),
    /// Write a mesh's triangles, flattened (a glTF's nodes with their
    /// transforms, in `kdray build`'s order), as OBJ.
    ExportObj(export_obj::Args),
}

/// What a subcommand returns: an error message for the user, already
/// naming the file and place.
type CmdResult = Result<(), Box<dyn std::error::Error>>;

pub(crate) fn main() -> ExitCode {
    let cli = Cli::parse();
    #[cfg(unix)]
    signals::install();
    if let Err(e) = apply_isa_env() {
        eprintln!("kdray: error: {e}");
        return ExitCode::FAILURE;
    }
    let result = match cli.command {
        Some(Command::Build(a)) => build_tree::run(&a),
        Some(Command::Info(a)) => info::run(&a),
        Some(Command::Trace(a)) => trace::run(&a),
        Some(Command::BuildPoints(a)) => build_points::run(&a),
        Some(Command::Knn(a)) => knn::run(&a),
        Some(Command::Distance(a)) => distance::run(&a),
        Some(Command::Rays(a)) => rays::run(&a),
        Some(Command::SortRays(a)) => sort_rays::run(&a),
        Some(Command::Render(a)) => render::run(&a),
        Some(Command::Demo(a)) => demo::run(&a),
        Some(Command::Bench(a)) => bench::run(&a),
        Some(Command::ExportObj(a)) => export_obj::run(&a),
        None => demo::run(&demo::Args::default()),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("kdray: error: {e}");
            ExitCode::FAILURE
        }
    }
}

/// `KDRAY_ISA=baseline|sse2|avx2|avx512` pins the kernel's lane code to
/// one instruction set level (`kdray_kernel::cpu`); unset or empty, the
/// processor's best. The answers are the same at every level.
fn apply_isa_env() -> Result<(), String> {
    let Some(v) = std::env::var_os("KDRAY_ISA") else {
        return Ok(());
    };
    let Some(name) = v.to_str().filter(|s| !s.is_empty()) else {
        return if v.is_empty() {
            Ok(())
        } else {
            Err(format!(
                "KDRAY_ISA={v:?} is not valid UTF-8 (use baseline, sse2, avx2 or avx512)"
            ))
        };
    };
    let level = kdray_kernel::Isa::from_name(name).ok_or_else(|| {
        format!("KDRAY_ISA={name:?} is not an instruction set level (use baseline, sse2, avx2 or avx512)")
    })?;
    kdray_kernel::set_isa(level).map_err(|e| format!("KDRAY_ISA={name}: {e}"))
}

/// Refuses `--threads 0` and counts past
/// [`kdray_tools::threads::MAX_THREADS`].
fn check_threads(threads: Option<usize>) -> Result<(), String> {
    match threads {
        Some(0) => Err("--threads must be at least 1".into()),
        Some(n) => kdray_tools::threads::check_count("--threads", n),
        None => Ok(()),
    }
}

/// The most timed passes a command runs (`--repeat`, `--reps`): more
/// measure nothing new, and a typo of a billion would run for years.
const MAX_REPEAT: u64 = 1000;

/// Refuses `name` (`--repeat`, `--reps`) of 0 or past [`MAX_REPEAT`].
fn check_repeat(name: &str, n: u64) -> Result<(), String> {
    if n == 0 {
        return Err(format!("{name} must be at least 1"));
    }
    if n > MAX_REPEAT {
        return Err(format!(
            "{name} {n} is more than the {MAX_REPEAT} timed passes kdray runs"
        ));
    }
    Ok(())
}

/// A rayon pool of `threads` workers (all cores when `None`).
fn thread_pool(threads: Option<usize>) -> Result<rayon::ThreadPool, Box<dyn std::error::Error>> {
    check_threads(threads)?;
    let n = threads.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    rayon::ThreadPoolBuilder::new()
        .num_threads(n)
        .build()
        .map_err(|e| format!("cannot start {}: {e}", plural(n, "thread")).into())
}

/// `"1 thread"`, `"2 threads"`.
fn plural(n: usize, what: &str) -> String {
    if n == 1 {
        format!("1 {what}")
    } else {
        format!("{n} {what}s")
    }
}

/// The most pixels (or camera rays) an image may have: 2^28, 16384 x 16384,
/// so the pixels, costs and rays of a picture stay within a few GB.
const MAX_PIXELS: u64 = 1 << 28;

/// Refuses a `width` x `height` image of no pixels or more than [`MAX_PIXELS`].
fn check_image(width: u32, height: u32, names: &str) -> Result<(), String> {
    let pixels = u64::from(width) * u64::from(height);
    if pixels == 0 {
        return Err(format!("{names} must be at least 1"));
    }
    if pixels > MAX_PIXELS {
        return Err(format!(
            "{names}: {width} x {height} is {pixels} pixels, more than the {MAX_PIXELS} (16384 x 16384) kdray makes"
        ));
    }
    Ok(())
}

/// The error for a valid blob of a kind `command` does not take: "this
/// is a point tree; `kdray rays` takes a triangle tree or a scene".
fn wrong_kind(
    path: &std::path::Path,
    kind: kdray_tools::blob::BlobKind,
    command: &str,
    takes: &str,
) -> String {
    format!(
        "{}: this is {}; `kdray {command}` takes {takes}",
        path.display(),
        kind.describe()
    )
}

/// [`kdray_tools::io::check_output_apart`] for a command reading the mesh
/// (or blob) `input`: the output may be neither it nor, for a glTF, a
/// buffer file it names.
fn check_apart_from_mesh(
    output: &std::path::Path,
    input: &std::path::Path,
) -> Result<(), kdray_tools::io::RecordFileError> {
    let files = kdray_tools::mesh::files_read(input);
    let inputs: Vec<&std::path::Path> = files.iter().map(std::path::PathBuf::as_path).collect();
    kdray_tools::io::check_output_apart(output, &inputs)
}

/// How the commands that read a mesh read it.
#[derive(clap::Args, Debug, Default, Clone, Copy)]
struct MeshArgs {
    /// Let a glTF's buffer URIs name files outside the glTF's folder
    /// (absolute paths, `..`); by default they are refused.
    #[arg(long)]
    allow_outside_uris: bool,
}

impl MeshArgs {
    /// Loads `path`, printing what was skipped (glTF points and lines) as
    /// warnings on stderr.
    fn load(
        self,
        path: &std::path::Path,
    ) -> Result<Vec<kdray_kernel::Triangle>, kdray_tools::mesh::MeshError> {
        let options = kdray_tools::mesh::LoadOptions {
            allow_outside_uris: self.allow_outside_uris,
        };
        let m = kdray_tools::mesh::load_with(path, &options)?;
        for s in &m.skipped {
            eprintln!("kdray: warning: {}: {s}", path.display());
        }
        Ok(m.triangles)
    }

    /// Loads a glTF file with its mesh references kept, printing what was
    /// skipped as warnings.
    fn load_instanced(
        self,
        path: &std::path::Path,
    ) -> Result<kdray_tools::mesh::InstancedGltf, Box<dyn std::error::Error>> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        if !matches!(ext.as_deref(), Some("gltf" | "glb")) {
            return Err(format!(
                "{}: --instances reads glTF files (.gltf, .glb), whose nodes reference meshes",
                path.display()
            )
            .into());
        }
        let options = kdray_tools::mesh::LoadOptions {
            allow_outside_uris: self.allow_outside_uris,
        };
        let mut skipped = Vec::new();
        let g = kdray_tools::mesh::load_gltf_instanced(path, &options, &mut skipped)?;
        for s in &skipped {
            eprintln!("kdray: warning: {}: {s}", path.display());
        }
        for (i, m) in g.meshes.iter().enumerate() {
            kdray_tools::mesh::check_finite(path, m).map_err(|e| format!("mesh {i}: {e}"))?;
        }
        if g.instances.is_empty() {
            return Err(format!("{}: the scene has no triangles", path.display()).into());
        }
        Ok(g)
    }
}
