//! The first hits along a ray through the tree: the walk of the closest
//! hit, every triangle of a leaf offered to the sorted buffer
//! ([`FirstHits`]), cells behind its last hit skipped once it is full.

use super::cell_ray::CellRay;
use super::counts::Tally;
use super::walk::{LeafIter, Visit, STACK};
use super::TriangleTree;
use crate::geometry::{Hit, Ray};
use crate::triangle::{dominant_axis, FirstHits, Ranked, ShearedRay, Triangle};

/// The first-hits search: every triangle of a leaf against `[tmin, the
/// buffer's bound]`, its hits tagged `tag` (a scene's instance).
struct FirstVisit<'r, 'o, R, const CROSSING: bool> {
    sr: &'r ShearedRay,
    tmin: f32,
    tmax: f32,
    tag: u32,
    first: &'r mut FirstHits<'o, R>,
}

impl<'a, T: Tally, R: Ranked, const CROSSING: bool> Visit<'a, T>
    for FirstVisit<'_, '_, R, CROSSING>
{
    #[inline(always)]
    fn bound(&self) -> f32 {
        self.first.bound(self.tmax)
    }

    #[inline(always)]
    fn leaf(&mut self, tris: &'a [Triangle], prims: LeafIter<'a>, tally: &mut T) -> bool {
        for p in prims {
            if let Some(tri) = tris.get(p as usize) {
                tally.triangles(1);
                self.first
                    .offer_by::<CROSSING>(self.sr, tri, (p, self.tag), self.tmin, self.tmax);
            }
        }
        false
    }
}

impl TriangleTree<'_> {
    /// The first `out.len()` hits of `ray` in `[tmin, tmax]`, sorted by
    /// `t` and at equal `t` by the lower triangle index, each triangle
    /// once, written to the front of `out`; returns how many. Exactly
    /// [`first_hits_brute`](crate::first_hits_brute) over all triangles;
    /// the first of them is [`TriangleTree::closest_hit`]. For
    /// transparency (the surfaces in front of the first opaque one),
    /// counting crossings, or every hit along a line of sight (a buffer as
    /// long as the ray can meet triangles). 0 for a miss, an invalid ray
    /// or an empty `out`.
    ///
    /// # Panics
    /// Never. No allocation; the stack is [`MAX_DEPTH`](crate::MAX_DEPTH)
    /// entries.
    ///
    /// # Example
    /// ```
    /// use glam::Vec3;
    /// use kdray_kernel::{first_hits_brute, Hit, Ray, TriangleTree};
    /// static CUBE: &kdray_kernel::Aligned<[u8]> =
    ///     kdray_kernel::include_aligned!("../../golden/cube-v3.kdt");
    /// let tree = TriangleTree::from_bytes(&CUBE.bytes)?;
    ///
    /// // From below the cube, straight up: the floor, a slanted triangle
    /// // inside, the roof; the fourth slot stays as it was.
    /// let ray = Ray::new(Vec3::new(0.3, 0.6, -1.0), Vec3::Z);
    /// let mut hits = [Hit::MISS; 4];
    /// let n = tree.first_hits(&ray, &mut hits);
    /// assert_eq!(n, 3);
    /// assert_eq!(hits.map(|h| h.prim)[..3], [1, 13, 2]);
    /// assert_eq!((hits[0].t, hits[2].t), (1.0, 2.0));
    /// assert_eq!(hits[0].bits(), tree.closest_hit(&ray).bits());
    /// // Room for one: the closest.
    /// assert_eq!(tree.first_hits(&ray, &mut hits[..1]), 1);
    /// // Exactly what testing every triangle finds.
    /// let mut brute = [Hit::MISS; 4];
    /// assert_eq!(first_hits_brute(tree.triangles(), &ray, &mut brute), n);
    /// assert_eq!(hits.map(|h| h.bits()), brute.map(|h| h.bits()));
    /// # Ok::<(), kdray_kernel::BlobError>(())
    /// ```
    #[must_use]
    pub fn first_hits(&self, ray: &Ray, out: &mut [Hit]) -> usize {
        self.first_hits_within::<STACK>(ray, out)
    }

    /// [`TriangleTree::first_hits`] on a `DEPTH`-entry stack.
    pub(super) fn first_hits_within<const DEPTH: usize>(
        &self,
        ray: &Ray,
        out: &mut [Hit],
    ) -> usize {
        if out.is_empty() {
            return 0;
        }
        let mut first = FirstHits::new(out);
        self.first_hits_into::<_, DEPTH>(ray, &mut first, 0);
        first.len()
    }

    /// Offers this tree's hits of `ray`, tagged `tag`, to `first` (a
    /// scene's first hits, over all its instances).
    pub(crate) fn first_hits_into<R: Ranked, const DEPTH: usize>(
        &self,
        ray: &Ray,
        first: &mut FirstHits<'_, R>,
        tag: u32,
    ) {
        self.first_hits_by::<R, DEPTH, false>(ray, first, tag);
    }

    /// [`TriangleTree::first_hits_into`]; by the crossing test (an edge or
    /// vertex of a closed mesh crossed once) when `CROSSING`.
    pub(crate) fn first_hits_by<R: Ranked, const DEPTH: usize, const CROSSING: bool>(
        &self,
        ray: &Ray,
        first: &mut FirstHits<'_, R>,
        tag: u32,
    ) {
        let Some(cr) = CellRay::new(ray, dominant_axis(&ray.dir), &self.bounds) else {
            return;
        };
        let Some(sr) = ShearedRay::new(ray) else {
            return;
        };
        let mut visit = FirstVisit::<R, CROSSING> {
            sr: &sr,
            tmin: ray.tmin,
            tmax: ray.tmax,
            tag,
            first,
        };
        let (lo, hi) = cr.start();
        self.walk::<(), _, DEPTH>(&cr, (0, lo, hi), &mut (), &mut visit);
    }
}
