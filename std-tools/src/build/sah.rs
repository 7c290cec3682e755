//! The SAH builder: at each cell, every box edge of the (cell-clipped)
//! triangle boxes on all three axes is a candidate split plane, and the one
//! minimising
//!
//! ```text
//! cost = C_trav + C_isect * (SA(L)/SA(cell) * N(L) + SA(R)/SA(cell) * N(R))
//! ```
//!
//! (times `1 - empty_bonus` when a side is empty) wins, unless a leaf,
//! `C_isect * N`, is cheaper. Triangles lying in the plane ("planar") are
//! tried on each side and go where the cost is lower.

use super::aabb::Aabb;
use super::{BuildNode, BuildParams};
use kdray_kernel::Axis;

/// A chosen split.
struct Split {
    axis: usize,
    pos: f32,
    planar_below: bool,
    cost: f64,
}

pub(super) fn build(boxes: &[Aabb], bounds: Aabb, params: &BuildParams) -> BuildNode {
    let ids: Vec<u32> = (0..boxes.len() as u32).collect();
    let limit = params.depth_limit(boxes.len());
    node(boxes, ids, bounds, 0, limit, params)
}

fn node(
    boxes: &[Aabb],
    ids: Vec<u32>,
    cell: Aabb,
    depth: u32,
    limit: u32,
    p: &BuildParams,
) -> BuildNode {
    if ids.len() <= 1 || depth >= limit {
        return BuildNode::Leaf(ids);
    }
    let Some(s) = best_split(boxes, &ids, &cell, p) else {
        return BuildNode::Leaf(ids);
    };
    let (mut below, mut above) = (Vec::new(), Vec::new());
    for &i in &ids {
        let b = boxes[i as usize].intersect(&cell);
        let (lo, hi) = (b.min[s.axis], b.max[s.axis]);
        if lo == s.pos && hi == s.pos {
            if s.planar_below {
                below.push(i);
            } else {
                above.push(i);
            }
            continue;
        }
        if lo < s.pos {
            below.push(i);
        }
        if hi > s.pos {
            above.push(i);
        }
    }
    let (cb, ca) = cell.split(s.axis, s.pos);
    BuildNode::Interior {
        axis: Axis::from_index(s.axis).unwrap_or(Axis::X),
        split: s.pos,
        below: Box::new(node(boxes, below, cb, depth + 1, limit, p)),
        above: Box::new(node(boxes, above, ca, depth + 1, limit, p)),
    }
}

/// The cheapest split of `cell`, if it beats making a leaf.
fn best_split(boxes: &[Aabb], ids: &[u32], cell: &Aabb, p: &BuildParams) -> Option<Split> {
    let area = cell.area();
    if area <= 0.0 {
        return None;
    }
    let n = ids.len();
    let c_trav = f64::from(p.traversal_cost);
    let c_isect = f64::from(p.intersection_cost);
    let leaf_cost = c_isect * n as f64;
    let mut best: Option<Split> = None;
    for axis in 0..3 {
        let (lo, hi) = (cell.min[axis], cell.max[axis]);
        let mut mins = Vec::with_capacity(n);
        let mut maxs = Vec::with_capacity(n);
        let mut planars = Vec::new();
        for &i in ids {
            let b = boxes[i as usize].intersect(cell);
            mins.push(b.min[axis]);
            maxs.push(b.max[axis]);
            if b.min[axis] == b.max[axis] {
                planars.push(b.min[axis]);
            }
        }
        mins.sort_unstable_by(f32::total_cmp);
        maxs.sort_unstable_by(f32::total_cmp);
        planars.sort_unstable_by(f32::total_cmp);
        let mut cands: Vec<f32> = mins
            .iter()
            .chain(&maxs)
            .copied()
            .filter(|&x| x > lo && x < hi)
            .collect();
        cands.sort_unstable_by(f32::total_cmp);
        cands.dedup();
        for &pos in &cands {
            let n_l = mins.partition_point(|&x| x < pos);
            let n_r = n - maxs.partition_point(|&x| x <= pos);
            let n_p =
                planars.partition_point(|&x| x <= pos) - planars.partition_point(|&x| x < pos);
            let (cb, ca) = cell.split(axis, pos);
            let (pl, pr) = (cb.area() / area, ca.area() / area);
            let cost = |nl: usize, nr: usize| {
                let bonus = if nl == 0 || nr == 0 {
                    1.0 - f64::from(p.empty_bonus)
                } else {
                    1.0
                };
                bonus * (c_trav + c_isect * (pl * nl as f64 + pr * nr as f64))
            };
            for (planar_below, c) in [(true, cost(n_l + n_p, n_r)), (false, cost(n_l, n_r + n_p))] {
                if c < leaf_cost && best.as_ref().is_none_or(|b| c < b.cost) {
                    best = Some(Split {
                        axis,
                        pos,
                        planar_below,
                        cost: c,
                    });
                }
            }
        }
    }
    best
}
