//! `kdray trace TREE RAYS -o HITS`: trace a ray file, write a hit file.

use super::json::JsonObject;
use super::{plural, thread_pool, wrong_kind, CmdResult};
use kdray_kernel::{Hit, Ray, Treelet};
use kdray_tools::blob::{Blob, BlobKind};
use kdray_tools::instances::{first_hits_scene, scene_offsets, trace_scene};
use kdray_tools::trace::{first_hits_into, trace_into, Order, PacketWidth, Query};
use kdray_tools::{io, memory};
use std::io::Write as _;
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `kdray trace`.
#[derive(clap::Args, Debug)]
pub(crate) struct Args {
    /// The tree blob.
    tree: PathBuf,
    /// The ray file (32-byte records, docs/formats.md).
    rays: PathBuf,
    /// Where to write the hit file (16-byte records).
    #[arg(short, long)]
    output: PathBuf,
    /// The first K hits of each ray instead of the closest: K records a
    /// ray in the hit file, by t then triangle index, each triangle once,
    /// unused slots miss records (docs/formats.md); K at most 1024. Single
    /// rays.
    #[arg(long, value_name = "K", conflicts_with = "any_hit")]
    first_hits: Option<usize>,
    /// Occlusion only: occluded rays get t = -inf, triangle 0xFFFFFFFE.
    #[arg(long)]
    any_hit: bool,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Rays traced together: `auto` (each block of 256 rays takes the walk
    /// timed cheapest on the batch: packets as wide as one register holds
    /// or single rays where origins lie close together, single rays or
    /// rays in turns where they lie far apart), or 1 (single rays), 4, 8 or
    /// 16 (packets of that many consecutive rays: order the file in pixel
    /// tiles, as `kdray rays --kind camera-tiled --packet N` does). The
    /// hits are the same bit for bit.
    #[arg(long, default_value = "auto", value_parser = parse_walk)]
    packet: Packets,
    /// Print one JSON object instead of the summary.
    #[arg(long)]
    json: bool,
    /// Timed passes; the best is reported (the Embree anchor takes the best of 5).
    #[arg(long, default_value_t = 1)]
    repeat: u32,
    /// Also count nodes visited and triangles tested per ray (a second,
    /// untimed pass).
    #[arg(long)]
    counts: bool,
    /// The order rays are traced in: `auto` traces a large batch of
    /// scattered any-hit rays (shadow rays from random surface points) in
    /// the Morton order of their origins; `morton` any batch in Morton
    /// order (closest-hit rays by origin and direction); the sort is
    /// included in the timing. `given` keeps the file's order. The hits
    /// are the same, in the file's order.
    #[arg(long, default_value = "auto", value_parser = parse_order)]
    order: Order,
}

/// `--order`: `auto`, `given` or `morton`.
fn parse_order(s: &str) -> Result<Order, String> {
    match s {
        "auto" => Ok(Order::Auto),
        "given" => Ok(Order::Given),
        "morton" => Ok(Order::Morton),
        _ => Err(format!("{s:?} is not an order: use auto, given or morton")),
    }
}

pub(crate) fn run(a: &Args) -> CmdResult {
    io::check_output_apart(&a.output, &[&a.tree, &a.rays])?;
    super::check_repeat("--repeat", a.repeat.into())?;
    let pool = thread_pool(a.threads)?;
    let blob = Blob::read(&a.tree).map_err(|e| format!("{}: {e}", a.tree.display()))?;
    match blob.kind() {
        BlobKind::Scene => return trace_scene_blob(a, &pool, &blob),
        BlobKind::Points => {
            return Err(wrong_kind(
                &a.tree,
                BlobKind::Points,
                "trace",
                "a triangle tree or a scene",
            )
            .into())
        }
        BlobKind::Triangles | BlobKind::Unknown => {}
    }
    let tree = blob
        .tree()
        .map_err(|e| format!("{}: invalid tree blob: {e}", a.tree.display()))?;
    let rays: Vec<Ray> = io::read_records(&a.rays, "ray")?;
    if let Some(k) = a.first_hits {
        return trace_first_hits(a, &pool, &rays, k, |r, hits| {
            first_hits_into(&tree, r, hits, k)
        });
    }
    let mut hits = memory::filled(rays.len(), Hit::MISS, "hit records")?;
    let query = if a.any_hit {
        Query::Any
    } else {
        Query::Closest
    };
    // Scattered closest-hit rays walk the tree's treelets (3 levels a
    // step); any hit keeps the one-plane walk.
    let mut lines = Vec::new();
    let seconds = if query == Query::Closest {
        lines.resize(tree.treelet_count(), Treelet::default());
        let lined = tree
            .treelets_into(&mut lines)
            .map_err(|e| format!("{}: {e}", a.tree.display()))?;
        best_of(a.repeat, || {
            pool.install(|| trace_into(&lined, &rays, &mut hits, query, a.packet.0, a.order));
        })
    } else {
        best_of(a.repeat, || {
            pool.install(|| trace_into(&tree, &rays, &mut hits, query, a.packet.0, a.order));
        })
    };
    io::write_records(&a.output, &hits)?;
    let per_ray = a.counts.then(|| {
        let mut total = (0u64, 0u64);
        for r in &rays {
            let c = match query {
                Query::Closest => tree.counting().closest_hit(r).1,
                Query::Any => tree.counting().any_hit(r).1,
            };
            total.0 += u64::from(c.nodes);
            total.1 += u64::from(c.triangles);
        }
        let n = rays.len().max(1) as f64;
        (total.0 as f64 / n, total.1 as f64 / n)
    });
    let hit_count = hits.iter().filter(|h| h.prim != kdray_kernel::MISS).count();
    let sorted = a.order.sorts(&tree, &rays, query);
    let mrays = rays.len() as f64 / seconds.max(1e-12) / 1e6;
    if a.json {
        let mut j = JsonObject::default()
            .with("rays", rays.len())
            .with("hits", hit_count)
            .with("threads", pool.current_num_threads())
            .with("query", if a.any_hit { "any" } else { "closest" })
            .with("packet", packet_json(a.packet))
            .with("order", if sorted { "morton" } else { "given" })
            .with("isa", kdray_kernel::isa().name())
            .with("repeat", a.repeat)
            .with("seconds", seconds)
            .with("mrays_per_s", mrays)
            .with("timing", TIMING);
        if let Some((nodes, tris)) = per_ray {
            j = j
                .with("nodes_per_ray", nodes)
                .with("triangles_per_ray", tris);
        }
        say!("{}", j.finish());
    } else {
        say!(
            "traced {} rays ({} {}) on {}, {}{}, best of {} in {seconds:.3} s: {mrays:.2} Mrays/s (excluding file I/O)",
            rays.len(),
            hit_count,
            if a.any_hit { "occluded" } else { "hit" },
            plural(pool.current_num_threads(), "thread"),
            a.packet
                .0
                .map_or("each block's walk timed".into(), |w| format!(
                    "packets of {}",
                    w.lanes()
                )),
            match (sorted, query) {
                (false, _) => "",
                (true, Query::Any) => ", in the Morton order of their origins",
                (true, Query::Closest) => ", in the Morton order of their origins and directions",
            },
            a.repeat,
        );
        if let Some((nodes, tris)) = per_ray {
            say!("per ray: {nodes:.1} nodes visited, {tris:.1} triangles tested");
        }
        say!("wrote {}", a.output.display());
    }
    Ok(())
}

/// What `seconds` in the JSON output covers.
const TIMING: &str =
    "seconds: the best pass, excluding reading the tree and rays and writing the hits";

/// The most records a ray `--first-hits` writes.
const MAX_FIRST_HITS: usize = 1024;

/// The hit records `--first-hits` holds in memory at once (16 MB): the
/// output is written in parts of this many, so K x rays records need not
/// fit (1024 x 1M rays would be 16 GB).
const FIRST_HITS_PART: usize = 1 << 20;

/// `kdray trace --first-hits K`: `k` records a ray, traced and written a
/// part of the rays at a time.
fn trace_first_hits(
    a: &Args,
    pool: &rayon::ThreadPool,
    rays: &[Ray],
    k: usize,
    fill: impl Fn(&[Ray], &mut [Hit]) -> usize + Send + Sync,
) -> CmdResult {
    if !(1..=MAX_FIRST_HITS).contains(&k) {
        return Err(format!("--first-hits {k}: must be 1 to {MAX_FIRST_HITS}").into());
    }
    if a.packet.0.is_some_and(|w| w != PacketWidth::One) {
        return Err("--first-hits traces single rays: leave --packet at auto or 1".into());
    }
    if a.counts {
        return Err(
            "--first-hits has no --counts: count the closest hits (without --first-hits)".into(),
        );
    }
    if a.order == Order::Morton {
        return Err("--first-hits traces the rays in the file's order: sort the file with `kdray sort-rays` instead of --order morton".into());
    }
    let part = (FIRST_HITS_PART / k).max(1);
    let mut hits = memory::filled(part.min(rays.len()) * k, Hit::MISS, "first-hit records")?;
    let mut out = io::Output::create(&a.output)?;
    let (mut seconds, mut found, mut hit_rays) = (f64::INFINITY, 0, 0);
    for pass in 0..a.repeat {
        let (mut pass_seconds, mut pass_found) = (0.0, 0);
        for r in rays.chunks(part) {
            let h = &mut hits[..r.len() * k];
            let t = Instant::now();
            pass_found += pool.install(|| fill(r, h));
            pass_seconds += t.elapsed().as_secs_f64();
            if pass == 0 {
                out.write_all(bytemuck::cast_slice(h))
                    .map_err(|e| out.error(&e))?;
                hit_rays += h
                    .chunks(k)
                    .filter(|h| h[0].prim != kdray_kernel::MISS)
                    .count();
            }
        }
        seconds = seconds.min(pass_seconds);
        found = pass_found;
    }
    out.commit()?;
    let rays = rays.len();
    let mrays = rays as f64 / seconds.max(1e-12) / 1e6;
    if a.json {
        let j = JsonObject::default()
            .with("rays", rays)
            .with("hits", hit_rays)
            .with("first_hits", k)
            .with("hits_found", found)
            .with("threads", pool.current_num_threads())
            .with("repeat", a.repeat)
            .with("seconds", seconds)
            .with("mrays_per_s", mrays)
            .with("timing", TIMING);
        say!("{}", j.finish());
    } else {
        say!(
            "traced the first {k} hits of {} rays ({hit_rays} hit, {found} hits in all) on {}, best of {} in {seconds:.3} s: {mrays:.2} Mrays/s (excluding file I/O)",
            rays,
            plural(pool.current_num_threads(), "thread"),
            a.repeat,
        );
        say!("wrote {}", a.output.display());
    }
    Ok(())
}

/// `kdray trace` over a scene blob: every instance, `prim` in the
/// flattened order (docs/formats.md). Packet lanes of a scene are traced
/// as single rays, so `--packet` changes nothing here.
fn trace_scene_blob(a: &Args, pool: &rayon::ThreadPool, blob: &Blob) -> CmdResult {
    let scene = blob
        .scene()
        .map_err(|e| format!("{}: invalid scene blob: {e}", a.tree.display()))?;
    // What the mesh path offers and a scene does not is refused, not
    // ignored: its rays are traced one at a time, in the file's order,
    // and it has no counted walk.
    let refuse = |what: &str| format!("{}: a scene blob {what}", a.tree.display());
    if a.counts {
        return Err(refuse("has no --counts (they count one tree's nodes): trace the flattened mesh's tree (kdray build without --instances) for them").into());
    }
    if a.packet.0.is_some_and(|w| w != PacketWidth::One) {
        return Err(refuse("traces single rays: leave --packet at auto or 1").into());
    }
    if a.order == Order::Morton {
        return Err(refuse("traces its rays in the file's order: sort the file with `kdray sort-rays` instead of --order morton").into());
    }
    let offsets = scene_offsets(&scene);
    let rays: Vec<Ray> = io::read_records(&a.rays, "ray")?;
    if let Some(k) = a.first_hits {
        return trace_first_hits(a, pool, &rays, k, |r, hits| {
            first_hits_scene(&scene, &offsets, r, hits, k)
        });
    }
    let mut hits = memory::filled(rays.len(), Hit::MISS, "hit records")?;
    let seconds = best_of(a.repeat, || {
        pool.install(|| trace_scene(&scene, &offsets, &rays, &mut hits, a.any_hit));
    });
    io::write_records(&a.output, &hits)?;
    let hit_count = hits.iter().filter(|h| h.prim != kdray_kernel::MISS).count();
    let mrays = rays.len() as f64 / seconds.max(1e-12) / 1e6;
    if a.json {
        let j = JsonObject::default()
            .with("rays", rays.len())
            .with("hits", hit_count)
            .with("threads", pool.current_num_threads())
            .with("query", if a.any_hit { "any" } else { "closest" })
            .with("packet", 1)
            .with("order", "given")
            .with("isa", kdray_kernel::isa().name())
            .with("repeat", a.repeat)
            .with("seconds", seconds)
            .with("mrays_per_s", mrays)
            .with("timing", TIMING)
            .with("instances", scene.instances().len());
        say!("{}", j.finish());
    } else {
        say!(
            "traced {} rays ({hit_count} {}) through a scene of {} instances on {}, best of {} in {seconds:.3} s: {mrays:.2} Mrays/s",
            rays.len(),
            if a.any_hit { "occluded" } else { "hit" },
            scene.instances().len(),
            plural(pool.current_num_threads(), "thread"),
            a.repeat,
        );
        say!("wrote {}", a.output.display());
    }
    Ok(())
}

/// The seconds of the best of `repeat` runs of `pass`, as the anchors
/// report theirs.
fn best_of(repeat: u32, mut pass: impl FnMut()) -> f64 {
    (0..repeat)
        .map(|_| {
            let t = Instant::now();
            pass();
            t.elapsed().as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min)
}

/// `--packet` of `trace`: `auto` (`None`: each block's walk timed), or a
/// width ([`Batch::width`](kdray_kernel::Batch::width)).
#[derive(Clone, Copy, Debug)]
struct Packets(Option<PacketWidth>);

/// `--packet` of `trace`: `auto`, or a width ([`parse_width`]).
fn parse_walk(s: &str) -> Result<Packets, String> {
    match s {
        "auto" => Ok(Packets(None)),
        _ => parse_width(s)
            .map(|w| Packets(Some(w)))
            .map_err(|_| format!("{s:?} is not a packet width: use auto, 1, 4, 8 or 16")),
    }
}

/// `--packet` in the JSON output: `"auto"`, or the width as a number.
fn packet_json(packets: Packets) -> serde_json::Value {
    packets.0.map_or("auto".into(), |w| w.lanes().into())
}

/// `--packet` (of `trace` and `render`): 1, 4, 8 or 16.
pub(super) fn parse_width(s: &str) -> Result<PacketWidth, String> {
    s.parse()
        .ok()
        .and_then(PacketWidth::from_lanes)
        .ok_or_else(|| format!("{s:?} is not a packet width: use 1, 4, 8 or 16"))
}
