//! `kdray render MESH_OR_TREE -o OUT.png`: a shaded picture or a
//! traversal-cost heatmap of a mesh or a tree blob.

use super::progress::counted_bar;
use super::trace::parse_width;
use super::{check_image, plural, thread_pool, wrong_kind, CmdResult, MeshArgs};
use glam::Vec3;
use kdray_kernel::{Bounds, PacketWidth, TriangleTree};
use kdray_tools::blob::{write_triangle_tree, Blob, BlobKind};
use kdray_tools::builders::{build, BuildParams, BuilderKind};
use kdray_tools::camera::{probe_tree, Camera, Placement};
use kdray_tools::instances::SceneTracer;
use kdray_tools::render::{
    bands, render, render_heatmap, RenderParams, TreeTracer, LEGEND_HEIGHT, MAX_SAMPLES,
};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of `kdray render`.
#[derive(clap::Args, Debug)]
pub(crate) struct Args {
    /// A mesh (.obj, .ply, .gltf, .glb; built with the default builder) or
    /// a tree blob (.kdt, validated).
    input: PathBuf,
    /// Where to write the PNG.
    #[arg(short, long)]
    output: PathBuf,
    #[command(flatten)]
    view: View,
    /// Render the traversal cost per pixel (nodes visited + triangles
    /// tested by the closest-hit walk of the ray through the pixel's
    /// centre, on a log scale) instead of the shaded picture. The PNG is
    /// 46 pixels taller than --height: the legend strip under the picture
    /// (whose rays are the shaded picture's).
    #[arg(long)]
    heatmap: bool,
    /// Rays per packet: 1, 4 (2x2 pixel tiles), 8 (4x2 tiles) or 16 (4x4
    /// tiles).
    #[arg(long, default_value = "8", value_parser = parse_width)]
    packet: PacketWidth,
    /// Rays per pixel, 1 to 64, at fixed sub-pixel offsets (a Hammersley
    /// set; 1 is the pixel's centre), averaged: smooth silhouettes and
    /// shadow edges. The shaded picture only.
    #[arg(long, default_value_t = 1)]
    samples: u32,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    #[command(flatten)]
    mesh_args: MeshArgs,
}

fn parse_vec3(s: &str) -> Result<Vec3, String> {
    let parts: Vec<f32> = s
        .split(',')
        .map(|p| p.trim().parse::<f32>())
        .collect::<Result<_, _>>()
        .map_err(|e| format!("{s:?}: {e} (want x,y,z)"))?;
    match parts[..] {
        [x, y, z] if parts.iter().all(|v| v.is_finite()) => Ok(Vec3::new(x, y, z)),
        _ => Err(format!("{s:?}: want three finite numbers x,y,z")),
    }
}

/// `--camera`: [`Placement`] by name.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum CameraArg {
    /// Inside when the scene encloses its bounds' centre, else outside.
    Auto,
    /// Framing the whole scene from outside.
    Outside,
    /// Inside the scene.
    Inside,
}

/// The camera and image size, for `render` and `rays` alike.
#[derive(clap::Args, Debug)]
pub(super) struct View {
    /// Eye position `x,y,z` (default: framing the whole scene).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    eye: Option<Vec3>,
    /// The point looked at, `x,y,z` (default: the scene's centre).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    target: Option<Vec3>,
    /// Vertical field of view in degrees.
    #[arg(long, allow_negative_numbers = true)]
    fov: Option<f32>,
    /// Where the camera stands without --eye: `outside` framing the whole
    /// scene, `inside` it (at the centre, stepped back along its longer
    /// side: rooms, courtyards), or `auto`: inside when the scene
    /// encloses its bounds' centre (most rays from there hit the front of
    /// a triangle), else outside. Meshes and triangle trees; a scene
    /// blob is framed from outside. [default: auto]
    #[arg(long, value_enum, conflicts_with = "eye")]
    camera: Option<CameraArg>,
    /// Image width in pixels.
    #[arg(long, default_value_t = 640)]
    pub(super) width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = 480)]
    pub(super) height: u32,
}

impl View {
    /// Refuses an image of no pixels or too many, an eye beyond the
    /// kernel's coordinate range (its rays may miss everything), and a
    /// field of view outside (0, 180) degrees.
    pub(super) fn check(&self) -> Result<(), String> {
        check_image(self.width, self.height, "--width and --height")?;
        if let Some(eye) = self.eye {
            if eye.abs().max_element() > kdray_kernel::MAX_COORD {
                return Err(format!(
                    "--eye {eye} is beyond the kernel's coordinate range of ±{:e} (kdray_kernel::MAX_COORD), where rays may miss every triangle",
                    kdray_kernel::MAX_COORD
                ));
            }
        }
        match self.fov {
            Some(f) if !(f > 0.0 && f < 180.0) => {
                Err(format!("--fov must be between 0 and 180 degrees, not {f}"))
            }
            _ => Ok(()),
        }
    }

    /// The camera over `scene` (bounds) placed as --camera says, probing
    /// `tree` (`None` for a scene blob: framed from outside), with the
    /// user's eye, target and field of view where given (an eye given
    /// frames from outside for what is not).
    pub(super) fn camera(
        &self,
        scene: &Bounds,
        tree: Option<&TriangleTree<'_>>,
    ) -> Result<Camera, String> {
        let placement = match self.camera.unwrap_or(CameraArg::Auto) {
            _ if self.eye.is_some() => Placement::Outside,
            CameraArg::Outside => Placement::Outside,
            CameraArg::Inside if tree.is_none() => {
                return Err(
                    "--camera inside probes one tree: render the flattened scene (kdray build without --instances), or give --eye"
                        .into(),
                )
            }
            CameraArg::Inside => Placement::Inside,
            CameraArg::Auto => Placement::Auto,
        };
        let framing = match tree {
            Some(tree) => Camera::placed(scene, placement, |r| probe_tree(tree, r)),
            None => Camera::framing(scene),
        };
        let camera = Camera {
            eye: self.eye.unwrap_or(framing.eye),
            target: self.target.unwrap_or(framing.target),
            fov_deg: self.fov.unwrap_or(framing.fov_deg),
            ..framing
        };
        // The camera's rays follow target - eye: with none, every pixel
        // would silently look down -z.
        if (camera.target - camera.eye).normalize_or_zero() == Vec3::ZERO {
            return Err(format!(
                "--eye {} and --target {} are the same point: the camera has no direction to look{}",
                camera.eye,
                camera.target,
                if self.target.is_none() {
                    " (--target defaults to the scene's centre)"
                } else {
                    ""
                }
            ));
        }
        Ok(camera)
    }
}

/// A tree blob from `path`: read when it is a `.kdt`, else the mesh
/// loaded and built with the default builder.
pub(super) fn tree_blob(
    path: &Path,
    mesh_args: MeshArgs,
) -> Result<Blob, Box<dyn std::error::Error>> {
    let is_blob = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("kdt"));
    Ok(if is_blob {
        Blob::read(path).map_err(|e| format!("{}: {e}", path.display()))?
    } else {
        let tris = mesh_args.load(path)?;
        let built = build(&tris, BuilderKind::default(), &BuildParams::default())?;
        write_triangle_tree(&built, &tris)?
    })
}

/// Refuses a sample count outside 1..=[`MAX_SAMPLES`], and more than one
/// for a heatmap (which counts one ray's walk a pixel).
fn check_samples(samples: u32, heatmap: bool) -> Result<(), String> {
    if !(1..=MAX_SAMPLES).contains(&samples) {
        return Err(format!(
            "--samples must be between 1 and {MAX_SAMPLES} rays a pixel, not {samples}"
        ));
    }
    if heatmap && samples > 1 {
        return Err(format!(
            "--samples {samples}: a heatmap counts the walk of one ray a pixel (the pixel's centre); drop --samples or --heatmap"
        ));
    }
    Ok(())
}

pub(crate) fn run(a: &Args) -> CmdResult {
    // Every argument is checked before the scene is loaded or built.
    super::check_apart_from_mesh(&a.output, &a.input)?;
    a.view.check()?;
    check_samples(a.samples, a.heatmap)?;
    let pool = thread_pool(a.threads)?;
    let blob = tree_blob(&a.input, a.mesh_args)?;
    match blob.kind() {
        BlobKind::Scene => return render_scene(a, &pool, &blob),
        BlobKind::Points => {
            return Err(wrong_kind(
                &a.input,
                BlobKind::Points,
                "render",
                "a mesh, a triangle tree or a scene",
            )
            .into())
        }
        BlobKind::Triangles | BlobKind::Unknown => {}
    }
    let tree = blob
        .tree()
        .map_err(|e| format!("{}: invalid tree blob: {e}", a.input.display()))?;
    let scene = tree.bounds();
    let camera = a.view.camera(&scene, Some(&tree))?;
    let (width, height) = (a.view.width, a.view.height);
    let params = RenderParams {
        samples: a.samples,
        ..RenderParams::new(camera, width, height)
    };
    let t = Instant::now();
    let image = if a.heatmap {
        let bar = counted_bar(u64::from(height));
        let h = pool.install(|| render_heatmap(&tree, &params, &|| bar.inc(1)));
        bar.finish();
        say!(
            "cost per pixel (nodes visited + triangles tested): min {}, mean {:.1}, max {}; the legend adds {LEGEND_HEIGHT} rows under the {width}x{height} picture",
            h.min,
            h.mean,
            h.max
        );
        h.image
    } else {
        let bar = counted_bar(bands(height, a.packet));
        let tracer = TreeTracer {
            tree: &tree,
            width: a.packet,
        };
        let img = pool.install(|| render(&tracer, &params, &|| bar.inc(1)));
        bar.finish();
        img
    };
    let seconds = t.elapsed().as_secs_f64();
    image.write_png(&a.output)?;
    say!(
        "rendered {}x{} {} ({}) on {} in {:.1} ms: {:.2} Mpixels/s (excluding loading and PNG writing)",
        width,
        height,
        if a.heatmap { "heatmap" } else { "picture" },
        if a.heatmap {
            "single rays, counted".to_string()
        } else {
            format!(
                "packets of {}, {}",
                a.packet.lanes(),
                plural(a.samples as usize, "ray") + " a pixel"
            )
        },
        plural(pool.current_num_threads(), "thread"),
        seconds * 1e3,
        f64::from(width) * f64::from(height) / seconds.max(1e-12) / 1e6
    );
    say!("wrote {}", a.output.display());
    Ok(())
}

/// `kdray render` of a scene blob: shaded pictures only, single rays.
fn render_scene(a: &Args, pool: &rayon::ThreadPool, blob: &Blob) -> CmdResult {
    if a.heatmap {
        return Err(format!(
            "{}: --heatmap counts one tree's nodes; render the flattened scene (kdray build without --instances) for it",
            a.input.display()
        )
        .into());
    }
    let scene = blob
        .scene()
        .map_err(|e| format!("{}: invalid scene blob: {e}", a.input.display()))?;
    let camera = a.view.camera(&scene.bounds(), None)?;
    let (width, height) = (a.view.width, a.view.height);
    let params = RenderParams {
        samples: a.samples,
        ..RenderParams::new(camera, width, height)
    };
    let tracer = SceneTracer::new(&scene);
    let t = Instant::now();
    let bar = counted_bar(bands(height, PacketWidth::One));
    let image = pool.install(|| render(&tracer, &params, &|| bar.inc(1)));
    bar.finish();
    let seconds = t.elapsed().as_secs_f64();
    image.write_png(&a.output)?;
    say!(
        "rendered {width}x{height} picture of a scene of {} instances on {} in {:.1} ms (single rays, excluding loading and PNG writing)",
        scene.instances().len(),
        plural(pool.current_num_threads(), "thread"),
        seconds * 1e3,
    );
    say!("wrote {}", a.output.display());
    Ok(())
}
