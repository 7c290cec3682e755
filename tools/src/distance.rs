//! Distance queries over slices of points on all cores: the closest
//! point, the distance, the signed distance and occupancy of every query,
//! each one call of the kernel's query ([`TriangleTree::closest_point_from`],
//! [`TriangleTree::contains`], [`TriangleTree::contains_voting`]) on the
//! current rayon pool, the queries taken in space (Morton) order so each
//! search starts from its predecessor's triangle. Every answer is the
//! kernel's for that query alone, whatever the order and thread count.
//!
//! The distance is `sqrt(distance2)` of the kernel's `f64` squared
//! distance, rounded once to `f32`; the signed distance is negative inside
//! (the sign is the kernel's `contains` by the chosen [`InsideRule`]).
//!
//! A scene ([`scene_distance_records`]) answers by the kernel's
//! [`Scene::closest_point_within`], each record naming its instance. It
//! has no signed distance: the rules compose over instances (crossings
//! add, so parity and the winding number of the union are sums over the
//! instances, a mirrored one counted negated), but a ray's crossings are
//! not yet counted once per instance through the top level; flatten the
//! scene (`kdray build` of its mesh file without `--instances`) to sign.

use crate::morton::point_order;
use crate::winding::WindingCaps;
use bytemuck::{Pod, Zeroable};
use kdray_kernel::{
    item_index, Bounds, ClosestPoint, NotSimilar, Scene, SceneClosestPoint, TriangleTree, MISS,
};
use rayon::prelude::*;

/// How inside and outside are told apart.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum InsideRule {
    /// The parity of one ray's crossings (closed meshes; the default).
    #[default]
    Parity,
    /// The majority of this many rays (1 to 7), each by parity: for open
    /// or self-intersecting meshes.
    Vote(u32),
    /// The generalized winding number above one half in magnitude
    /// ([`WindingCaps`]): for open meshes, the rule the `f64` oracle of
    /// the benchmarks uses. The batch functions close the mesh's holes
    /// once per call.
    Winding,
}

impl InsideRule {
    /// Is `q` inside the mesh of `tree` by this rule? For
    /// [`InsideRule::Winding`] this closes the mesh's holes on every call
    /// (`O(n)`): for many points use the batch functions, or
    /// [`WindingCaps::contains`] with caps made once.
    #[must_use]
    pub fn contains(self, tree: &TriangleTree<'_>, q: [f32; 3]) -> bool {
        Inside::new(self, tree).contains(tree, q)
    }
}

/// An [`InsideRule`] ready for many points: the caps of
/// [`InsideRule::Winding`] made once.
struct Inside {
    rule: InsideRule,
    caps: Option<WindingCaps>,
}

impl Inside {
    fn new(rule: InsideRule, tree: &TriangleTree<'_>) -> Inside {
        let caps = (rule == InsideRule::Winding).then(|| WindingCaps::new(tree.triangles()));
        Inside { rule, caps }
    }

    fn contains(&self, tree: &TriangleTree<'_>, q: [f32; 3]) -> bool {
        match (self.rule, &self.caps) {
            (_, Some(caps)) => caps.contains(tree, q),
            (InsideRule::Vote(n), None) => tree.contains_voting(q, n),
            (_, None) => tree.contains(q),
        }
    }
}

/// One `.dist` record (docs/formats.md): the closest point, its triangle,
/// barycentrics and the distance. `repr(C)`, Pod, 28 bytes.
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
#[repr(C)]
pub struct DistanceRecord {
    /// The closest point; NaN when there is none within the maximum
    /// distance (or the query is not finite).
    pub point: [f32; 3],
    /// Its triangle; [`MISS`] (0xFFFFFFFF) when there is none.
    pub prim: u32,
    /// Barycentric weight of the triangle's second vertex (NaN for none).
    pub u: f32,
    /// Barycentric weight of its third vertex (NaN for none).
    pub v: f32,
    /// The distance (negative inside for a signed query); `+inf` (`-inf`
    /// inside) with no triangle within the maximum distance, NaN for a
    /// query that is not finite.
    pub distance: f32,
}

const _: () = assert!(std::mem::size_of::<DistanceRecord>() == 28);

impl DistanceRecord {
    /// The record of a kernel answer (`None`: nothing within reach) for a
    /// query whose coordinates are finite or not (`finite`).
    #[must_use]
    pub fn new(c: Option<ClosestPoint>, finite: bool) -> DistanceRecord {
        match c {
            Some(c) => DistanceRecord {
                point: c.point,
                prim: c.prim,
                u: c.u,
                v: c.v,
                distance: distance(&c),
            },
            None => DistanceRecord {
                point: [f32::NAN; 3],
                prim: MISS,
                u: f32::NAN,
                v: f32::NAN,
                distance: if finite { f32::INFINITY } else { f32::NAN },
            },
        }
    }
}

/// One scene `.dist` record (docs/formats.md): a [`DistanceRecord`] in
/// world space (`prim` the triangle in its instance's mesh) and the
/// instance. `repr(C)`, Pod, 32 bytes.
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
#[repr(C)]
pub struct SceneDistanceRecord {
    /// The closest point, its triangle, barycentrics and distance.
    pub record: DistanceRecord,
    /// The instance's index in the scene; [`MISS`] when there is none.
    pub instance: u32,
}

const _: () = assert!(std::mem::size_of::<SceneDistanceRecord>() == 32);

impl SceneDistanceRecord {
    /// The record of a scene's answer (`None`: nothing within reach) for
    /// a query whose coordinates are finite or not (`finite`).
    #[must_use]
    pub fn new(c: Option<SceneClosestPoint>, finite: bool) -> SceneDistanceRecord {
        let mesh = c.map(|c| ClosestPoint {
            point: c.point,
            prim: c.prim,
            u: c.u,
            v: c.v,
            distance2: c.distance2,
        });
        SceneDistanceRecord {
            record: DistanceRecord::new(mesh, finite),
            instance: c.map_or(MISS, |c| c.instance),
        }
    }
}

/// The distance of a closest point: the square root of its `f64` squared
/// distance, rounded once.
#[must_use]
pub fn distance(c: &ClosestPoint) -> f32 {
    c.distance2.sqrt() as f32
}

/// The distance from `q` to the mesh, as a [`DistanceRecord`] has it,
/// the search starting from triangle `start` (then set to the answer's).
fn distance_from(tree: &TriangleTree<'_>, q: [f32; 3], start: &mut u32) -> f32 {
    record_from(tree, q, f32::INFINITY, start).distance
}

/// The [`DistanceRecord`] of `q` within `max_distance`, the search starting
/// from triangle `start` (then set to the answer's).
fn record_from(
    tree: &TriangleTree<'_>,
    q: [f32; 3],
    max_distance: f32,
    start: &mut u32,
) -> DistanceRecord {
    let finite = q.iter().all(|c| c.is_finite());
    let c = tree.closest_point_from(q, max_distance, *start);
    if let Some(c) = &c {
        *start = c.prim;
    }
    DistanceRecord::new(c, finite)
}

/// Queries per rayon task: enough work to amortise the task.
const CHUNK: usize = 256;

/// Batches of at most this many queries (one task's worth) are answered on
/// the calling thread, in their own order: the pool would run them as one
/// task anyway, after a hand-off that costs 8 to 80 us (its threads
/// asleep) and a space sort (measured: 32 queries near the bunny's surface
/// in 35 us on the calling thread, 33 in 115 us through the pool).
pub const SERIAL_QUERIES: usize = CHUNK;

/// Queries answered into one buffer before it is copied out: the buffer
/// is reused, so its pages are touched once. With every answer held
/// until the end, zeroing their fresh pages took 3.5% of a run over 1M
/// near-surface points (perf).
const ROUND: usize = 1 << 14;

/// `out[i] = each(start, queries[i])` for every pair, on the current rayon
/// pool (a batch of at most [`SERIAL_QUERIES`] on the calling thread), the
/// queries taken in the Morton order of their positions over
/// `bounds` ([`point_order`]; a tree's or a scene's box): a walk finds the cells and triangles
/// its predecessor read still in cache, and `start` (`u32::MAX` at the
/// start of each task) carries the previous answer's triangle, a tight
/// first bound for the next closest-point search. Each answer is the
/// kernel's for its query alone, whatever the order.
fn in_space_order<T: Send>(
    bounds: &Bounds,
    queries: &[[f32; 3]],
    out: &mut [T],
    each: impl Fn(&mut u32, [f32; 3]) -> T + Sync,
) {
    let n = queries.len().min(out.len());
    if n <= SERIAL_QUERIES {
        let mut start = u32::MAX;
        for (o, q) in out.iter_mut().zip(queries) {
            *o = each(&mut start, *q);
        }
        return;
    }
    let Some(order) = point_order(&queries[..n], bounds) else {
        // Past `u32::MAX` queries: in their own order.
        out.par_chunks_mut(CHUNK)
            .zip(queries.par_chunks(CHUNK))
            .for_each(|(out, queries)| {
                let mut start = u32::MAX;
                for (o, q) in out.iter_mut().zip(queries) {
                    *o = each(&mut start, *q);
                }
            });
        return;
    };
    let mut answers: Vec<T> = Vec::with_capacity(ROUND.min(n));
    for round in order.chunks(ROUND) {
        round
            .par_iter()
            .with_min_len(CHUNK)
            .map_init(|| u32::MAX, |start, &i| each(start, queries[item_index(i)]))
            .collect_into_vec(&mut answers);
        for (answer, &i) in answers.drain(..).zip(round) {
            out[item_index(i)] = answer;
        }
    }
}

/// The closest point of every query within `max_distance`
/// (`f32::INFINITY`: no limit), into `out` (`None`: nothing within
/// reach, or a query or `max_distance` the kernel refuses); on the current
/// rayon pool. Pairs queries and `out` slots up to the shorter of the two.
pub fn closest_points(
    tree: &TriangleTree<'_>,
    queries: &[[f32; 3]],
    max_distance: f32,
    out: &mut [Option<ClosestPoint>],
) {
    in_space_order(&tree.bounds(), queries, out, |start, q| {
        let c = tree.closest_point_from(q, max_distance, *start);
        if let Some(c) = &c {
            *start = c.prim;
        }
        c
    });
}

/// The `.dist` record of every query (see [`DistanceRecord`]): the
/// closest point within `max_distance` and its distance, signed by `sign`
/// when given (negative inside); on the current rayon pool.
pub fn distance_records(
    tree: &TriangleTree<'_>,
    queries: &[[f32; 3]],
    max_distance: f32,
    sign: Option<InsideRule>,
    out: &mut [DistanceRecord],
) {
    let inside = sign.map(|rule| Inside::new(rule, tree));
    in_space_order(&tree.bounds(), queries, out, |start, q| {
        let mut r = record_from(tree, q, max_distance, start);
        if inside.as_ref().is_some_and(|i| i.contains(tree, q)) {
            r.distance = -r.distance;
        }
        r
    });
}

/// The distance of every query to the mesh (`+inf` for an empty mesh, NaN
/// for a query that is not finite), into `out`; on the current rayon pool.
pub fn distances(tree: &TriangleTree<'_>, queries: &[[f32; 3]], out: &mut [f32]) {
    in_space_order(&tree.bounds(), queries, out, |start, q| {
        distance_from(tree, q, start)
    });
}

/// The signed distance of every query (negative inside by `rule`), into
/// `out`; on the current rayon pool.
pub fn signed_distances(
    tree: &TriangleTree<'_>,
    queries: &[[f32; 3]],
    rule: InsideRule,
    out: &mut [f32],
) {
    let inside = Inside::new(rule, tree);
    in_space_order(&tree.bounds(), queries, out, |start, q| {
        let d = distance_from(tree, q, start);
        if inside.contains(tree, q) {
            -d
        } else {
            d
        }
    });
}

/// Whether every query lies inside the mesh by `rule`, into `out`; on the
/// current rayon pool.
pub fn occupancy(
    tree: &TriangleTree<'_>,
    queries: &[[f32; 3]],
    rule: InsideRule,
    out: &mut [bool],
) {
    let inside = Inside::new(rule, tree);
    in_space_order(&tree.bounds(), queries, out, |_, q| {
        inside.contains(tree, q)
    });
}

/// The scene `.dist` record of every query (see [`SceneDistanceRecord`]):
/// the closest point over the instances `mask` selects within
/// `max_distance`, in world space; on the current rayon pool, the queries
/// in space order over the scene's box.
///
/// # Errors
/// [`NotSimilar`], before any query is answered, when a selected instance
/// is scaled unevenly or sheared (the kernel's refusal).
pub fn scene_distance_records(
    scene: &Scene<'_>,
    queries: &[[f32; 3]],
    mask: u32,
    max_distance: f32,
    out: &mut [SceneDistanceRecord],
) -> Result<(), NotSimilar> {
    scene.check_similar(mask)?;
    in_space_order(&scene.bounds(), queries, out, |_, q| {
        let finite = q.iter().all(|c| c.is_finite());
        let c = scene.closest_point_within(q, mask, max_distance);
        SceneDistanceRecord::new(c.ok().flatten(), finite)
    });
    Ok(())
}
