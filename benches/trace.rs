//! Single-ray closest hit: the tree against brute force on the same rays,
//! on the bunny (when `../shared/meshes` is there) and the built-in scene.
//! Compare the ratio within one run; the machine is shared and noisy.

mod common;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use kdray::kernel::Bounds;
use kdray::kernel::{closest_hit_brute, Ray};
use kdray::tools::blob::{write_triangle_tree, Blob};
use kdray::tools::builders::{build, BuildParams, BuilderKind};
use kdray::tools::camera::{random_rays, Camera};
use std::hint::black_box;

fn trace(c: &mut Criterion) {
    for (name, tris, focus) in common::scenes(&["stanford-bunny"]) {
        let built = build(&tris, BuilderKind::default(), &BuildParams::default()).unwrap();
        let blob: Blob = write_triangle_tree(&built, &tris).expect("the bench tree fits a blob");
        let tree = blob.tree().unwrap();
        let bounds = tris.iter().fold(Bounds::EMPTY, |b, x| b.union(&x.bounds()));
        let sets: [(&str, Vec<Ray>); 2] = [
            ("camera", Camera::framing(&focus).rays(256, 256)),
            ("random", random_rays(&bounds, 65_536, 1)),
        ];
        let mut g = c.benchmark_group(format!("trace/{name}"));
        g.sample_size(10);
        for (kind, rays) in &sets {
            g.throughput(Throughput::Elements(rays.len() as u64));
            g.bench_with_input(BenchmarkId::new("tree", kind), rays, |b, rays| {
                b.iter(|| {
                    rays.iter()
                        .map(|r| tree.closest_hit(black_box(r)).t)
                        .sum::<f32>()
                })
            });
            let few = &rays[..64];
            g.throughput(Throughput::Elements(few.len() as u64));
            g.bench_with_input(BenchmarkId::new("brute", kind), few, |b, rays| {
                b.iter(|| {
                    rays.iter()
                        .map(|r| closest_hit_brute(&tris, black_box(r)).t)
                        .sum::<f32>()
                })
            });
        }
        g.finish();
    }
}

criterion_group!(benches, trace);
criterion_main!(benches);
