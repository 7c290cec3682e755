//! Point k-d tree builds and k-NN queries (k = 1, 10) beside kiddo's
//! const-generic `ImmutableKdTree<f32, D>`, at D = 2, 3, 8 and 16, on
//! uniform, clustered and duplicate-heavy sets, one thread. Deterministic
//! inputs; builds outside the timed query loops.
//!
//! `KDRAY_BENCH_N` sets the point count (default 100k); the queries are
//! N/10 at D <= 3 and N/100 above (a 16-D query visits far more of the
//! tree). Filter by group: `cargo bench --bench knn -- 'knn_query/D8'`.
//! `docs/results.md` ("Point trees") has the table and how it is made.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use kdray::kernel::Neighbour;
use kdray::tools::points::{build_points, PointParams};
use kdray::tools::rng::Rng;
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use std::hint::black_box;
use std::num::NonZeroUsize;
use std::time::Duration;

/// The three sets at D: uniform in the unit cube; 100 tight clusters;
/// duplicate-heavy (a fifth in 20 piles, the rest on a 4-value lattice).
fn sets<const D: usize>(n: usize, seed: u64) -> Vec<(&'static str, Vec<[f32; D]>)> {
    let mut r = Rng::new(seed);
    let centres: Vec<[f32; D]> = (0..100).map(|_| std::array::from_fn(|_| r.f32())).collect();
    let uniform = (0..n).map(|_| std::array::from_fn(|_| r.f32())).collect();
    let clustered = (0..n)
        .map(|i| {
            let c = centres[i % 100];
            std::array::from_fn(|a| c[a] + r.range(-0.01, 0.01))
        })
        .collect();
    let dupes = (0..n)
        .map(|_| {
            if r.below(5) == 0 {
                centres[r.below(20)]
            } else {
                std::array::from_fn(|_| r.below(4) as f32 / 4.0)
            }
        })
        .collect();
    vec![
        ("uniform", uniform),
        ("clustered", clustered),
        ("dupes", dupes),
    ]
}

/// One pass of kdray over `qs` into `out` (k = `out.len()`). Not inlined,
/// as [`kiddo_pass`], so a profiler names each library's share.
#[inline(never)]
fn kdray_pass<const D: usize>(
    tree: &kdray::kernel::PointTreeN<'_, D>,
    qs: &[[f32; D]],
    out: &mut [Neighbour],
) {
    for q in qs {
        black_box(tree.knn(*q, out));
    }
}

/// One pass of kiddo over `qs`: `nearest_one` for k = 1, else `nearest_n`
/// (with one scratch buffer for the pass, as a caller would keep).
#[inline(never)]
fn kiddo_pass<const D: usize>(kd: &ImmutableKdTree<f32, D>, qs: &[[f32; D]], k: usize) {
    let Some(kk) = NonZeroUsize::new(k) else {
        return;
    };
    let mut scratch = kd.create_scratch::<SquaredEuclidean<f32>>();
    for q in qs {
        if k == 1 {
            let r = kd.query(q).nearest_one::<SquaredEuclidean<f32>>();
            black_box(r.execute());
        } else {
            let r = kd.query(q).nearest_n::<SquaredEuclidean<f32>>(kk);
            black_box(r.with_scratch(&mut scratch).execute().len());
        }
    }
}

fn bench_dim<const D: usize>(c: &mut Criterion) {
    let n: usize = std::env::var("KDRAY_BENCH_N")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(100_000);
    let nq = (if D <= 3 { n / 10 } else { n / 100 }).max(1);
    let points = sets::<D>(n, 1);
    let queries = sets::<D>(nq, 2);
    let params = PointParams {
        parallel_min: usize::MAX,
        ..PointParams::default()
    };

    let mut g = c.benchmark_group(format!("knn_build/D{D}"));
    g.sample_size(10);
    g.warm_up_time(Duration::from_millis(500));
    g.throughput(Throughput::Elements(n as u64));
    for (name, pts) in &points {
        // Interleaved per set: kdray, then kiddo.
        g.bench_with_input(BenchmarkId::new("kdray", name), pts, |b, pts| {
            b.iter(|| build_points(black_box(pts), &params).unwrap())
        });
        g.bench_with_input(BenchmarkId::new("kiddo", name), pts, |b, pts| {
            b.iter(|| ImmutableKdTree::<f32, D>::new_from_slice(black_box(pts)).unwrap())
        });
    }
    g.finish();

    for k in [1usize, 10] {
        let mut g = c.benchmark_group(format!("knn_query/D{D}_k{k}"));
        g.sample_size(10);
        g.warm_up_time(Duration::from_millis(500));
        g.throughput(Throughput::Elements(nq as u64));
        for ((name, pts), (_, qs)) in points.iter().zip(&queries) {
            let built = build_points(pts, &params).unwrap();
            let tree = built.view().unwrap();
            let mut out = vec![Neighbour::NONE; k];
            g.bench_function(BenchmarkId::new("kdray", name), |b| {
                b.iter(|| kdray_pass(&tree, qs, &mut out))
            });
            let kd = ImmutableKdTree::<f32, D>::new_from_slice(pts).unwrap();
            g.bench_function(BenchmarkId::new("kiddo", name), |b| {
                b.iter(|| kiddo_pass(&kd, qs, k))
            });
        }
        g.finish();
    }
}

/// Best of `rounds` interleaved passes of kdray and kiddo over the same
/// queries (seconds each): the ratio the load of a shared machine moves
/// least, as the criterion groups run one after the other.
fn interleaved<const D: usize>(rounds: usize) {
    let n: usize = std::env::var("KDRAY_BENCH_N")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(100_000);
    let nq = (if D <= 3 { n / 10 } else { n / 100 }).max(1);
    let params = PointParams {
        parallel_min: usize::MAX,
        ..PointParams::default()
    };
    let best = |f: &mut dyn FnMut(), best: &mut f64| {
        let t = std::time::Instant::now();
        f();
        *best = best.min(t.elapsed().as_secs_f64());
    };
    // `KDRAY_KNN_SETS=uniform,dupes`: only those sets (for a profiler).
    let only = std::env::var("KDRAY_KNN_SETS").ok();
    for ((name, pts), (_, qs)) in sets::<D>(n, 1).iter().zip(&sets::<D>(nq, 2)) {
        if only
            .as_deref()
            .is_some_and(|o| !o.split(',').any(|s| s == *name))
        {
            continue;
        }
        let (mut bk, mut bd) = (f64::INFINITY, f64::INFINITY);
        for _ in 0..rounds {
            best(
                &mut || drop(black_box(build_points(pts, &params).unwrap())),
                &mut bk,
            );
            best(
                &mut || {
                    drop(black_box(
                        ImmutableKdTree::<f32, D>::new_from_slice(pts).unwrap(),
                    ))
                },
                &mut bd,
            );
        }
        println!(
            "D{D} {name} build: kdray {:.1} ms, kiddo {:.1} ms, {:.2}x",
            bk * 1e3,
            bd * 1e3,
            bd / bk
        );
        let built = build_points(pts, &params).unwrap();
        let tree = built.view().unwrap();
        let kd = ImmutableKdTree::<f32, D>::new_from_slice(pts).unwrap();
        // `KDRAY_KNN_K=10`: only that k (for a profiler).
        let ks = std::env::var("KDRAY_KNN_K").map_or(vec![1, 10], |k| {
            k.split(',').filter_map(|k| k.parse().ok()).collect()
        });
        for &k in &ks {
            let mut out = vec![Neighbour::NONE; k];
            let (mut tk, mut td) = (f64::INFINITY, f64::INFINITY);
            for _ in 0..rounds {
                best(&mut || kdray_pass(&tree, qs, &mut out), &mut tk);
                best(&mut || kiddo_pass(&kd, qs, k), &mut td);
            }
            let qps = |t: f64| qs.len() as f64 / t;
            println!(
                "D{D} {name} k={k}: kdray {:.0} q/s, kiddo {:.0} q/s, {:.2}x",
                qps(tk),
                qps(td),
                td / tk
            );
        }
    }
}

fn bench(c: &mut Criterion) {
    // `KDRAY_KNN_RATIOS=R`: only the interleaved table, best of R rounds.
    if let Some(rounds) = std::env::var("KDRAY_KNN_RATIOS")
        .ok()
        .and_then(|s| s.parse().ok())
    {
        let only = std::env::var("KDRAY_KNN_DIMS").unwrap_or_else(|_| "2,3,8,16".into());
        for d in only.split(',') {
            match d.trim() {
                "2" => interleaved::<2>(rounds),
                "3" => interleaved::<3>(rounds),
                "8" => interleaved::<8>(rounds),
                "16" => interleaved::<16>(rounds),
                other => eprintln!("KDRAY_KNN_DIMS: no bench at D = {other}"),
            }
        }
        return;
    }
    bench_dim::<2>(c);
    bench_dim::<3>(c);
    bench_dim::<8>(c);
    bench_dim::<16>(c);
}

criterion_group!(benches, bench);
criterion_main!(benches);
