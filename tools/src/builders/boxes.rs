//! The box builders: a cell's triangles as (index, box clipped to the
//! cell), split by a rule that looks only at the boxes: SAH with binning
//! ([`binned`](super::binned)), or the median / middle baselines
//! ([`median`](super::median)).
//!
//! A triangle goes below when its box starts before the plane and above
//! when it ends after it (both when it straddles: its box is then cut by
//! the plane, which still holds every point of the triangle in each cell);
//! a box lying in the plane goes to the side the rule chose.

use super::clip::{cut_box, cut_triangle};
use super::cost::CostModel;
use super::item::Item;
use super::subdivide::{Choice, Splitter};
use super::thresholds::PARALLEL_MIN;
use super::{binned, median};
use kdray_kernel::Bounds;
use kdray_kernel::Triangle;
use rayon::prelude::*;

/// How a box builder picks its plane.
#[derive(Clone, Copy, Debug)]
pub(super) enum Rule {
    /// SAH at the boundaries of this many equal bins per axis.
    Binned(usize),
    /// The median of the box centres on the widest axis; leaves at this size.
    Median(usize),
    /// The middle of the widest axis; leaves at this size.
    Middle(usize),
}

/// How a box builder bounds the parts of a triangle straddling the plane,
/// by the size of the cell: the larger the cell, the more a tight box
/// saves below it.
#[derive(Clone, Copy)]
pub(super) struct Straddlers<'a> {
    /// The triangles.
    pub(super) triangles: &'a [Triangle],
    /// Cells of at least this many triangles cut the triangle by the plane
    /// ([`cut_triangle`]); smaller ones cut its box ([`cut_box`]).
    pub(super) cut_min: usize,
}

/// The box splitter.
pub(super) struct BoxSplitter<'a> {
    pub(super) rule: Rule,
    pub(super) cost: CostModel,
    /// `None`: every straddler's box is cut by the plane.
    pub(super) straddlers: Option<Straddlers<'a>>,
}

impl BoxSplitter<'_> {
    /// The root cell's items.
    pub(super) fn root(boxes: &[Bounds]) -> Vec<Item> {
        boxes
            .iter()
            .enumerate()
            .map(|(i, &b)| Item { tri: i as u32, b })
            .collect()
    }
}

impl Splitter for BoxSplitter<'_> {
    type Set = Vec<Item>;

    fn count(&self, set: &Vec<Item>) -> usize {
        set.len()
    }

    fn bytes(&self, set: &Vec<Item>) -> usize {
        bytes(set)
    }

    fn prims(&self, set: Vec<Item>) -> Vec<u32> {
        prims(set)
    }

    fn choose(&self, set: &Vec<Item>, cell: &Bounds) -> Option<Choice> {
        match self.rule {
            Rule::Binned(bins) => binned::choose_saving(set, cell, bins, &self.cost),
            Rule::Median(leaf) => median::choose(set, cell, leaf, true),
            Rule::Middle(leaf) => median::choose(set, cell, leaf, false),
        }
    }

    fn partition(&self, set: Vec<Item>, cell: &Bounds, c: &Choice) -> (Vec<Item>, Vec<Item>) {
        let n = set.len();
        let (a, p) = (c.axis, c.pos);
        match self.straddlers {
            Some(s) if n >= s.cut_min => partition(set, c, |it| {
                cut_triangle(&s.triangles[it.tri as usize], &it.b, cell, a, p)
            }),
            _ => partition(set, c, |it| cut_box(&it.b, cell, a, p)),
        }
    }
}

/// The working-set bytes of a cell's items.
pub(super) fn bytes(items: &Vec<Item>) -> usize {
    items.capacity() * std::mem::size_of::<Item>()
}

/// A leaf's triangles: partitions keep the root's index order, so the
/// items are already sorted. Copied into a list of their own: collected in
/// place, each leaf kept its items' storage (7 times the bytes; with
/// partitions in place, its ancestors' too) until the tree was laid out.
pub(super) fn prims(items: Vec<Item>) -> Vec<u32> {
    items.iter().map(|i| i.tri).collect()
}

/// Which sides of the plane of `c` an item goes to (module docs): (below,
/// above); a straddler goes to both.
#[inline]
fn sides(it: &Item, c: &Choice) -> (bool, bool) {
    let (lo, hi, p) = (it.b.min[c.axis], it.b.max[c.axis], c.pos);
    // `&` and `|`, not `&&` and `||`: no branches (which side an item
    // goes to is unpredictable).
    let planar = (lo == p) & (hi == p);
    (
        (lo < p) | (planar & c.planar_below),
        (hi > p) | (planar & !c.planar_below),
    )
}

/// The items of the cells below and above the plane of `c` (module docs),
/// in the order of `set`; `cut` gives a straddling item's boxes in the
/// child cells (`None`: it misses that child). The cell below keeps the
/// storage of `set` (its items are moved forward in place), the cell above
/// gets an exactly sized list; when every item goes to one side (a plane
/// cutting off empty space), that side takes `set` as it is. Large cells
/// are split in parallel chunks, joined in order: the same result for any
/// thread count.
pub(super) fn partition<F>(mut set: Vec<Item>, c: &Choice, cut: F) -> (Vec<Item>, Vec<Item>)
where
    F: Fn(&Item) -> (Option<Bounds>, Option<Bounds>) + Sync,
{
    let count = |chunk: &[Item]| {
        chunk.iter().fold((0usize, 0usize), |(b, a), it| {
            let (gb, ga) = sides(it, c);
            (b + usize::from(gb), a + usize::from(ga))
        })
    };
    let (nb, na) = if set.len() >= PARALLEL_MIN {
        set.par_chunks(PARALLEL_MIN)
            .map(count)
            .reduce(|| (0, 0), |x, y| (x.0 + y.0, x.1 + y.1))
    } else {
        count(&set)
    };
    if na == 0 {
        return (set, Vec::new());
    }
    if nb == 0 {
        return (Vec::new(), set);
    }
    // Moves `chunk`'s items below to its front (an item yields at most one
    // item below, so writes never overtake reads) and writes those above
    // to `above`, which has a spare slot: an item on one side is written
    // to both and kept where it goes, without a branch on the side.
    // Returns how many there are below and above.
    let split = |chunk: &mut [Item], above: &mut [Item]| {
        let (mut kept, mut up) = (0, 0);
        for i in 0..chunk.len() {
            let it = chunk[i];
            match sides(&it, c) {
                (true, true) => {
                    let (b, t) = cut(&it);
                    if let Some(b) = b {
                        chunk[kept] = Item { tri: it.tri, b };
                        kept += 1;
                    }
                    if let Some(b) = t {
                        above[up] = Item { tri: it.tri, b };
                        up += 1;
                    }
                }
                (gb, ga) => {
                    chunk[kept] = it;
                    above[up] = it;
                    kept += usize::from(gb);
                    up += usize::from(ga);
                }
            }
        }
        (kept, up)
    };
    let room = |n: usize| vec![Item::NONE; n + 1];
    let mut above;
    if set.len() >= PARALLEL_MIN {
        let parts: Vec<(usize, Vec<Item>)> = set
            .par_chunks_mut(PARALLEL_MIN)
            .map(|chunk| {
                let mut above = room(count(chunk).1);
                let (kept, up) = split(chunk, &mut above);
                above.truncate(up);
                (kept, above)
            })
            .collect();
        above = Vec::with_capacity(na);
        let mut below = 0;
        for (k, (kept, a)) in parts.into_iter().enumerate() {
            let from = k * PARALLEL_MIN;
            set.copy_within(from..from + kept, below);
            below += kept;
            above.extend_from_slice(&a);
        }
        set.truncate(below);
    } else {
        above = room(na);
        let (kept, up) = split(&mut set, &mut above);
        set.truncate(kept);
        above.truncate(up);
    }
    (set, above)
}
