//! A triangle tree no deeper than a compile-time bound, walked on a stack
//! of that many entries: the single-ray queries for a fixed stack budget.

use super::TriangleTree;
use crate::blob::BlobError;
use crate::geometry::{Hit, Ray};

/// A [`TriangleTree`] whose depth is at most `DEPTH`, so that a single
/// ray's walk keeps at most `DEPTH` pending far cells (one per level):
/// [`ShallowTree::closest_hit`] and [`ShallowTree::any_hit`] answer as
/// the tree's own queries, bit for bit, on a stack of `DEPTH` entries of
/// 12 bytes instead of [`MAX_DEPTH`](crate::MAX_DEPTH)'s 64.
///
/// For firmware with a fixed stack budget: build the blob with a depth
/// limit (`kdray build --max-depth 24`; the default limit of
/// `8 + 1.3 log2 n` is 24 up to about 5,000 triangles), check it once at
/// boot with [`ShallowTree::new`], and the bound holds for every ray. The
/// figures for `DEPTH = 24` on `thumbv7em` are in the README's firmware
/// section.
///
/// # Example
/// ```
/// use glam::Vec3;
/// use kdray_kernel::{Ray, ShallowTree, TriangleTree};
/// static CUBE: &kdray_kernel::Aligned<[u8]> =
///     kdray_kernel::include_aligned!("../../golden/cube-v3.kdt");
/// let tree = TriangleTree::from_bytes(&CUBE.bytes)?;
///
/// let shallow = ShallowTree::<24>::new(tree)?;
/// let ray = Ray::new(Vec3::new(0.3, 0.6, -1.0), Vec3::Z);
/// assert_eq!(shallow.closest_hit(&ray).bits(), tree.closest_hit(&ray).bits());
/// assert_eq!(shallow.any_hit(&ray), tree.any_hit(&ray));
///
/// // The cube is one leaf, depth 0: no stack at all walks it.
/// assert_eq!(tree.max_depth(), 0);
/// assert!(ShallowTree::<0>::new(tree)?.any_hit(&ray));
/// # Ok::<(), kdray_kernel::BlobError>(())
/// ```
#[derive(Clone, Copy, Debug)]
pub struct ShallowTree<'a, const DEPTH: usize> {
    tree: TriangleTree<'a>,
}

impl<'a, const DEPTH: usize> ShallowTree<'a, DEPTH> {
    /// `tree`, if its depth ([`TriangleTree::max_depth`]) is at most
    /// `DEPTH`. For a tree loaded without the structural check that depth
    /// is the header's word; a tree deeper than it ends a walk where the
    /// stack has no room (a wrong answer for an invalid blob, never a
    /// fault), as [`MAX_DEPTH`](crate::MAX_DEPTH) does for the tree's own
    /// queries.
    ///
    /// # Errors
    /// [`BlobError::DeeperThanStack`] for a deeper tree, which says both
    /// depths and how to rebuild the blob.
    pub fn new(tree: TriangleTree<'a>) -> Result<Self, BlobError> {
        let depth = tree.max_depth();
        if depth as usize > DEPTH {
            return Err(BlobError::DeeperThanStack {
                depth,
                stack: u32::try_from(DEPTH).unwrap_or(u32::MAX),
            });
        }
        Ok(Self { tree })
    }

    /// The tree, for everything else (packets, streams, statistics).
    #[must_use]
    pub fn tree(&self) -> &TriangleTree<'a> {
        &self.tree
    }

    /// [`TriangleTree::closest_hit`], on a `DEPTH`-entry stack.
    ///
    /// # Panics
    /// Never.
    #[inline]
    #[must_use]
    pub fn closest_hit(&self, ray: &Ray) -> Hit {
        self.tree.closest_hit_tallied::<_, DEPTH>(ray, &mut ())
    }

    /// [`TriangleTree::any_hit`], on a `DEPTH`-entry stack.
    ///
    /// # Panics
    /// Never.
    #[inline]
    #[must_use]
    pub fn any_hit(&self, ray: &Ray) -> bool {
        self.tree.any_hit_tallied::<_, DEPTH>(ray, &mut ())
    }

    /// [`TriangleTree::first_hits`], on a `DEPTH`-entry stack.
    ///
    /// # Panics
    /// Never.
    #[inline]
    #[must_use]
    pub fn first_hits(&self, ray: &Ray, out: &mut [Hit]) -> usize {
        self.tree.first_hits_within::<DEPTH>(ray, out)
    }
}
