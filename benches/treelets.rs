//! Scattered closest-hit rays with and without the tree's treelets
//! (`TriangleTree::treelets_into`: 7 split planes a vector step, four
//! rays in turns) against the one-plane walk, on the same rays in one
//! run; the answers are checked equal bit for bit. Each block takes its
//! kind's second walk (`Trial::Second`): scattered blocks in turns,
//! coherent ones as single rays. Camera rays, which the slice entry
//! points never send through the treelets, show what a coherent batch
//! pays (nothing: the same path).
//!
//! ```sh
//! taskset -c 0 cargo bench --bench treelets
//! ```

mod common;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use kdray::kernel::{Batch, Hit, Ray, TraceBatch, Treelet, Trial};
use kdray::tools::blob::write_triangle_tree;
use kdray::tools::builders::{build, BuildParams, BuilderKind};
use kdray::tools::camera::{random_rays, Camera};

fn treelets(c: &mut Criterion) {
    for (name, tris, focus) in common::scenes(&["stanford-bunny", "teapot", "sponza"]) {
        let built = build(&tris, BuilderKind::default(), &BuildParams::default()).unwrap();
        let blob = write_triangle_tree(&built, &tris).expect("the bench tree fits a blob");
        let tree = blob.tree().unwrap();
        let mut lines = vec![Treelet::default(); tree.treelet_count()];
        let lined = tree.treelets_into(&mut lines).unwrap();
        let bounds = tree.bounds();
        let sets: [(&str, Vec<Ray>); 2] = [
            ("random", random_rays(&bounds, 65_536, 1)),
            ("camera", Camera::framing(&focus).rays(256, 256)),
        ];
        let mut g = c.benchmark_group(format!("treelets/{name}"));
        g.sample_size(10);
        for (kind, rays) in &sets {
            let (mut a, mut b) = (vec![Hit::MISS; rays.len()], vec![Hit::MISS; rays.len()]);
            tree.closest_hits(
                rays,
                &mut a,
                Batch {
                    trial: Trial::Second,
                    ..Batch::default()
                },
            );
            lined.closest_hits(
                rays,
                &mut b,
                Batch {
                    trial: Trial::Second,
                    ..Batch::default()
                },
            );
            assert!(
                a.iter().zip(&b).all(|(x, y)| x.bits() == y.bits()),
                "{name} {kind}"
            );
            g.throughput(Throughput::Elements(rays.len() as u64));
            let layouts: [(&str, &dyn TraceBatch); 2] =
                [("one-plane", &tree), ("treelets", &lined)];
            for (label, t) in layouts {
                g.bench_with_input(BenchmarkId::new(label, kind), rays, |bench, rays| {
                    bench.iter(|| {
                        t.closest_hits(
                            rays,
                            &mut a,
                            Batch {
                                trial: Trial::Second,
                                ..Batch::default()
                            },
                        )
                    })
                });
            }
        }
        g.finish();
    }
}

criterion_group!(benches, treelets);
criterion_main!(benches);
