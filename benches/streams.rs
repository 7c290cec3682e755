//! Batches as ray streams (`Streams::Always`) against the batch calls'
//! own choice without them (`Streams::Never`: packets, or single rays in
//! turns) and against `closest_hit` / `any_hit` one ray at a time, on the
//! same rays, one thread: nanoseconds a ray, best of five interleaved
//! rounds, and each walk's time over the batch path's. The answers are
//! checked equal bit for bit first.
//!
//! ```sh
//! taskset -c 0 cargo bench --bench streams
//! ```
//! `KDRAY_STREAMS=single|batch|streams` runs only that walk (for
//! callgrind: `--toggle-collect='*walk_*'`, one round), `KDRAY_STREAMS_MESH`
//! only that mesh, `KDRAY_STREAMS_CASE` only that row (`random closest`), `KDRAY_BENCH_CACHE` a folder to keep the built trees in,
//! `KDRAY_BENCH_RAYS` a folder of the Embree anchor's ray files
//! (`rays-NAME/primary.rays`, `random.rays`: `anchors/embree/rays.sh`).

mod common;

use kdray::kernel::{
    Batch, Hit, Ray, Streams, TriangleTree, STREAM_SCRATCH_WORDS, WIDE_STREAM_WORDS,
};
use kdray::tools::camera::{random_rays, Camera};
use kdray::tools::io::read_records;
use std::path::PathBuf;
use std::time::Instant;

/// Closest hits (`hits`) or any hits (`occ`) of `rays` by one walk.
type Walk = fn(&TriangleTree, &[Ray], &mut [Hit], &mut [bool], bool, &mut [u64]);

#[inline(never)]
fn walk_single(
    t: &TriangleTree,
    rays: &[Ray],
    hits: &mut [Hit],
    occ: &mut [bool],
    any: bool,
    _: &mut [u64],
) {
    if any {
        for (o, r) in occ.iter_mut().zip(rays) {
            *o = t.any_hit(r);
        }
    } else {
        for (h, r) in hits.iter_mut().zip(rays) {
            *h = t.closest_hit(r);
        }
    }
}

#[inline(never)]
fn walk_batch(
    t: &TriangleTree,
    rays: &[Ray],
    hits: &mut [Hit],
    occ: &mut [bool],
    any: bool,
    _: &mut [u64],
) {
    let batch = Batch {
        streams: Streams::Never,
        ..Batch::default()
    };
    if any {
        t.any_hits(rays, occ, batch);
    } else {
        t.closest_hits(rays, hits, batch);
    }
}

#[inline(never)]
fn walk_streams(
    t: &TriangleTree,
    rays: &[Ray],
    hits: &mut [Hit],
    occ: &mut [bool],
    any: bool,
    scratch: &mut [u64],
) {
    let batch = Batch {
        scratch,
        streams: Streams::Always,
        ..Batch::default()
    };
    if any {
        t.any_hits(rays, occ, batch);
    } else {
        t.closest_hits(rays, hits, batch);
    }
}

#[inline(never)]
fn walk_wide(
    t: &TriangleTree,
    rays: &[Ray],
    hits: &mut [Hit],
    occ: &mut [bool],
    any: bool,
    scratch: &mut [u64],
) {
    walk_streams(t, rays, hits, occ, any, scratch);
}

fn main() {
    let only = std::env::var("KDRAY_STREAMS").ok();
    let mesh = std::env::var("KDRAY_STREAMS_MESH").ok();
    let case = std::env::var("KDRAY_STREAMS_CASE").ok();
    let rounds = if only.is_some() { 1 } else { 5 };
    let names: Vec<&str> = match &mesh {
        Some(m) => vec![m.as_str()],
        None => vec!["stanford-bunny", "teapot", "sponza"],
    };
    let walks: [(&str, Walk); 4] = [
        ("single", walk_single),
        ("batch", walk_batch),
        ("streams", walk_streams),
        ("wide", walk_wide),
    ];
    let mut scratch = vec![0u64; STREAM_SCRATCH_WORDS];
    let mut wide_scratch: Vec<u64> = Vec::new();
    if let Some(k) = std::env::var("KDRAY_WIDE_SINGLE")
        .ok()
        .and_then(|k| k.parse().ok())
    {
        kdray::kernel::WIDE_SINGLE.store(k, std::sync::atomic::Ordering::Relaxed);
    }
    println!(
        "{:<16} {:<13} {:>9} {:>9} {:>9} {:>9} {:>8} {:>8} {:>7} {:>7}",
        "mesh",
        "rays",
        "single",
        "batch",
        "streams",
        "wide",
        "s/single",
        "w/single",
        "nodes",
        "tris"
    );
    for (name, tris, focus) in common::scenes(&names) {
        if mesh.as_deref().is_some_and(|m| m != name) {
            continue;
        }
        let blob = common::tree_blob(&name, &tris);
        let tree = blob.tree().unwrap();
        // The anchors' ray files when given (`rays.sh` folders), else
        // 65536 camera and random rays made here.
        let files = std::env::var("KDRAY_BENCH_RAYS").ok().map(|d| {
            let at = |f: &str| PathBuf::from(&d).join(format!("rays-{name}/{f}.rays"));
            let read = |f: &str| read_records::<Ray>(&at(f), "rays").expect("a ray file");
            (read("primary"), read("random"))
        });
        let sets: [(&str, Vec<Ray>); 2] = match files {
            Some((camera, random)) => [("camera", camera), ("random", random)],
            None => [
                ("camera", Camera::framing(&focus).rays(256, 256)),
                ("random", random_rays(&tree.bounds(), 65_536, 1)),
            ],
        };
        for (kind, rays) in &sets {
            for any in [false, true] {
                let label = format!("{kind} {}", if any { "any" } else { "closest" });
                if case.as_deref().is_some_and(|c| c != label) {
                    continue;
                }
                let n = rays.len();
                let mut hits = vec![vec![Hit::MISS; n]; 4];
                let mut occ = vec![vec![false; n]; 4];
                let mut best = [f64::INFINITY; 4];
                let wide_rays = std::env::var("KDRAY_WIDE_RAYS")
                    .ok()
                    .and_then(|w| w.parse().ok())
                    .unwrap_or(n);
                wide_scratch.resize(wide_rays * WIDE_STREAM_WORDS, 0);
                // The single walk's work a ray.
                let (mut nodes, mut tris) = (0u64, 0u64);
                for r in rays {
                    let c = if any {
                        tree.counting().any_hit(r).1
                    } else {
                        tree.counting().closest_hit(r).1
                    };
                    nodes += u64::from(c.nodes);
                    tris += u64::from(c.triangles);
                }
                for _round in 0..rounds {
                    for (k, (label, walk)) in walks.iter().enumerate() {
                        if only.as_deref().is_some_and(|o| o != *label) {
                            continue;
                        }
                        let s = if k == 3 {
                            &mut wide_scratch
                        } else {
                            &mut scratch
                        };
                        let t = Instant::now();
                        walk(&tree, rays, &mut hits[k], &mut occ[k], any, s);
                        best[k] = best[k].min(t.elapsed().as_secs_f64() * 1e9 / n as f64);
                    }
                }
                if only.is_none() {
                    let bits = |h: &Vec<Hit>| h.iter().map(Hit::bits).collect::<Vec<_>>();
                    assert!(
                        bits(&hits[0]) == bits(&hits[2]) && occ[0] == occ[2],
                        "{name} {kind}"
                    );
                    assert!(
                        bits(&hits[0]) == bits(&hits[1]) && occ[0] == occ[1],
                        "{name} {kind}"
                    );
                    let differ = (0..n)
                        .filter(|&i| {
                            hits[0][i].bits() != hits[3][i].bits() || occ[0][i] != occ[3][i]
                        })
                        .count();
                    assert!(differ == 0, "{name} {kind}: {differ} wide answers differ");
                }
                let c: Vec<f64> = kdray::kernel::WIDE_COUNTS
                    .iter()
                    .map(|c| c.swap(0, std::sync::atomic::Ordering::Relaxed) as f64)
                    .collect();
                let runs = if only.is_some() { 1.0 } else { rounds as f64 };
                eprintln!(
                    "wide a ray: interior {:.2} leaf {:.2} single-from {:.2}; streams: interior {:.0} leaf {:.0} single {:.0}; mean len {:.0}",
                    c[0] / runs / n as f64,
                    c[1] / runs / n as f64,
                    c[2] / runs / n as f64,
                    c[3] / runs,
                    c[4] / runs,
                    c[5] / runs,
                    c[0] / c[3].max(1.0)
                );
                println!(
                    "{:<16} {:<13} {:>9.1} {:>9.1} {:>9.1} {:>9.1} {:>8.2} {:>8.2} {:>7.1} {:>7.1}",
                    name,
                    label,
                    best[0],
                    best[1],
                    best[2],
                    best[3],
                    best[0] / best[2],
                    best[0] / best[3],
                    nodes as f64 / n as f64,
                    tris as f64 / n as f64
                );
            }
        }
    }
}
