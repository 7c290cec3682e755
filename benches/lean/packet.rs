//! The lean walk for a coherent packet: the lecture's loop once for all
//! lanes. At an interior node every lane computes its own t_split; the
//! lanes with `t_split >= lo` go to the near child, those with
//! `t_split <= hi` to the far child (an empty child takes none); the far
//! child waits on one stack with its lanes and their own `[lo, hi]`.
//! At a leaf each triangle is tested against all lanes at once (plain
//! `f32` Möller-Trumbore, the single lean walk's arithmetic in lanes),
//! and a lane whose best hit lies within the cell is done (early exit
//! per lane). Packets whose lanes disagree on a direction sign would not
//! share a near child: their lanes take the single lean walk.

use super::lanes::{Lanes, Ymm, Zmm};
use super::{leaf_run, lean_closest};
use kdray::kernel::{Ray, Triangle, TriangleTree};
use std::hint::black_box;

/// A far child waiting on the stack: its lanes and their intervals.
#[derive(Clone, Copy)]
struct Pending<V> {
    node: u32,
    lanes: u32,
    lo: V,
    hi: V,
}

/// The stack depth, as the single lean walk's (deeper far children are
/// dropped, as there).
const DEPTH: usize = 64;

/// One lane coordinate of each ray of a packet.
#[inline(always)]
fn column<V: Lanes<N>, const N: usize>(rays: &[Ray], at: fn(&Ray) -> f32) -> V {
    let mut a = [0.0f32; N];
    for (x, r) in a.iter_mut().zip(rays) {
        *x = at(r);
    }
    V::from_array(a)
}

/// Each lane's best `t` and triangle (its bits in an `f32` lane).
struct Best<V> {
    t: V,
    prim: V,
}

/// Plain Möller-Trumbore of one triangle against the lanes in `lanes`:
/// the single lean walk's operations, in its order, in every lane; a
/// lane that hits nearer than its best keeps the hit.
#[inline(always)]
fn moller_trumbore_lanes<V: Lanes<N>, const N: usize>(
    tri: &Triangle,
    p: u32,
    org: &[V; 3],
    dir: &[V; 3],
    tmin: V,
    lanes: u32,
    best: &mut Best<V>,
) {
    let sub = |a: [f32; 3], b: [f32; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let [v0, v1, v2] = tri.v;
    let (e1, e2) = (sub(v1, v0), sub(v2, v0));
    let [e1x, e1y, e1z] = [V::splat(e1[0]), V::splat(e1[1]), V::splat(e1[2])];
    let [e2x, e2y, e2z] = [V::splat(e2[0]), V::splat(e2[1]), V::splat(e2[2])];
    let [dx, dy, dz] = *dir;
    // p = d x e2, det = e1 . p
    let px = dy.mul(e2z).sub(dz.mul(e2y));
    let py = dz.mul(e2x).sub(dx.mul(e2z));
    let pz = dx.mul(e2y).sub(dy.mul(e2x));
    let det = e1x.mul(px).add(e1y.mul(py)).add(e1z.mul(pz));
    let (zero, one) = (V::splat(0.0), V::splat(1.0));
    let inv = one.div(det);
    // s = o - v0, u = (s . p) / det
    let sx = org[0].sub(V::splat(v0[0]));
    let sy = org[1].sub(V::splat(v0[1]));
    let sz = org[2].sub(V::splat(v0[2]));
    let u = sx.mul(px).add(sy.mul(py)).add(sz.mul(pz)).mul(inv);
    // q = s x e1, v = (d . q) / det
    let qx = sy.mul(e1z).sub(sz.mul(e1y));
    let qy = sz.mul(e1x).sub(sx.mul(e1z));
    let qz = sx.mul(e1y).sub(sy.mul(e1x));
    let v = dx.mul(qx).add(dy.mul(qy)).add(dz.mul(qz)).mul(inv);
    let inside = lanes & det.ne(zero) & zero.le(u) & u.le(one) & !v.lt(zero) & !one.lt(u.add(v));
    if inside == 0 {
        return;
    }
    let t = e2x.mul(qx).add(e2y.mul(qy)).add(e2z.mul(qz)).mul(inv);
    let wins = inside & tmin.lt(t) & t.lt(best.t);
    if wins != 0 {
        best.t = V::select(wins, t, best.t);
        best.prim = V::select(wins, V::splat(f32::from_bits(p)), best.prim);
    }
}

/// The closest hit of each ray of a packet of `N` (`(t, triangle)`,
/// `u32::MAX` for none) into `out`; `false` (nothing written) when its
/// rays disagree on a direction sign.
#[inline(always)]
fn lean_packet<V: Lanes<N>, const N: usize>(
    tree: &TriangleTree,
    rays: &[Ray],
    stack: &mut [Pending<V>; DEPTH],
    out: &mut [(f32, u32)],
) -> bool {
    let (nodes, prims, tris, b) = (
        tree.nodes(),
        tree.prim_indices(),
        tree.triangles(),
        tree.bounds(),
    );
    let org: [V; 3] = [
        column(rays, |r| r.origin[0]),
        column(rays, |r| r.origin[1]),
        column(rays, |r| r.origin[2]),
    ];
    let dir: [V; 3] = [
        column(rays, |r| r.dir[0]),
        column(rays, |r| r.dir[1]),
        column(rays, |r| r.dir[2]),
    ];
    let (tmin, tmax): (V, V) = (column(rays, |r| r.tmin), column(rays, |r| r.tmax));
    let one = V::splat(1.0);
    let inv = [one.div(dir[0]), one.div(dir[1]), one.div(dir[2])];
    // One near child for every lane only when the lanes share their
    // signs: the single walk's `above_first`, from any lane.
    let all = u32::MAX >> (32 - N);
    let mut above_first = [0usize; 3];
    for (a, i) in above_first.iter_mut().zip(&inv) {
        match i.lt(V::splat(0.0)) {
            0 => *a = 0,
            m if m == all => *a = 1,
            _ => return false,
        }
    }
    // Clip each lane to the scene box (slab test).
    let (mut lo, mut hi) = (tmin, tmax);
    for (a, (o, i)) in org.iter().zip(&inv).enumerate() {
        let t0 = V::splat(b.min[a]).sub(*o).mul(*i);
        let t1 = V::splat(b.max[a]).sub(*o).mul(*i);
        lo = lo.max(t0.min(t1));
        hi = hi.min(t0.max(t1));
    }
    let mut best = Best {
        t: tmax,
        prim: V::splat(f32::from_bits(u32::MAX)),
    };
    // Lanes still searching.
    let mut alive = all & !hi.lt(lo);
    let (mut lanes, mut node, mut sp) = (alive, nodes[0], 0);
    'walk: while alive != 0 {
        let axis = node.axis_bits();
        if axis < 3 {
            let t = V::splat(node.split()).sub(org[axis]).mul(inv[axis]);
            let near = node.upper() as usize + above_first[axis];
            let far = near ^ 1;
            let (n, f) = (nodes[near], nodes[far]);
            // The single walk's tests lane by lane: near unless
            // t_split < lo, far unless t_split > hi; empty cells skipped.
            let go_near = if n.is_empty_leaf() {
                0
            } else {
                lanes & lo.le(t)
            };
            let go_far = if f.is_empty_leaf() {
                0
            } else {
                lanes & t.le(hi)
            };
            if go_near != 0 {
                if go_far != 0 && sp < DEPTH {
                    stack[sp] = Pending {
                        node: far as u32,
                        lanes: go_far,
                        lo: lo.max(t),
                        hi,
                    };
                    sp += 1;
                }
                (node, lanes, hi) = (n, go_near, hi.min(t));
                continue;
            } else if go_far != 0 {
                (node, lanes, lo) = (f, go_far, lo.max(t));
                continue;
            }
        } else {
            let one = [node.word0()];
            for &p in leaf_run(node, prims, &one) {
                moller_trumbore_lanes(&tris[p as usize], p, &org, &dir, tmin, lanes, &mut best);
            }
            // A lane whose best hit lies in this cell is done.
            alive &= !(lanes & best.t.le(hi));
            if alive == 0 {
                break;
            }
        }
        // Next pending cell that starts before the best hit of one of its lanes.
        loop {
            if sp == 0 {
                break 'walk;
            }
            sp -= 1;
            let p = stack[sp];
            let open = p.lanes & alive & p.lo.le(best.t);
            if open != 0 {
                (node, lanes, lo, hi) = (nodes[p.node as usize], open, p.lo, p.hi);
                break;
            }
        }
    }
    let (t, prim) = (best.t.to_array(), best.prim.to_array());
    for (o, (t, p)) in out.iter_mut().zip(t.iter().zip(&prim)) {
        *o = (*t, p.to_bits());
    }
    true
}

/// Every ray of `rays` in packets of `N` consecutive rays; the rays of an
/// incoherent or short packet by the single lean walk.
#[inline(always)]
fn lean_packets<V: Lanes<N>, const N: usize>(
    tree: &TriangleTree,
    rays: &[Ray],
    out: &mut [(f32, u32)],
) {
    // One stack for all packets: no zeroing per packet.
    let empty = Pending {
        node: 0,
        lanes: 0,
        lo: V::splat(0.0),
        hi: V::splat(0.0),
    };
    let mut stack = [empty; DEPTH];
    let mut single = [(0u32, 0.0f32, 0.0f32); 64];
    for (rs, os) in rays.chunks(N).zip(out.chunks_mut(N)) {
        let rs = black_box(rs);
        if rs.len() != N || !lean_packet::<V, N>(tree, rs, &mut stack, os) {
            for (o, r) in os.iter_mut().zip(rs) {
                *o = lean_closest(tree, r, &mut single);
            }
        }
    }
}

/// 16 lanes in one AVX-512 register.
#[target_feature(enable = "avx512f")]
fn lean_packets_avx512(tree: &TriangleTree, rays: &[Ray], out: &mut [(f32, u32)]) {
    lean_packets::<Zmm, 16>(tree, rays, out);
}

/// 8 lanes in one AVX2 register.
#[target_feature(enable = "avx2")]
fn lean_packets_avx2(tree: &TriangleTree, rays: &[Ray], out: &mut [(f32, u32)]) {
    lean_packets::<Ymm, 8>(tree, rays, out);
}

/// How many lanes the lean packet walk takes here when asked for `lanes`
/// (16, else 8): 16 with AVX-512, 8 with AVX2, `None` without either.
pub(crate) fn lanes_here(lanes: usize) -> Option<usize> {
    if lanes == 16 && is_x86_feature_detected!("avx512f") {
        Some(16)
    } else if is_x86_feature_detected!("avx2") {
        Some(8)
    } else {
        None
    }
}

/// The lean packet walk over `rays` in packets of [`lanes_here`]`(lanes)`
/// (nothing without AVX2).
#[inline(never)]
pub(crate) fn trace_tiles_lean(
    tree: &TriangleTree,
    rays: &[Ray],
    out: &mut [(f32, u32)],
    lanes: usize,
) {
    match lanes_here(lanes) {
        // SAFETY: avx512f was detected.
        Some(16) => unsafe { lean_packets_avx512(tree, rays, out) },
        // SAFETY: avx2 was detected.
        Some(_) => unsafe { lean_packets_avx2(tree, rays, out) },
        None => {}
    }
}
