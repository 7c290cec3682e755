//! Ray packets: 4, 8 or 16 rays traced together through one walk of the tree,
//! each lane answering exactly as its single ray would, bit for bit.
//!
//! - [`Packet`] holds the rays in structure-of-arrays layout with a
//!   `valid` flag per lane (inactive lanes miss); build one from rays
//!   ([`Packet::from_rays`]) or glam vectors ([`Packet::from_vec3`]).
//! - [`TriangleTree::closest_hit4`] / [`closest_hit8`](TriangleTree::closest_hit8)
//!   / [`closest_hit16`](TriangleTree::closest_hit16) and
//!   [`any_hit4`](TriangleTree::any_hit4) / [`any_hit8`](TriangleTree::any_hit8)
//!   / [`any_hit16`](TriangleTree::any_hit16) trace one packet with
//!   `wide`'s `f32x4` / `f32x8` / `f32x16`.
//! - [`TriangleTree::closest_hits`] and [`TriangleTree::any_hits`] take a
//!   slice of rays and form packets of consecutive rays themselves: order
//!   the rays in small image tiles (4x2 pixels for 8 lanes, two such
//!   tiles side by side for 16).
//! - [`TriangleTree::closest_hit_lanes`] / [`any_hit_lanes`](TriangleTree::any_hit_lanes)
//!   are the scalar path (one single ray per lane), always compiled; the
//!   `scalar-packets` feature makes every packet entry point take it.
//!
//! # Exactness
//! Each lane starts from the single ray's own prepared numbers
//! ([`ShearedRay`](crate::triangle::ShearedRay), [`CellRay`](super::cell_ray::CellRay)), runs
//! the same triangle test in lanes (same operations, same order, no FMA,
//! no approximate reciprocal, the same `f64` fallback) and keeps hits by
//! the same [`Closest`](crate::triangle::Closest) rule; the walk applies the single
//! ray's slack rule per lane, by the same code (`walk.rs` explains why the
//! few extra cells a lane visits for its neighbours cannot change an
//! answer). Packets whose rays disagree on a direction sign are traced
//! ray by ray: they would not walk together anyway.

mod intersect;
mod lane_rays;
mod walk;

use super::TriangleTree;
use crate::geometry::{item_index, sort_items, Bounds, Hit, MortonGrid, Ray, MISS};
use crate::lanes::{dispatch, Job, Lanes, Level};
use glam::Vec3;
use lane_rays::LaneRays;
use walk::LaneStack;

/// `N` rays in structure-of-arrays layout, with a valid flag per lane.
///
/// Lane `l` is the ray `origin[.][l] + t * dir[.][l]` over
/// `[tmin[l], tmax[l]]`; a lane with `valid[l] == false` is not traced and
/// reports a miss.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Packet<const N: usize> {
    /// Origin x, y, z, each for all lanes.
    pub origin: [[f32; N]; 3],
    /// Direction x, y, z, each for all lanes.
    pub dir: [[f32; N]; 3],
    /// Start of each lane's interval.
    pub tmin: [f32; N],
    /// End of each lane's interval.
    pub tmax: [f32; N],
    /// Which lanes are traced.
    pub valid: [bool; N],
}

/// A packet of 4 rays (`f32x4` lanes).
pub type Packet4 = Packet<4>;
/// A packet of 8 rays (`f32x8` lanes).
pub type Packet8 = Packet<8>;
/// A packet of 16 rays (`f32x16` lanes).
pub type Packet16 = Packet<16>;

impl<const N: usize> Packet<N> {
    /// A packet with every lane inactive.
    pub const EMPTY: Packet<N> = Packet {
        origin: [[0.0; N]; 3],
        dir: [[0.0; N]; 3],
        tmin: [0.0; N],
        tmax: [0.0; N],
        valid: [false; N],
    };

    /// The first `N` rays of `rays` in lanes `0..`; lanes past the end of
    /// `rays` are inactive.
    #[inline]
    #[must_use]
    pub fn from_rays(rays: &[Ray]) -> Packet<N> {
        let mut p = Packet::EMPTY;
        for (l, ray) in rays.iter().take(N).enumerate() {
            p.set_ray(l, ray);
        }
        p
    }

    /// All lanes active, over the common interval `[tmin, tmax]`.
    #[inline]
    #[must_use]
    pub fn from_vec3(origins: [Vec3; N], dirs: [Vec3; N], tmin: f32, tmax: f32) -> Packet<N> {
        Packet {
            origin: core::array::from_fn(|a| origins.map(|o| o[a])),
            dir: core::array::from_fn(|a| dirs.map(|d| d[a])),
            tmin: [tmin; N],
            tmax: [tmax; N],
            valid: [true; N],
        }
    }

    /// Lane `lane` as a ray (an all-zero ray for `lane >= N`).
    #[inline]
    #[must_use]
    pub fn ray(&self, lane: usize) -> Ray {
        let at = |x: &[f32; N]| x.get(lane).copied().unwrap_or(0.0);
        Ray {
            origin: self.origin.each_ref().map(at),
            tmin: at(&self.tmin),
            dir: self.dir.each_ref().map(at),
            tmax: at(&self.tmax),
        }
    }

    /// Puts `ray` in lane `lane` and activates it (nothing for `lane >= N`).
    #[inline]
    pub fn set_ray(&mut self, lane: usize, ray: &Ray) {
        if lane >= N {
            return;
        }
        for a in 0..3 {
            self.origin[a][lane] = ray.origin[a];
            self.dir[a][lane] = ray.dir[a];
        }
        self.tmin[lane] = ray.tmin;
        self.tmax[lane] = ray.tmax;
        self.valid[lane] = true;
    }
}

/// How many rays the slice entry points trace together.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum PacketWidth {
    /// Single rays.
    One,
    /// Packets of 4 (`f32x4`).
    Four,
    /// Packets of 8 (`f32x8`), the default.
    #[default]
    Eight,
    /// Packets of 16 (`f32x16`): one AVX-512 register per lane vector,
    /// where a node step costs about what it costs for 8 lanes and serves
    /// twice the rays (`docs/results.md`). Built without AVX-512 the slice
    /// entry points trace these slices 8 rays at a time (16 lanes would be
    /// two registers per operation, no faster); the answers are the same.
    Sixteen,
}

impl PacketWidth {
    /// The width for a ray count of 1, 4, 8 or 16.
    #[must_use]
    pub const fn from_lanes(n: usize) -> Option<PacketWidth> {
        match n {
            1 => Some(PacketWidth::One),
            4 => Some(PacketWidth::Four),
            8 => Some(PacketWidth::Eight),
            16 => Some(PacketWidth::Sixteen),
            _ => None,
        }
    }

    /// The rays per packet: 1, 4, 8 or 16.
    #[must_use]
    pub const fn lanes(self) -> usize {
        match self {
            PacketWidth::One => 1,
            PacketWidth::Four => 4,
            PacketWidth::Eight => 8,
            PacketWidth::Sixteen => 16,
        }
    }
}

impl<'a> TriangleTree<'a> {
    /// The closest hit of each lane of `packet`, bit for bit
    /// [`closest_hit`](TriangleTree::closest_hit) of that lane's ray
    /// ([`Hit::MISS`] for inactive lanes).
    ///
    /// # Panics
    /// Never. No allocation; the stack is [`MAX_DEPTH`](crate::MAX_DEPTH) entries.
    ///
    /// # Example
    /// ```
    /// use glam::Vec3;
    /// use kdray_kernel::{Packet4, TriangleTree};
    /// static CUBE: &kdray_kernel::Aligned<[u8]> =
    ///     kdray_kernel::include_aligned!("../../../golden/cube-v3.kdt");
    /// let tree = TriangleTree::from_bytes(&CUBE.bytes)?;
    ///
    /// // A 2x2 bundle of parallel rays from below the cube.
    /// let origins = [(0.2, 0.2), (0.4, 0.2), (0.2, 0.4), (0.4, 0.4)]
    ///     .map(|(x, y)| Vec3::new(x, y, -1.0));
    /// let packet = Packet4::from_vec3(origins, [Vec3::Z; 4], 0.0, f32::INFINITY);
    /// let hits = tree.closest_hit4(&packet);
    /// for (lane, hit) in hits.iter().enumerate() {
    ///     // Every lane is bit for bit its single ray.
    ///     assert_eq!(hit.bits(), tree.closest_hit(&packet.ray(lane)).bits());
    ///     assert_eq!(hit.t, 1.0);
    /// }
    /// # Ok::<(), kdray_kernel::BlobError>(())
    /// ```
    #[inline]
    #[must_use]
    pub fn closest_hit4(&self, packet: &Packet4) -> [Hit; 4] {
        dispatch(ClosestPacket4(self, packet))
    }

    /// [`closest_hit4`](TriangleTree::closest_hit4) for 8 lanes.
    ///
    /// # Panics
    /// Never.
    #[inline]
    #[must_use]
    pub fn closest_hit8(&self, packet: &Packet8) -> [Hit; 8] {
        dispatch(ClosestPacket8(self, packet))
    }

    /// [`closest_hit4`](TriangleTree::closest_hit4) for 16 lanes.
    ///
    /// # Panics
    /// Never.
    #[inline]
    #[must_use]
    pub fn closest_hit16(&self, packet: &Packet16) -> [Hit; 16] {
        dispatch(ClosestPacket16(self, packet))
    }

    /// Whether each lane of `packet` hits any triangle, exactly as
    /// [`any_hit`](TriangleTree::any_hit) of that lane's ray (`false` for
    /// inactive lanes).
    ///
    /// # Panics
    /// Never.
    #[inline]
    #[must_use]
    pub fn any_hit4(&self, packet: &Packet4) -> [bool; 4] {
        dispatch(AnyPacket4(self, packet))
    }

    /// [`any_hit4`](TriangleTree::any_hit4) for 8 lanes.
    ///
    /// # Panics
    /// Never.
    #[inline]
    #[must_use]
    pub fn any_hit8(&self, packet: &Packet8) -> [bool; 8] {
        dispatch(AnyPacket8(self, packet))
    }

    /// [`any_hit4`](TriangleTree::any_hit4) for 16 lanes.
    ///
    /// # Panics
    /// Never.
    #[inline]
    #[must_use]
    pub fn any_hit16(&self, packet: &Packet16) -> [bool; 16] {
        dispatch(AnyPacket16(self, packet))
    }

    /// One packet's closest hits in `V` lanes (the scalar path with the
    /// `scalar-packets` feature): the body of every `closest_hitN`.
    #[inline(always)]
    fn closest_packet<V: Lanes<N>, const N: usize>(&self, packet: &Packet<N>) -> [Hit; N] {
        if cfg!(feature = "scalar-packets") {
            return self.closest_hit_lanes(packet);
        }
        let lr = LaneRays::<V, N>::new(packet, &self.bounds);
        self.closest_lanes(&lr, &mut LaneStack::new(lr.s2))
    }

    /// One packet's any-hit answers in `V` lanes: the body of every
    /// `any_hitN`.
    #[inline(always)]
    fn any_packet<V: Lanes<N>, const N: usize>(&self, packet: &Packet<N>) -> [bool; N] {
        if cfg!(feature = "scalar-packets") {
            return self.any_hit_lanes(packet);
        }
        let lr = LaneRays::<V, N>::new(packet, &self.bounds);
        lane_bools(self.any_lanes(&lr, &mut LaneStack::new(lr.s2)))
    }

    /// The scalar packet path: each active lane traced as a single ray.
    #[must_use]
    pub fn closest_hit_lanes<const N: usize>(&self, packet: &Packet<N>) -> [Hit; N] {
        core::array::from_fn(|l| match packet.valid[l] {
            true => self.closest_hit(&packet.ray(l)),
            false => Hit::MISS,
        })
    }

    /// The scalar any-hit packet path.
    #[must_use]
    pub fn any_hit_lanes<const N: usize>(&self, packet: &Packet<N>) -> [bool; N] {
        core::array::from_fn(|l| packet.valid[l] && self.any_hit(&packet.ray(l)))
    }

    /// The closest hit of every ray, in packets of 8 consecutive rays:
    /// `hits[i]` is bit for bit `closest_hit(&rays[i])`. Only the first
    /// `min(rays.len(), hits.len())` entries are traced.
    ///
    /// # Panics
    /// Never.
    ///
    /// # Example
    /// ```
    /// use glam::Vec3;
    /// use kdray_kernel::{Hit, Ray, TriangleTree};
    /// static CUBE: &kdray_kernel::Aligned<[u8]> =
    ///     kdray_kernel::include_aligned!("../../../golden/cube-v3.kdt");
    /// let tree = TriangleTree::from_bytes(&CUBE.bytes)?;
    ///
    /// // 11 rays fanning out from inside the cube: a packet of 8, then one of 3.
    /// let rays: Vec<Ray> = (0..11)
    ///     .map(|i| Ray::new(Vec3::splat(0.5), Vec3::new(1.0, i as f32 * 0.1 - 0.5, 0.3)))
    ///     .collect();
    /// let mut hits = vec![Hit::MISS; rays.len()];
    /// tree.closest_hits(&rays, &mut hits);
    /// for (ray, hit) in rays.iter().zip(&hits) {
    ///     assert!(hit.is_hit()); // the cube is closed
    ///     assert_eq!(hit.bits(), tree.closest_hit(ray).bits());
    /// }
    /// # Ok::<(), kdray_kernel::BlobError>(())
    /// ```
    pub fn closest_hits(&self, rays: &[Ray], hits: &mut [Hit]) {
        self.closest_hits_with(PacketWidth::Eight, rays, hits);
    }

    /// [`closest_hits`](TriangleTree::closest_hits) with a chosen width.
    pub fn closest_hits_with(&self, width: PacketWidth, rays: &[Ray], hits: &mut [Hit]) {
        self.slice_with::<ClosestHit>(width, rays, hits);
    }

    /// Whether each ray hits anything, in packets of 8 consecutive rays:
    /// `occluded[i] == any_hit(&rays[i])`. Only the first
    /// `min(rays.len(), occluded.len())` entries are traced.
    ///
    /// # Panics
    /// Never.
    pub fn any_hits(&self, rays: &[Ray], occluded: &mut [bool]) {
        self.any_hits_with(PacketWidth::Eight, rays, occluded);
    }

    /// [`any_hits`](TriangleTree::any_hits) with a chosen width.
    pub fn any_hits_with(&self, width: PacketWidth, rays: &[Ray], occluded: &mut [bool]) {
        self.slice_with::<AnyHit>(width, rays, occluded);
    }

    /// [`any_hits_with`](TriangleTree::any_hits_with) over a batch traced
    /// in the Morton order of its rays' origins ([`MortonGrid`],
    /// [`sort_items`]), each answer in its ray's slot: the same answers.
    /// For a large batch of scattered shadow rays (origins far apart from
    /// one ray to the next, [`TriangleTree::rays_scattered`]), whose walks
    /// then share cells, nodes and triangles that stay in cache: on a
    /// million shadow rays from random surface points (`matrix.sh`'s),
    /// one core, against `any_hits_with` over the batch in its order,
    /// 1.7-2.4x the rays a second single and 3.2-4.2x 8-wide, the sort
    /// included (bunny and teapot; docs/results.md). `scratch` holds two `u64`
    /// a ray (2 `rays.len()`); with less, or past `u32::MAX` rays, the
    /// batch is traced in its own order. Rays are gathered 256 at a time
    /// on the stack (8 KiB).
    pub fn any_hits_by_origin(
        &self,
        width: PacketWidth,
        rays: &[Ray],
        occluded: &mut [bool],
        scratch: &mut [u64],
    ) {
        let rays = rays.get(..occluded.len()).unwrap_or(rays);
        self.any_hits_by_origin_each(width, rays, scratch, |i, o| {
            if let Some(x) = occluded.get_mut(i) {
                *x = o;
            }
        });
    }

    /// [`any_hits_by_origin`](TriangleTree::any_hits_by_origin), handing
    /// each answer to `answer(ray index, occluded)` (for outputs of another
    /// type, as the C API's `int32_t`s).
    pub fn any_hits_by_origin_each(
        &self,
        width: PacketWidth,
        rays: &[Ray],
        scratch: &mut [u64],
        mut answer: impl FnMut(usize, bool),
    ) {
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
                self.any_hits_with(width, c, a);
            }
            for (k, &a) in answers.iter().enumerate().take(m) {
                answer(at(k), a);
            }
        }
    }

    /// The slice entry points at any width, for either query.
    fn slice_with<Q: SliceQuery>(&self, width: PacketWidth, rays: &[Ray], out: &mut [Q::Out]) {
        // The scalar path traces each ray alone (the packet entry points'
        // `scalar-packets` rule).
        let width = if cfg!(feature = "scalar-packets") {
            PacketWidth::One
        } else {
            width
        };
        // Blocks of rays whose origins lie far apart share no cells: single
        // rays walked in turns (`stream.rs`). Blocks hold whole packets of
        // every width, so the others are packed as the slice is.
        let mut memo = Q::Memo::default();
        let turns = Q::STREAM.filter(|_| {
            IN_TURNS && (self.data_bytes() > TURNS_MIN_BYTES || !self.lines.is_empty())
        });
        for (rays, out) in rays.chunks(BLOCK).zip(out.chunks_mut(BLOCK)) {
            if let Some(stream) = turns.filter(|_| scattered(rays, &self.bounds)) {
                stream(self, rays, out);
                continue;
            }
            match width {
                PacketWidth::One => {
                    for (o, r) in out.iter_mut().zip(rays) {
                        *o = Q::one_after(self, r, &mut memo);
                    }
                }
                PacketWidth::Four => dispatch(Slice4::<Q>(self, rays, out)),
                // 16 lanes only where they are one register (`PacketWidth::Sixteen`).
                PacketWidth::Sixteen if sixteen_lanes() => {
                    dispatch(Slice16::<Q>(self, rays, out));
                }
                PacketWidth::Eight | PacketWidth::Sixteen => dispatch(Slice8::<Q>(self, rays, out)),
            }
        }
    }
}

impl TriangleTree<'_> {
    /// Whether consecutive rays of `rays` start far apart in this tree's
    /// scene: the test the slice entry points make on each block of 256
    /// rays before choosing a walk (random rays and shadow rays from
    /// random surface points are scattered; camera rays and rays in pixel
    /// order are not). A caller holding a large batch of scattered rays
    /// gains by tracing them in the order of their origins
    /// (`kdray_tools::trace` does).
    #[must_use]
    pub fn rays_scattered(&self, rays: &[Ray]) -> bool {
        scattered(rays, &self.bounds)
    }

    /// The bytes a walk reads from: nodes, primitive indices, triangles.
    pub(super) fn data_bytes(&self) -> usize {
        core::mem::size_of_val(self.nodes)
            + core::mem::size_of_val(self.prims)
            + core::mem::size_of_val(self.triangles)
    }
}

/// The rays the slice entry points choose a path for at a time (a multiple
/// of every packet width).
const BLOCK: usize = 256;

/// Whether scattered rays are walked in turns: where the walks' misses can
/// overlap (an out-of-order core with caches and a prefetch, x86-64 here).
/// Elsewhere (a microcontroller) turns would only add work and 6 KiB of
/// stack for their eight walks.
const IN_TURNS: bool = cfg!(target_arch = "x86_64");

/// Trees of at most this many bytes (nodes, indices and triangles) walk
/// scattered rays one at a time: 1 MiB, the L2 cache of the x86-64 cores
/// measured. A tree that stays in cache has no misses for turns to
/// overlap, only their hand-over to pay: the teapot (455 KB) ran random
/// rays at 0.71x in turns, where the bunny (4.7 MB) ran them at 1.08-1.45x
/// (one core, interleaved, plain build). Sponza (6.0 MB) still loses on
/// random rays (0.76-0.94x against no turns, three interleaved rounds):
/// they end after 8.3 steps, in the top of the tree, which stays cached;
/// the bunny's take 11.3 and gain 1.05-1.14x. Under `cfg(fuzzing)` every tree qualifies, so the fuzz
/// targets' small trees reach the walk in turns.
pub(super) const TURNS_MIN_BYTES: usize = if cfg!(fuzzing) { 0 } else { 1 << 20 };

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
fn scattered(rays: &[Ray], bounds: &Bounds) -> bool {
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

/// Whether the slice entry points trace `PacketWidth::Sixteen` in 16
/// lanes: where 16 lanes are one register (AVX-512, built for or
/// detected). Elsewhere they are two `f32x8` or four `f32x4` per
/// operation, and 8-lane packets are as fast or faster (an AVX2 build: 16
/// lanes 2% slower), so those slices go 8 at a time.
#[inline]
fn sixteen_lanes() -> bool {
    cfg!(target_feature = "avx512f") || crate::cpu::isa() == crate::cpu::Isa::Avx512
}

/// The packet entry points' jobs: one packet in the level's lane type of
/// its width.
macro_rules! packet_jobs {
    ($($job:ident, $n:literal, $x:ident, $out:ty, $method:ident;)*) => {$(
        #[doc = concat!("`", stringify!($method), "` of one packet of ", $n, ".")]
        struct $job<'t, 'a>(&'t TriangleTree<'a>, &'t Packet<$n>);

        impl Job for $job<'_, '_> {
            type Out = $out;
            #[inline(always)]
            fn run<L: Level>(self) -> $out {
                self.0.$method::<L::$x, $n>(self.1)
            }
        }
    )*};
}

packet_jobs! {
    ClosestPacket4, 4, X4, [Hit; 4], closest_packet;
    ClosestPacket8, 8, X8, [Hit; 8], closest_packet;
    ClosestPacket16, 16, X16, [Hit; 16], closest_packet;
    AnyPacket4, 4, X4, [bool; 4], any_packet;
    AnyPacket8, 8, X8, [bool; 8], any_packet;
    AnyPacket16, 16, X16, [bool; 16], any_packet;
}

/// The slice entry points' jobs: a slice of rays in packets of a width.
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

/// A query the slice entry points run, as a single ray and over lanes.
trait SliceQuery {
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
    /// Each ray's answer, single rays walked in turns (`stream.rs`), for
    /// a query whose scattered rays take turns.
    const STREAM: Option<Stream<Self::Out>>;
    fn lanes<V: Lanes<N>, const N: usize>(
        tree: &TriangleTree<'_>,
        lr: &LaneRays<V, N>,
        stack: &mut LaneStack<V>,
    ) -> [Self::Out; N];
}

/// A slice of rays walked in turns, answers into the second slice.
type Stream<Out> = fn(&TriangleTree<'_>, &[Ray], &mut [Out]);

/// The closest hit.
struct ClosestHit;

impl SliceQuery for ClosestHit {
    type Out = Hit;
    type Memo = ();
    #[inline(always)]
    fn one(tree: &TriangleTree<'_>, ray: &Ray) -> Hit {
        tree.closest_hit(ray)
    }
    const STREAM: Option<Stream<Hit>> =
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
struct AnyHit;

/// The triangle that occluded the last ray ([`MISS`] before any did).
struct Occluder(u32);

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
    const STREAM: Option<Stream<bool>> = None;
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

/// A lane bitmask as booleans.
#[inline]
fn lane_bools<const N: usize>(bits: u32) -> [bool; N] {
    core::array::from_fn(|l| bits >> l & 1 == 1)
}

#[cfg(test)]
mod tests;
