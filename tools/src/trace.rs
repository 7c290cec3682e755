//! Tracing many rays on all threads of the current rayon pool: each
//! block's walk chosen by the kernel's batch calls (`width: None`, timed on
//! the batch), or one ray at a time or in 4-, 8- or 16-wide packets.
//!
//! Packets are formed from consecutive rays, so they pay only when
//! neighbouring rays are coherent: order ray files in small image tiles
//! (e.g. `primary_tiled.rays` from the Embree anchor's `rays.sh`: 4x2
//! pixel tiles, one 8-wide packet each). Answers are the same bit for bit
//! whatever the width.
//!
//! A large batch of scattered shadow rays (any hit; origins far apart
//! from one ray to the next, as from random surface points) is traced in
//! the Morton order of its origins ([`Order::Auto`]), each answer written
//! back to its ray's slot: neighbouring rays then share the cells, nodes
//! and triangles their walks read, which stay in cache (where in the
//! batch's order each walk waits on memory), and the kernel's batch calls'
//! occluder cache answers many of them. The answers are the same: each
//! ray's walk does not depend on the others. `matrix.sh`'s 1M shadow
//! rays, one core, the sort (~40 ms) included: single rays 1.9-2.6x,
//! 8-wide packets 2.2-5.4x (bunny, sponza, teapot). [`Order::Morton`]
//! sorts any batch, closest-hit rays by origin and direction.

use crate::morton;
pub use kdray_kernel::PacketWidth;
use kdray_kernel::{item_index, Batch, Hit, Ray, RayKey, TraceBatch, TriangleTree};
use rayon::prelude::*;

/// Which query to run per ray.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Query {
    /// The closest hit.
    #[default]
    Closest,
    /// Any hit (occlusion): [`Hit::OCCLUDED`] or [`Hit::MISS`].
    Any,
}

/// The fewest rays a parallel task takes: enough to amortise scheduling.
/// A multiple of 16, so tasks never split a packet.
const CHUNK: usize = 1024;

/// The most rays a parallel task takes: 1024 of the kernel's blocks, over
/// which its batch call times its walks once (its first four blocks and
/// one in a hundred or more after are trials, half a block each walk),
/// and a gathered chunk of 8 MB.
const TASK_MAX: usize = 1 << 18;

/// Rays per parallel task for a batch of `n`: four tasks a thread of the
/// current pool, to balance cheap and expensive parts of an image, between
/// [`CHUNK`] and [`TASK_MAX`], a multiple of [`CHUNK`].
fn task_len(n: usize) -> usize {
    let per = n.div_ceil(4 * rayon::current_num_threads().max(1));
    per.next_multiple_of(CHUNK).clamp(CHUNK, TASK_MAX)
}

/// The order a batch's rays are traced in (the hits are written in the
/// batch's order either way).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Order {
    /// The Morton order of the origins for a large batch of scattered
    /// any-hit rays ([`Order::sorts`]), else the batch's.
    #[default]
    Auto,
    /// The batch's own order.
    Given,
    /// Morton order ([`Order::key`]) whatever the batch (of at most
    /// `u32::MAX` rays): for a caller who knows its rays are scattered.
    Morton,
}

/// Batches of fewer rays are traced in their order: the cells their walks
/// share would not pay for sorting them.
const REORDER_MIN: usize = 1 << 14;

impl Order {
    /// Whether a batch of `rays` for `query` is traced in Morton order
    /// ([`Order::key`]): with [`Order::Morton`], any batch of at most
    /// `u32::MAX` rays; with [`Order::Auto`], an any-hit batch of at least
    /// 16,384 rays (and at most `u32::MAX`), scattered ([`TriangleTree::rays_scattered`])
    /// in most of eight blocks of 256 taken across it. `Auto` keeps
    /// closest-hit batches in their order: sorted by origin and direction,
    /// `matrix.sh`'s random rays traced 1.3-1.4x faster over the bunny and
    /// 1.6-1.7x over sponza (the sorted file traced as given), but sorting
    /// them took about as long as it saved (one core, interleaved, 1M
    /// rays: bunny 0.74-1.13x, sponza 0.97-1.27x, the sort, the gather of
    /// each chunk and the scatter of the hits included); the kernel walks
    /// them in turns instead.
    #[must_use]
    pub fn sorts(self, tree: &TriangleTree<'_>, rays: &[Ray], query: Query) -> bool {
        if self == Order::Morton {
            return u32::try_from(rays.len()).is_ok();
        }
        let batch = REORDER_MIN..=u32::MAX as usize;
        if self != Order::Auto || query != Query::Any || !batch.contains(&rays.len()) {
            return false;
        }
        let blocks = 8;
        let scattered = (0..blocks)
            .filter(|k| {
                let at = k * (rays.len() - 256) / (blocks - 1);
                tree.rays_scattered(&rays[at..at + 256])
            })
            .count();
        scattered > blocks / 2
    }

    /// The key a sorted batch for `query` is ordered by: shadow rays
    /// (any hit) by their origins alone, since their directions follow
    /// from their origins (towards the light); closest-hit rays (bounce
    /// and random rays, in all directions from nearby points) by origin
    /// and direction. Crossed over, both lose (files sorted offline,
    /// traced as given, one core): random rays by origin alone 5-12%
    /// slower, shadow rays by origin and direction ~25% slower.
    #[must_use]
    pub fn key(query: Query) -> RayKey {
        match query {
            Query::Closest => RayKey::OriginDirection,
            Query::Any => RayKey::Origin,
        }
    }
}

/// Traces every ray of `rays` into the matching slot of `hits` (which must
/// be as long), in parallel on the current rayon pool, `width` rays at a
/// time ([`Batch::width`]; `None`: each block's walk timed), in the order
/// `order` picks.
pub fn trace_into(
    tree: &impl TraceBatch,
    rays: &[Ray],
    hits: &mut [Hit],
    query: Query,
    width: Option<PacketWidth>,
    order: Order,
) {
    let sorted = order.sorts(&tree.tree(), rays, query);
    if let Some(order) = sorted
        .then(|| morton::ray_order(rays, Order::key(query)))
        .flatten()
    {
        // Each task gathers its chunk of rays in order (a few KiB that stay
        // in cache) and traces them; the answers go back to their rays'
        // slots after. (Gathering the whole batch first took as long, and
        // a copy of it: 32 MB a million rays.)
        let mut out = vec![Hit::MISS; order.len()];
        let task = task_len(order.len());
        order
            .par_chunks(task)
            .zip(out.par_chunks_mut(task))
            .for_each(|(o, h)| {
                let chunk: Vec<Ray> = o.iter().map(|&i| rays[item_index(i)]).collect();
                trace_serial(tree, &chunk, h, query, width);
            });
        for (&i, h) in order.iter().zip(out) {
            if let Some(slot) = hits.get_mut(item_index(i)) {
                *slot = h;
            }
        }
    } else {
        trace_chunks(tree, rays, hits, query, width);
    }
}

/// The first `k` hits of each ray ([`TriangleTree::first_hits`]) into
/// `hits`, `k` slots a ray (at least `k * rays.len()` of them), in
/// parallel on the current rayon pool: a ray's hits by `t` then triangle
/// index, its unused slots miss records. Returns how many hits in all.
pub fn first_hits_into(tree: &TriangleTree<'_>, rays: &[Ray], hits: &mut [Hit], k: usize) -> usize {
    let k = k.max(1);
    rays.par_chunks(CHUNK)
        .zip(hits.par_chunks_mut(CHUNK * k))
        .map(|(r, h)| {
            r.iter()
                .zip(h.chunks_mut(k))
                .map(|(ray, slots)| {
                    slots.fill(Hit::MISS);
                    tree.first_hits(ray, slots)
                })
                .sum::<usize>()
        })
        .sum()
}

/// [`trace_into`] in the batch's order.
fn trace_chunks(
    tree: &impl TraceBatch,
    rays: &[Ray],
    hits: &mut [Hit],
    query: Query,
    width: Option<PacketWidth>,
) {
    let task = task_len(rays.len());
    rays.par_chunks(task)
        .zip(hits.par_chunks_mut(task))
        .for_each(|(r, h)| trace_serial(tree, r, h, query, width));
}

/// Traces on the calling thread, `width` rays at a time ([`Batch::width`]),
/// in one batch call.
pub fn trace_serial(
    tree: &impl TraceBatch,
    rays: &[Ray],
    hits: &mut [Hit],
    query: Query,
    width: Option<PacketWidth>,
) {
    match query {
        Query::Closest => tree.closest_hits(
            rays,
            hits,
            Batch {
                width,
                ..Batch::default()
            },
        ),
        Query::Any => {
            let mut occluded = vec![false; rays.len().min(hits.len())];
            tree.any_hits(
                rays,
                &mut occluded,
                Batch {
                    width,
                    ..Batch::default()
                },
            );
            for (h, &o) in hits.iter_mut().zip(&occluded) {
                *h = Hit::occlusion(o);
            }
        }
    }
}
