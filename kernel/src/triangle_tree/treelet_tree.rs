//! A triangle tree with its treelets: the same questions as
//! [`TriangleTree`], its batches walking scattered rays 7 split planes a
//! vector step (`treelets.rs`).

use super::{Batch, PacketLanes, TriangleTree};
use crate::geometry::{Hit, Ray};
use crate::triangle_tree::packet::Packet;

/// A [`TriangleTree`] with its treelets, from
/// [`TriangleTree::treelets_into`]: the same queries with the same answers
/// bit for bit. Only its batch calls differ: blocks of scattered rays
/// (bounces, random rays) walk the treelets, four rays in turns, on a
/// processor with AVX2. Cheap to copy; it borrows the blob and the
/// treelets.
#[derive(Clone, Copy, Debug)]
pub struct TreeletTree<'a> {
    /// The tree with its `lines` set: kept inside, so a plain
    /// [`TriangleTree`] never walks treelets.
    lined: TriangleTree<'a>,
}

impl<'a> TreeletTree<'a> {
    /// `lined`, a tree whose `lines` hold its treelets.
    pub(super) const fn new(lined: TriangleTree<'a>) -> TreeletTree<'a> {
        TreeletTree { lined }
    }

    /// The tree without its treelets (for everything else it answers:
    /// statistics, first hits, the sections).
    #[must_use]
    pub fn tree(&self) -> TriangleTree<'a> {
        TriangleTree {
            lines: &[],
            ..self.lined
        }
    }

    /// The view the C API keeps in its handle: a tree whose batch calls
    /// walk these treelets. Not for Rust callers, who keep the
    /// `TreeletTree`.
    #[doc(hidden)]
    #[must_use]
    pub fn lined_view(&self) -> TriangleTree<'a> {
        self.lined
    }

    /// [`TriangleTree::closest_hit`].
    #[inline]
    #[must_use]
    pub fn closest_hit(&self, ray: &Ray) -> Hit {
        self.lined.closest_hit(ray)
    }

    /// [`TriangleTree::any_hit`].
    #[inline]
    #[must_use]
    pub fn any_hit(&self, ray: &Ray) -> bool {
        self.lined.any_hit(ray)
    }

    /// [`TriangleTree::first_hits`].
    pub fn first_hits(&self, ray: &Ray, out: &mut [Hit]) -> usize {
        self.lined.first_hits(ray, out)
    }

    /// [`TriangleTree::closest_hit_packet`].
    #[inline]
    #[must_use]
    pub fn closest_hit_packet<const N: usize>(&self, packet: &Packet<N>) -> [Hit; N]
    where
        Packet<N>: PacketLanes<N>,
    {
        self.lined.closest_hit_packet(packet)
    }

    /// [`TriangleTree::any_hit_packet`].
    #[inline]
    #[must_use]
    pub fn any_hit_packet<const N: usize>(&self, packet: &Packet<N>) -> [bool; N]
    where
        Packet<N>: PacketLanes<N>,
    {
        self.lined.any_hit_packet(packet)
    }

    /// [`TriangleTree::closest_hits`], blocks of scattered rays through
    /// the treelets.
    pub fn closest_hits(&self, rays: &[Ray], hits: &mut [Hit], batch: Batch<'_>) {
        self.lined.closest_hits(rays, hits, batch);
    }

    /// [`TriangleTree::any_hits`] (any hit walks back to front, without
    /// the treelets).
    pub fn any_hits(&self, rays: &[Ray], occluded: &mut [bool], batch: Batch<'_>) {
        self.lined.any_hits(rays, occluded, batch);
    }
}

/// The batch calls of a triangle tree in either layout, [`TriangleTree`]
/// and [`TreeletTree`]: for code that traces batches through whichever it
/// is given (as `kdray_tools::trace` does). Each method is the type's own.
pub trait TraceBatch: Sync {
    /// [`TriangleTree::closest_hits`].
    fn closest_hits(&self, rays: &[Ray], hits: &mut [Hit], batch: Batch<'_>);
    /// [`TriangleTree::any_hits`].
    fn any_hits(&self, rays: &[Ray], occluded: &mut [bool], batch: Batch<'_>);
    /// The tree, for the questions about it rather than its rays
    /// ([`TriangleTree::rays_scattered`], the sections).
    fn tree(&self) -> TriangleTree<'_>;
}

impl TraceBatch for TriangleTree<'_> {
    fn closest_hits(&self, rays: &[Ray], hits: &mut [Hit], batch: Batch<'_>) {
        TriangleTree::closest_hits(self, rays, hits, batch);
    }
    fn any_hits(&self, rays: &[Ray], occluded: &mut [bool], batch: Batch<'_>) {
        TriangleTree::any_hits(self, rays, occluded, batch);
    }
    fn tree(&self) -> TriangleTree<'_> {
        *self
    }
}

impl TraceBatch for TreeletTree<'_> {
    fn closest_hits(&self, rays: &[Ray], hits: &mut [Hit], batch: Batch<'_>) {
        TreeletTree::closest_hits(self, rays, hits, batch);
    }
    fn any_hits(&self, rays: &[Ray], occluded: &mut [bool], batch: Batch<'_>) {
        TreeletTree::any_hits(self, rays, occluded, batch);
    }
    fn tree(&self) -> TriangleTree<'_> {
        TreeletTree::tree(self)
    }
}
