//! The top-level walk: the lecture's loop over the instance tree, with the
//! mesh walk's slack rule (`triangle_tree::cell_ray`): a cell is skipped
//! only when the ray's interval misses it by more than the slack, and a
//! far cell popped after a hit only when it starts more than the slack
//! beyond it. In a leaf, each instance the ray's mask selects is traced in
//! its own space by its mesh tree, over `[tmin, best t]`.

use super::Scene;
use crate::blob::{Node, MAX_DEPTH};
use crate::geometry::{Hit, Ray, MISS};
use crate::lanes::Span;
use crate::triangle::{FirstHits, Ranked, ShearedRay};
use crate::triangle_tree::cell_ray::CellRay;
use crate::triangle_tree::packet::Packet;
use bytemuck::{Pod, Zeroable};

/// A scene's closest hit: `repr(C)`, Pod, 20 bytes. `instance` and `prim`
/// are [`MISS`] for a miss; `t`, `u`, `v` as in [`Hit`] (`u`, `v` the
/// barycentric weights of the mesh triangle's vertices 1 and 2).
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
#[repr(C)]
pub struct SceneHit {
    /// Ray parameter of the hit (the same in world and instance space);
    /// `+inf` for a miss.
    pub t: f32,
    /// The triangle's index in its mesh.
    pub prim: u32,
    /// Barycentric weight of vertex 1.
    pub u: f32,
    /// Barycentric weight of vertex 2.
    pub v: f32,
    /// The instance's index in the scene.
    pub instance: u32,
}

impl SceneHit {
    /// The miss record.
    pub const MISS: SceneHit = SceneHit {
        t: f32::INFINITY,
        prim: MISS,
        u: 0.0,
        v: 0.0,
        instance: MISS,
    };

    /// Did the ray hit?
    #[inline]
    #[must_use]
    pub const fn is_hit(&self) -> bool {
        self.instance != MISS
    }

    /// The mesh-level hit record (`prim` the triangle in its mesh).
    #[inline]
    #[must_use]
    pub fn hit(&self) -> Hit {
        Hit {
            t: self.t,
            prim: self.prim,
            u: self.u,
            v: self.v,
        }
    }

    /// Bitwise equality, as the exactness tests compare.
    #[inline]
    #[must_use]
    pub fn bits(&self) -> [u32; 5] {
        bytemuck::cast(*self)
    }

    /// Keeps `h`, the hit of instance `instance` found over `[tmin, self.t]`,
    /// if it wins: smaller `t`, or equal `t` and a lower instance (the
    /// mesh tree already chose the lower triangle).
    #[inline(always)]
    pub(crate) fn keep(&mut self, h: Hit, instance: u32) {
        if h.is_hit() && (h.t < self.t || (h.t == self.t && instance < self.instance)) {
            *self = SceneHit {
                t: h.t,
                prim: h.prim,
                u: h.u,
                v: h.v,
                instance,
            };
        }
    }
}

/// A scene's first hits are ranked by `t`, then instance, then triangle.
impl Ranked for SceneHit {
    #[inline(always)]
    fn t(&self) -> f32 {
        self.t
    }
    #[inline(always)]
    fn key(&self) -> u64 {
        Self::key_of(self.prim, self.instance)
    }
    #[inline(always)]
    fn key_of(prim: u32, instance: u32) -> u64 {
        u64::from(instance) << 32 | u64::from(prim)
    }
    #[inline(always)]
    fn from_hit(h: Hit, instance: u32) -> SceneHit {
        SceneHit {
            t: h.t,
            prim: h.prim,
            u: h.u,
            v: h.v,
            instance,
        }
    }
}

/// A far cell waiting on the stack with its interval (widened by the slack).
#[derive(Clone, Copy, Debug, Default)]
struct Pending {
    node: u32,
    lo: f32,
    hi: f32,
}

/// What the walk does with a leaf's instances.
trait Visit {
    /// The end of the ray's current interval.
    fn bound(&self) -> f32;
    /// Traces instance `i`; `true` when the answer is known.
    fn instance(&mut self, scene: &Scene<'_>, i: u32) -> bool;
    /// Far child first when both are visited (the mesh walk's
    /// `Visit::FAR_FIRST`, `triangle_tree/walk.rs`).
    const FAR_FIRST: bool = false;
}

/// The instances a ray has traced lately: an instance's box lies in
/// several leaves, and its first visit traced the whole ray (over `[tmin,
/// best t]`, not the cell), so a later visit can only find the same hit
/// or none (the interval has only shrunk) and is skipped. Eight entries,
/// replaced in turn; an instance that dropped out is traced again, which
/// costs time, never an answer.
#[derive(Default)]
pub(super) struct Mailbox {
    ids: [u32; MAILBOX],
    len: usize,
}

/// Entries in a [`Mailbox`].
const MAILBOX: usize = 8;

impl Mailbox {
    /// Was `i` traced lately? If not, it is noted as traced now.
    #[inline(always)]
    pub(super) fn seen(&mut self, i: u32) -> bool {
        let filled = self.ids.get(..self.len.min(MAILBOX)).unwrap_or(&[]);
        if filled.contains(&i) {
            return true;
        }
        if let Some(slot) = self.ids.get_mut(self.len % MAILBOX) {
            *slot = i;
        }
        self.len = self.len.wrapping_add(1);
        false
    }
}

struct ClosestVisit<'r> {
    ray: &'r Ray,
    mask: u32,
    best: SceneHit,
    traced: Mailbox,
}

impl Visit for ClosestVisit<'_> {
    #[inline(always)]
    fn bound(&self) -> f32 {
        self.best.t.min(self.ray.tmax)
    }

    #[inline(always)]
    fn instance(&mut self, scene: &Scene<'_>, i: u32) -> bool {
        // The best instance met again (it lies in several leaves) cannot win.
        if i == self.best.instance || self.traced.seen(i) {
            return false;
        }
        let Some((inst, mesh)) = scene.selected(i, self.mask) else {
            return false;
        };
        let mut local = inst.local_ray(self.ray);
        local.tmax = self.bound();
        self.best.keep(mesh.closest_hit(&local), i);
        false
    }
}

struct FirstVisit<'r, 'o> {
    ray: &'r Ray,
    mask: u32,
    first: FirstHits<'o, SceneHit>,
    traced: Mailbox,
}

impl Visit for FirstVisit<'_, '_> {
    #[inline(always)]
    fn bound(&self) -> f32 {
        self.first.bound(self.ray.tmax)
    }

    #[inline(always)]
    fn instance(&mut self, scene: &Scene<'_>, i: u32) -> bool {
        // An instance traced lately offered every hit up to the bound,
        // which has only shrunk since.
        if self.traced.seen(i) {
            return false;
        }
        if let Some((inst, mesh)) = scene.selected(i, self.mask) {
            let local = inst.local_ray(self.ray);
            mesh.first_hits_into::<_, { MAX_DEPTH as usize }>(&local, &mut self.first, i);
        }
        false
    }
}

struct AnyVisit<'r> {
    ray: &'r Ray,
    mask: u32,
    traced: Mailbox,
}

impl Visit for AnyVisit<'_> {
    /// Back to front: a shadow ray leaves the instance it starts on last.
    const FAR_FIRST: bool = true;

    #[inline(always)]
    fn bound(&self) -> f32 {
        self.ray.tmax
    }

    #[inline(always)]
    fn instance(&mut self, scene: &Scene<'_>, i: u32) -> bool {
        !self.traced.seen(i)
            && scene
                .selected(i, self.mask)
                .is_some_and(|(inst, mesh)| mesh.any_hit(&inst.local_ray(self.ray)))
    }
}

impl<'a> Scene<'a> {
    /// Instance `i` and its mesh, when `mask` selects it.
    #[inline(always)]
    pub(crate) fn selected(
        &self,
        i: u32,
        mask: u32,
    ) -> Option<(&'a super::Instance, crate::triangle_tree::TriangleTree<'a>)> {
        let inst = self.instances.get(i as usize)?;
        if inst.mask() & mask == 0 {
            return None;
        }
        Some((inst, self.mesh(inst.mesh())?))
    }

    /// The closest hit of `ray` among the instances `mask` selects
    /// (`instance mask & mask != 0`): the smallest `t`, then the lower
    /// instance, then the lower triangle, bit for bit
    /// [`Scene::closest_hit_brute`]. [`SceneHit::MISS`] for a miss or an
    /// invalid ray.
    ///
    /// # Panics
    /// Never. No allocation; the stack is [`MAX_DEPTH`] entries here and
    /// one mesh walk's below.
    #[must_use]
    pub fn closest_hit(&self, ray: &Ray, mask: u32) -> SceneHit {
        let mut visit = ClosestVisit {
            ray,
            mask,
            best: SceneHit::MISS,
            traced: Mailbox::default(),
        };
        self.walk(ray, &mut visit);
        visit.best
    }

    /// Does any instance `mask` selects hit `ray` in `[tmin, tmax]`?
    /// Exactly when [`Scene::any_hit_brute`] says so.
    ///
    /// # Panics
    /// Never.
    #[must_use]
    pub fn any_hit(&self, ray: &Ray, mask: u32) -> bool {
        self.walk(
            ray,
            &mut AnyVisit {
                ray,
                mask,
                traced: Mailbox::default(),
            },
        )
    }

    /// The first `out.len()` hits of `ray` among the instances `mask`
    /// selects, sorted by `t`, then instance, then triangle, each
    /// instance's triangle once, written to the front of `out`; returns
    /// how many. Bit for bit [`Scene::first_hits_brute`]; the first is
    /// [`Scene::closest_hit`] (the mesh-level query:
    /// [`TriangleTree::first_hits`](crate::TriangleTree::first_hits)).
    ///
    /// # Panics
    /// Never. No allocation; the stack is [`MAX_DEPTH`] entries here and
    /// one mesh walk's below.
    #[must_use]
    pub fn first_hits(&self, ray: &Ray, mask: u32, out: &mut [SceneHit]) -> usize {
        if out.is_empty() {
            return 0;
        }
        let mut visit = FirstVisit {
            ray,
            mask,
            first: FirstHits::new(out),
            traced: Mailbox::default(),
        };
        self.walk(ray, &mut visit);
        visit.first.len()
    }

    /// [`Scene::closest_hit`] for each active lane of a packet of 4, 8 or
    /// 16 rays (inactive lanes miss): each lane bit for bit its single ray.
    #[must_use]
    pub fn closest_hit_packet<const N: usize>(
        &self,
        packet: &Packet<N>,
        mask: u32,
    ) -> [SceneHit; N] {
        core::array::from_fn(|l| match packet.valid.get(l) {
            Some(true) => self.closest_hit(&packet.ray(l), mask),
            _ => SceneHit::MISS,
        })
    }

    /// [`Scene::any_hit`] for each active lane of a packet (inactive lanes: `false`).
    #[must_use]
    pub fn any_hit_packet<const N: usize>(&self, packet: &Packet<N>, mask: u32) -> [bool; N] {
        core::array::from_fn(|l| {
            packet.valid.get(l) == Some(&true) && self.any_hit(&packet.ray(l), mask)
        })
    }

    /// The traversal loop: `visit` sees each non-empty leaf's instances in
    /// front-to-back order of cells (back to front with `V::FAR_FIRST`). `true` when `visit` stopped it.
    fn walk<V: Visit>(&self, ray: &Ray, visit: &mut V) -> bool {
        let Some(sr) = ShearedRay::new(ray) else {
            return false;
        };
        let Some(cr) = CellRay::new(ray, sr.k[2], &self.bounds) else {
            return false;
        };
        let s2 = cr.slack + cr.slack;
        let mut stack = [Pending::default(); MAX_DEPTH as usize];
        let mut sp = 0usize;
        let (mut lo, mut hi) = cr.start();
        let Some(&(mut node)) = self.nodes.first() else {
            return false;
        };
        loop {
            let axis = node.axis_bits();
            if let (Some(&o), Some(&inv)) = (cr.org.get(axis), cr.inv.get(axis)) {
                // Compute parametric distance along ray to split plane.
                let t_split = (node.split() - o) * inv;
                let first = node.first_child(cr.above_first_nibbles);
                let second = node.other_child(first);
                let (Some(&near), Some(&far)) = (self.nodes.get(first), self.nodes.get(second))
                else {
                    return false; // only an unchecked, invalid tree
                };
                // "Not outside", so a NaN t_split visits both (walk.rs).
                #[allow(clippy::neg_cmp_op_on_partial_ord)]
                let (visit_near, visit_far) = (!(t_split < lo), !(t_split > hi));
                let far_lo = lo.far_lo(t_split, s2);
                let both = visit_near && visit_far && !near.is_empty_leaf() && !far.is_empty_leaf();
                if V::FAR_FIRST && both {
                    // Back to front: the near child waits.
                    let Some(slot) = stack.get_mut(sp) else {
                        return false;
                    };
                    *slot = Pending {
                        node: first as u32,
                        lo,
                        hi: hi.near_hi(t_split, s2),
                    };
                    sp += 1;
                    node = far;
                    lo = far_lo;
                } else if visit_near {
                    if visit_far && !far.is_empty_leaf() {
                        // Advance to the near child, enqueue the far one.
                        let Some(slot) = stack.get_mut(sp) else {
                            return false;
                        };
                        *slot = Pending {
                            node: second as u32,
                            lo: far_lo,
                            hi,
                        };
                        sp += 1;
                    }
                    node = near;
                    hi = hi.near_hi(t_split, s2);
                } else {
                    node = far;
                    lo = far_lo;
                }
                continue;
            }
            if visit_leaf(self, node, visit) {
                return true;
            }
            let cutoff = visit.bound().cutoff(s2);
            // Advance to the next far cell that can still hold a better hit.
            loop {
                let Some(next) = sp.checked_sub(1) else {
                    return false;
                };
                sp = next;
                let Some(p) = stack.get(sp) else {
                    return false;
                };
                if p.lo <= cutoff {
                    let Some(&n) = self.nodes.get(p.node as usize) else {
                        return false;
                    };
                    (node, lo, hi) = (n, p.lo, Span::min(p.hi, cutoff));
                    break;
                }
            }
        }
    }
}

/// Visits the instances of leaf `node`: its one instance or its run of
/// the instance-index array.
#[inline(always)]
fn visit_leaf<V: Visit>(scene: &Scene<'_>, node: Node, visit: &mut V) -> bool {
    let count = node.upper();
    if count == 1 {
        return visit.instance(scene, node.word0());
    }
    let start = node.word0() as usize;
    let run = scene
        .prims
        .get(start..start.saturating_add(count as usize))
        .unwrap_or(&[]);
    run.iter().any(|&i| visit.instance(scene, i))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_mailbox_remembers_the_last_eight_instances() {
        let mut m = Mailbox::default();
        // Nothing seen yet, instance 0 included (the empty slots hold 0).
        assert!(!m.seen(0));
        assert!(m.seen(0));
        for i in 1..8 {
            assert!(!m.seen(i), "{i} is new");
        }
        assert!((0..8).all(|i| m.seen(i)), "all eight remembered");
        // A ninth replaces the oldest, 0, which is then traced again.
        assert!(!m.seen(8));
        assert!(!m.seen(0));
        assert!(m.seen(8) && m.seen(7));
    }
}
