//! Who answers the renderer's rays: the tree (single rays or packets) or
//! brute force over every triangle (the oracle the tests render with).

use kdray_kernel::{
    any_hit_brute, closest_hit_brute, Batch, Hit, PacketWidth, Ray, Triangle, TriangleTree,
};

/// Answers batches of rays (one tile's worth, traced as one packet when
/// the width allows).
pub trait Tracer: Sync {
    /// The triangles hits index into.
    fn triangles(&self) -> &[Triangle];
    /// The packet width tiles are sized for.
    fn packet_width(&self) -> PacketWidth;
    /// The closest hit of each ray.
    fn closest(&self, rays: &[Ray], hits: &mut [Hit]);
    /// Whether each ray hits anything.
    fn occluded(&self, rays: &[Ray], out: &mut [bool]);
}

/// The tree, traced with packets of `width` consecutive rays.
#[derive(Clone, Copy, Debug)]
pub struct TreeTracer<'t, 'a> {
    /// The tree.
    pub tree: &'t TriangleTree<'a>,
    /// Rays per packet.
    pub width: PacketWidth,
}

impl Tracer for TreeTracer<'_, '_> {
    fn triangles(&self) -> &[Triangle] {
        self.tree.triangles()
    }
    fn packet_width(&self) -> PacketWidth {
        self.width
    }
    fn closest(&self, rays: &[Ray], hits: &mut [Hit]) {
        self.tree.closest_hits(
            rays,
            hits,
            Batch {
                width: Some(self.width),
                ..Batch::default()
            },
        );
    }
    fn occluded(&self, rays: &[Ray], out: &mut [bool]) {
        self.tree.any_hits(
            rays,
            out,
            Batch {
                width: Some(self.width),
                ..Batch::default()
            },
        );
    }
}

/// Every ray tested against every triangle.
#[derive(Clone, Copy, Debug)]
pub struct BruteTracer<'a>(pub &'a [Triangle]);

impl Tracer for BruteTracer<'_> {
    fn triangles(&self) -> &[Triangle] {
        self.0
    }
    fn packet_width(&self) -> PacketWidth {
        PacketWidth::One
    }
    fn closest(&self, rays: &[Ray], hits: &mut [Hit]) {
        for (h, r) in hits.iter_mut().zip(rays) {
            *h = closest_hit_brute(self.0, r);
        }
    }
    fn occluded(&self, rays: &[Ray], out: &mut [bool]) {
        for (o, r) in out.iter_mut().zip(rays) {
            *o = any_hit_brute(self.0, r);
        }
    }
}
