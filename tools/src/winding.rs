//! The generalized winding number of a mesh (Jacobson et al. 2013): the
//! signed solid angle the mesh subtends at a point, over `4π`. It is 1
//! inside a closed mesh whose normals point out, 0 outside, and varies
//! smoothly across the holes of an open one; a point is inside when
//! `|w| > 1/2`. The sign rule for open meshes ([`InsideRule::Winding`]).
//!
//! Summing the solid angle of every triangle costs `O(n)` per point.
//! Instead the mesh's holes are closed by caps: the boundary (every edge
//! not cancelled by an edge running the other way, vertices matched by
//! their exact coordinates) falls into loops, and each connected loop set
//! is closed by a fan of triangles from an apex at the mean of its
//! vertices. The capped mesh is closed, so its winding number is an
//! integer, the same along every ray: the signed crossings of one ray
//! ([`TriangleTree::winding_crossings`] over the mesh, plus
//! [`winding_crossings_brute`] over the caps the ray passes near), exact
//! under the strict fill rule. The ray is [`INSIDE_RAYS`]`[0]` with its
//! components' signs turned towards the nearer faces of the tree's box,
//! so its walk is short; a point outside the box (which holds the capped
//! mesh) is 0 without one.
//!
//! The mesh's own winding number is that integer minus the caps' solid
//! angles, summed exactly in `f64` only where they could decide: a set
//! of cap triangles of area `A` within a ball of radius `R`, seen from
//! distance `D > R` to its centre, subtends at most `A / (4π (D - R)^2)`.
//! Each cap is bounded by its ball, then its triangles in groups of
//! [`GROUP`] consecutive ones along the boundary loops (a small ball
//! each); the groups are summed exactly in tiers, the nearest first, and
//! as soon as the bounds of what is left cannot move `|w|` across `1/2`
//! the rest is skipped. For a closed mesh there are no caps and the rule
//! is the ray's signed crossings.
//!
//! [`InsideRule::Winding`]: crate::distance::InsideRule::Winding

use kdray_kernel::{winding_crossings_brute, Bounds, Triangle, TriangleTree, INSIDE_RAYS};
use std::collections::HashMap;

/// The caps that close an open mesh's holes (module docs), built once per
/// mesh; empty for a closed, consistently oriented mesh.
#[derive(Clone, Debug, Default)]
pub struct WindingCaps {
    caps: Vec<Cap>,
}

/// One fan over a connected set of boundary loops.
#[derive(Clone, Debug)]
struct Cap {
    /// `(b, a, apex)` for each boundary edge `a -> b`: the boundary with
    /// the mesh's orientation reversed, so the caps cancel it. In the
    /// order of the loops, so neighbouring triangles fill a [`Ball`].
    triangles: Vec<Triangle>,
    /// Every cap triangle lies in this ball.
    ball: Ball,
    /// [`GROUP`] triangles at a time, in order: each group's ball.
    groups: Vec<Ball>,
}

/// A ball holding some triangles and their area: from `q` at distance
/// `D` from its centre, beyond its radius `R`, they subtend at most
/// `area / (4π (D - R)^2)` (over `4π`).
#[derive(Clone, Copy, Debug)]
struct Ball {
    centre: [f64; 3],
    radius: f64,
    area: f64,
}

/// Cap triangles per [`Cap::groups`] ball.
const GROUP: usize = 8;

impl Ball {
    /// The ball about `centre` holding every vertex of `triangles`.
    fn around(centre: [f64; 3], triangles: &[Triangle]) -> Ball {
        let radius = triangles
            .iter()
            .flat_map(|t| t.v)
            .map(|p| {
                let d = sub(wide(p), centre);
                dot(d, d).sqrt()
            })
            .fold(0.0f64, f64::max);
        let area = triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.v.map(wide);
                let n = cross(sub(b, a), sub(c, a));
                dot(n, n).sqrt() / 2.0
            })
            .sum();
        Ball {
            centre,
            // Rounding margin: the triangles lie within their vertices' ball.
            radius: radius * (1.0 + 1e-9),
            area,
        }
    }

    /// The ball about the mean of the vertices of `triangles`.
    fn of(triangles: &[Triangle]) -> Ball {
        let n = (3 * triangles.len()).max(1) as f64;
        let sum = triangles.iter().flat_map(|t| t.v).fold([0.0f64; 3], |m, p| {
            let p = wide(p);
            [m[0] + p[0], m[1] + p[1], m[2] + p[2]]
        });
        Ball::around(sum.map(|c| c / n), triangles)
    }

    /// The bound on the magnitude of the winding number of what the ball
    /// holds, seen from `q` (infinite from within the ball).
    fn bound(&self, q: [f64; 3]) -> f64 {
        let to = sub(self.centre, q);
        let beyond = dot(to, to).sqrt() - self.radius;
        if beyond > 0.0 {
            self.area / (4.0 * std::f64::consts::PI * beyond * beyond)
        } else {
            f64::INFINITY
        }
    }
}

/// The boundary edges of one cap in the order of their loops: each edge
/// followed by one leaving its head, where there is one not yet taken.
fn loop_order(mut edges: Vec<(u32, u32)>) -> Vec<(u32, u32)> {
    edges.sort_unstable();
    let mut taken = vec![false; edges.len()];
    let mut out = Vec::with_capacity(edges.len());
    for first in 0..edges.len() {
        let mut at = first;
        while !taken[at] {
            taken[at] = true;
            out.push(edges[at]);
            let head = edges[at].1;
            let from = edges.partition_point(|e| e.0 < head);
            let next = (from..edges.len())
                .take_while(|&i| edges[i].0 == head)
                .find(|&i| !taken[i]);
            match next {
                Some(i) => at = i,
                None => break,
            }
        }
    }
    out
}

/// `a - b` in `f64`.
fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn wide(p: [f32; 3]) -> [f64; 3] {
    p.map(f64::from)
}

/// The signed solid angle of `tri` seen from `q`, over `4π` (Van Oosterom
/// and Strackee's formula): positive when `q` lies behind the triangle's
/// normal `(v1 - v0) x (v2 - v0)`.
#[must_use]
pub fn triangle_winding(tri: &Triangle, q: [f64; 3]) -> f64 {
    let [a, b, c] = tri.v.map(|p| sub(wide(p), q));
    let (la, lb, lc) = (dot(a, a).sqrt(), dot(b, b).sqrt(), dot(c, c).sqrt());
    let det = dot(a, cross(b, c));
    let den = la * lb * lc + dot(a, b) * lc + dot(b, c) * la + dot(c, a) * lb;
    2.0 * det.atan2(den) / (4.0 * std::f64::consts::PI)
}

/// The smallest label in `x`'s set (union-find with path halving).
fn root(parent: &mut [u32], mut x: u32) -> u32 {
    while parent[x as usize] != x {
        let up = parent[parent[x as usize] as usize];
        parent[x as usize] = up;
        x = up;
    }
    x
}

impl WindingCaps {
    /// The caps of the mesh `triangles` (module docs): `O(n)` hashing of
    /// the vertices and edges; about 10 ms for 70k triangles.
    #[must_use]
    pub fn new(triangles: &[Triangle]) -> WindingCaps {
        // Vertices by their exact coordinates.
        let mut ids: HashMap<[u32; 3], u32> = HashMap::new();
        let mut points: Vec<[f32; 3]> = Vec::new();
        let mut id = |p: [f32; 3]| {
            // -0.0 and 0.0 are one point.
            let key = p.map(|c| (c + 0.0).to_bits());
            *ids.entry(key).or_insert_with(|| {
                points.push(p);
                points.len() as u32 - 1
            })
        };
        // Net uses of each undirected edge: +1 for `lo -> hi`, -1 back.
        let mut net: HashMap<(u32, u32), i64> = HashMap::new();
        for tri in triangles {
            let v = tri.v.map(&mut id);
            for (a, b) in [(v[0], v[1]), (v[1], v[2]), (v[2], v[0])] {
                if a != b {
                    *net.entry((a.min(b), a.max(b))).or_insert(0) += if a < b { 1 } else { -1 };
                }
            }
        }
        let mut boundary: Vec<(u32, u32)> = Vec::new();
        for (&(lo, hi), &n) in &net {
            let edge = if n > 0 { (lo, hi) } else { (hi, lo) };
            boundary.extend(std::iter::repeat_n(edge, n.unsigned_abs() as usize));
        }
        // In a fixed order, whatever the hashing.
        boundary.sort_unstable();
        let mut parent: Vec<u32> = (0..points.len() as u32).collect();
        for &(a, b) in &boundary {
            let (ra, rb) = (root(&mut parent, a), root(&mut parent, b));
            parent[ra.max(rb) as usize] = ra.min(rb);
        }
        let mut groups: Vec<(u32, Vec<(u32, u32)>)> = Vec::new();
        let mut group_of: HashMap<u32, usize> = HashMap::new();
        for &(a, b) in &boundary {
            let r = root(&mut parent, a);
            let g = *group_of.entry(r).or_insert_with(|| {
                groups.push((r, Vec::new()));
                groups.len() - 1
            });
            groups[g].1.push((a, b));
        }
        let caps = groups
            .into_iter()
            .map(|(_, edges)| {
                let edges = loop_order(edges);
                let mut verts: Vec<u32> = edges.iter().flat_map(|&(a, b)| [a, b]).collect();
                verts.sort_unstable();
                verts.dedup();
                let mean = verts.iter().fold([0.0f64; 3], |m, &v| {
                    let p = wide(points[v as usize]);
                    [m[0] + p[0], m[1] + p[1], m[2] + p[2]]
                });
                let n = verts.len() as f64;
                let apex32 = mean.map(|c| (c / n) as f32);
                let triangles: Vec<Triangle> = edges
                    .iter()
                    .map(|&(a, b)| Triangle {
                        v: [points[b as usize], points[a as usize], apex32],
                    })
                    .collect();
                Cap {
                    ball: Ball::around(wide(apex32), &triangles),
                    groups: triangles.chunks(GROUP).map(Ball::of).collect(),
                    triangles,
                }
            })
            .collect();
        WindingCaps { caps }
    }

    /// How many cap triangles close the mesh (the boundary edges): 0 for a
    /// closed, consistently oriented mesh.
    #[must_use]
    pub fn triangle_count(&self) -> usize {
        self.caps.iter().map(|c| c.triangles.len()).sum()
    }

    /// The winding number of the capped mesh at `q`: the signed crossings
    /// of one ray with `tree`'s mesh and with the caps it passes near
    /// (module docs). 0 for a point outside the tree's box, which holds
    /// the capped mesh (every apex is a mean of mesh vertices).
    fn capped_crossings(&self, tree: &TriangleTree<'_>, q: [f32; 3]) -> i64 {
        let b = tree.bounds();
        if !b.contains(q) {
            return 0;
        }
        let dir = shortest_ray(&b, q);
        let d = wide(dir);
        let qw = wide(q);
        let mut w = i64::from(tree.winding_crossings(q, dir));
        for cap in &self.caps {
            // The ray's nearest point to the apex; the cap can be crossed
            // only if that lies within its radius.
            let to = sub(cap.ball.centre, qw);
            let t = (dot(to, d) / dot(d, d)).max(0.0);
            let gap = sub(to, d.map(|c| c * t));
            if dot(gap, gap) <= cap.ball.radius * cap.ball.radius * (1.0 + 1e-9) {
                w += i64::from(winding_crossings_brute(&cap.triangles, q, dir));
            }
        }
        w
    }

    /// The generalized winding number of `tree`'s mesh at `q`, every cap's
    /// solid angle summed exactly. NaN for a point with a NaN or infinite
    /// coordinate.
    #[must_use]
    pub fn winding_number(&self, tree: &TriangleTree<'_>, q: [f32; 3]) -> f64 {
        if !q.iter().all(|c| c.is_finite()) {
            return f64::NAN;
        }
        let qw = wide(q);
        let caps: f64 = self
            .caps
            .iter()
            .flat_map(|c| &c.triangles)
            .map(|t| triangle_winding(t, qw))
            .sum();
        self.capped_crossings(tree, q) as f64 - caps
    }

    /// Is `q` inside `tree`'s mesh: `|w| > 1/2` for its winding number
    /// `w`, the caps' solid angles bounded instead of summed where the
    /// bounds decide (module docs). `false` for a point with a NaN or
    /// infinite coordinate.
    #[must_use]
    pub fn contains(&self, tree: &TriangleTree<'_>, q: [f32; 3]) -> bool {
        if !q.iter().all(|c| c.is_finite()) {
            return false;
        }
        let whole = self.capped_crossings(tree, q) as f64;
        if self.caps.is_empty() {
            return whole.abs() > 0.5;
        }
        // The caps' solid angles, nearest first: in each tier the groups
        // of cap triangles whose bound reaches the tier's are summed
        // exactly, the others bounded (a whole cap by its own ball while
        // that bound is below the tier); `w` then lies within `far` of
        // the partial sum. The last tier sums every triangle.
        let qw = wide(q);
        let decided = |w: f64, far: f64| ((w.abs() - 0.5).abs() > far).then_some(w.abs() > 0.5);
        let mut exact = 0.0f64;
        let mut done: Option<f64> = None;
        for tier in TIERS {
            let mut far = 0.0f64;
            for cap in &self.caps {
                let cap_bound = cap.ball.bound(qw);
                if cap_bound < tier {
                    far += cap_bound;
                    continue;
                }
                for (group, ball) in cap.triangles.chunks(GROUP).zip(&cap.groups) {
                    // A group's bound by the smaller ball, the same in
                    // every tier: summed in the first tier it reaches.
                    let b = ball.bound(qw).min(cap_bound);
                    if b < tier {
                        far += b;
                    } else if done.is_none_or(|d| b < d) {
                        exact += group.iter().map(|t| triangle_winding(t, qw)).sum::<f64>();
                    }
                }
            }
            if let Some(inside) = decided(whole - exact, far) {
                return inside;
            }
            done = Some(tier);
        }
        (whole - exact).abs() > 0.5
    }
}

/// The tiers of [`WindingCaps::contains`]: the bounds (over `4π`) above
/// which a group of cap triangles is summed exactly; the first bounds
/// whole caps, the last sums everything.
const TIERS: [f64; 4] = [f64::INFINITY, 1.0 / 16.0, 1.0 / 256.0, 0.0];

/// [`INSIDE_RAYS`]`[0]` with each component's sign turned towards the
/// nearer face of the box `b` along its axis: the ray that leaves the
/// box soonest, so its walk crosses the fewest cells. The capped mesh is
/// closed, so its signed crossings are the same along every ray.
fn shortest_ray(b: &Bounds, q: [f32; 3]) -> [f32; 3] {
    core::array::from_fn(|a| {
        let c = INSIDE_RAYS[0][a].abs();
        if b.max[a] - q[a] < q[a] - b.min[a] {
            c
        } else {
            -c
        }
    })
}

