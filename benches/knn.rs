//! Point k-d tree build and k-NN queries (k = 1, 10) beside kiddo's
//! `ImmutableKdTree` and brute force, on uniform, clustered and surface
//! (sphere shell) points. Deterministic inputs; builds outside the timed
//! query loops. `KDRAY_BENCH_N` sets the point count (default 100k; the
//! issue's 1M with `KDRAY_BENCH_N=1000000`), queries are N/10.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use kdray::kernel::{knn_brute, Neighbour};
use kdray::tools::points::{build_points, PointParams};
use kdray::tools::rng::Rng;
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use std::hint::black_box;
use std::num::NonZeroUsize;

fn sets(n: usize, seed: u64) -> Vec<(&'static str, Vec<[f32; 3]>)> {
    let mut r = Rng::new(seed);
    let centres: Vec<[f32; 3]> = (0..100).map(|_| [r.f32(), r.f32(), r.f32()]).collect();
    let uniform = (0..n).map(|_| [r.f32(), r.f32(), r.f32()]).collect();
    let clustered = (0..n)
        .map(|i| {
            let c = centres[i % 100];
            std::array::from_fn(|a| c[a] + r.range(-0.01, 0.01))
        })
        .collect();
    let surface = (0..n)
        .map(|_| r.unit_vector().map(|c| 0.5 + 0.5 * c))
        .collect();
    vec![
        ("uniform", uniform),
        ("clustered", clustered),
        ("surface", surface),
    ]
}

fn bench(c: &mut Criterion) {
    let n: usize = std::env::var("KDRAY_BENCH_N")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(100_000);
    let nq = (n / 10).max(1);
    let points = sets(n, 1);
    let queries = sets(nq, 2);
    let params = PointParams {
        parallel_min: usize::MAX,
        ..PointParams::default()
    };

    let mut g = c.benchmark_group("knn_build");
    g.sample_size(10);
    g.throughput(Throughput::Elements(n as u64));
    for (name, pts) in &points {
        g.bench_with_input(BenchmarkId::new("kdray", name), pts, |b, pts| {
            b.iter(|| build_points(black_box(pts), &params).unwrap())
        });
        g.bench_with_input(BenchmarkId::new("kiddo", name), pts, |b, pts| {
            b.iter(|| ImmutableKdTree::<f32, 3>::new_from_slice(black_box(pts)).unwrap())
        });
    }
    g.finish();

    for k in [1usize, 10] {
        let mut g = c.benchmark_group(format!("knn_query_k{k}"));
        g.sample_size(10);
        g.throughput(Throughput::Elements(nq as u64));
        for ((name, pts), (_, qs)) in points.iter().zip(&queries) {
            let built = build_points(pts, &params).unwrap();
            let tree = built.view().unwrap();
            let mut out = vec![Neighbour::NONE; k];
            g.bench_function(BenchmarkId::new("kdray", name), |b| {
                b.iter(|| {
                    for q in qs {
                        black_box(tree.knn(*q, &mut out));
                    }
                })
            });
            let kd = ImmutableKdTree::<f32, 3>::new_from_slice(pts).unwrap();
            let kk = NonZeroUsize::new(k).unwrap();
            let mut scratch = kd.create_scratch::<SquaredEuclidean<f32>>();
            g.bench_function(BenchmarkId::new("kiddo", name), |b| {
                b.iter(|| {
                    for q in qs {
                        if k == 1 {
                            let r = kd.query(q).nearest_one::<SquaredEuclidean<f32>>();
                            black_box(r.execute());
                        } else {
                            let r = kd.query(q).nearest_n::<SquaredEuclidean<f32>>(kk);
                            black_box(r.with_scratch(&mut scratch).execute().len());
                        }
                    }
                })
            });
            // Brute force on a slice of the queries: it is ~1000x slower.
            let few = &qs[..qs.len().min(20)];
            g.throughput(Throughput::Elements(few.len() as u64));
            g.bench_function(BenchmarkId::new("brute", name), |b| {
                b.iter(|| {
                    for q in few {
                        black_box(knn_brute(pts, *q, f32::INFINITY, &mut out));
                    }
                })
            });
            g.throughput(Throughput::Elements(nq as u64));
        }
        g.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
