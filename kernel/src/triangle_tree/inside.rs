//! Inside or outside: the parity of the crossings of a ray from the query
//! point, each triangle counted once.
//!
//! A ray from a point inside a closed mesh leaves it an odd number of
//! times. The crossings are counted with the watertight test under the
//! strict fill rule ([`ShearedRay::crossing`]): a ray through a shared
//! edge or vertex crosses exactly one of the triangles there (never none,
//! never two), and one that grazes a silhouette edge crosses both or
//! neither, which keeps the parity. A triangle listed in several leaves is
//! counted once: the walk is the first hits' ([`FirstHits`] keeps each
//! triangle once), taken in rounds of [`ROUND`] crossings, each round
//! counting those before its last `t` and the next starting at that `t`.
//!
//! For open or self-intersecting meshes parity is not well defined (a ray
//! through a hole misses a wall). [`TriangleTree::contains_voting`] shoots
//! several rays in fixed directions and takes the majority: a point is
//! misjudged only when most of its rays pass through holes.
//!
//! A point outside the tree's bounds is outside (a closed mesh lies in its
//! box); a point on the surface (distance 0) may be reported either way.

use super::walk::STACK;
use super::TriangleTree;
use crate::geometry::{next_up, Hit, Ray};
use crate::triangle::{FirstHits, ShearedRay, Triangle};

/// Crossings found per round of the walk.
const ROUND: usize = 16;

/// The fixed ray directions: [`TriangleTree::contains`] uses the first,
/// [`TriangleTree::contains_voting`] the first `rays`. No component is
/// zero and none is a simple ratio of another, so rays rarely run along a
/// mesh's axis-aligned faces or edges (which the fill rule handles anyway).
pub const INSIDE_RAYS: [[f32; 3]; 7] = [
    [0.382, 0.7013, 0.5952],
    [-0.6235, 0.4339, -0.6502],
    [0.809, -0.5388, 0.2351],
    [-0.2588, -0.6691, 0.6963],
    [0.5446, 0.2079, -0.8125],
    [-0.8829, -0.2756, -0.3802],
    [0.1045, -0.9135, -0.3934],
];

impl TriangleTree<'_> {
    /// Is `q` inside the (closed) mesh: does the ray from `q` along
    /// [`INSIDE_RAYS`]`[0]` cross it an odd number of times (module docs)?
    /// `false` for a point outside the tree's bounds or with a NaN or
    /// infinite coordinate.
    ///
    /// # Panics
    /// Never. No allocation; the stack is [`MAX_DEPTH`](crate::MAX_DEPTH)
    /// entries and a buffer of 16 hits.
    ///
    /// # Example
    /// ```
    /// use kdray_kernel::{Triangle, TriangleTree};
    /// use kdray_tools::blob::write_triangle_tree;
    /// use kdray_tools::builders::{build, BuildParams, BuilderKind};
    ///
    /// // A closed octahedron |x| + |y| + |z| <= 1.
    /// let p = [[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, -1.0]];
    /// let mut tris = Vec::new();
    /// for x in 0..2 {
    ///     for y in 2..4 {
    ///         for z in 4..6 {
    ///             tris.push(Triangle { v: [p[x], p[y], p[z]] });
    ///         }
    ///     }
    /// }
    /// let built = build(&tris, BuilderKind::default(), &BuildParams::default())?;
    /// let blob = write_triangle_tree(&built, &tris)?;
    /// let tree = blob.tree()?;
    /// assert!(tree.contains([0.1, 0.2, -0.3]));
    /// assert!(!tree.contains([0.5, 0.5, 0.5])); // inside the box, outside the mesh
    /// // Along +x from the centre the ray passes exactly through the
    /// // vertex (1, 0, 0), shared by four triangles: crossed once.
    /// assert_eq!(tree.crossings([0.0; 3], [1.0, 0.0, 0.0]), 1);
    /// // Along the edge direction (1, 1, 0): through an edge of two, once.
    /// assert_eq!(tree.crossings([0.0; 3], [1.0, 1.0, 0.0]), 1);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    #[must_use]
    pub fn contains(&self, q: [f32; 3]) -> bool {
        self.bounds.contains(q) && self.crossings(q, INSIDE_RAYS[0]) % 2 == 1
    }

    /// Is `q` inside by the majority of `rays` rays (`1..=7`; clamped)
    /// along the first directions of [`INSIDE_RAYS`], each counting its
    /// crossings' parity: the rule for open or self-intersecting meshes
    /// (module docs). An even `rays` breaks a tie as outside. The same as
    /// [`TriangleTree::contains`] for `rays = 1`.
    #[must_use]
    pub fn contains_voting(&self, q: [f32; 3], rays: u32) -> bool {
        if !self.bounds.contains(q) {
            return false;
        }
        let n = (rays as usize).clamp(1, INSIDE_RAYS.len());
        let inside = INSIDE_RAYS
            .iter()
            .take(n)
            .filter(|&&d| self.crossings(q, d) % 2 == 1)
            .count();
        2 * inside > n
    }

    /// How many triangles the ray from `q` along `dir` crosses at `t >= 0`,
    /// each once, a shared edge or vertex once (module docs): exactly
    /// [`crossings_brute`](crate::crossings_brute) over all triangles. 0 for a
    /// point or direction with a NaN or infinite coordinate or a zero
    /// direction.
    #[must_use]
    pub fn crossings(&self, q: [f32; 3], dir: [f32; 3]) -> u32 {
        self.crossing_sum(q, dir, |_| 1) as u32
    }

    /// The signed crossings of the ray from `q` along `dir` (each crossing
    /// as [`TriangleTree::crossings`] counts it): `+1` for a triangle whose
    /// normal `(v1 - v0) x (v2 - v0)` points along the ray, `-1` against
    /// it. For a closed, consistently oriented mesh this is the winding
    /// number of `q` (`+1` inside a mesh whose normals point out, 0
    /// outside) along every ray; for an open one it is the winding number
    /// of the mesh closed by caps over its holes only when the caps are
    /// counted too (see [`winding_crossings_brute`](crate::winding_crossings_brute)).
    /// Exactly `winding_crossings_brute` over all triangles; 0 for a
    /// point or direction with a NaN or infinite coordinate or a zero
    /// direction.
    #[must_use]
    pub fn winding_crossings(&self, q: [f32; 3], dir: [f32; 3]) -> i32 {
        let ray = Ray {
            origin: q,
            tmin: 0.0,
            dir,
            tmax: f32::INFINITY,
        };
        let Some(sr) = ShearedRay::new(&ray) else {
            return 0;
        };
        self.crossing_sum(q, dir, |prim| {
            self.triangles
                .get(prim as usize)
                .map_or(0, |tri| sr.crossing_sign(tri))
        })
    }

    /// The sum of `weight(prim)` over the crossings of the ray from `q`
    /// along `dir`, each triangle once (module docs), wrapping.
    fn crossing_sum(&self, q: [f32; 3], dir: [f32; 3], weight: impl Fn(u32) -> i32) -> i32 {
        let mut sum = 0i32;
        let mut tmin = 0.0f32;
        loop {
            let ray = Ray {
                origin: q,
                tmin,
                dir,
                tmax: f32::INFINITY,
            };
            let mut out = [Hit::MISS; ROUND];
            let mut first = FirstHits::new(&mut out);
            self.first_hits_by::<Hit, STACK, true>(&ray, &mut first, 0);
            let n = first.len();
            let add = |sum: i32, hits: &[Hit]| {
                hits.iter().fold(sum, |s, h| s.wrapping_add(weight(h.prim)))
            };
            let Some(last) = out.last().filter(|_| n == ROUND).map(|h| h.t) else {
                return add(sum, out.get(..n).unwrap_or(&[]));
            };
            let before = out.iter().filter(|h| h.t < last).count();
            if before > 0 {
                sum = add(sum, out.get(..before).unwrap_or(&[]));
                tmin = last;
            } else {
                // A round's worth of crossings at one `t` (coincident
                // surfaces): counted over every triangle, then past it.
                sum = sum.wrapping_add(crossings_at(self.triangles, &ray, last, &weight));
                tmin = next_up(last);
            }
            if tmin.is_nan() || tmin == f32::INFINITY {
                return sum;
            }
        }
    }
}

/// The sum of `weight(prim)` over the triangles `ray` crosses at
/// exactly `t`, wrapping.
fn crossings_at(triangles: &[Triangle], ray: &Ray, t: f32, weight: impl Fn(u32) -> i32) -> i32 {
    let Some(sr) = ShearedRay::new(ray) else {
        return 0;
    };
    (0u32..)
        .zip(triangles)
        .filter(|(_, tri)| sr.crossing(tri, t, t).is_some())
        .fold(0i32, |s, (i, _)| s.wrapping_add(weight(i)))
}

#[cfg(test)]
mod tests {
    use crate::triangle::{winding_crossings_brute, Triangle};

    /// A tetrahedron with its normals pointing out.
    const TETRA: [Triangle; 4] = {
        let (o, x, y, z) = (
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
        );
        [
            Triangle { v: [o, y, x] },
            Triangle { v: [o, x, z] },
            Triangle { v: [o, z, y] },
            Triangle { v: [x, y, z] },
        ]
    };

    #[test]
    fn winding_crossings_are_one_inside_outward_normals() {
        let inside = [0.1, 0.2, 0.15];
        for dir in super::INSIDE_RAYS {
            assert_eq!(winding_crossings_brute(&TETRA, inside, dir), 1, "{dir:?}");
            let flipped = TETRA.map(|t| Triangle {
                v: [t.v[0], t.v[2], t.v[1]],
            });
            assert_eq!(winding_crossings_brute(&flipped, inside, dir), -1);
            // Outside: in and out again, or no crossing.
            assert_eq!(winding_crossings_brute(&TETRA, [-0.5, -0.5, -0.5], dir), 0);
        }
    }
}
