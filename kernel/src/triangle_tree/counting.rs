//! The single-ray queries that also count their work, for heatmaps and
//! tuning: one wrapper, not a counted twin of every query.

use super::counts::TraversalCounts;
use super::walk::STACK;
use super::TriangleTree;
use crate::geometry::{Hit, Ray};

/// A tree whose queries also count the nodes visited and the triangles
/// tested ([`TriangleTree::counting`]); the answers are the tree's own,
/// a little slower.
#[derive(Clone, Copy, Debug)]
pub struct Counting<'t, 'a>(&'t TriangleTree<'a>);

impl<'a> TriangleTree<'a> {
    /// This tree's queries, counting their work.
    ///
    /// # Example
    /// ```
    /// use glam::Vec3;
    /// use kdray_kernel::{Ray, TriangleTree};
    /// static CUBE: &kdray_kernel::Aligned<[u8]> =
    ///     kdray_kernel::include_aligned!("../../golden/cube-v3.kdt");
    /// let tree = TriangleTree::from_bytes(&CUBE.bytes)?;
    /// let ray = Ray::new(Vec3::new(0.3, 0.6, -1.0), Vec3::Z);
    /// let (hit, counts) = tree.counting().closest_hit(&ray);
    /// assert_eq!(hit, tree.closest_hit(&ray));
    /// assert!(counts.nodes > 0 && counts.triangles > 0);
    /// # Ok::<(), kdray_kernel::BlobError>(())
    /// ```
    #[must_use]
    pub fn counting(&self) -> Counting<'_, 'a> {
        Counting(self)
    }
}

impl Counting<'_, '_> {
    /// [`TriangleTree::closest_hit`] and its work.
    #[must_use]
    pub fn closest_hit(&self, ray: &Ray) -> (Hit, TraversalCounts) {
        let mut counts = TraversalCounts::default();
        let hit = self.0.closest_hit_tallied::<_, STACK>(ray, &mut counts);
        (hit, counts)
    }

    /// [`TriangleTree::any_hit`] and its work.
    #[must_use]
    pub fn any_hit(&self, ray: &Ray) -> (bool, TraversalCounts) {
        let mut counts = TraversalCounts::default();
        let hit = self.0.any_hit_tallied::<_, STACK>(ray, &mut counts);
        (hit, counts)
    }
}
