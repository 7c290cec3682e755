//! Perfect splits: the box of the part of a triangle inside a cell.
//!
//! A triangle that straddles a split plane is clipped (Sutherland-Hodgman,
//! on the triangle itself, not its box) to each child's cell, so each child
//! sees only the box of what really lies in it: tighter boxes, fewer
//! references, and triangles that only graze a child's box are dropped.
//!
//! The box must never lose a point where the triangle test may accept a
//! hit, or the tree would lose hits. So the clip is conservative: it runs
//! in `f64` against the cell grown by a margin `eps`, the larger of one far
//! above the `f64` rounding of the clip and the triangle test's own margin
//! (`hit_margin`: the `f32` test accepts a ray a rounding off the
//! triangle), the resulting box is grown by `eps` again, rounded outward
//! to `f32` (next float toward -inf for the minimum, toward +inf for the
//! maximum) and intersected with the cell. A triangle is dropped from a
//! cell only when it misses the grown cell.

use kdray_kernel::Bounds;
use kdray_kernel::Triangle;

/// The margin relative to the largest coordinate magnitude: 2^-40, about
/// 2^12 times the `f64` rounding of six clips and 2^-16 of an `f32` ulp.
const MARGIN: f64 = 1.0 / 1_099_511_627_776.0;

/// Vertices of a triangle clipped by six planes: at most 3 + 6.
const MAX_VERTICES: usize = 9;

/// A convex polygon on a fixed buffer.
#[derive(Clone, Copy)]
struct Polygon {
    v: [[f64; 3]; MAX_VERTICES],
    len: usize,
}

impl Polygon {
    /// Keeps the part on the inner side of the plane `x[axis] = plane`:
    /// `x[axis] >= plane` when `keep_above`, else `x[axis] <= plane`.
    fn clip(&mut self, axis: usize, plane: f64, keep_above: bool) {
        let inside = |p: &[f64; 3]| {
            if keep_above {
                p[axis] >= plane
            } else {
                p[axis] <= plane
            }
        };
        if self.v[..self.len].iter().all(inside) {
            // Most planes cut nothing: no copy.
            return;
        }
        let mut out = Polygon {
            v: [[0.0; 3]; MAX_VERTICES],
            len: 0,
        };
        let mut push = |p: [f64; 3]| {
            if let Some(slot) = out.v.get_mut(out.len) {
                *slot = p;
                out.len += 1;
            }
        };
        for i in 0..self.len {
            let (a, b) = (self.v[i], self.v[(i + 1) % self.len]);
            if inside(&a) {
                push(a);
            }
            if inside(&a) != inside(&b) {
                // The edge crosses the plane: add the crossing point, on
                // the plane exactly.
                let t = (plane - a[axis]) / (b[axis] - a[axis]);
                let mut p: [f64; 3] = std::array::from_fn(|k| a[k] + t * (b[k] - a[k]));
                p[axis] = plane;
                push(p);
            }
        }
        *self = out;
    }

    /// The part on the inner side of the plane (see [`Polygon::clip`]).
    fn clipped(mut self, axis: usize, plane: f64, keep_above: bool) -> Polygon {
        self.clip(axis, plane, keep_above);
        self
    }
}

/// The largest `f32` at most `x`.
fn round_down(x: f64) -> f32 {
    let f = x as f32;
    if f64::from(f) > x {
        f.next_down()
    } else {
        f
    }
}

/// The smallest `f32` at least `x`.
fn round_up(x: f64) -> f32 {
    let f = x as f32;
    if f64::from(f) < x {
        f.next_up()
    } else {
        f
    }
}

/// The boxes of the parts of `tri` in the two cells made by splitting
/// `cell` at `pos` on `axis` (below, above): each holds every point of the
/// triangle in its closed cell and lies within it; `None` for a cell the
/// triangle misses. The triangle is clipped to `cell` once, then cut by
/// the plane.
#[must_use]
pub(super) fn split_boxes(
    tri: &Triangle,
    cell: &Bounds,
    axis: usize,
    pos: f32,
) -> (Option<Bounds>, Option<Bounds>) {
    let eps = margin(tri, cell);
    let poly = clip_to_cell(tri, cell, eps);
    let (below, above) = cell.split(axis, pos);
    let plane = f64::from(pos);
    (
        bounds(&poly.clipped(axis, plane + eps, false), &below, eps),
        bounds(&poly.clipped(axis, plane - eps, true), &above, eps),
    )
}

/// The boxes of the parts of `tri` in the two cells made by splitting
/// `cell` at `pos` on `axis` (below, above), cheaply: the box of the part
/// of the whole triangle on each side of the plane (its vertices there and
/// where its edges cross the plane), intersected with `b`, the triangle's
/// box in `cell`, and with the child cell. Looser than [`split_boxes`]
/// (the triangle is not clipped to the cell first), as conservative: each
/// holds every point within [`hit_margin`] of the triangle in its closed
/// cell (`b` holds those in `cell`). It runs in `f32`: vertices and
/// crossing points are grown by that margin; when a crossing overflows,
/// the box `b` is cut instead ([`cut_box`]). `None` for an empty box.
#[must_use]
pub(super) fn cut_triangle(
    tri: &Triangle,
    b: &Bounds,
    cell: &Bounds,
    axis: usize,
    pos: f32,
) -> (Option<Bounds>, Option<Bounds>) {
    // One margin for vertices and crossing points: the triangle test's
    // (`2^-17` of the scale), far above a crossing point's `f32` rounding
    // (about 8 errors of `2^-24`); at least the smallest normal float,
    // below which rounding is absolute (`2^-149` an operation). Vertices
    // within it of the plane count on both sides.
    let eps = hit_margin(tri).max(f32::MIN_POSITIVE);
    let mut lo = [[f32::INFINITY; 3]; 2];
    let mut hi = [[f32::NEG_INFINITY; 3]; 2];
    let mut finite = true;
    for i in 0..3 {
        let (a, c) = (tri.v[i], tri.v[(i + 1) % 3]);
        // Compares, not `min` / `max`: no NaN handling (a NaN can only
        // come from an overflowing crossing, which `finite` catches).
        let mut add = |side: usize, l: f32, h: f32, k: usize| {
            lo[side][k] = if l < lo[side][k] { l } else { lo[side][k] };
            hi[side][k] = if h > hi[side][k] { h } else { hi[side][k] };
        };
        for (side, on) in [(0, a[axis] <= pos + eps), (1, a[axis] >= pos - eps)] {
            if on {
                for (k, &x) in a.iter().enumerate() {
                    add(side, x - eps, x + eps, k);
                }
            }
        }
        if (a[axis] < pos && c[axis] > pos) || (a[axis] > pos && c[axis] < pos) {
            // The edge crosses the plane: the crossing point, on the plane
            // exactly, grown by the margin elsewhere, belongs to both sides.
            let t = (pos - a[axis]) / (c[axis] - a[axis]);
            for k in 0..3 {
                let x = a[k] + t * (c[k] - a[k]);
                finite &= x.is_finite();
                let (l, h) = if k == axis {
                    (pos, pos)
                } else {
                    (x - eps, x + eps)
                };
                add(0, l, h, k);
                add(1, l, h, k);
            }
        }
    }
    if !finite {
        return cut_box(b, cell, axis, pos);
    }
    let (below, above) = cell.split(axis, pos);
    let boxed = |side: usize, child: &Bounds| {
        let part = Bounds {
            min: lo[side],
            max: hi[side],
        };
        let r = part.intersect(b).intersect(child);
        (0..3).all(|k| r.min[k] <= r.max[k]).then_some(r)
    };
    (boxed(0, &below), boxed(1, &above))
}

/// The box `b` (within `cell`) cut by the plane at `pos` on `axis`:
/// (below, above), both kept.
#[must_use]
pub(super) fn cut_box(
    b: &Bounds,
    cell: &Bounds,
    axis: usize,
    pos: f32,
) -> (Option<Bounds>, Option<Bounds>) {
    let (below, above) = cell.split(axis, pos);
    (Some(b.intersect(&below)), Some(b.intersect(&above)))
}

/// A box holding every point of `tri` that lies in the closed `cell`,
/// within `cell`; `None` when the triangle misses the cell.
#[must_use]
#[cfg(test)]
pub(super) fn clipped_box(tri: &Triangle, cell: &Bounds) -> Option<Bounds> {
    let eps = margin(tri, cell);
    bounds(&clip_to_cell(tri, cell, eps), cell, eps)
}

/// The clip margin for `tri` in `cell`: the clip's own rounding margin,
/// or the triangle test's ([`hit_margin`]) when larger.
fn margin(tri: &Triangle, cell: &Bounds) -> f64 {
    let scale = tri
        .v
        .iter()
        .flatten()
        .chain(&cell.min)
        .chain(&cell.max)
        .fold(0.0f64, |m, &c| m.max(f64::from(c).abs()));
    (scale * MARGIN).max(f64::from(hit_margin(tri)))
}

/// How far from `tri` the triangle test may accept a hit: `2^-17` of its
/// largest coordinate magnitude, at least the margin of
/// [`Triangle::hit_bounds`] on every axis (`2^-18 (|lo| + |hi|)`). A ray
/// whose shear rounds (a direction component below `f32`'s range beside
/// the dominant one, an origin far away) passes the `f32` edge test a
/// rounding away from the triangle, so each part is grown by this
/// margin and a triangle within it of a cell is kept there.
fn hit_margin(tri: &Triangle) -> f32 {
    let scale = tri.v.iter().flatten().fold(0.0f32, |m, &c| m.max(c.abs()));
    scale * HIT_MARGIN
}

/// [`hit_margin`]'s scale: `2^-17`.
const HIT_MARGIN: f32 = 1.0 / 131_072.0;

/// `tri` clipped to `cell` grown by `eps`.
fn clip_to_cell(tri: &Triangle, cell: &Bounds, eps: f64) -> Polygon {
    let mut poly = Polygon {
        v: [[0.0; 3]; MAX_VERTICES],
        len: 3,
    };
    for (slot, p) in poly.v.iter_mut().zip(&tri.v) {
        *slot = p.map(f64::from);
    }
    for axis in 0..3 {
        poly.clip(axis, f64::from(cell.min[axis]) - eps, true);
        poly.clip(axis, f64::from(cell.max[axis]) + eps, false);
    }
    poly
}

/// The box of `poly` grown by `eps`, rounded outward, within `cell`.
fn bounds(poly: &Polygon, cell: &Bounds, eps: f64) -> Option<Bounds> {
    if poly.len == 0 {
        return None;
    }
    // Rounding is monotone: round the extremes only.
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for p in &poly.v[..poly.len] {
        for a in 0..3 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    let b = Bounds {
        min: lo.map(|x| round_down(x - eps)),
        max: hi.map(|x| round_up(x + eps)),
    };
    let b = b.intersect(cell);
    (0..3).all(|a| b.min[a] <= b.max[a]).then_some(b)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    /// Asserts that `b` holds (to a rounding slack) every point of a
    /// barycentric grid of `n` steps over `t` lying in `cell`, and is
    /// `Some` when any does.
    fn assert_holds_points_in(b: Option<Bounds>, t: &Triangle, cell: &Bounds, n: usize) {
        for i in 0..=n {
            for j in 0..=(n - i) {
                let (u, v) = (i as f32 / n as f32, j as f32 / n as f32);
                let p: [f32; 3] = std::array::from_fn(|a| {
                    t.v[0][a] + u * (t.v[1][a] - t.v[0][a]) + v * (t.v[2][a] - t.v[0][a])
                });
                if (0..3).all(|a| p[a] >= cell.min[a] && p[a] <= cell.max[a]) {
                    let b = b.expect("a point inside: kept");
                    let slack = |a: usize| 1e-3 * (1.0 + p[a].abs());
                    assert!(
                        (0..3).all(|a| p[a] >= b.min[a] - slack(a) && p[a] <= b.max[a] + slack(a))
                    );
                }
            }
        }
    }

    fn tri(v: [[f32; 3]; 3]) -> Triangle {
        Triangle { v }
    }

    fn cell(min: [f32; 3], max: [f32; 3]) -> Bounds {
        Bounds { min, max }
    }

    #[test]
    fn diagonal_triangle_gets_a_tighter_box_than_its_box() {
        let t = tri([[0.0, 0.0, 0.0], [4.0, 0.0, 0.0], [0.0, 4.0, 0.0]]);
        let b = clipped_box(&t, &cell([2.0, 0.0, 0.0], [4.0, 4.0, 1.0])).unwrap();
        assert_eq!(b.min[0], 2.0f32.next_down().max(2.0));
        // Only y <= 2 of the triangle lies at x >= 2.
        assert!(b.max[1] > 2.0 && b.max[1] < 2.0001, "{b:?}");
    }

    #[test]
    fn split_boxes_hold_what_clipped_boxes_hold() {
        let t = tri([[0.0, 0.0, 0.0], [4.0, 1.0, 0.5], [0.5, 4.0, 1.0]]);
        let c = cell([0.0, 0.0, 0.0], [4.0, 4.0, 1.0]);
        let (b, a) = split_boxes(&t, &c, 0, 2.0);
        let (cb, ca) = c.split(0, 2.0);
        for (got, want) in [(b, clipped_box(&t, &cb)), (a, clipped_box(&t, &ca))] {
            let (g, w) = (got.unwrap(), want.unwrap());
            assert!((0..3).all(|k| g.min[k] <= w.min[k] + 1e-6 && g.max[k] >= w.max[k] - 1e-6));
        }
    }

    #[test]
    fn triangle_missing_the_cell_is_dropped() {
        let t = tri([[0.0, 0.0, 0.0], [4.0, 0.0, 0.0], [0.0, 4.0, 0.0]]);
        assert!(clipped_box(&t, &cell([3.0, 3.0, -1.0], [4.0, 4.0, 1.0])).is_none());
    }

    #[test]
    fn grazing_triangle_is_kept() {
        // Touches the cell at one vertex only.
        let t = tri([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]]);
        let b = clipped_box(&t, &cell([2.0, -1.0, -1.0], [3.0, 1.0, 1.0])).unwrap();
        assert!(b.min[0] <= 2.0 && b.max[0] >= 2.0);
    }

    #[test]
    fn box_holds_every_clipped_point() {
        let mut rng = Rng::new(7);
        let mut r = || rng.range(-1.0, 1.0);
        for _ in 0..2000 {
            let t = tri(std::array::from_fn(|_| std::array::from_fn(|_| r() * 1e3)));
            let c = cell(
                [r() * 500.0, r() * 500.0, r() * 500.0],
                [600.0, 600.0, 600.0],
            );
            let b = clipped_box(&t, &c);
            assert_holds_points_in(b, &t, &c, 20);
        }
    }

    #[test]
    fn parts_hold_points_within_the_hit_margin_of_the_triangle() {
        let mut rng = Rng::new(17);
        let mut r = || rng.range(-1.0, 1.0);
        let mut held = 0;
        for k in 0..3000 {
            let mut t = tri(std::array::from_fn(|_| std::array::from_fn(|_| r())));
            let c = cell([-1.0; 3], [1.0; 3]);
            let axis = k % 3;
            let pos = r() * 0.5;
            if k % 2 == 0 {
                // A vertex on the plane, the others above it (a fan's pole).
                t.v[0][axis] = pos;
                for v in &mut t.v[1..] {
                    v[axis] = pos + v[axis].abs() + 0.01;
                }
            }
            // The documented margin, `2^-17` of the largest coordinate.
            let scale = t.v.iter().flatten().fold(0.0f32, |m, &c| m.max(c.abs()));
            let m = scale / 131_072.0 * 0.9;
            let halves = c.split(axis, pos);
            let b = clipped_box(&t, &c).expect("inside the cell");
            for (parts, name) in [
                (split_boxes(&t, &c, axis, pos), "split_boxes"),
                (cut_triangle(&t, &b, &c, axis, pos), "cut_triangle"),
            ] {
                // Each vertex moved out by the margin towards each corner:
                // the points beyond the triangle's own box.
                for (vi, corner) in (0..3).flat_map(|vi| (0..8).map(move |c| (vi, c))) {
                    let p: [f32; 3] = std::array::from_fn(|a| {
                        let sign = if corner >> a & 1 == 0 { -1.0 } else { 1.0 };
                        t.v[vi][a] + m * sign
                    });
                    for (got, child) in [(parts.0, &halves.0), (parts.1, &halves.1)] {
                        if (0..3).all(|a| child.min[a] <= p[a] && p[a] <= child.max[a]) {
                            let g = got.unwrap_or_else(|| panic!("{name}: {p:?} lost, {t:?}"));
                            assert!(
                                (0..3).all(|a| g.min[a] <= p[a] && p[a] <= g.max[a]),
                                "{name}: {p:?} outside {g:?}"
                            );
                            held += 1;
                        }
                    }
                }
            }
        }
        assert!(held > 50_000, "{held}");
    }

    #[test]
    fn cut_triangle_boxes_hold_every_point_in_their_cell() {
        let mut rng = Rng::new(11);
        let mut r = || rng.range(-1.0, 1.0);
        let mut cut = 0;
        for _ in 0..3000 {
            let t = tri(std::array::from_fn(|_| std::array::from_fn(|_| r() * 1e3)));
            let c = cell([r() * 600.0, r() * 600.0, r() * 600.0], [700.0; 3]);
            let Some(b) = clipped_box(&t, &c) else {
                continue;
            };
            let axis = (r().abs() * 3.0) as usize % 3;
            let pos = b.min[axis] + (b.max[axis] - b.min[axis]) * r().abs();
            if !(pos > c.min[axis] && pos < c.max[axis]) {
                continue;
            }
            cut += 1;
            let halves = c.split(axis, pos);
            let (below, above) = cut_triangle(&t, &b, &c, axis, pos);
            for (got, child) in [(below, halves.0), (above, halves.1)] {
                if let Some(g) = got {
                    assert!((0..3).all(|a| g.min[a] >= child.min[a] && g.max[a] <= child.max[a]));
                }
                assert_holds_points_in(got, &t, &child, 24);
            }
        }
        assert!(cut > 1000, "{cut}");
    }

    #[test]
    fn cut_triangle_overflowing_crossing_cuts_the_box() {
        // Edges spanning -3e38..3e38 overflow `c - a`: the box is cut.
        let t = tri([[-3e38, -3e38, 0.0], [3e38, 3e38, 1.0], [3e38, -3e38, 0.0]]);
        let c = cell([-3e38; 3], [3e38; 3]);
        let b = t.bounds().intersect(&c);
        assert_eq!(cut_triangle(&t, &b, &c, 1, 0.0), cut_box(&b, &c, 1, 0.0));
    }
}
