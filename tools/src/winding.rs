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
//! The cap triangles are grouped eight consecutive ones along the
//! boundary loops (a small ball each), under a tree of balls (median
//! splits); the tree is walked in tiers, the nearest groups summed
//! exactly first and every ball whose bound is below the tier's bounded,
//! and as soon as the bounds of what is left cannot move `|w|` across
//! `1/2`
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
    /// Cap after cap, `(b, a, apex)` for each boundary edge `a -> b`: the
    /// boundary with the mesh's orientation reversed, so the caps cancel
    /// it. Each cap's in the order of its loops, so neighbouring
    /// triangles fill a small [`Ball`].
    triangles: Vec<Triangle>,
    /// The ball tree over the groups of [`GROUP`] consecutive triangles of
    /// a cap, root first; empty without caps.
    nodes: Vec<BallNode>,
}

/// A node of the ball tree: its ball holds every triangle below it.
#[derive(Clone, Copy, Debug)]
struct BallNode {
    ball: Ball,
    held: Held,
}

/// What a [`BallNode`] holds.
#[derive(Clone, Copy, Debug)]
enum Held {
    /// The cap triangles `start..end`.
    Triangles(usize, usize),
    /// Two child nodes.
    Children(usize, usize),
}

/// The ball tree is built by median splits, so its depth stays below
/// `log2` of the number of groups plus one: this many suffice.
const TREE_DEPTH: usize = 64;

/// A ball holding some triangles and their area: from `q` at distance
/// `D` from its centre, beyond its radius `R`, they subtend at most
/// `area / (4π (D - R)^2)` (over `4π`).
#[derive(Clone, Copy, Debug)]
struct Ball {
    centre: [f64; 3],
    radius: f64,
    area: f64,
}

/// Cap triangles per leaf of the ball tree.
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
        let sum = triangles
            .iter()
            .flat_map(|t| t.v)
            .fold([0.0f64; 3], |m, p| {
                let p = wide(p);
                [m[0] + p[0], m[1] + p[1], m[2] + p[2]]
            });
        Ball::around(sum.map(|c| c / n), triangles)
    }

    /// The ball holding both `a` and `b`, with their areas together.
    fn merge(a: &Ball, b: &Ball) -> Ball {
        let centre = core::array::from_fn(|i| (a.centre[i] + b.centre[i]) / 2.0);
        let reach = |x: &Ball| {
            let d = sub(x.centre, centre);
            dot(d, d).sqrt() + x.radius
        };
        Ball {
            centre,
            radius: reach(a).max(reach(b)) * (1.0 + 1e-9),
            area: a.area + b.area,
        }
    }

    /// Does the ray from `q` along `d` pass within the ball?
    fn meets_ray(&self, q: [f64; 3], d: [f64; 3]) -> bool {
        // The ray's nearest point to the centre.
        let to = sub(self.centre, q);
        let t = (dot(to, d) / dot(d, d)).max(0.0);
        let gap = sub(to, d.map(|c| c * t));
        dot(gap, gap) <= self.radius * self.radius * (1.0 + 1e-9)
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

/// Appends the ball tree over `leaves` (a ball and its triangles each) to
/// `nodes`, split at the median centre along the widest axis; its root's
/// index.
fn build_tree(leaves: &mut [(Ball, usize, usize)], nodes: &mut Vec<BallNode>) -> usize {
    let at = nodes.len();
    if let [(ball, start, end)] = *leaves {
        nodes.push(BallNode {
            ball,
            held: Held::Triangles(start, end),
        });
        return at;
    }
    let extent = |a: usize| {
        let (lo, hi) = leaves
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), l| {
                (lo.min(l.0.centre[a]), hi.max(l.0.centre[a]))
            });
        hi - lo
    };
    let axis = (0..3)
        .max_by(|&a, &b| extent(a).total_cmp(&extent(b)))
        .unwrap_or(0);
    leaves.sort_by(|a, b| a.0.centre[axis].total_cmp(&b.0.centre[axis]));
    // A placeholder, filled once the children are built.
    nodes.push(BallNode {
        ball: leaves[0].0,
        held: Held::Children(0, 0),
    });
    let (left, right) = leaves.split_at_mut(leaves.len() / 2);
    let l = build_tree(left, nodes);
    let r = build_tree(right, nodes);
    nodes[at] = BallNode {
        ball: Ball::merge(&nodes[l].ball, &nodes[r].ball),
        held: Held::Children(l, r),
    };
    at
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
        let mut all: Vec<Triangle> = Vec::new();
        let mut leaves: Vec<(Ball, usize, usize)> = Vec::new();
        for (_, edges) in groups {
            let edges = loop_order(edges);
            let mut verts: Vec<u32> = edges.iter().flat_map(|&(a, b)| [a, b]).collect();
            verts.sort_unstable();
            verts.dedup();
            let mean = verts.iter().fold([0.0f64; 3], |m, &v| {
                let p = wide(points[v as usize]);
                [m[0] + p[0], m[1] + p[1], m[2] + p[2]]
            });
            let n = verts.len() as f64;
            let apex = mean.map(|c| (c / n) as f32);
            let first = all.len();
            all.extend(edges.iter().map(|&(a, b)| Triangle {
                v: [points[b as usize], points[a as usize], apex],
            }));
            for start in (first..all.len()).step_by(GROUP) {
                let end = (start + GROUP).min(all.len());
                leaves.push((Ball::of(&all[start..end]), start, end));
            }
        }
        let mut nodes = Vec::with_capacity(2 * leaves.len());
        if !leaves.is_empty() {
            build_tree(&mut leaves, &mut nodes);
        }
        WindingCaps {
            triangles: all,
            nodes,
        }
    }

    /// Walks the ball tree depth first from the root with `visit(node,
    /// carried)`, which returns the value to carry into the node's
    /// children to go into them, `None` to pass them by (the root
    /// carries `+inf`).
    fn walk(&self, mut visit: impl FnMut(&BallNode, f64) -> Option<f64>) {
        if self.nodes.is_empty() {
            return;
        }
        let mut stack = [(0usize, f64::INFINITY); TREE_DEPTH];
        let mut len = 1;
        while len > 0 {
            len -= 1;
            let (at, carried) = stack[len];
            let node = &self.nodes[at];
            if let (Some(c), Held::Children(l, r)) = (visit(node, carried), node.held) {
                // The depth bound (see TREE_DEPTH) keeps both in range.
                stack[len] = (r, c);
                stack[len + 1] = (l, c);
                len += 2;
            }
        }
    }

    /// The cap triangles held by a leaf (none for an interior node).
    fn held(&self, node: &BallNode) -> &[Triangle] {
        match node.held {
            Held::Triangles(start, end) => &self.triangles[start..end],
            Held::Children(..) => &[],
        }
    }

    /// How many cap triangles close the mesh (the boundary edges): 0 for a
    /// closed, consistently oriented mesh.
    #[must_use]
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
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
        // Only the cap triangles in balls the ray meets can be crossed.
        self.walk(|node, _| {
            if !node.ball.meets_ray(qw, d) {
                return None;
            }
            let held = self.held(node);
            if !held.is_empty() {
                w += i64::from(winding_crossings_brute(held, q, dir));
            }
            Some(0.0)
        });
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
        let caps: f64 = self.triangles.iter().map(|t| triangle_winding(t, qw)).sum();
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
        if self.nodes.is_empty() {
            return whole.abs() > 0.5;
        }
        // The caps' solid angles, nearest first: in each tier a node of
        // the ball tree whose bound is below the tier's is bounded, the
        // leaves at or above it summed exactly; `w` then lies within `far`
        // of the partial sum. A node's bound is the smaller of its ball's
        // and its parent's, so it never grows going down: a leaf is summed
        // in the first tier its bound reaches, and never bounded again
        // (every node above it reaches that tier too). The last tier sums
        // every triangle.
        let qw = wide(q);
        let decided = |w: f64, far: f64| ((w.abs() - 0.5).abs() > far).then_some(w.abs() > 0.5);
        let mut exact = 0.0f64;
        let mut done: Option<f64> = None;
        for tier in TIERS {
            let mut far = 0.0f64;
            self.walk(|node, carried| {
                let b = node.ball.bound(qw).min(carried);
                if b < tier {
                    far += b;
                    return None;
                }
                if done.is_none_or(|d| b < d) {
                    exact += self
                        .held(node)
                        .iter()
                        .map(|t| triangle_winding(t, qw))
                        .sum::<f64>();
                }
                Some(b)
            });
            if let Some(inside) = decided(whole - exact, far) {
                return inside;
            }
            done = Some(tier);
        }
        (whole - exact).abs() > 0.5
    }
}

/// The tiers of [`WindingCaps::contains`]: the bounds (over `4π`) above
/// which a leaf of the ball tree is summed exactly; the first bounds
/// all caps by the root's ball, the last sums everything.
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
