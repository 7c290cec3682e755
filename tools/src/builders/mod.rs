//! Tree builders: triangles in, nodes and primitive runs out, in the
//! kernel's depth-first layout.
//!
//! Every builder produces a [`BuildNode`] tree through the shared
//! recursion (`subdivide`); [`layout::flatten`] turns it into kernel
//! [`Node`]s (one definition of the layout). Every point of a triangle lies
//! in the closed cell of some leaf that references it, so the traversal
//! finds every hit.
//!
//! | builder | split plane | trees | use |
//! |---|---|---|---|
//! | [`BuilderKind::Sah`] | SAH with perfect splits: min-max binning (256 bins) down to cells of 16 triangles, every clipped box edge priced exactly below (`sah`, `small`, `clip`) | the best | the default |
//! | [`BuilderKind::Sweep`] | exact SAH with perfect splits: Wald & Havran's O(N log N) event sweep below 4096 triangles, binning above (`sah`, `events`, `small`, `clip`) | as good, slower to build | the reference |
//! | [`BuilderKind::Binned`] | SAH at 32 bin boundaries and the boxes' extremes; a split only where it saves a tenth of the leaf's cost; straddlers cut by the plane (`binned`, `boxes`) | a few % dearer, ~3x faster to build | rebuilds |
//! | [`BuilderKind::Fast`] | SAH at 16 bin boundaries on the longest axis, boxes never clipped, one flat array partitioned in place (`fast`) | dearer, ~15x faster to build than `middle` | deforming meshes, rebuilt every frame |
//! | [`BuilderKind::Median`] | median of the box centres, widest axis (`median`, `boxes`) | - | baseline |
//! | [`BuilderKind::Middle`] | middle of the cell, widest axis (`median`, `boxes`) | - | baseline |
//!
//! Measured trees and build times: `docs/results.md`; the tuning
//! thresholds, with what each alternative measured: `thresholds.rs`.

mod binned;
mod boxes;
mod clip;
mod cost;
mod events;
pub mod fast;
mod item;
pub mod kept;
pub mod layout;
mod median;
mod monitor;
pub mod refill;
mod sah;
mod small;
mod subdivide;
mod thresholds;

pub use cost::CostModel;
pub use layout::{flatten, BuildNode, Split};
pub use monitor::BuildMonitor;

use kdray_kernel::{Bounds, Node, Triangle, MAX_DEPTH};
use std::fmt;
use thresholds::{CUT_MIN, FAST_BINS, FAST_LEAF_SIZE, SWEEP_MAX, SWEEP_NONE};

/// The cost model and limits, with the defaults documented per field.
#[derive(Clone, Debug, PartialEq)]
pub struct BuildParams {
    /// Cost of one traversal step (C_trav). Default 1.0.
    pub traversal_cost: f32,
    /// Cost of one ray/triangle test (C_isect). Default 0.5: against 1.5,
    /// a tree of a third of the nodes that traces camera rays as fast and
    /// random rays faster (the smaller tree misses the cache less); lower
    /// still (0.25) trades more triangle tests for little gain. Tried 0.35
    /// for fewer references per triangle (bunny 3.31 -> 2.82): shadow rays
    /// 4% more instructions and 9% more L1 misses, from 24.2 triangle
    /// tests per ray instead of 19.4.
    pub intersection_cost: f32,
    /// Fraction of the cost forgiven when one side of a split is empty
    /// (the lecture's "big empty cells"). Default 0.2. Tried 0: bunny
    /// shadow rays 10% fewer nodes but 15% more triangle tests, 1% more
    /// instructions and 6% more L1 misses.
    pub empty_bonus: f32,
    /// Deepest leaf allowed; `None` picks `8 + 1.3 log2(n)` (PBRT's rule),
    /// at most [`MAX_DEPTH`], which also caps any value given.
    pub max_depth: Option<u32>,
    /// How many splits in a row may cost more than a leaf, in the hope that
    /// the splits below them pay; subtrees that end up costing more than a
    /// leaf are collapsed. Default 1: each level of look-ahead multiplies the work near the leaves.
    /// The binned builder, made for fast rebuilds, never looks ahead: it
    /// splits only where a split saves a tenth of the leaf's cost.
    pub lookahead: u32,
    /// How much dearer than a leaf a split may be and still be looked
    /// ahead of, as a factor of the leaf's cost. Default 1.05: look-ahead
    /// splits dearer than that paid off less than one time in a hundred
    /// (bunny, sponza), yet were most of the subtrees built and thrown away.
    pub lookahead_margin: f32,
    /// Cells whose largest extent is below this fraction of the scene's are
    /// leaves. Default 2^-20: far below any useful cell, well above the
    /// scale where planes run out of distinct `f32` positions.
    pub min_cell_fraction: f32,
    /// Bins per axis of the binned builder (at most 256). Default 32.
    pub bins: usize,
    /// Leaf size of the median and middle baselines. Default 2.
    pub baseline_leaf_size: usize,
    /// Worker threads; `None` builds on the caller's rayon pool (all cores
    /// by default). The tree is the same for any count.
    pub threads: Option<usize>,
}

impl Default for BuildParams {
    fn default() -> Self {
        BuildParams {
            traversal_cost: 1.0,
            intersection_cost: 0.5,
            empty_bonus: 0.2,
            max_depth: None,
            lookahead: 1,
            lookahead_margin: 1.05,
            min_cell_fraction: 1.0 / 1_048_576.0,
            bins: 32,
            baseline_leaf_size: 2,
            threads: None,
        }
    }
}

impl BuildParams {
    /// Refuses what no build can use: a traversal or intersection cost
    /// that is not a positive number, an empty bonus outside [0, 1), a
    /// depth limit past [`MAX_DEPTH`] (the deepest tree the kernel's
    /// traversal stack holds) and more than
    /// [`crate::threads::MAX_THREADS`] threads. `name` spells a field
    /// (`"max_depth"`) as the caller's user does (`--max-depth`).
    ///
    /// # Errors
    /// The first field at fault, named, with its value.
    pub fn check(&self, name: impl Fn(&str) -> String) -> Result<(), String> {
        for (field, v) in [
            ("traversal_cost", self.traversal_cost),
            ("intersection_cost", self.intersection_cost),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!(
                    "{} must be a positive number, not {v}",
                    name(field)
                ));
            }
        }
        if !(0.0..1.0).contains(&self.empty_bonus) {
            return Err(format!(
                "{} must be in [0, 1), not {}",
                name("empty_bonus"),
                self.empty_bonus
            ));
        }
        if let Some(d) = self.max_depth.filter(|&d| d > MAX_DEPTH) {
            return Err(format!(
                "{} {d} is more than {MAX_DEPTH}, the deepest tree the kernel's traversal stack holds",
                name("max_depth")
            ));
        }
        self.threads
            .map_or(Ok(()), |n| crate::threads::check_count(&name("threads"), n))
    }

    /// The depth limit for `n` triangles.
    #[must_use]
    pub fn depth_limit(&self, n: usize) -> u32 {
        let auto = || (8.0 + 1.3 * (n.max(1) as f64).log2()).round() as u32;
        self.max_depth.unwrap_or_else(auto).min(MAX_DEPTH)
    }
}

/// Which builder.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum BuilderKind {
    /// SAH with perfect splits (the default): min-max binning with 256
    /// bins down to cells of 16 triangles, every clipped box edge priced
    /// below. Trees as good as [`Sweep`](BuilderKind::Sweep)'s, in about
    /// 60% of its build time.
    #[default]
    Sah,
    /// Exact SAH over every clipped box edge: Wald & Havran's O(N log N)
    /// event sweep (binned above 4096 triangles), the reference.
    Sweep,
    /// SAH over bin boundaries: faster builds, slightly worse trees.
    Binned,
    /// SAH at a few bin boundaries on the longest axis over unclipped
    /// triangle boxes, one thread ([`fast`]): for meshes rebuilt every
    /// frame.
    Fast,
    /// Median of the box centres on the widest axis (a baseline).
    Median,
    /// Middle of the cell on the widest axis (a baseline).
    Middle,
}

impl BuilderKind {
    /// All builders, for tables and tests.
    pub const ALL: [BuilderKind; 6] = [
        BuilderKind::Sah,
        BuilderKind::Sweep,
        BuilderKind::Binned,
        BuilderKind::Fast,
        BuilderKind::Median,
        BuilderKind::Middle,
    ];

    /// The name used on the command line.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            BuilderKind::Sah => "sah",
            BuilderKind::Sweep => "sweep",
            BuilderKind::Binned => "binned",
            BuilderKind::Fast => "fast",
            BuilderKind::Median => "median",
            BuilderKind::Middle => "middle",
        }
    }

    /// The builder called `name`.
    #[must_use]
    pub fn from_name(name: &str) -> Option<BuilderKind> {
        Self::ALL.into_iter().find(|b| b.name() == name)
    }

    /// The builder called `name`, or a message naming the builders.
    pub fn parse(name: &str) -> Result<BuilderKind, String> {
        Self::from_name(name).ok_or_else(|| {
            let names = Self::ALL.map(BuilderKind::name).join(", ");
            format!("unknown builder '{name}' (expected one of {names})")
        })
    }
}

/// A built tree: the kernel's nodes and primitive indices, the scene
/// bounds and the depth of the deepest node.
#[derive(Clone, Debug, PartialEq)]
pub struct BuiltTree {
    /// Nodes in the kernel's depth-first layout.
    pub nodes: Vec<Node>,
    /// Primitive runs of leaves with several primitives.
    pub prims: Vec<u32>,
    /// The root cell.
    pub bounds: Bounds,
    /// The depth of the deepest node.
    pub max_depth: u32,
}

/// Why a build failed.
#[derive(Debug, Clone, PartialEq)]
pub enum BuildError {
    /// A triangle with a NaN or infinite coordinate.
    NonFinite {
        /// The triangle's index.
        triangle: usize,
    },
    /// A triangle with a vertex coordinate beyond the kernel's range,
    /// `±`[`kdray_kernel::MAX_COORD`].
    OutOfRange {
        /// The triangle's index.
        triangle: usize,
        /// The offending coordinate.
        coordinate: f32,
    },
    /// More triangles than a node's 30-bit fields can count.
    TooManyTriangles {
        /// How many there are.
        count: usize,
    },
    /// The worker threads could not be started.
    Threads {
        /// What rayon said.
        message: String,
    },
}

impl fmt::Display for BuildError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            BuildError::NonFinite { triangle } => {
                write!(f, "triangle {triangle} has a non-finite vertex coordinate")
            }
            BuildError::OutOfRange {
                triangle,
                coordinate,
            } => write!(
                f,
                "triangle {triangle} has a vertex coordinate {coordinate:e} beyond the \
                 kernel's range of ±{:e} (kdray_kernel::MAX_COORD)",
                kdray_kernel::MAX_COORD
            ),
            BuildError::TooManyTriangles { count } => write!(
                f,
                "{count} triangles is more than a tree can index ({})",
                kdray_kernel::format::node::MAX_NODE_FIELD
            ),
            BuildError::Threads { message } => {
                write!(f, "cannot start the build threads: {message}")
            }
        }
    }
}

impl std::error::Error for BuildError {}

/// Builds a tree over `triangles` with `kind`.
///
/// # Errors
/// [`BuildError`] for non-finite triangles, triangles beyond
/// [`kdray_kernel::MAX_COORD`] or too many of them.
pub fn build(
    triangles: &[Triangle],
    kind: BuilderKind,
    params: &BuildParams,
) -> Result<BuiltTree, BuildError> {
    build_monitored(triangles, kind, params, &BuildMonitor::new())
}

/// [`build`], reporting progress and working memory to `monitor`, which
/// another thread may read while the build runs.
///
/// # Errors
/// [`BuildError`] for non-finite triangles, triangles beyond
/// [`kdray_kernel::MAX_COORD`] or too many of them, or when
/// the thread pool cannot start.
pub fn build_monitored(
    triangles: &[Triangle],
    kind: BuilderKind,
    params: &BuildParams,
    monitor: &BuildMonitor,
) -> Result<BuiltTree, BuildError> {
    check_triangles(triangles)?;
    // No thread count: build on the caller's rayon pool (the global one,
    // or whichever the caller installed), so repeated builds start no
    // threads. A count: a pool of that size for this build.
    let Some(threads) = params.threads else {
        return Ok(build_in_pool(triangles, kind, params, monitor));
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| BuildError::Threads {
            message: e.to_string(),
        })?;
    Ok(pool.install(|| build_in_pool(triangles, kind, params, monitor)))
}

/// The mesh checks every builder makes: finite triangles within
/// [`kdray_kernel::MAX_COORD`], few enough for the node's index field.
///
/// # Errors
/// The first [`BuildError`] found.
pub(crate) fn check_triangles(triangles: &[Triangle]) -> Result<(), BuildError> {
    // One pass without a branch per coordinate (a NaN fails the compare,
    // so in range is finite too); the error's details only on failure.
    let in_range = |t: &Triangle| {
        t.v.iter()
            .flatten()
            .fold(true, |ok, c| ok & (c.abs() <= kdray_kernel::MAX_COORD))
    };
    let all_in_range = triangles.iter().fold(true, |ok, t| ok & in_range(t));
    if triangles.len() <= kdray_kernel::format::node::MAX_NODE_FIELD as usize && all_in_range {
        return Ok(());
    }
    if let Some(triangle) = triangles.iter().position(|t| !t.is_finite()) {
        return Err(BuildError::NonFinite { triangle });
    }
    if let Some(triangle) = triangles.iter().position(|t| !t.in_range()) {
        let coordinate = triangles[triangle]
            .v
            .iter()
            .flatten()
            .copied()
            .fold(0.0f32, |m, c| if c.abs() > m.abs() { c } else { m });
        return Err(BuildError::OutOfRange {
            triangle,
            coordinate,
        });
    }
    if triangles.len() > kdray_kernel::format::node::MAX_NODE_FIELD as usize {
        return Err(BuildError::TooManyTriangles {
            count: triangles.len(),
        });
    }
    Ok(())
}

/// Each triangle's [`Triangle::hit_bounds`]: every builder lists
/// triangles by these (the clipping ones then clip with the same margin),
/// so that the walk finds every hit brute force takes, including a
/// sliver's past its short end, where its `f32` edge test passes by
/// rounding. The margin is `2^-18` of the coordinates: planes rarely fall
/// inside it.
pub(crate) fn hit_boxes(triangles: &[Triangle]) -> Vec<Bounds> {
    triangles.iter().map(Triangle::hit_bounds).collect()
}

fn build_in_pool(
    triangles: &[Triangle],
    kind: BuilderKind,
    params: &BuildParams,
    monitor: &BuildMonitor,
) -> BuiltTree {
    use rayon::prelude::*;
    // The root cell holds the triangles; every builder lists each one by
    // the box its hits lie in (`hit_boxes`).
    let bounds = if triangles.is_empty() {
        Bounds::ZERO
    } else {
        triangles
            .par_iter()
            .map(Triangle::bounds)
            .reduce(|| Bounds::EMPTY, |a, b| a.union(&b))
    };
    let hit = hit_boxes(triangles);
    let extent = (0..3).fold(0.0f32, |m, a| m.max(bounds.max[a] - bounds.min[a]));
    let cost = CostModel::from_params(params);
    let limits = subdivide::Limits {
        cost,
        depth: params.depth_limit(triangles.len()),
        min_extent: extent * params.min_cell_fraction,
        lookahead: params.lookahead,
        lookahead_margin: f64::from(params.lookahead_margin),
    };
    let root = match kind {
        BuilderKind::Fast => {
            let p = fast::FastParams {
                cost,
                bins: FAST_BINS,
                leaf_size: FAST_LEAF_SIZE,
                depth: limits.depth,
                shrink_bins: true,
            };
            return fast::build_monitored(&hit, bounds, &p, monitor);
        }
        BuilderKind::Sah | BuilderKind::Sweep => {
            let sweep_max = if kind == BuilderKind::Sah {
                SWEEP_NONE
            } else {
                SWEEP_MAX
            };
            let s = sah::EventSah {
                triangles,
                cost,
                sweep_max,
            };
            // The hit boxes within the root cell, then clipped with the
            // triangle test's margin (`clip`), so a hit the `f32` test
            // accepts a rounding off the triangle is in a cell that lists it.
            let within: Vec<Bounds> = hit.iter().map(|h| h.intersect(&bounds)).collect();
            let set = s.root(&within);
            subdivide::subdivide(&s, set, bounds, &limits, monitor)
        }
        BuilderKind::Binned | BuilderKind::Median | BuilderKind::Middle => {
            let leaf = params.baseline_leaf_size;
            let rule = match kind {
                BuilderKind::Binned => boxes::Rule::Binned(params.bins),
                BuilderKind::Median => boxes::Rule::Median(leaf),
                _ => boxes::Rule::Middle(leaf),
            };
            let straddlers = (kind == BuilderKind::Binned).then_some(boxes::Straddlers {
                triangles,
                cut_min: CUT_MIN,
            });
            let s = boxes::BoxSplitter {
                rule,
                cost,
                straddlers,
            };
            // The binned builder then cuts each box at each plane.
            let set = boxes::BoxSplitter::root(&hit);
            subdivide::subdivide(&s, set, bounds, &limits, monitor)
        }
    };
    flatten(root, bounds)
}
