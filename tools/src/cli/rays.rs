//! `kdray rays SCENE -o OUT.rays --kind KIND`: a ray file to try the other
//! commands on (`docs/formats.md`): camera rays in row order or in packet
//! tiles, random rays through the scene, or the shadow rays of a render.

use super::render::{tree_blob, View};
use super::trace::parse_width;
use super::{wrong_kind, CmdResult, MeshArgs, MAX_PIXELS};
use kdray_kernel::{Batch, Hit, PacketWidth, Ray};
use kdray_tools::blob::BlobKind;
use kdray_tools::camera::random_ray_iter;
use kdray_tools::render::{shadow_ray, tile_size, tiled_pixels_into, RenderParams};
use kdray_tools::{io, memory};
use std::path::PathBuf;

/// Which rays `kdray rays` makes.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    /// One ray per pixel through `render`'s camera, row by row.
    Camera,
    /// The same rays in packet tiles (`--packet`), for `trace --packet`.
    CameraTiled,
    /// `--count` rays from uniform points in the scene's box in uniform
    /// directions (the incoherent case).
    Random,
    /// From each camera ray's hit towards `render`'s light, for
    /// `trace --any-hit` (surfaces facing away from the light get none).
    Shadow,
}

/// Arguments of `kdray rays`.
#[derive(clap::Args, Debug)]
pub(crate) struct Args {
    /// A mesh (.obj, .ply, .gltf, .glb) or a tree blob (.kdt).
    scene: PathBuf,
    /// Where to write the rays (32-byte records, docs/formats.md).
    #[arg(short, long)]
    output: PathBuf,
    /// What rays.
    #[arg(long, value_enum, default_value = "camera")]
    kind: Kind,
    /// The camera (camera, camera-tiled, shadow), framing the scene as
    /// `render` does.
    #[command(flatten)]
    view: View,
    /// camera-tiled: the packet width the tiles are for: 4 (2x2 pixels),
    /// 8 (4x2) or 16 (4x4), as `render` traces them.
    #[arg(long, default_value = "8", value_parser = parse_width)]
    packet: PacketWidth,
    /// random: how many rays.
    #[arg(long, default_value_t = 262_144)]
    count: usize,
    /// random: the seed (the same seed, the same rays).
    #[arg(long, default_value_t = 7)]
    seed: u64,
    #[command(flatten)]
    mesh_args: MeshArgs,
}

pub(crate) fn run(a: &Args) -> CmdResult {
    super::check_apart_from_mesh(&a.output, &a.scene)?;
    a.view.check()?;
    if a.count == 0 || a.count as u64 > MAX_PIXELS {
        return Err(format!(
            "--count must be between 1 and {MAX_PIXELS}, not {}",
            a.count
        )
        .into());
    }
    let blob = tree_blob(&a.scene, a.mesh_args)?;
    let tree = || {
        blob.tree()
            .map_err(|e| format!("{}: invalid tree blob: {e}", a.scene.display()))
    };
    // A scene blob frames and aims rays as a flattened mesh does; only
    // shadow rays need one tree's triangles (to shade the camera hits).
    let flat = match blob.kind() {
        BlobKind::Triangles | BlobKind::Unknown => Some(tree()?),
        BlobKind::Scene | BlobKind::Points => None,
    };
    let scene = match blob.kind() {
        BlobKind::Scene if a.kind == Kind::Shadow => {
            return Err(format!(
                "{}: this is {}; `kdray rays --kind shadow` takes a triangle tree or a mesh (build it without --instances)",
                a.scene.display(),
                BlobKind::Scene.describe()
            )
            .into())
        }
        BlobKind::Scene => blob
            .scene()
            .map_err(|e| format!("{}: invalid scene blob: {e}", a.scene.display()))?
            .bounds(),
        BlobKind::Points => {
            return Err(wrong_kind(&a.scene, BlobKind::Points, "rays", "a mesh, a triangle tree or a scene").into())
        }
        BlobKind::Triangles | BlobKind::Unknown => tree()?.bounds(),
    };
    let camera = a.view.camera(&scene, flat.as_ref())?;
    let (w, h) = (a.view.width, a.view.height);
    // Every buffer is reserved before it is filled: an image or count
    // past the memory there is gets an error naming it, not an abort.
    let pixels = w as usize * h as usize;
    let rays: Vec<Ray> = match a.kind {
        Kind::Camera => memory::collected(pixels, camera.ray_iter(w, h), "camera rays")?,
        Kind::CameraTiled => {
            let mut order = memory::with_capacity(pixels, "pixel coordinates")?;
            tiled_pixels_into(w, h, tile_size(a.packet), &mut order);
            let rays = order.iter().map(|&[x, y]| camera.ray(x, y, w, h));
            memory::collected(pixels, rays, "tiled camera rays")?
        }
        Kind::Random => memory::collected(
            a.count,
            random_ray_iter(&scene, a.count, a.seed),
            "random rays",
        )?,
        Kind::Shadow => {
            let tree = tree()?;
            let params = RenderParams::new(camera, w, h);
            let mut rays = memory::collected(pixels, camera.ray_iter(w, h), "camera rays")?;
            let mut hits = memory::filled(pixels, Hit::MISS, "camera hits")?;
            tree.closest_hits(
                &rays,
                &mut hits,
                Batch {
                    width: Some(PacketWidth::One),
                    ..Batch::default()
                },
            );
            // Each shadow ray overwrites a camera ray already used (there
            // are at most as many), so no third buffer is needed.
            let mut kept = 0;
            for i in 0..rays.len() {
                if let Some(s) = shadow_ray(tree.triangles(), &rays[i], &hits[i], &params) {
                    rays[kept] = s;
                    kept += 1;
                }
            }
            rays.truncate(kept);
            rays
        }
    };
    io::write_records(&a.output, &rays)?;
    say!(
        "wrote {} {} rays to {}",
        rays.len(),
        match a.kind {
            Kind::Camera => "camera",
            Kind::CameraTiled => "tiled camera",
            Kind::Random => "random",
            Kind::Shadow => "shadow",
        },
        a.output.display()
    );
    Ok(())
}
