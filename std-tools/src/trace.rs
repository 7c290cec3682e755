//! Tracing many rays on all threads of the current rayon pool, one ray at
//! a time or in 4-, 8- or 16-wide packets.
//!
//! Packets are formed from consecutive rays, so they pay only when
//! neighbouring rays are coherent: order ray files in small image tiles
//! (e.g. `primary_tiled.rays` from the Embree anchor's `rays.sh`: 4x2
//! pixel tiles, one 8-wide packet each). Answers are the same bit for bit
//! whatever the width.

pub use kdray_kernel::PacketWidth;
use kdray_kernel::{Hit, Ray, TriangleTree};
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

/// Rays per parallel task: large enough to amortise scheduling, small
/// enough to balance cheap and expensive parts of an image. A multiple of
/// 8, so tasks never split a packet.
const CHUNK: usize = 1024;

/// Traces every ray of `rays` into the matching slot of `hits` (which must
/// be as long), in parallel on the current rayon pool, `width` rays at a
/// time.
pub fn trace_into(
    tree: &TriangleTree<'_>,
    rays: &[Ray],
    hits: &mut [Hit],
    query: Query,
    width: PacketWidth,
) {
    rays.par_chunks(CHUNK)
        .zip(hits.par_chunks_mut(CHUNK))
        .for_each(|(r, h)| trace_serial(tree, r, h, query, width));
}

/// Traces on the calling thread, `width` rays at a time.
pub fn trace_serial(
    tree: &TriangleTree<'_>,
    rays: &[Ray],
    hits: &mut [Hit],
    query: Query,
    width: PacketWidth,
) {
    match query {
        Query::Closest => tree.closest_hits_with(width, rays, hits),
        Query::Any => {
            let mut occluded = [false; CHUNK];
            for (r, h) in rays.chunks(CHUNK).zip(hits.chunks_mut(CHUNK)) {
                tree.any_hits_with(width, r, &mut occluded);
                for (h, &o) in h.iter_mut().zip(&occluded) {
                    *h = Hit::occlusion(o);
                }
            }
        }
    }
}
