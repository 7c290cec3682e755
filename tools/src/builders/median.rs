//! The baselines the lecture warns against ("All of these techniques
//! stink"): split the widest axis of the cell at the median of the
//! triangles' box centres (`median`) or at its middle (`middle`); stop at a
//! leaf size or the depth limit. Kept only to measure the SAH against.

use super::item::Item;
use super::subdivide::Choice;
use kdray_kernel::Bounds;

/// The plane for `cell`, or `None` at `leaf_size` triangles or fewer.
pub(super) fn choose(
    items: &[Item],
    cell: &Bounds,
    leaf_size: usize,
    median: bool,
) -> Option<Choice> {
    if items.len() <= leaf_size {
        return None;
    }
    let extent = |a: usize| f64::from(cell.max[a]) - f64::from(cell.min[a]);
    let axis = (0..3).fold(0, |best, a| if extent(a) > extent(best) { a } else { best });
    let (lo, hi) = (cell.min[axis], cell.max[axis]);
    let middle = lo * 0.5 + hi * 0.5;
    let mut pos = middle;
    if median {
        let mut centres: Vec<f32> = items
            .iter()
            .map(|it| it.b.min[axis] * 0.5 + it.b.max[axis] * 0.5)
            .collect();
        let mid = centres.len() / 2;
        let (_, &mut m, _) = centres.select_nth_unstable_by(mid, f32::total_cmp);
        if m > lo && m < hi {
            pos = m;
        }
    }
    (pos > lo && pos < hi).then_some(Choice {
        axis,
        pos: pos + 0.0,
        planar_below: true,
        cost: None,
    })
}
