//! Batches: a slice of rays, each ray's answer in its slot, traced by
//! whichever walk suits each block of [`BLOCK`] rays, timed on the batch
//! (`walk_choice.rs`): packets of consecutive rays or single rays where
//! their origins lie close together (camera tiles), single rays alone or
//! walked in turns where they lie far apart (bounces, random rays), and,
//! given scratch memory, a scattered any-hit batch in the Morton order of
//! its origins. Every path gives each ray its single ray's answer, bit for
//! bit.

use super::packet::{lane_bools, LaneRays, LaneStack, PacketWidth};
use super::walk_choice::{ticks, Step, Trial, Trials, Walk, CLOCK};
use super::TriangleTree;
use crate::geometry::{item_index, sort_items, Bounds, Hit, MortonGrid, Ray, MISS};
use crate::lanes::{dispatch, Job, Lanes, Level};

/// How a batch is traced ([`TriangleTree::closest_hits`],
/// [`TriangleTree::any_hits`]): `Batch::default()` suits most batches.
/// Whatever it says, each ray gets its single ray's answer bit for bit.
#[derive(Debug, Default)]
pub struct Batch<'s> {
    /// How many consecutive rays walk together. `None` (the default): the
    /// batch call chooses for each block of 256 rays, by timing the walks
    /// on the batch itself. It sorts each block into coherent (origins
    /// close together: camera rays, shadow rays in pixel or Morton order)
    /// or scattered (random rays, bounces), and for each kind times its
    /// two candidates on the first blocks and keeps the cheaper per ray,
    /// trying the other again now and then: coherent blocks take packets
    /// at the widest width one register holds (16 lanes with AVX-512, 8
    /// with AVX2, else 4) or single rays; scattered closest-hit blocks
    /// single rays or rays walked in turns (through the treelets of a
    /// [`TreeletTree`](crate::TreeletTree)), scattered any-hit blocks
    /// single rays or packets. Without a counter to time them (off x86-64)
    /// coherent blocks take packets and scattered ones single rays. For
    /// packets to pay, order coherent rays in small image tiles (4x2
    /// pixels for 8 lanes, 4x4 for 16).
    ///
    /// `Some(width)`: every block in packets of `width`
    /// ([`PacketWidth::One`]: each ray walked alone), nothing sorted or
    /// timed: for benchmarks and for callers who have measured their rays.
    pub width: Option<PacketWidth>,
    /// Room for an any-hit batch to be traced in the Morton order of its
    /// rays' origins (a radix sort of one key a ray): two words a ray
    /// (`2 * rays.len()`). Give it for a large batch of scattered shadow
    /// rays, as from random surface points: their walks then share cells,
    /// nodes and triangles that stay in cache (docs/results.md has the
    /// gain). With less, or past `u32::MAX` rays, or for closest hits
    /// (which walk scattered blocks in turns instead), the batch is traced
    /// in its own order.
    pub scratch: &'s mut [u64],
    /// Whether the batch is walked as ray streams, which keep their rays'
    /// ids and intervals in `scratch`: [`STREAM_SCRATCH_WORDS`](crate::STREAM_SCRATCH_WORDS) words.
    pub streams: Streams,
    /// How the blocks of a batch with `width: None` choose their walk:
    /// timed (the default), or fixed, for the tests, fuzz targets and
    /// benchmarks that must reach a given walk.
    #[doc(hidden)]
    pub trial: Trial,
}

/// Whether a batch is walked as ray streams: blocks of 256 rays walked
/// down the tree together, each split plane tested against all the rays
/// that reach it. Any choice gives each ray its single ray's answer.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Streams {
    /// The batch call chooses: today, never. Tried: streams for scattered
    /// blocks: random rays 0.91-1.02x of single rays (bunny, teapot,
    /// sponza, one core, AVX-512 machine), camera rays 0.15-0.37x of
    /// packets, because 256 rays split into streams of fewer than 12
    /// after ~5 of their ~20 steps and go on as single walks, the
    /// partitions (~45 scalar instructions a ray and node) on top.
    #[default]
    Auto,
    /// Every block as streams, in as much of `scratch` as there is
    /// (streams that find no room go on as single rays).
    Always,
    /// Never.
    Never,
}

impl TriangleTree<'_> {
    /// The closest hit of every ray: `hits[i]` is bit for bit
    /// `closest_hit(&rays[i])`. Only the first
    /// `min(rays.len(), hits.len())` entries are traced.
    ///
    /// # Panics
    /// Never. No allocation.
    ///
    /// # Example
    /// ```
    /// use glam::Vec3;
    /// use kdray_kernel::{Batch, Hit, Ray, TriangleTree};
    /// static CUBE: &kdray_kernel::Aligned<[u8]> =
    ///     kdray_kernel::include_aligned!("../../golden/cube-v3.kdt");
    /// let tree = TriangleTree::from_bytes(&CUBE.bytes)?;
    ///
    /// // 11 rays fanning out from inside the cube: a packet of 8, then one of 3.
    /// let rays: Vec<Ray> = (0..11)
    ///     .map(|i| Ray::new(Vec3::splat(0.5), Vec3::new(1.0, i as f32 * 0.1 - 0.5, 0.3)))
    ///     .collect();
    /// let mut hits = vec![Hit::MISS; rays.len()];
    /// tree.closest_hits(&rays, &mut hits, Batch::default());
    /// for (ray, hit) in rays.iter().zip(&hits) {
    ///     assert!(hit.is_hit()); // the cube is closed
    ///     assert_eq!(hit.bits(), tree.closest_hit(ray).bits());
    /// }
    /// # Ok::<(), kdray_kernel::BlobError>(())
    /// ```
    pub fn closest_hits(&self, rays: &[Ray], hits: &mut [Hit], batch: Batch<'_>) {
        if batch.streams == Streams::Always {
            return self.closest_hits_streamed(rays, hits, batch.scratch);
        }
        self.slice_with::<ClosestHit>(&mut Plan::new::<ClosestHit>(&batch), rays, hits);
    }

    /// Whether each ray hits anything: `occluded[i] == any_hit(&rays[i])`.
    /// Only the first `min(rays.len(), occluded.len())` entries are traced.
    ///
    /// # Panics
    /// Never. No allocation (rays gathered in Morton order take 8 KiB of
    /// stack, 256 at a time).
    pub fn any_hits(&self, rays: &[Ray], occluded: &mut [bool], batch: Batch<'_>) {
        let rays = rays.get(..occluded.len()).unwrap_or(rays);
        if batch.streams == Streams::Always {
            return self.any_hits_streamed(rays, occluded, batch.scratch);
        }
        if batch.scratch.len() / 2 < rays.len() {
            // No room to sort: the batch in its own order, in place.
            let mut plan = Plan::new::<AnyHit>(&batch);
            return self.slice_with::<AnyHit>(&mut plan, rays, occluded);
        }
        self.any_hits_each(rays, batch, |i, o| {
            if let Some(x) = occluded.get_mut(i) {
                *x = o;
            }
        });
    }

    /// [`any_hits`](TriangleTree::any_hits), handing each answer to
    /// `answer(ray index, occluded)`: for outputs of another type, as the C
    /// API's `int32_t`s.
    #[doc(hidden)]
    pub fn any_hits_each(
        &self,
        rays: &[Ray],
        batch: Batch<'_>,
        mut answer: impl FnMut(usize, bool),
    ) {
        let mut plan = Plan::new::<AnyHit>(&batch);
        let scratch = batch.scratch;
        let n = rays.len();
        let (items, spare) = scratch.split_at_mut(scratch.len() / 2);
        let mut sorted = false;
        if let (Some(items), Ok(_)) = (items.get_mut(..n), u32::try_from(n)) {
            let grid = MortonGrid::over_origins(rays);
            for (i, (item, r)) in items.iter_mut().zip(rays).enumerate() {
                *item = grid.item(r, i as u32);
            }
            sorted = sort_items(items, spare);
        }
        let none = Ray {
            origin: [0.0; 3],
            tmin: 0.0,
            dir: [0.0; 3],
            tmax: 0.0,
        };
        let mut chunk = [none; BLOCK];
        let mut answers = [false; BLOCK];
        for start in (0..n).step_by(BLOCK) {
            let m = BLOCK.min(n - start);
            // The `k`-th ray of this chunk: sorted, or the batch's own.
            let at = |k: usize| match scratch.get(start + k) {
                Some(&it) if sorted => item_index(it),
                _ => start + k,
            };
            for (k, c) in chunk.iter_mut().enumerate().take(m) {
                *c = rays.get(at(k)).copied().unwrap_or(none);
            }
            if let (Some(c), Some(a)) = (chunk.get(..m), answers.get_mut(..m)) {
                self.slice_with::<AnyHit>(&mut plan, c, a);
            }
            for (k, &a) in answers.iter().enumerate().take(m) {
                answer(at(k), a);
            }
        }
    }

    /// A batch in its own order, each block in the walk `plan` gives it,
    /// for either query.
    pub(super) fn slice_with<Q: SliceQuery>(
        &self,
        plan: &mut Plan,
        rays: &[Ray],
        out: &mut [Q::Out],
    ) {
        let mut memo = Q::Memo::default();
        for (rays, out) in rays.chunks(BLOCK).zip(out.chunks_mut(BLOCK)) {
            let Some(width) = plan.width else {
                let trials = match scattered(rays, &self.bounds) {
                    true => &mut plan.scattered,
                    false => &mut plan.coherent,
                };
                // A trial's halves are whole 16-lane packets: a block of
                // fewer than 32 rays (a batch's last) takes the fixed rule.
                let timed = CLOCK && rays.len() >= 32;
                match trials.next(plan.trial, timed) {
                    Step::Take(walk) => self.block_with::<Q>(walk, rays, out, &mut memo),
                    Step::Trial { order } => {
                        let half = (rays.len() / 2) & !15;
                        let r = rays.split_at_checked(half).unwrap_or((rays, &[]));
                        let o = out.split_at_mut(half.min(out.len()));
                        let mut ticks_of = |i: usize, rays: &[Ray], out: &mut [Q::Out]| {
                            let start = ticks();
                            self.block_with::<Q>(trials.walk(i), rays, out, &mut memo);
                            ticks().zip(start).map_or(0, |(e, s)| e.wrapping_sub(s))
                        };
                        let t = [ticks_of(order[0], r.0, o.0), ticks_of(order[1], r.1, o.1)];
                        trials.record(order, t, [r.0.len(), r.1.len()]);
                    }
                }
                continue;
            };
            self.block_with::<Q>(Walk::Packets(width), rays, out, &mut memo);
        }
    }

    /// One block of rays (at most [`BLOCK`]) in the walk `walk`.
    #[inline(always)]
    fn block_with<Q: SliceQuery>(
        &self,
        walk: Walk,
        rays: &[Ray],
        out: &mut [Q::Out],
        memo: &mut Q::Memo,
    ) {
        // The scalar path traces each ray alone (the packet entry points'
        // `scalar-packets` rule).
        let walk = match walk {
            Walk::Packets(_) if cfg!(feature = "scalar-packets") => Walk::Single,
            w => w,
        };
        match (walk, Q::IN_TURNS_WALK) {
            (Walk::InTurns, Some(in_turns)) => in_turns(self, rays, out),
            (Walk::Single | Walk::InTurns | Walk::Packets(PacketWidth::One), _) => {
                for (o, r) in out.iter_mut().zip(rays) {
                    *o = Q::one_after(self, r, memo);
                }
            }
            (Walk::Packets(PacketWidth::Four), _) => dispatch(Slice4::<Q>(self, rays, out)),
            // 16 lanes only where they are one register (`PacketWidth::Sixteen`).
            (Walk::Packets(PacketWidth::Sixteen), _) if sixteen_lanes() => {
                dispatch(Slice16::<Q>(self, rays, out));
            }
            (Walk::Packets(PacketWidth::Eight | PacketWidth::Sixteen), _) => {
                dispatch(Slice8::<Q>(self, rays, out));
            }
        }
    }

    /// Whether consecutive rays of `rays` start far apart in this tree's
    /// scene: the test the batch calls make on each block of 256
    /// rays before choosing a walk (random rays and shadow rays from
    /// random surface points are scattered; camera rays and rays in pixel
    /// order are not). A caller holding a large batch of scattered rays
    /// gains by tracing them in the order of their origins
    /// (`kdray_tools::trace` does).
    #[must_use]
    pub fn rays_scattered(&self, rays: &[Ray]) -> bool {
        scattered(rays, &self.bounds)
    }
}

/// The rays the batch calls choose a path for at a time (a multiple
/// of every packet width).
const BLOCK: usize = 256;

/// What a batch call carries from block to block: the width it was given,
/// or each kind of block's trials.
pub(super) struct Plan {
    /// [`Batch::width`].
    width: Option<PacketWidth>,
    /// [`Batch::trial`].
    trial: Trial,
    /// Blocks whose rays start close together: packets at the widest
    /// width one register holds, or single rays.
    pub(super) coherent: Trials,
    /// Blocks whose rays start far apart: single rays, or rays walked in
    /// turns where the query and the processor have them (closest hits on
    /// x86-64), else packets.
    pub(super) scattered: Trials,
}

impl Plan {
    /// The plan `batch` asks for.
    pub(super) fn new<Q: SliceQuery>(batch: &Batch<'_>) -> Plan {
        let packets = Walk::Packets(widest());
        let in_turns = match Q::IN_TURNS_WALK {
            Some(_) if IN_TURNS => Walk::InTurns,
            _ => packets,
        };
        Plan {
            width: batch.width,
            trial: batch.trial,
            coherent: Trials::new([packets, Walk::Single], 2),
            scattered: Trials::new([Walk::Single, in_turns], 2),
        }
    }
}

/// Whether scattered rays may be walked in turns: where the walks' misses
/// can overlap (an out-of-order core with caches and a prefetch, x86-64
/// here, where the trials time them against single rays). Elsewhere (a
/// microcontroller) turns would only add work and 6 KiB of stack for
/// their eight walks.
const IN_TURNS: bool = cfg!(target_arch = "x86_64");

/// Whether consecutive rays of `rays` start far apart: on average more
/// than 1/16 of the scene's largest extent (largest coordinate difference),
/// over the first two rays of every eight (every pair cost camera rays 2%).
/// Camera rays (one origin) and shadow rays in pixel or Morton order are
/// not; random rays and shadow rays from random surface points are, and
/// closest-hit walks of such rays wait on memory, which rays walked in
/// turns overlap (bunny, one core: random rays ~1.1-1.35x). Camera rays in turns
/// ran 2.8x slower and Morton-ordered shadow rays 2.3x (a turn costs
/// ~80 instructions and the interleaved branches predict worse), hence
/// the test.
pub(super) fn scattered(rays: &[Ray], bounds: &Bounds) -> bool {
    let extent = (0..3).fold(0.0f32, |e, a| e.max(bounds.max[a] - bounds.min[a]));
    let (mut gaps, mut pairs) = (0.0f32, 0u32);
    for c in rays.chunks(8) {
        if let [a, b, ..] = c {
            gaps += (0..3).fold(0.0f32, |d, k| d.max((a.origin[k] - b.origin[k]).abs()));
            pairs += 1;
        }
    }
    gaps > extent * pairs as f32 / 16.0
}

/// The widest packets one register holds, the coherent blocks' candidate:
/// 16 lanes with AVX-512, 8 with AVX (built for) or AVX2 (detected), else
/// 4 (SSE2, NEON, simd128).
pub(super) fn widest() -> PacketWidth {
    if sixteen_lanes() {
        PacketWidth::Sixteen
    } else if cfg!(target_feature = "avx") || crate::cpu::isa() >= crate::cpu::Isa::Avx2 {
        PacketWidth::Eight
    } else {
        PacketWidth::Four
    }
}

/// Whether the batch calls trace `PacketWidth::Sixteen` in 16
/// lanes: where 16 lanes are one register (AVX-512, built for or
/// detected). Elsewhere they are two `f32x8` or four `f32x4` per
/// operation, and 8-lane packets are as fast or faster (an AVX2 build: 16
/// lanes 2% slower), so those slices go 8 at a time.
#[inline]
fn sixteen_lanes() -> bool {
    cfg!(target_feature = "avx512f") || crate::cpu::isa() == crate::cpu::Isa::Avx512
}

/// The batch calls' jobs: a slice of rays in packets of a width.
macro_rules! slice_jobs {
    ($($job:ident, $n:literal, $x:ident;)*) => {$(
        #[doc = concat!("A slice of rays in packets of ", $n, ".")]
        struct $job<'t, 'a, 'o, Q: SliceQuery>(&'t TriangleTree<'a>, &'t [Ray], &'o mut [Q::Out]);

        impl<Q: SliceQuery> Job for $job<'_, '_, '_, Q> {
            type Out = ();
            #[inline(always)]
            fn run<L: Level>(self) {
                let $job(tree, rays, out) = self;
                in_packets::<L::$x, Q, $n>(tree, rays, out);
            }
        }
    )*};
}

slice_jobs! {
    Slice4, 4, X4;
    Slice8, 8, X8;
    Slice16, 16, X16;
}

/// A query the batch calls run, as a single ray and over lanes.
pub(super) trait SliceQuery {
    /// One ray's answer.
    type Out: Copy;
    /// What one ray's query leaves for the next in a coherent slice.
    type Memo: Default;
    fn one(tree: &TriangleTree<'_>, ray: &Ray) -> Self::Out;
    /// One ray's answer, after the ray before it in a coherent slice
    /// (by default, [`SliceQuery::one`]).
    #[inline(always)]
    fn one_after(tree: &TriangleTree<'_>, ray: &Ray, _: &mut Self::Memo) -> Self::Out {
        Self::one(tree, ray)
    }
    /// Each ray's answer, single rays walked in turns (`turns.rs`), for
    /// a query whose scattered rays take turns.
    const IN_TURNS_WALK: Option<InTurns<Self::Out>>;
    fn lanes<V: Lanes<N>, const N: usize>(
        tree: &TriangleTree<'_>,
        lr: &LaneRays<V, N>,
        stack: &mut LaneStack<V>,
    ) -> [Self::Out; N];
}

/// A slice of rays walked in turns, answers into the second slice.
type InTurns<Out> = fn(&TriangleTree<'_>, &[Ray], &mut [Out]);

/// The closest hit.
pub(super) struct ClosestHit;

impl SliceQuery for ClosestHit {
    type Out = Hit;
    type Memo = ();
    #[inline(always)]
    fn one(tree: &TriangleTree<'_>, ray: &Ray) -> Hit {
        tree.closest_hit(ray)
    }
    const IN_TURNS_WALK: Option<InTurns<Hit>> =
        Some(|tree, rays, out| tree.closest_hits_scattered(rays, out));
    #[inline(always)]
    fn lanes<V: Lanes<N>, const N: usize>(
        tree: &TriangleTree<'_>,
        lr: &LaneRays<V, N>,
        stack: &mut LaneStack<V>,
    ) -> [Hit; N] {
        tree.closest_lanes(lr, stack)
    }
}

/// Any hit (occlusion).
pub(super) struct AnyHit;

/// The triangle that occluded the last ray ([`MISS`] before any did).
pub(super) struct Occluder(u32);

impl Default for Occluder {
    fn default() -> Occluder {
        Occluder(MISS)
    }
}

impl SliceQuery for AnyHit {
    type Out = bool;
    /// The last occluder (an occluder cache of one triangle), kept by
    /// single rays. Tried for packets too (the last occluder tested on
    /// every lane before the walk, the walk naming its occluder): 8- and
    /// 16-wide Morton-ordered shadow packets ran 0.6-0.94x, the lane test
    /// and the walk's extra state costing more than the rare packet whose
    /// lanes it all answered.
    type Memo = Occluder;
    #[inline(always)]
    fn one(tree: &TriangleTree<'_>, ray: &Ray) -> bool {
        tree.any_hit(ray)
    }
    #[inline(always)]
    fn one_after(tree: &TriangleTree<'_>, ray: &Ray, memo: &mut Occluder) -> bool {
        tree.any_hit_remembering(ray, &mut memo.0)
    }
    /// No turns: walked back to front (`walk.rs`, `Visit::FAR_FIRST`),
    /// shadow rays start from the light's end, which every ray of a light
    /// shares and the cache keeps. Turns against none, plain build, one
    /// core, file-order shadow rays, two runs: bunny 0.94-1.10x single,
    /// 0.94-1.0x 8-wide (the noise), sponza 0.66-0.68x / 0.53-0.61x
    /// (front to back, turns had paid 1.46x on the bunny, 1.0x on sponza).
    const IN_TURNS_WALK: Option<InTurns<bool>> = None;
    #[inline(always)]
    fn lanes<V: Lanes<N>, const N: usize>(
        tree: &TriangleTree<'_>,
        lr: &LaneRays<V, N>,
        stack: &mut LaneStack<V>,
    ) -> [bool; N] {
        lane_bools(tree.any_lanes(lr, stack))
    }
}

/// Traces `rays` in packets of `N` consecutive rays (the last one partly
/// inactive) and writes each lane's answer to `out`; packets whose rays
/// disagree on a direction sign go ray by ray (`Q::one`). Out of line:
/// one function per width, query and level (its `Job` wrapper), each with
/// its own registers (with a third width inlined into `slice_with`, the
/// 8-wide walk lost ~5%).
#[inline(always)]
fn in_packets<V: Lanes<N>, Q: SliceQuery, const N: usize>(
    tree: &TriangleTree<'_>,
    rays: &[Ray],
    out: &mut [Q::Out],
) {
    let mut stack = LaneStack::new(V::splat(0.0));
    for (rs, os) in rays.chunks(N).zip(out.chunks_mut(N)) {
        let cols = LaneRays::<V, N>::columns(rs);
        if !LaneRays::signs_agree(&cols) {
            for (o, r) in os.iter_mut().zip(rs) {
                *o = Q::one(tree, r);
            }
            continue;
        }
        let answers = Q::lanes(
            tree,
            &LaneRays::from_rays(&cols, rs, &tree.bounds),
            &mut stack,
        );
        for (o, a) in os.iter_mut().zip(answers).take(rs.len()) {
            *o = a;
        }
    }
}
