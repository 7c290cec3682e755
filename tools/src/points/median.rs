//! The median coordinate of a node's points on the split axis, for the
//! builder that moves points through their keys (`by_keys`).
//!
//! Large nodes find it by Floyd and Rivest's sampling: a strided sample's
//! keys bracket the median's rank, one pass over the node counts the keys
//! below the bracket and gathers those inside it, and only those few are
//! selected. The answer is the coordinate a selection over every key
//! gives (up to the sign of a zero, which compares equal): the sample
//! only decides how much work finding it takes, and when the bracket
//! misses the median, every key is selected after all. The knn bench's
//! builds against selecting every key (three interleaved rounds, ratio
//! to kiddo): 2-D 1.01-1.02x -> 1.04-1.06x, 8-D 1.19-1.22x ->
//! 1.23-1.25x, 16-D duplicates 0.99-1.00x -> 1.01-1.05x.

use super::store::coordinate_order;
use kdray_kernel::Scalar;

/// Nodes of fewer points copy and select all their keys. Of 256, 512,
/// 1,024 and 4,096, 1,024 gave the knn bench's fastest builds, by 1-3%.
const SAMPLED_MIN: usize = 1024;

/// Buffers a thread reuses from node to node.
#[derive(Default)]
pub(super) struct MedianScratch<S> {
    /// The keys selected among: a sample, or every key.
    keys: Vec<S>,
    /// The keys inside the sample's bracket (as long as the largest node,
    /// so that each key is written without a branch on whether it counts).
    band: Vec<S>,
}

/// The key of rank `rank` (counted from 0 in [`coordinate_order`]) among
/// the coordinates of `points` on axis `a`; `rank < points.len()`.
pub(super) fn key_of_rank<const D: usize, S: Scalar>(
    points: &[[S; D]],
    a: usize,
    rank: usize,
    scratch: &mut MedianScratch<S>,
) -> S {
    if points.len() >= SAMPLED_MIN {
        if let Some(key) = sampled(points, a, rank, scratch) {
            return key;
        }
    }
    let keys = &mut scratch.keys;
    keys.clear();
    keys.extend(points.iter().map(|p| p[a]));
    *keys.select_nth_unstable_by(rank, coordinate_order).1
}

/// [`key_of_rank`] through a sample of about `n^(2/3)` keys, or `None`
/// when the sample's bracket misses the rank.
fn sampled<const D: usize, S: Scalar>(
    points: &[[S; D]],
    a: usize,
    rank: usize,
    scratch: &mut MedianScratch<S>,
) -> Option<S> {
    let n = points.len();
    let keys = &mut scratch.keys;
    keys.clear();
    keys.extend(points.iter().step_by(stride(n)).map(|p| p[a]));
    let m = keys.len();
    // The rank's place in the sample, give or take `sqrt(m) / 2` (its
    // standard deviation for a random sample): two of those either side,
    // so about one node in twenty selects every key after all (four
    // either side widen every bracket: builds 1-2% slower).
    let at = (rank as u64 * m as u64 / n as u64) as usize;
    let reach = (m as f64).sqrt() as usize + 1;
    let (lo_at, hi_at) = (at.saturating_sub(reach), (at + reach).min(m - 1));
    let (_, &mut lo, above) = keys.select_nth_unstable_by(lo_at, coordinate_order);
    let hi = match (hi_at - lo_at).checked_sub(1) {
        Some(at) => *above.select_nth_unstable_by(at, coordinate_order).1,
        None => lo,
    };
    let band = &mut scratch.band;
    if band.len() < n {
        band.resize(n, S::ZERO);
    }
    let (mut below, mut inside) = (0, 0);
    for p in points {
        let x = p[a];
        // `inside <= ` the points read so far `< n`: each key is written,
        // and kept only when it lies in `[lo, hi]`.
        band[inside] = x;
        inside += usize::from((lo <= x) & (x <= hi));
        below += usize::from(x < lo);
    }
    let at = rank.checked_sub(below).filter(|&at| at < inside)?;
    Some(
        *band[..inside]
            .select_nth_unstable_by(at, coordinate_order)
            .1,
    )
}

/// The sample's step through a node of `n` points, for a sample of about
/// `n^(2/3)` keys: that size balances the sample's own selections against
/// the bracket's, which holds about `4 / sqrt(m)` of the node (Floyd and
/// Rivest's choice, up to constants).
fn stride(n: usize) -> usize {
    let m = (n as f64).cbrt().powi(2) as usize;
    (n / m.max(1)).max(1)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every rank of nodes of every shape the sample meets: uniform keys,
    /// a few distinct values, sorted, and a pile of equals, against a
    /// sort.
    #[test]
    fn every_rank_matches_a_sort() {
        let mut r = crate::rng::Rng::new(20);
        let mut scratch = MedianScratch::default();
        for n in [1, 2, 100, SAMPLED_MIN - 1, SAMPLED_MIN, 10_007] {
            // The sample sees only the largest keys: its bracket misses.
            let step = stride(n);
            let fooled = |i: usize| {
                if i.is_multiple_of(step) {
                    1e6
                } else {
                    i as f32
                }
            };
            let sets: [Vec<[f32; 2]>; 5] = [
                (0..n).map(|_| [r.range(-1.0, 1.0), 0.0]).collect(),
                (0..n).map(|_| [r.below(5) as f32, 1.0]).collect(),
                (0..n).map(|i| [i as f32, 2.0]).collect(),
                vec![[3.0, 3.0]; n],
                (0..n).map(|i| [fooled(i), 4.0]).collect(),
            ];
            if n >= SAMPLED_MIN {
                let fooled = &sets[4];
                assert_eq!(sampled(fooled, 0, n / 2, &mut scratch), None, "n {n}");
            }
            for points in &sets {
                let mut sorted: Vec<f32> = points.iter().map(|p| p[0]).collect();
                sorted.sort_by(f32::total_cmp);
                for rank in [0, n / 3, n / 2, n - 1] {
                    let key = key_of_rank(points, 0, rank, &mut scratch);
                    assert_eq!(key, sorted[rank], "n {n} rank {rank}");
                }
            }
        }
    }
}
