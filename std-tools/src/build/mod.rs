//! Tree builders: triangles in, nodes and primitive runs out, in the
//! kernel's depth-first layout.
//!
//! Every builder produces a [`BuildNode`] tree; [`layout::flatten`] turns
//! it into kernel [`Node`]s (one definition of the layout). A primitive is
//! referenced by every leaf whose closed cell its (clipped) box overlaps, so
//! the traversal finds every hit.

mod aabb;
pub mod layout;
mod sah;

pub use aabb::Aabb;
pub use layout::{flatten, BuildNode};

use kdray_kernel::{Bounds, Node, Triangle, MAX_DEPTH};
use std::fmt;

/// The cost model and limits, with the defaults documented per field.
#[derive(Clone, Debug, PartialEq)]
pub struct BuildParams {
    /// Cost of one traversal step (C_trav). Default 1.0.
    pub traversal_cost: f32,
    /// Cost of one ray/triangle test (C_isect). Default 1.5: measured, a
    /// triangle test costs about 1.5 traversal steps in this kernel.
    pub intersection_cost: f32,
    /// Fraction of the cost forgiven when one side of a split is empty
    /// (the lecture's "big empty cells"). Default 0.2.
    pub empty_bonus: f32,
    /// Deepest leaf allowed; `None` picks `8 + 1.3 log2(n)` (PBRT's rule),
    /// at most [`MAX_DEPTH`], which also caps any value given.
    pub max_depth: Option<u32>,
}

impl Default for BuildParams {
    fn default() -> Self {
        BuildParams {
            traversal_cost: 1.0,
            intersection_cost: 1.5,
            empty_bonus: 0.2,
            max_depth: None,
        }
    }
}

impl BuildParams {
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
    /// Full SAH over every box-edge candidate plane (the default).
    #[default]
    Sah,
}

impl BuilderKind {
    /// All builders, for tables and tests.
    pub const ALL: [BuilderKind; 1] = [BuilderKind::Sah];

    /// The name used on the command line.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            BuilderKind::Sah => "sah",
        }
    }

    /// The builder called `name`.
    #[must_use]
    pub fn from_name(name: &str) -> Option<BuilderKind> {
        Self::ALL.into_iter().find(|b| b.name() == name)
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
    /// More triangles than a node's 30-bit fields can count.
    TooManyTriangles {
        /// How many there are.
        count: usize,
    },
}

impl fmt::Display for BuildError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            BuildError::NonFinite { triangle } => {
                write!(f, "triangle {triangle} has a non-finite vertex coordinate")
            }
            BuildError::TooManyTriangles { count } => write!(
                f,
                "{count} triangles is more than a tree can index ({})",
                kdray_kernel::node::MAX_NODE_FIELD
            ),
        }
    }
}

impl std::error::Error for BuildError {}

/// Builds a tree over `triangles` with `kind`.
///
/// # Errors
/// [`BuildError`] for non-finite triangles or too many of them.
pub fn build(
    triangles: &[Triangle],
    kind: BuilderKind,
    params: &BuildParams,
) -> Result<BuiltTree, BuildError> {
    if let Some(triangle) = triangles.iter().position(|t| !t.is_finite()) {
        return Err(BuildError::NonFinite { triangle });
    }
    if triangles.len() > kdray_kernel::node::MAX_NODE_FIELD as usize {
        return Err(BuildError::TooManyTriangles {
            count: triangles.len(),
        });
    }
    let boxes: Vec<Aabb> = triangles.iter().map(Aabb::of_triangle).collect();
    let bounds = boxes.iter().fold(Aabb::EMPTY, |a, b| a.union(b));
    let bounds = if triangles.is_empty() {
        Aabb::ZERO
    } else {
        bounds
    };
    let root = match kind {
        BuilderKind::Sah => sah::build(&boxes, bounds, params),
    };
    Ok(flatten(&root, bounds.to_bounds()))
}
