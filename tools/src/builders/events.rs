//! Sweep events: where a triangle's (clipped) box starts, ends, or lies
//! flat, along one axis, packed in a `u64` whose integer order is the sweep
//! order: position, then end < planar < start, then triangle index.
//!
//! ```text
//! bits 63..32  the position, as an order-preserving integer
//! bits 31..30  the kind: 0 end, 1 planar, 2 start
//! bits 29..0   the triangle (at most 2^30 - 1 of them, as in a node)
//! ```
//!
//! Keys are unique, so any sort gives the same order: the tree does not
//! depend on the sort algorithm or the thread count.

use kdray_kernel::Bounds;

/// A triangle's box ends here (sorts first at a position).
pub(super) const END: u64 = 0;
/// A triangle lies in the plane at this position.
pub(super) const PLANAR: u64 = 1;
/// A triangle's box starts here (sorts last at a position).
pub(super) const START: u64 = 2;

const TRI_MASK: u64 = (1 << 30) - 1;

/// An `f32` as an integer with the same order (`-0` taken as `+0`): the
/// sort key of a position, bits 63..32 of its events.
#[inline]
pub(super) fn position_key(x: f32) -> u32 {
    let b = (x + 0.0).to_bits();
    if b >> 31 == 1 {
        !b
    } else {
        b | 1 << 31
    }
}

/// The event of `kind` for triangle `tri` at `pos`.
#[inline]
pub(super) fn event(pos: f32, kind: u64, tri: u32) -> u64 {
    (u64::from(position_key(pos)) << 32) | kind << 30 | (u64::from(tri) & TRI_MASK)
}

/// The sort key of an event's position (see [`position_key`]).
#[inline]
pub(super) fn position_key_of(e: u64) -> u32 {
    (e >> 32) as u32
}

/// The position of an event.
#[inline]
pub(super) fn pos(e: u64) -> f32 {
    let o = position_key_of(e);
    f32::from_bits(if o >> 31 == 1 { o & !(1 << 31) } else { !o })
}

/// The kind of an event.
#[inline]
pub(super) fn kind(e: u64) -> u64 {
    (e >> 30) & 3
}

/// The triangle of an event.
#[inline]
pub(super) fn tri(e: u64) -> u32 {
    (e & TRI_MASK) as u32
}

/// The events of triangle `tri` with box `b` on `axis`: one planar event,
/// or a start and an end.
#[inline]
pub(super) fn push(out: &mut Vec<u64>, b: &Bounds, axis: usize, tri: u32) {
    let (lo, hi) = (b.min[axis], b.max[axis]);
    if lo == hi {
        out.push(event(lo, PLANAR, tri));
    } else {
        out.push(event(lo, START, tri));
        out.push(event(hi, END, tri));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_sort_by_position_then_kind_then_triangle() {
        let xs = [-1e30f32, -2.5, 0.0, 1e-40, 3.0, f32::MAX];
        for w in xs.windows(2) {
            assert!(event(w[0], START, 9) < event(w[1], END, 0), "{w:?}");
        }
        assert_eq!(event(-0.0, END, 1), event(0.0, END, 1));
        assert!(event(1.0, END, 5) < event(1.0, PLANAR, 0));
        assert!(event(1.0, PLANAR, 5) < event(1.0, START, 0));
        for x in xs {
            let e = event(x, PLANAR, 77);
            assert_eq!(pos(e), x + 0.0);
            assert_eq!((kind(e), tri(e)), (PLANAR, 77));
        }
    }
}
