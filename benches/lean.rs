//! The k-d tree's own bound on this machine: the lecture's loop over the
//! same blob, lean (no slack, plain `f32` Möller-Trumbore, no `f64` `t`,
//! no tie rule, empty children skipped at the parent, early exit once the
//! best hit lies within the current cell), printed beside `closest_hit` on
//! the same rays: nanoseconds a ray, best of five interleaved rounds.
//! Not exact (it is the reference, not an answer): it also prints how many
//! rays it answers differently, which should be a few in a million.
//!
//! The "warm" columns are each walk's floor without memory: every ray
//! walked twice in a row, the second walk's time (the twice-walked run's
//! less the once-walked one's). The second walk finds every node pair,
//! index and triangle it reads in L1 and its branches just taken, so the
//! floor is optimistic: no schedule that hides the misses of these walks
//! (rays in turns, prefetches, streams of rays that share few nodes)
//! takes a ray below it.
//!
//! The "tiles" row does the same for packets: camera rays in 4x2 pixel
//! tiles, two consecutive tiles a packet of 16, walked by the lean loop
//! once for all lanes (`lean/packet.rs`) beside kdray's packet path
//! (`closest_hits` with `width: Some(PacketWidth::Sixteen)`). It is
//! labelled with the lanes the lean walk takes: `tiles16` with AVX-512,
//! `tiles8` with AVX2 only (kdray then takes 8 as well), none without.
//!
//! ```sh
//! taskset -c 0 cargo bench --bench lean
//! # the anchor's rays for the tiles row:
//! KDRAY_BENCH_RAYS=/tmp/kdray-matrix taskset -c 0 cargo bench --bench lean
//! # instructions a ray (one variant, one mesh, few rays):
//! KDRAY_BENCH_CACHE=/tmp KDRAY_LEAN=lean KDRAY_LEAN_MESH=teapot KDRAY_LEAN_RAYS=16384 valgrind --tool=callgrind \
//!   --collect-atstart=no --toggle-collect='*trace_rays*' target/release/deps/lean-*
//! # the packet walks: KDRAY_LEAN_SET=tiles, --toggle-collect='*trace_tiles*', all the rays
//! # (KDRAY_LEAN_RAYS cuts an anchor file to the image's top rows, which miss)
//! ```
//! `KDRAY_LEAN=lean|tree` runs only that walk, once (`lean warm`, `tree
//! warm`: its twice-walked run), `KDRAY_LEAN_MESH` only that
//! mesh (`stanford-bunny`, `teapot`, `sponza`), `KDRAY_LEAN_SET` only that ray set (`camera`,
//! `random`, `tiles`), `KDRAY_LEAN_RAYS` sets the
//! number of rays of each set (65536; it cuts an anchor file to that many),
//! `KDRAY_LEAN_LANES=8` runs both packet walks 8 lanes wide,
//! `KDRAY_BENCH_CACHE` a folder to keep the built trees in,
//! `KDRAY_BENCH_RAYS` a folder of the Embree anchor's ray files for the
//! random and tiles rows (`rays-NAME/random.rays`, `primary_tiled.rays`:
//! `anchors/embree/rays.sh`; a scene without them takes rays made here).

mod common;
#[cfg(target_arch = "x86_64")]
#[path = "lean/lanes.rs"]
mod lanes;
#[cfg(target_arch = "x86_64")]
#[path = "lean/packet.rs"]
mod packet;

use kdray::kernel::{Batch, Hit, Node, PacketWidth, Ray, Triangle, TriangleTree};
use kdray::tools::camera::{random_rays, Camera};
use kdray::tools::render::{tile_size, tiled_pixels};
use std::hint::black_box;
use std::time::Instant;

/// Plain Möller-Trumbore in `f32`: the hit's `t` in `(tmin, tmax)`.
#[inline(always)]
fn moller_trumbore(tri: &Triangle, o: [f32; 3], d: [f32; 3], tmin: f32, tmax: f32) -> Option<f32> {
    let sub = |a: [f32; 3], b: [f32; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let cross = |a: [f32; 3], b: [f32; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let dot = |a: [f32; 3], b: [f32; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let [v0, v1, v2] = tri.v;
    let (e1, e2) = (sub(v1, v0), sub(v2, v0));
    let p = cross(d, e2);
    let det = dot(e1, p);
    if det == 0.0 {
        return None;
    }
    let inv = 1.0 / det;
    let s = sub(o, v0);
    let u = dot(s, p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = cross(s, e1);
    let v = dot(d, q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = dot(e2, q) * inv;
    (t > tmin && t < tmax).then_some(t)
}

/// A leaf's primitives: its one (`one`, the leaf's word 0) or its run in
/// the index array (the node's format, `docs/formats.md`).
#[inline(always)]
fn leaf_run<'a>(node: Node, prims: &'a [u32], one: &'a [u32; 1]) -> &'a [u32] {
    let count = node.upper() as usize;
    if count == 1 {
        one
    } else {
        &prims[node.word0() as usize..][..count]
    }
}

/// The lecture's walk: `(t, triangle)` of the closest hit, `u32::MAX` for none.
#[inline(always)]
fn lean_closest(tree: &TriangleTree, ray: &Ray, stack: &mut [(u32, f32, f32); 64]) -> (f32, u32) {
    let (nodes, prims, tris, b) = (
        tree.nodes(),
        tree.prim_indices(),
        tree.triangles(),
        tree.bounds(),
    );
    let (o, d) = (ray.origin, ray.dir);
    let inv = d.map(|x| 1.0 / x);
    // Clip to the scene box (slab test).
    let (mut lo, mut hi) = (ray.tmin, ray.tmax);
    for a in 0..3 {
        let (t0, t1) = ((b.min[a] - o[a]) * inv[a], (b.max[a] - o[a]) * inv[a]);
        lo = lo.max(t0.min(t1));
        hi = hi.min(t0.max(t1));
    }
    let mut best = (ray.tmax, u32::MAX);
    if lo > hi {
        return best;
    }
    let above_first = inv.map(|x| usize::from(x < 0.0));
    let mut sp = 0;
    let mut node: Node = nodes[0];
    loop {
        let axis = node.axis_bits();
        if axis < 3 {
            // One FP subtract, one FP multiply.
            let t = (node.split() - o[axis]) * inv[axis];
            let near = node.upper() as usize + above_first[axis];
            let far = near ^ 1;
            let (n, f) = (nodes[near], nodes[far]);
            let (go_near, go_far) = (t >= lo && !n.is_empty_leaf(), t <= hi && !f.is_empty_leaf());
            if go_near {
                if go_far && sp < 64 {
                    stack[sp] = (far as u32, t, hi);
                    sp += 1;
                }
                hi = hi.min(t);
                node = n;
                continue;
            } else if go_far {
                lo = lo.max(t);
                node = f;
                continue;
            }
        } else {
            let one = [node.word0()];
            for &p in leaf_run(node, prims, &one) {
                if let Some(t) = moller_trumbore(&tris[p as usize], o, d, ray.tmin, best.0) {
                    best = (t, p);
                }
            }
            // The best hit lies in this cell: no later cell holds a closer one.
            if best.0 <= hi {
                return best;
            }
        }
        // Next pending cell that starts before the best hit.
        loop {
            if sp == 0 {
                return best;
            }
            sp -= 1;
            let (n, l, h) = stack[sp];
            if l <= best.0 {
                (node, lo, hi) = (nodes[n as usize], l, h);
                break;
            }
        }
    }
}

/// The walk a measurement runs: each ray's answer into `out`, each ray
/// walked `TIMES` times in a row (2: the warm columns).
#[inline(never)]
fn trace_rays_lean<const TIMES: usize>(tree: &TriangleTree, rays: &[Ray], out: &mut [(f32, u32)]) {
    // One stack for all rays: no zeroing per ray.
    let mut stack = [(0u32, 0.0f32, 0.0f32); 64];
    for (o, r) in out.iter_mut().zip(rays) {
        for _ in 0..TIMES {
            *o = lean_closest(tree, black_box(r), &mut stack);
        }
    }
}

/// `closest_hit` over the same rays, as [`trace_rays_lean`].
#[inline(never)]
fn trace_rays_tree<const TIMES: usize>(tree: &TriangleTree, rays: &[Ray], out: &mut [(f32, u32)]) {
    for (o, r) in out.iter_mut().zip(rays) {
        for _ in 0..TIMES {
            let h = tree.closest_hit(black_box(r));
            *o = (h.t, h.prim);
        }
    }
}

/// kdray's packet path over the same rays: `closest_hits` in packets of
/// `lanes` (16 or 8) consecutive rays.
#[inline(never)]
fn trace_tiles_tree(tree: &TriangleTree, rays: &[Ray], hits: &mut [Hit], lanes: usize) {
    let width = if lanes == 8 {
        PacketWidth::Eight
    } else {
        PacketWidth::Sixteen
    };
    let batch = Batch {
        width: Some(width),
        ..Batch::default()
    };
    tree.closest_hits(black_box(rays), hits, batch);
}

/// Nanoseconds a ray of the `K` walks `run(0, ..)`, `run(1, ..)`, ... over
/// `rays`, best of `rounds` interleaved rounds; `only` runs the walks
/// labelled so.
fn best_of<const K: usize>(
    rays: &[Ray],
    rounds: usize,
    labels: [&str; K],
    only: Option<&str>,
    mut run: impl FnMut(usize, &[Ray]),
) -> [f64; K] {
    let mut best = [f64::INFINITY; K];
    for _round in 0..rounds {
        for (k, label) in labels.iter().enumerate() {
            if only.is_some_and(|o| o != *label) {
                continue;
            }
            let t = Instant::now();
            run(k, rays);
            best[k] = best[k].min(t.elapsed().as_secs_f64() * 1e9 / rays.len() as f64);
        }
    }
    best
}

fn main() {
    let only = std::env::var("KDRAY_LEAN").ok();
    let mesh = std::env::var("KDRAY_LEAN_MESH").ok();
    let set = std::env::var("KDRAY_LEAN_SET").ok();
    let count: Option<usize> = std::env::var("KDRAY_LEAN_RAYS")
        .ok()
        .and_then(|s| s.parse().ok());
    let n = count.unwrap_or(65_536);
    let lanes = match std::env::var("KDRAY_LEAN_LANES").ok().as_deref() {
        Some("8") => 8,
        _ => 16,
    };
    let rounds = if only.is_some() { 1 } else { 5 };
    let names: Vec<&str> = match &mesh {
        Some(m) => vec![m.as_str()],
        None => vec!["stanford-bunny", "teapot", "sponza"],
    };
    type Walk = fn(&TriangleTree, &[Ray], &mut [(f32, u32)]);
    let walks: [Walk; 4] = [
        trace_rays_lean::<1>,
        trace_rays_tree::<1>,
        trace_rays_lean::<2>,
        trace_rays_tree::<2>,
    ];
    println!(
        "{:<16} {:<7} {:>10} {:>10} {:>7} {:>9} {:>10} {:>10}",
        "mesh", "rays", "lean ns", "tree ns", "ratio", "differ", "lean warm", "tree warm"
    );
    for (name, tris, focus) in common::scenes(&names) {
        if mesh.as_deref().is_some_and(|m| m != name) {
            continue;
        }
        let blob = common::tree_blob(&name, &tris);
        let tree = blob.tree().unwrap();
        let side = (n as f64).sqrt() as u32;
        let camera = Camera::framing(&focus);
        let sets: [(&str, Vec<Ray>); 2] = [
            ("camera", camera.rays(side, side)),
            (
                "random",
                match common::anchor_rays(&name, "random") {
                    Some(mut rays) => {
                        rays.truncate(count.unwrap_or(rays.len()));
                        rays
                    }
                    None => random_rays(&tree.bounds(), n, 1),
                },
            ),
        ];
        for (kind, rays) in &sets {
            if set.as_deref().is_some_and(|s| s != *kind) {
                continue;
            }
            let mut out: [Vec<(f32, u32)>; 4] =
                core::array::from_fn(|_| vec![(0.0, 0); rays.len()]);
            let labels = ["lean", "tree", "lean warm", "tree warm"];
            let best = best_of(rays, rounds, labels, only.as_deref(), |k, r| {
                walks[k](&tree, r, &mut out[k]);
            });
            let differ = out[0]
                .iter()
                .zip(&out[1])
                .filter(|(a, b)| a.1 != b.1)
                .count();
            let warm = [best[2] - best[0], best[3] - best[1]];
            print_row(&name, kind, [best[0], best[1]], differ, Some(warm));
        }
        if set.as_deref().is_none_or(|s| s == "tiles") {
            #[cfg(target_arch = "x86_64")]
            tiles_row(
                &name,
                &tree,
                &camera,
                side,
                count,
                lanes,
                rounds,
                only.as_deref(),
            );
        }
    }
}

/// The "tiles" row: camera rays in 4x2 tiles, two tiles a packet of 16
/// (the anchor's file when given, else `side` x `side` made here), the
/// lean packet walk against kdray's packet path, each `lanes` wide.
#[cfg(target_arch = "x86_64")]
#[allow(clippy::too_many_arguments)]
fn tiles_row(
    name: &str,
    tree: &TriangleTree,
    camera: &Camera,
    side: u32,
    count: Option<usize>,
    lanes: usize,
    rounds: usize,
    only: Option<&str>,
) {
    let Some(here) = packet::lanes_here(lanes) else {
        eprintln!("{name} tiles skipped: the lean packet walk needs AVX2");
        return;
    };
    let tiles = match common::anchor_rays(name, "primary_tiled") {
        Some(mut rays) => {
            rays.truncate(count.unwrap_or(rays.len()));
            rays
        }
        None => {
            let side = side & !3;
            tiled_pixels(side, side, tile_size(PacketWidth::Eight))
                .iter()
                .map(|&[x, y]| camera.ray(x, y, side, side))
                .collect()
        }
    };
    let mut lean = vec![(0.0f32, 0u32); tiles.len()];
    let mut hits = vec![Hit::MISS; tiles.len()];
    let best = best_of(&tiles, rounds, ["lean", "tree"], only, |k, r| {
        if k == 0 {
            packet::trace_tiles_lean(tree, r, &mut lean, lanes);
        } else {
            trace_tiles_tree(tree, r, &mut hits, lanes);
        }
    });
    let differ = lean
        .iter()
        .zip(&hits)
        .filter(|(a, h)| a.1 != h.prim)
        .count();
    print_row(name, &format!("tiles{here}"), best, differ, None);
}

/// One row: the two walks' nanoseconds a ray, their ratio, how many rays
/// they answer differently, and their warm floors where measured.
fn print_row(name: &str, kind: &str, best: [f64; 2], differ: usize, warm: Option<[f64; 2]>) {
    // A walk left out (`KDRAY_LEAN`) has no floor.
    let warm = warm
        .filter(|w| w.iter().all(|x| x.is_finite()))
        .map_or(String::new(), |[l, t]| format!(" {l:>10.1} {t:>10.1}"));
    println!(
        "{:<16} {:<7} {:>10.1} {:>10.1} {:>7.2} {:>9}{warm}",
        name,
        kind,
        best[0],
        best[1],
        best[1] / best[0],
        differ
    );
}
