//! Tracing many rays on all threads of the current rayon pool.

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
/// enough to balance cheap and expensive parts of an image.
const CHUNK: usize = 1024;

/// Traces every ray of `rays` into the matching slot of `hits` (which must
/// be as long), in parallel on the current rayon pool.
pub fn trace_into(tree: &TriangleTree<'_>, rays: &[Ray], hits: &mut [Hit], query: Query) {
    rays.par_chunks(CHUNK)
        .zip(hits.par_chunks_mut(CHUNK))
        .for_each(|(r, h)| trace_serial(tree, r, h, query));
}

/// Traces on the calling thread.
pub fn trace_serial(tree: &TriangleTree<'_>, rays: &[Ray], hits: &mut [Hit], query: Query) {
    for (r, h) in rays.iter().zip(hits) {
        *h = match query {
            Query::Closest => tree.closest_hit(r),
            Query::Any => Hit::occlusion(tree.any_hit(r)),
        };
    }
}
