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

use kdray::kernel::{Batch, Hit, Ray, Streams, TriangleTree, STREAM_SCRATCH_WORDS};
use kdray::tools::camera::{random_rays, Camera};
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

fn main() {
    let only = std::env::var("KDRAY_STREAMS").ok();
    let mesh = std::env::var("KDRAY_STREAMS_MESH").ok();
    let case = std::env::var("KDRAY_STREAMS_CASE").ok();
    let rounds = if only.is_some() { 1 } else { 5 };
    let names: Vec<&str> = match &mesh {
        Some(m) => vec![m.as_str()],
        None => vec!["stanford-bunny", "teapot", "sponza"],
    };
    let walks: [(&str, Walk); 3] = [
        ("single", walk_single),
        ("batch", walk_batch),
        ("streams", walk_streams),
    ];
    let mut scratch = vec![0u64; STREAM_SCRATCH_WORDS];
    println!(
        "{:<16} {:<13} {:>9} {:>9} {:>9} {:>8} {:>8}",
        "mesh", "rays", "single", "batch", "streams", "s/batch", "s/single"
    );
    for (name, tris, focus) in common::scenes(&names) {
        if mesh.as_deref().is_some_and(|m| m != name) {
            continue;
        }
        let blob = common::tree_blob(&name, &tris);
        let tree = blob.tree().unwrap();
        // The anchors' ray files when given (`rays.sh` folders), else
        // 65536 camera and random rays made here.
        let files = (
            common::anchor_rays(&name, "primary"),
            common::anchor_rays(&name, "random"),
        );
        let sets: [(&str, Vec<Ray>); 2] = match files {
            (Some(camera), Some(random)) => [("camera", camera), ("random", random)],
            _ => [
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
                let mut hits = vec![vec![Hit::MISS; n]; 3];
                let mut occ = vec![vec![false; n]; 3];
                let mut best = [f64::INFINITY; 3];
                for _round in 0..rounds {
                    for (k, (label, walk)) in walks.iter().enumerate() {
                        if only.as_deref().is_some_and(|o| o != *label) {
                            continue;
                        }
                        let t = Instant::now();
                        walk(&tree, rays, &mut hits[k], &mut occ[k], any, &mut scratch);
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
                }
                println!(
                    "{:<16} {:<13} {:>9.1} {:>9.1} {:>9.1} {:>8.2} {:>8.2}",
                    name,
                    label,
                    best[0],
                    best[1],
                    best[2],
                    best[1] / best[2],
                    best[0] / best[2]
                );
            }
        }
    }
}
