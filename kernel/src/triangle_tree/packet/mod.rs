//! Ray packets: 4, 8 or 16 rays traced together through one walk of the tree,
//! each lane answering exactly as its single ray would, bit for bit.
//!
//! - [`Packet`] holds the rays in structure-of-arrays layout with a
//!   `valid` flag per lane (inactive lanes miss); build one from rays
//!   ([`Packet::from_rays`]) or glam vectors ([`Packet::from_vec3`]).
//! - [`TriangleTree::closest_hit_packet`] and
//!   [`any_hit_packet`](TriangleTree::any_hit_packet) trace one packet of
//!   4, 8 or 16 lanes ([`PacketLanes`]) with `wide`'s `f32x4` / `f32x8` /
//!   `f32x16` at the dispatched level.
//! - The scalar path (one single ray per lane) is always compiled; the
//!   `scalar-packets` feature makes every packet entry point take it.
//! - Batches form packets of consecutive rays themselves (`batch.rs`).
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
use crate::geometry::{Hit, Ray};
use crate::lanes::{dispatch, Job, Lanes, Level};
use glam::Vec3;
pub(super) use lane_rays::LaneRays;
pub(super) use walk::LaneStack;

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

/// How many rays a batch traces together, when the caller fixes it
/// ([`Batch::width`](crate::Batch::width)).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PacketWidth {
    /// Single rays.
    One,
    /// Packets of 4 (`f32x4`).
    Four,
    /// Packets of 8 (`f32x8`).
    Eight,
    /// Packets of 16 (`f32x16`): one AVX-512 register per lane vector,
    /// where a node step costs about what it costs for 8 lanes and serves
    /// twice the rays (`docs/results.md`). Built without AVX-512 a batch
    /// traces these 8 rays at a time (16 lanes would be
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
    /// The closest hit of each lane of `packet` (4, 8 or 16 lanes), bit
    /// for bit [`closest_hit`](TriangleTree::closest_hit) of that lane's ray
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
    /// let hits = tree.closest_hit_packet(&packet);
    /// for (lane, hit) in hits.iter().enumerate() {
    ///     // Every lane is bit for bit its single ray.
    ///     assert_eq!(hit.bits(), tree.closest_hit(&packet.ray(lane)).bits());
    ///     assert_eq!(hit.t, 1.0);
    /// }
    /// # Ok::<(), kdray_kernel::BlobError>(())
    /// ```
    #[inline]
    #[must_use]
    pub fn closest_hit_packet<const N: usize>(&self, packet: &Packet<N>) -> [Hit; N]
    where
        Packet<N>: PacketLanes<N>,
    {
        <Packet<N> as PacketLanes<N>>::closest(self, packet)
    }

    /// Whether each lane of `packet` hits any triangle, exactly as
    /// [`any_hit`](TriangleTree::any_hit) of that lane's ray (`false` for
    /// inactive lanes).
    ///
    /// # Panics
    /// Never.
    #[inline]
    #[must_use]
    pub fn any_hit_packet<const N: usize>(&self, packet: &Packet<N>) -> [bool; N]
    where
        Packet<N>: PacketLanes<N>,
    {
        <Packet<N> as PacketLanes<N>>::any(self, packet)
    }

    /// One packet's closest hits in `V` lanes (the scalar path with the
    /// `scalar-packets` feature): the body of `closest_hit_packet`.
    #[inline(always)]
    fn closest_packet<V: Lanes<N>, const N: usize>(&self, packet: &Packet<N>) -> [Hit; N] {
        if cfg!(feature = "scalar-packets") {
            return self.closest_hit_lanes(packet);
        }
        let lr = LaneRays::<V, N>::new(packet, &self.bounds);
        self.closest_lanes(&lr, &mut LaneStack::new(lr.s2))
    }

    /// One packet's any-hit answers in `V` lanes: the body of
    /// `any_hit_packet`.
    #[inline(always)]
    fn any_packet<V: Lanes<N>, const N: usize>(&self, packet: &Packet<N>) -> [bool; N] {
        if cfg!(feature = "scalar-packets") {
            return self.any_hit_lanes(packet);
        }
        let lr = LaneRays::<V, N>::new(packet, &self.bounds);
        lane_bools(self.any_lanes(&lr, &mut LaneStack::new(lr.s2)))
    }

    /// The scalar packet path: each active lane traced as a single ray.
    fn closest_hit_lanes<const N: usize>(&self, packet: &Packet<N>) -> [Hit; N] {
        core::array::from_fn(|l| match packet.valid[l] {
            true => self.closest_hit(&packet.ray(l)),
            false => Hit::MISS,
        })
    }

    /// The scalar any-hit packet path.
    fn any_hit_lanes<const N: usize>(&self, packet: &Packet<N>) -> [bool; N] {
        core::array::from_fn(|l| packet.valid[l] && self.any_hit(&packet.ray(l)))
    }
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

/// The packets traced in lanes: [`Packet4`], [`Packet8`] and
/// [`Packet16`] (the widths the kernel has lane types for), as
/// [`TriangleTree::closest_hit_packet`] takes them.
pub trait PacketLanes<const N: usize> {
    /// [`TriangleTree::closest_hit_packet`] at this width.
    #[doc(hidden)]
    fn closest(tree: &TriangleTree<'_>, packet: &Packet<N>) -> [Hit; N];
    /// [`TriangleTree::any_hit_packet`] at this width.
    #[doc(hidden)]
    fn any(tree: &TriangleTree<'_>, packet: &Packet<N>) -> [bool; N];
}

macro_rules! packet_lanes {
    ($($n:literal, $closest:ident, $any:ident;)*) => {$(
        impl PacketLanes<$n> for Packet<$n> {
            #[inline]
            fn closest(tree: &TriangleTree<'_>, packet: &Packet<$n>) -> [Hit; $n] {
                dispatch($closest(tree, packet))
            }
            #[inline]
            fn any(tree: &TriangleTree<'_>, packet: &Packet<$n>) -> [bool; $n] {
                dispatch($any(tree, packet))
            }
        }
    )*};
}

packet_lanes! {
    4, ClosestPacket4, AnyPacket4;
    8, ClosestPacket8, AnyPacket8;
    16, ClosestPacket16, AnyPacket16;
}

/// A lane bitmask as booleans.
#[inline]
pub(super) fn lane_bools<const N: usize>(bits: u32) -> [bool; N] {
    core::array::from_fn(|l| bits >> l & 1 == 1)
}

#[cfg(test)]
mod tests;
