//! Point k-d trees: the builder ([`build_points`]), the queries over many
//! points at once ([`knn_all`]), and their parameters.
//!
//! ```text
//! .pts file -> io::read_records -> build_points -> BuiltPoints
//!           -> blob::write_point_tree -> Blob -> Blob::point_tree() -> kernel queries
//! ```

mod builder;
mod by_keys;
mod in_place;
mod median;
mod store;

pub use builder::{
    build_points, check_point, default_leaf_size, BuiltPoints, PointBuildError, PointParams,
    MAX_POINTS,
};

use kdray_kernel::{Neighbour, PointTreeN, Scalar};
use rayon::prelude::*;

/// The `k` nearest points of every query, `k` records per query in query
/// order (`.knn` layout, [`Neighbour::NONE`] where fewer than `k` points
/// exist), on the current rayon pool. `out.len()` must be
/// `queries.len() * k`; extra records are left as they are.
pub fn knn_all<const D: usize, S: Scalar>(
    tree: &PointTreeN<'_, D, S>,
    queries: &[[S; D]],
    k: usize,
    out: &mut [Neighbour<S>],
) {
    if k == 0 {
        return;
    }
    // Chunks of queries per task: enough work to amortise the task.
    const CHUNK: usize = 256;
    out.par_chunks_mut(k * CHUNK)
        .zip(queries.par_chunks(CHUNK))
        .for_each(|(out, queries)| {
            for (o, q) in out.chunks_exact_mut(k).zip(queries) {
                let found = tree.knn(*q, o);
                o[found..].fill(Neighbour::NONE);
            }
        });
}
