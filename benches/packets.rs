//! Single rays vs 4-, 8- and 16-wide packets on the Stanford bunny
//! (`../shared/meshes/stanford-bunny.obj`; skipped with a message when
//! absent), one thread:
//! - `camera`: 1024x1024 pinhole rays framing the bunny, ordered in 4x2
//!   pixel tiles, so 8-wide packets are 4x2 tiles, 4-wide packets the
//!   tiles' 4x1 rows and 16-wide ones two tiles side by side (closest
//!   hit);
//! - `shadow`: from each camera hit towards a point light, same order
//!   (any hit);
//! - `random`: 2^20 rays with random origins in the bunny's box and random
//!   directions (closest hit): the incoherent worst case for packets.
//!
//! `RUSTFLAGS="-C target-cpu=native" taskset -c 0 cargo bench --bench packets`

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use glam::Vec3;
use kdray::kernel::{Batch, Hit, PacketWidth, Ray, TriangleTree};
use kdray::tools::blob::{write_triangle_tree, Blob};
use kdray::tools::builders::{build, BuildParams, BuilderKind};
use kdray::tools::mesh;
use kdray::tools::rng::Rng;
use std::hint::black_box;
use std::path::Path;

const SIDE: usize = 1024;
const WIDTHS: [(PacketWidth, &str); 4] = [
    (PacketWidth::One, "single"),
    (PacketWidth::Four, "4"),
    (PacketWidth::Eight, "8"),
    (PacketWidth::Sixteen, "16"),
];

/// Camera rays framing `lo..hi` from the front (+z), in 4x2 tiles.
fn camera_rays(lo: Vec3, hi: Vec3) -> Vec<Ray> {
    let centre = (lo + hi) * 0.5;
    let radius = (hi - lo).length() * 0.5;
    let eye = centre + Vec3::new(0.0, 0.0, 2.5 * radius);
    let half = 0.45; // tan of the half field of view
    let mut rays = Vec::with_capacity(SIDE * SIDE);
    for ty in (0..SIDE).step_by(2) {
        for tx in (0..SIDE).step_by(4) {
            for l in 0..8 {
                let (x, y) = (tx + l % 4, ty + l / 4);
                let px = ((x as f32 + 0.5) / SIDE as f32 * 2.0 - 1.0) * half;
                let py = (1.0 - (y as f32 + 0.5) / SIDE as f32 * 2.0) * half;
                rays.push(Ray::new(eye, Vec3::new(px, py, -1.0)));
            }
        }
    }
    rays
}

/// From each camera hit towards a point light above and to the side.
fn shadow_rays(tree: &TriangleTree, camera: &[Ray], light: Vec3) -> Vec<Ray> {
    let mut hits = vec![Hit::MISS; camera.len()];
    tree.closest_hits(camera, &mut hits, Batch::default());
    camera
        .iter()
        .zip(&hits)
        .filter(|(_, h)| h.is_hit())
        .map(|(r, h)| {
            let p = r.at(h.t);
            Ray::with_range(p, light - p, 1e-4, 1.0)
        })
        .collect()
}

fn random_rays(lo: Vec3, hi: Vec3, n: usize) -> Vec<Ray> {
    let mut rng = Rng::new(42);
    let mut f = || rng.f32();
    (0..n)
        .map(|_| {
            let o = lo + (hi - lo) * Vec3::new(f(), f(), f());
            let d = Vec3::new(f(), f(), f()) - 0.5;
            Ray::new(o, d)
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/meshes/stanford-bunny.obj");
    if !path.exists() {
        eprintln!("packets bench: {} not found; skipping", path.display());
        return;
    }
    let tris = mesh::load(&path).expect("bunny loads");
    let built = build(&tris, BuilderKind::Sah, &BuildParams::default()).expect("bunny builds");
    let blob: Blob = write_triangle_tree(&built, &tris).expect("the bench tree fits a blob");
    let tree = blob.tree().expect("blob validates");
    let (lo, hi) = (Vec3::from(built.bounds.min), Vec3::from(built.bounds.max));
    let camera = camera_rays(lo, hi);
    let shadow = shadow_rays(&tree, &camera, hi + (hi - lo) * Vec3::new(1.0, 2.0, 1.5));
    let random = random_rays(lo, hi, SIDE * SIDE);

    let mut g = c.benchmark_group("bunny");
    g.sample_size(10);
    for (name, rays) in [("camera", &camera), ("random", &random)] {
        g.throughput(Throughput::Elements(rays.len() as u64));
        let mut hits = vec![Hit::MISS; rays.len()];
        for (width, wname) in WIDTHS {
            g.bench_function(BenchmarkId::new(name, wname), |b| {
                b.iter(|| {
                    tree.closest_hits(
                        black_box(rays),
                        &mut hits,
                        Batch {
                            width: Some(width),
                            ..Batch::default()
                        },
                    )
                })
            });
        }
    }
    g.throughput(Throughput::Elements(shadow.len() as u64));
    let mut occluded = vec![false; shadow.len()];
    for (width, wname) in WIDTHS {
        g.bench_function(BenchmarkId::new("shadow", wname), |b| {
            b.iter(|| {
                tree.any_hits(
                    black_box(&shadow),
                    &mut occluded,
                    Batch {
                        width: Some(width),
                        ..Batch::default()
                    },
                )
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
