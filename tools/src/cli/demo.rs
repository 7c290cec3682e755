//! `kdray demo` (and `kdray` with no command): the built-in scene, built
//! and traced, with the tree's speed beside brute force, on camera rays;
//! then rendered, shaded and as a traversal-cost heatmap, into `out/`.

use super::report::print_stats;
use super::{check_image, plural, thread_pool, CmdResult};
use kdray_kernel::{closest_hit_brute, Hit};
use kdray_kernel::{PacketWidth, TriangleTree};
use kdray_tools::blob::write_triangle_tree;
use kdray_tools::builders::{build, BuildParams, BuilderKind};
use kdray_tools::camera::Camera;
use kdray_tools::demo_scene::teapot_in_stadium;
use kdray_tools::render::{render, render_heatmap, RenderParams, TreeTracer};
use kdray_tools::stats::{tree_stats, CostModel};
use kdray_tools::trace::{trace_into, trace_serial, Order, Query};
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `kdray demo`.
#[derive(clap::Args, Debug)]
pub(crate) struct Args {
    /// Image width and height of the camera rays.
    #[arg(long, default_value_t = 512)]
    size: u32,
    /// Rays checked against brute force.
    #[arg(long, default_value_t = 2000)]
    brute_sample: usize,
    /// Where the pictures go (created if missing).
    #[arg(long, default_value = "out")]
    out_dir: PathBuf,
}

impl Default for Args {
    fn default() -> Self {
        Args {
            size: 512,
            brute_sample: 2000,
            out_dir: PathBuf::from("out"),
        }
    }
}

pub(crate) fn run(a: &Args) -> CmdResult {
    // The folder and the ray count are checked before the work.
    check_image(a.size, a.size, "--size")?;
    if a.out_dir.exists() && !a.out_dir.is_dir() {
        return Err(format!(
            "--out-dir {}: is a file, not a folder (the pictures go in a folder)",
            a.out_dir.display()
        )
        .into());
    }
    std::fs::create_dir_all(&a.out_dir)
        .map_err(|e| format!("{}: cannot create: {e}", a.out_dir.display()))?;
    let scene = teapot_in_stadium();
    say!(
        "built-in scene: teapot in a stadium, {} triangles",
        scene.triangles.len()
    );
    let params = BuildParams::default();
    let t = Instant::now();
    let built = build(&scene.triangles, BuilderKind::default(), &params)?;
    let build_ms = t.elapsed().as_secs_f64() * 1e3;
    let blob = write_triangle_tree(&built, &scene.triangles)?;
    let tree = blob.tree()?;
    say!("  build              {build_ms:.1} ms");
    print_stats(&tree_stats(&tree, CostModel::from_params(&params)));

    let rays = Camera::framing(&scene.focus).rays(a.size, a.size);
    let mut hits = vec![Hit::MISS; rays.len()];
    let t = Instant::now();
    // The camera's rays are in row order, not tiles: single rays.
    trace_serial(
        &tree,
        &rays,
        &mut hits,
        Query::Closest,
        Some(PacketWidth::One),
    );
    let one = t.elapsed().as_secs_f64();
    let pool = thread_pool(None)?;
    let t = Instant::now();
    pool.install(|| {
        let (q, w) = (Query::Closest, Some(PacketWidth::One));
        trace_into(&tree, &rays, &mut hits, q, w, Order::Auto);
    });
    let all = t.elapsed().as_secs_f64();
    let hit = hits.iter().filter(|h| h.is_hit()).count();
    let threads = pool.current_num_threads();
    let on_all = if threads == 1 {
        String::new()
    } else {
        format!(
            ", {:.2} Mrays/s on {}",
            rays.len() as f64 / all / 1e6,
            plural(threads, "thread")
        )
    };
    say!(
        "traced {}x{} camera rays ({hit} hit): {:.2} Mrays/s on 1 thread{on_all}",
        a.size,
        a.size,
        rays.len() as f64 / one / 1e6,
    );

    // Exactly --brute-sample rays (or all of them), spread evenly.
    let n = a.brute_sample.min(rays.len());
    if n == 0 {
        say!("brute force: skipped (--brute-sample 0)");
    } else {
        check_brute(&tree, &scene.triangles, &rays, n, one)?;
    }
    let camera = Camera::framing(&scene.focus);
    draw(&tree, camera, &pool, &a.out_dir)
}

/// Brute force over every triangle on `n` of `rays`, spread evenly: the
/// tree must agree bit for bit, and the ratio of times (`one`: the tree's
/// seconds for all the rays on one thread) is what the tree buys.
fn check_brute(
    tree: &TriangleTree<'_>,
    triangles: &[kdray_kernel::Triangle],
    rays: &[kdray_kernel::Ray],
    n: usize,
    one: f64,
) -> CmdResult {
    let sample: Vec<_> = (0..n).map(|i| &rays[i * rays.len() / n]).collect();
    let t = Instant::now();
    let brute: Vec<Hit> = sample
        .iter()
        .map(|r| closest_hit_brute(triangles, r))
        .collect();
    let brute_s = t.elapsed().as_secs_f64() / sample.len().max(1) as f64;
    let tree_s = one / rays.len().max(1) as f64;
    let mismatches = sample
        .iter()
        .zip(&brute)
        .filter(|(r, b)| tree.closest_hit(r).bits() != b.bits())
        .count();
    say!(
        "brute force on {} of those rays: {:.4} Mrays/s; the tree is {:.0}x faster and agrees on {}/{} bit for bit",
        sample.len(),
        1.0 / brute_s / 1e6,
        brute_s / tree_s,
        sample.len() - mismatches,
        sample.len()
    );
    if mismatches > 0 {
        return Err(format!("{mismatches} rays disagree with brute force").into());
    }
    Ok(())
}

/// Rays a pixel of the demo's shaded picture.
const SAMPLES: u32 = 16;

/// The picture (16 rays a pixel) and the heatmap of the scene, 640x480,
/// on `pool`, written to `dir` (which exists): the pictures in `docs/`,
/// which `tests/pictures.rs` re-renders.
fn draw(
    tree: &TriangleTree<'_>,
    camera: Camera,
    pool: &rayon::ThreadPool,
    dir: &std::path::Path,
) -> CmdResult {
    let params = RenderParams::new(camera, 640, 480);
    let t = Instant::now();
    let tracer = TreeTracer {
        tree,
        width: PacketWidth::Eight,
    };
    let sampled = RenderParams {
        samples: SAMPLES,
        ..params
    };
    let picture = pool.install(|| render(&tracer, &sampled, &|| ()));
    let picture_ms = t.elapsed().as_secs_f64() * 1e3;
    let t = Instant::now();
    let heat = pool.install(|| render_heatmap(tree, &params, &|| ()));
    let heat_ms = t.elapsed().as_secs_f64() * 1e3;
    let (p, h) = (
        dir.join("teapot-stadium.png"),
        dir.join("teapot-stadium-heatmap.png"),
    );
    picture.write_png(&p)?;
    heat.image.write_png(&h)?;
    say!(
        "rendered 640x480 ({SAMPLES} rays a pixel in packets of 8, shadow rays) in {picture_ms:.0} ms: {}",
        p.display()
    );
    say!(
        "heatmap of nodes visited + triangles tested per pixel, log scale (min {}, mean {:.1}, max {}) in {heat_ms:.0} ms: {}",
        heat.min,
        heat.mean,
        heat.max,
        h.display()
    );
    Ok(())
}
