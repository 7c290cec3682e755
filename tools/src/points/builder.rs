//! The lecture's point k-d tree builder, for any dimension D and for f32
//! or f64 coordinates: split the widest dimension at the median (an O(n)
//! selection per level, so O(n log n) in all), keep the tight bounds of the
//! points under every node, stop at `leaf_size` points or when the widest
//! extent is at most `min_width`.
//!
//! The points are partitioned in one of two layouts (`store::Store`),
//! chosen by their size, so that when the recursion ends they are in leaf
//! order: each leaf's run is a slice of one array, as the kernel's blob
//! stores them. Subtrees of at least `parallel_min` points are built on
//! rayon tasks and spliced into the depth-first layout afterwards; the
//! output is the same for any thread count.

use super::by_keys::{Columns, FromInput};
use super::in_place::{in_place, leaf_major, InPlace, Item};
use super::store::Store;
use kdray_kernel::{
    max_point_coord, max_point_coord_log2, BlobError, PointNode, PointNodeKind, PointTreeN, Scalar,
    MAX_DEPTH, MAX_POINT_FIELD,
};
use std::fmt;

/// The builder's parameters, defaults documented per field.
#[derive(Clone, Debug, PartialEq)]
pub struct PointParams {
    /// A node with at most this many points is a leaf (the lecture's m;
    /// median splits make leaves of m/2 to m points). Default `None`:
    /// [`default_leaf_size`] of the points' dimension.
    pub leaf_size: Option<usize>,
    /// A node whose widest extent is at most this is a leaf, however many
    /// points it holds. Default 0: only piles of equal points stop early
    /// (they cannot be split; the query scans such a pile in O(k)).
    pub min_width: f64,
    /// Subtrees of at least this many points are built in parallel.
    /// Default 65536.
    pub parallel_min: usize,
}

impl PointParams {
    /// The leaf size a build of `dim`-dimensional points takes: the one
    /// given, or [`default_leaf_size`], within `1..=MAX_POINT_FIELD`.
    #[must_use]
    pub fn leaf_size_for(&self, dim: usize) -> usize {
        self.leaf_size
            .unwrap_or(default_leaf_size(dim))
            .clamp(1, MAX_POINT_FIELD as usize)
    }
}

/// [`PointParams`] as a build runs with them: the leaf size settled.
struct Limits {
    leaf_size: usize,
    min_width: f64,
    parallel_min: usize,
}

impl Default for PointParams {
    fn default() -> Self {
        PointParams {
            leaf_size: None,
            min_width: 0.0,
            parallel_min: 1 << 16,
        }
    }
}

/// The leaf size (the lecture's m) a build of `dim`-dimensional points
/// takes by default: 32 below 8-D, 64 from 8-D on.
///
/// Up to 3-D, measured on the 1M-point anchor sets (uniform, clustered,
/// bunny), one core, k = 1 and 10: m = 6 and 8 were 10-40% slower than 16
/// and 32, which were within noise of each other (32 ahead on the
/// bunny), and 32 builds ~10% faster. At 8-D and 16-D (the knn bench's
/// 100k-point sets, leaves of 32 and 64 interleaved, two rounds against
/// kiddo) 64 builds 8-37% faster, a level fewer, and queries run as
/// fast or faster (docs/results.md, "Leaves of 64 points from 8-D on").
/// Tried below 8-D (the knn bench, two interleaved rounds, 2-D and 3-D
/// against 32's builds 1.01-1.02x and k = 10 1.03-1.07x kiddo): leaves of
/// 48 build 0.99-1.08x but answer k = 10 at 0.94-1.02x, of 64 build
/// 1.08-1.22x but answer k = 10 at 0.82-0.93x: a query scans more points
/// per leaf than the level saved costs.
#[must_use]
pub const fn default_leaf_size(dim: usize) -> usize {
    if dim >= 8 {
        64
    } else {
        32
    }
}

/// Why a point build failed.
#[derive(Debug, Clone, PartialEq)]
pub enum PointBuildError {
    /// A point with a NaN or infinite coordinate.
    NonFinite {
        /// The point's index.
        point: usize,
        /// The axis of the first bad coordinate.
        axis: usize,
        /// Its value.
        value: f64,
    },
    /// A point with a coordinate beyond `±2^limit_log2`
    /// ([`kdray_kernel::max_point_coord`]), where squared distances could
    /// overflow.
    OutOfRange {
        /// The point's index.
        point: usize,
        /// The axis of the first coordinate out of range.
        axis: usize,
        /// Its value.
        value: f64,
        /// `log2` of the range's bound.
        limit_log2: u32,
    },
    /// More points than a tree can index.
    TooManyPoints {
        /// How many there are.
        count: usize,
    },
}

/// The most points a tree holds: its node count (about 2n / leaf size,
/// at most 2n) and every index must fit the blob's 32-bit counts.
pub const MAX_POINTS: usize = (1 << 30) - 1;

impl fmt::Display for PointBuildError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PointBuildError::NonFinite { point, axis, value } => {
                write!(
                    f,
                    "point {point} has a non-finite coordinate {value} (axis {axis})"
                )
            }
            PointBuildError::OutOfRange {
                point,
                axis,
                value,
                limit_log2,
            } => write!(
                f,
                "point {point} has coordinate {value:e} (axis {axis}), beyond the range ±2^{limit_log2} ({:e}) in which squared distances cannot overflow",
                2f64.powi(*limit_log2 as i32)
            ),
            PointBuildError::TooManyPoints { count } => write!(
                f,
                "{count} points is more than a tree can index ({MAX_POINTS})"
            ),
        }
    }
}

impl std::error::Error for PointBuildError {}

/// A built point tree, in the kernel's layout (see `kdray_kernel::PointTreeN`).
#[derive(Clone, Debug, PartialEq)]
pub struct BuiltPoints<const D: usize, S: Scalar = f32> {
    /// Nodes in the depth-first layout; leaves hold runs of the arrays below.
    pub nodes: Vec<PointNode>,
    /// The split location of each interior node (0 for a leaf).
    pub splits: Vec<S>,
    /// The input index of each point of `points`.
    pub indices: Vec<u32>,
    /// The points' coordinates in leaf order, each leaf's run axis by axis
    /// (`kdray_kernel::PointTreeN::coords`).
    pub coords: Vec<S>,
    /// The tight bounds `[min, max]` of the points at or below each node.
    pub bounds: Vec<[[S; D]; 2]>,
    /// The depth of the deepest node.
    pub max_depth: u32,
}

impl<const D: usize, S: Scalar> BuiltPoints<D, S> {
    /// The validated kernel view ([`PointTreeN::from_parts`]).
    ///
    /// # Errors
    /// The kernel's [`BlobError`] (never, for a tree [`build_points`] made).
    pub fn view(&self) -> Result<PointTreeN<'_, D, S>, BlobError> {
        PointTreeN::from_parts(
            &self.nodes,
            &self.splits,
            &self.indices,
            &self.coords,
            &self.bounds,
        )
    }
}

/// Checks that point `point` is one a tree holds and answers for: every
/// coordinate finite and within `±`[`kdray_kernel::max_point_coord`]
/// (queries are held to the same rule: beyond it the kernel answers
/// nothing).
///
/// # Errors
/// [`PointBuildError::NonFinite`] or [`PointBuildError::OutOfRange`]
/// naming the point, the axis and the value.
pub fn check_point<const D: usize, S: Scalar>(
    point: usize,
    p: &[S; D],
) -> Result<(), PointBuildError> {
    if let Some(axis) = p.iter().position(|c| !c.is_finite()) {
        return Err(PointBuildError::NonFinite {
            point,
            axis,
            value: p[axis].to_f64(),
        });
    }
    let limit = max_point_coord::<D, S>();
    if let Some(axis) = p.iter().position(|c| c.abs() > limit) {
        return Err(PointBuildError::OutOfRange {
            point,
            axis,
            value: p[axis].to_f64(),
            limit_log2: max_point_coord_log2::<D, S>(),
        });
    }
    Ok(())
}

/// Builds the tree over `points` (index = position).
///
/// # Errors
/// [`PointBuildError::NonFinite`] naming the first NaN or infinite
/// coordinate, [`PointBuildError::OutOfRange`] the first beyond
/// [`kdray_kernel::max_point_coord`]; [`PointBuildError::TooManyPoints`]
/// past [`MAX_POINTS`].
pub fn build_points<const D: usize, S: Scalar>(
    points: &[[S; D]],
    params: &PointParams,
) -> Result<BuiltPoints<D, S>, PointBuildError> {
    for (point, p) in points.iter().enumerate() {
        check_point(point, p)?;
    }
    if points.len() > MAX_POINTS {
        return Err(PointBuildError::TooManyPoints {
            count: points.len(),
        });
    }
    let params = Limits {
        leaf_size: params.leaf_size_for(D),
        min_width: params.min_width,
        parallel_min: params.parallel_min,
    };
    if in_place::<D, S>() {
        let mut items: Vec<Item<D, S>> = points
            .iter()
            .enumerate()
            .map(|(i, &p)| Item { p, index: i as u32 })
            .collect();
        let tree = grow_parallel(InPlace(&mut items), 0, 0, &params);
        Ok(BuiltPoints {
            coords: leaf_major(&tree.nodes, &items),
            indices: items.iter().map(|it| it.index).collect(),
            ..tree.into_built()
        })
    } else {
        let n = points.len();
        // Zeroed, so never written before the partitions write them.
        let mut p = vec![[S::ZERO; D]; n];
        let mut indices = vec![0; n];
        let mut spare_p = vec![[S::ZERO; D]; n];
        let mut spare_indices = vec![0; n];
        let run = FromInput {
            points,
            first: Columns {
                p: &mut p,
                index: &mut indices,
            },
            second: Columns {
                p: &mut spare_p,
                index: &mut spare_indices,
            },
        };
        let tree = grow_parallel(run, 0, 0, &params);
        Ok(BuiltPoints {
            coords: p.into_flattened(),
            indices,
            ..tree.into_built()
        })
    }
}

/// A subtree in the depth-first layout with its root at 0; leaf offsets
/// are already absolute.
struct Subtree<const D: usize, S> {
    nodes: Vec<PointNode>,
    splits: Vec<S>,
    bounds: Vec<[[S; D]; 2]>,
    max_depth: u32,
}

impl<const D: usize, S: Scalar> Subtree<D, S> {
    /// The whole tree, its points still to be filled in.
    fn into_built(self) -> BuiltPoints<D, S> {
        BuiltPoints {
            nodes: self.nodes,
            splits: self.splits,
            indices: Vec::new(),
            coords: Vec::new(),
            bounds: self.bounds,
            max_depth: self.max_depth,
        }
    }
}

/// The split axis for a node, or `None` for a leaf: few points, too
/// narrow (a pile of equal points always is), or at the depth limit.
/// The widest axis; of equal extents the lowest.
fn split_axis<const D: usize, S: Scalar>(
    len: usize,
    b: &[[S; D]; 2],
    depth: u32,
    params: &Limits,
) -> Option<usize> {
    if len <= params.leaf_size || depth >= MAX_DEPTH {
        return None;
    }
    let extent = |a: usize| b[1][a] - b[0][a];
    let mut widest = 0;
    for a in 1..D {
        if extent(a) > extent(widest) {
            widest = a;
        }
    }
    (extent(widest).to_f64() > params.min_width).then_some(widest)
}

/// An interior node splitting axis `a` (below D, so it fits).
fn interior(a: usize, child: usize) -> PointNode {
    PointNode::interior(a as u32, child as u32).unwrap_or(PointNode::EMPTY_LEAF)
}

/// Builds the subtree over `run` into `t`, its root at `slot`.
fn grow<const D: usize, S: Scalar, R: Store<D, S>>(
    mut run: R,
    offset: usize,
    depth: u32,
    slot: usize,
    t: &mut Subtree<D, S>,
    params: &Limits,
    scratch: &mut R::Scratch,
) {
    let b = run.bounds();
    t.bounds[slot] = b;
    t.max_depth = t.max_depth.max(depth);
    let Some(axis) = split_axis(run.len(), &b, depth, params) else {
        t.nodes[slot] = run.leaf(offset, scratch);
        return;
    };
    let (mid, split) = run.partition(axis, scratch);
    let child = t.nodes.len();
    t.nodes[slot] = interior(axis, child);
    t.splits[slot] = split;
    t.nodes.extend([PointNode::EMPTY_LEAF; 2]);
    t.splits.extend([S::ZERO; 2]);
    t.bounds.extend([b; 2]);
    let [below, above] = run.children(mid);
    grow(below, offset, depth + 1, child, t, params, scratch);
    grow(
        above,
        offset + mid,
        depth + 1,
        child + 1,
        t,
        params,
        scratch,
    );
}

/// [`grow`] for a subtree rooted at 0, forking the two halves of large
/// nodes onto rayon tasks. A node below `parallel_min` goes to [`grow`]
/// before its box is taken, which [`grow`] takes (a serial build reads
/// the root's points once less); only a leaf of `parallel_min` points or
/// more, a pile of equal points, has its box taken twice.
fn grow_parallel<const D: usize, S: Scalar, R: Store<D, S>>(
    mut run: R,
    offset: usize,
    depth: u32,
    params: &Limits,
) -> Subtree<D, S> {
    let mut scratch = R::Scratch::default();
    if run.len() >= params.parallel_min {
        let b = run.bounds();
        if let Some(axis) = split_axis(run.len(), &b, depth, params) {
            let (mid, split) = run.partition(axis, &mut scratch);
            let [below, above] = run.children(mid);
            let (below, above) = rayon::join(
                || grow_parallel(below, offset, depth + 1, params),
                || grow_parallel(above, offset + mid, depth + 1, params),
            );
            return splice(interior(axis, 1), split, b, depth, below, above);
        }
    }
    // The root's slots, which `grow` fills.
    let mut t = Subtree {
        nodes: vec![PointNode::EMPTY_LEAF],
        splits: vec![S::ZERO],
        bounds: vec![[[S::ZERO; D]; 2]],
        max_depth: 0,
    };
    grow(run, offset, depth, 0, &mut t, params, &mut scratch);
    t
}

/// Joins two subtrees under a new root. Depth-first, the below subtree's
/// child pairs come first (right after the root's pair at 1, 2), then the
/// above subtree's: a child at local `c >= 1` moves to `c - 1 + base`.
fn splice<const D: usize, S: Scalar>(
    root: PointNode,
    split: S,
    b: [[S; D]; 2],
    depth: u32,
    below: Subtree<D, S>,
    above: Subtree<D, S>,
) -> Subtree<D, S> {
    let below_base = 3;
    let above_base = below_base + below.nodes.len() - 1;
    let moved = |n: PointNode, base: usize| match n.kind() {
        PointNodeKind::Interior { axis, child } => {
            interior(axis as usize, child as usize - 1 + base)
        }
        PointNodeKind::Leaf { .. } => n,
    };
    let mut nodes = Vec::with_capacity(below.nodes.len() + above.nodes.len() + 1);
    nodes.push(root);
    nodes.push(moved(below.nodes[0], below_base));
    nodes.push(moved(above.nodes[0], above_base));
    nodes.extend(below.nodes[1..].iter().map(|&n| moved(n, below_base)));
    nodes.extend(above.nodes[1..].iter().map(|&n| moved(n, above_base)));
    let mut splits = Vec::with_capacity(nodes.len());
    splits.extend([split, below.splits[0], above.splits[0]]);
    splits.extend_from_slice(&below.splits[1..]);
    splits.extend_from_slice(&above.splits[1..]);
    let mut bounds = Vec::with_capacity(nodes.len());
    bounds.extend([b, below.bounds[0], above.bounds[0]]);
    bounds.extend_from_slice(&below.bounds[1..]);
    bounds.extend_from_slice(&above.bounds[1..]);
    Subtree {
        nodes,
        splits,
        bounds,
        max_depth: depth.max(below.max_depth).max(above.max_depth),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::points::by_keys::ByKeys;

    fn lcg_points<const D: usize>(n: usize, seed: u64) -> Vec<[f32; D]> {
        let mut rng = crate::rng::Rng::new(seed);
        (0..n).map(|_| std::array::from_fn(|_| rng.f32())).collect()
    }

    /// Builds `n` points at D serially and in parallel: the same tree,
    /// valid, every point where its index says (after the leaf-major
    /// layout), whichever store the points went through.
    fn parallel_and_serial_agree<const D: usize>(n: usize) {
        let pts = lcg_points::<D>(n, 3);
        let serial = build_points(
            &pts,
            &PointParams {
                parallel_min: usize::MAX,
                ..Default::default()
            },
        )
        .unwrap();
        let parallel = build_points(
            &pts,
            &PointParams {
                parallel_min: 100,
                ..Default::default()
            },
        )
        .unwrap();
        assert_eq!(serial, parallel);
        let tree = serial.view().unwrap();
        assert_eq!(tree.len(), n);
        for (at, &i) in tree.indices().iter().enumerate() {
            assert_eq!(tree.point(at), Some(pts[i as usize]), "D {D} n {n}");
        }
    }

    #[test]
    fn parallel_and_serial_builds_are_identical_and_valid() {
        // 3-D in place; 2-D and 8-D through their keys, the root read
        // from the input (and, at 20 points, a root that is a leaf).
        for n in [20, 5000] {
            parallel_and_serial_agree::<3>(n);
            parallel_and_serial_agree::<2>(n);
            parallel_and_serial_agree::<8>(n);
        }
    }

    #[test]
    fn signed_zeros_split_as_equals_and_every_point_is_found() {
        // -0 and +0 compare equal in the median selection: the tree must
        // still validate (every point on its side of each split plane).
        let pts: Vec<[f32; 3]> = (0..500)
            .map(|i| {
                let z = if i % 3 == 0 { -0.0 } else { 0.0 };
                [z, (i % 7) as f32, if i % 2 == 0 { -0.0 } else { 0.0 }]
            })
            .collect();
        let built = build_points(&pts, &PointParams::default()).unwrap();
        let tree = built.view().unwrap();
        for p in &pts {
            let n = tree.nearest(*p).unwrap();
            assert_eq!(n.d2, 0.0);
        }
    }

    /// The indices `partition` sends below on axis 0 of points whose
    /// first coordinates are `xs` (the rest 0), in the order `order`
    /// gives them, with the split.
    fn below_set<const D: usize>(xs: &[f32], order: usize) -> (Vec<u32>, f32) {
        let mut items: Vec<Item<D, f32>> = xs
            .iter()
            .enumerate()
            .map(|(i, &x)| Item {
                p: std::array::from_fn(|a| if a == 0 { x } else { 0.0 }),
                index: i as u32,
            })
            .collect();
        match order {
            1 => items.reverse(),
            2 => items.rotate_left(37),
            3 => items.sort_by(|a, b| b.p[0].total_cmp(&a.p[0])),
            _ => {}
        }
        let (split, mut ids) = if in_place::<D, f32>() {
            let mut run = InPlace(&mut items);
            let (mid, split) = run.partition(0, &mut ());
            (split, run.0[..mid].iter().map(|it| it.index).collect())
        } else {
            let mut p: Vec<[f32; D]> = items.iter().map(|it| it.p).collect();
            let mut index: Vec<u32> = items.iter().map(|it| it.index).collect();
            let (mut spare_p, mut spare_index) = (p.clone(), index.clone());
            let mut run = ByKeys {
                now: Columns {
                    p: &mut p,
                    index: &mut index,
                },
                spare: Columns {
                    p: &mut spare_p,
                    index: &mut spare_index,
                },
                now_is_final: true,
            };
            let (mid, split) = run.partition(0, &mut Default::default());
            (split, run.now.index[..mid].to_vec())
        };
        ids.sort_unstable();
        (ids, split)
    }

    #[test]
    fn which_points_go_below_depends_on_coordinates_and_indices_only() {
        // The median of the first set is below its largest coordinate;
        // in the second, two thirds of the points sit at the largest, so
        // ties split by index. 3-D points are selected where they lie,
        // 2-D and 8-D ones through their coordinates: all send the same
        // points.
        let mut rng = crate::rng::Rng::new(4);
        let lattice: Vec<f32> = (0..101).map(|_| rng.below(4) as f32).collect();
        let piled: Vec<f32> = (0..101)
            .map(|_| if rng.below(3) == 0 { rng.f32() } else { 1.0 })
            .collect();
        assert!(in_place::<3, f32>());
        assert!(!in_place::<2, f32>() && !in_place::<8, f32>());
        for xs in [lattice, piled] {
            let (ids, split) = below_set::<3>(&xs, 0);
            let at_or_below = xs.iter().filter(|&&x| x <= split).count();
            let expected = if at_or_below < xs.len() {
                at_or_below
            } else {
                50
            };
            assert_eq!(ids.len(), expected);
            for order in 0..4 {
                assert_eq!(below_set::<3>(&xs, order), (ids.clone(), split), "{order}");
                assert_eq!(below_set::<2>(&xs, order), (ids.clone(), split), "{order}");
                assert_eq!(below_set::<8>(&xs, order), (ids.clone(), split), "{order}");
            }
        }
    }

    /// The largest leaf of `built`.
    fn largest_leaf<const D: usize>(built: &BuiltPoints<D>) -> u32 {
        (built.nodes.iter())
            .filter_map(|n| match n.kind() {
                PointNodeKind::Leaf { count, .. } => Some(count),
                PointNodeKind::Interior { .. } => None,
            })
            .max()
            .unwrap_or(0)
    }

    #[test]
    fn the_default_leaf_size_follows_the_dimension_and_a_given_one_wins() {
        // Median splits leave leaves of m/2 to m points: at the default,
        // 3-D leaves reach past 16 and stop at 32, 8-D and 16-D ones
        // reach past 32 and stop at 64.
        let default = PointParams::default();
        let three = largest_leaf(&build_points(&lcg_points::<3>(5000, 7), &default).unwrap());
        assert!((17..=32).contains(&three), "3-D leaves of up to {three}");
        let eight = largest_leaf(&build_points(&lcg_points::<8>(5000, 7), &default).unwrap());
        assert!((33..=64).contains(&eight), "8-D leaves of up to {eight}");
        let sixteen = largest_leaf(&build_points(&lcg_points::<16>(5000, 7), &default).unwrap());
        assert!(
            (33..=64).contains(&sixteen),
            "16-D leaves of up to {sixteen}"
        );
        let given = PointParams {
            leaf_size: Some(32),
            ..PointParams::default()
        };
        let eight = largest_leaf(&build_points(&lcg_points::<8>(5000, 7), &given).unwrap());
        assert!(
            (17..=32).contains(&eight),
            "8-D leaves of up to {eight} at m = 32"
        );
    }

    #[test]
    fn nan_points_are_rejected_by_index() {
        let mut pts = lcg_points::<3>(10, 1);
        pts[7][1] = f32::NAN;
        let e = build_points(&pts, &PointParams::default()).unwrap_err();
        assert!(matches!(e, PointBuildError::NonFinite { point: 7, .. }));
        assert!(e.to_string().contains("point 7"));
    }

    #[test]
    fn a_pile_is_one_leaf_and_empty_sets_build() {
        let pile = vec![[1.0f32, 2.0, 3.0]; 1000];
        let t = build_points(&pile, &PointParams::default()).unwrap();
        assert_eq!(t.nodes.len(), 1);
        assert!(t.view().is_ok());
        let empty = build_points::<3, f32>(&[], &PointParams::default()).unwrap();
        assert!(empty.view().is_ok());
    }
}
