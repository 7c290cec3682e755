//! The box builders: a cell's triangles as (index, box clipped to the
//! cell), split by a rule that looks only at the boxes: SAH with binning
//! ([`binned`](super::binned)), or the median / middle baselines
//! ([`median`](super::median)).
//!
//! A triangle goes below when its box starts before the plane and above
//! when it ends after it (both when it straddles: its box is then cut by
//! the plane, which still holds every point of the triangle in each cell);
//! a box lying in the plane goes to the side the rule chose.

use super::aabb::Aabb;
use super::cost::CostModel;
use super::subdivide::{Choice, Splitter};
use super::{binned, median};

/// One triangle of a cell.
#[derive(Clone, Copy, Debug)]
pub(super) struct Item {
    /// The triangle.
    pub(super) tri: u32,
    /// Its box, clipped to the cell.
    pub(super) b: Aabb,
}

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

/// The box splitter.
pub(super) struct BoxSplitter {
    pub(super) rule: Rule,
    pub(super) cost: CostModel,
}

impl BoxSplitter {
    /// The root cell's items.
    pub(super) fn root(boxes: &[Aabb]) -> Vec<Item> {
        boxes
            .iter()
            .enumerate()
            .map(|(i, &b)| Item { tri: i as u32, b })
            .collect()
    }
}

impl Splitter for BoxSplitter {
    type Set = Vec<Item>;

    fn count(&self, set: &Vec<Item>) -> usize {
        set.len()
    }

    fn bytes(&self, set: &Vec<Item>) -> usize {
        set.capacity() * std::mem::size_of::<Item>()
    }

    fn prims(&self, set: Vec<Item>) -> Vec<u32> {
        // Partitions keep the root's index order: already sorted.
        set.into_iter().map(|i| i.tri).collect()
    }

    fn choose(&self, set: &Vec<Item>, cell: &Aabb) -> Option<Choice> {
        match self.rule {
            Rule::Binned(bins) => binned::choose(set, cell, bins, &self.cost),
            Rule::Median(leaf) => median::choose(set, cell, leaf, true),
            Rule::Middle(leaf) => median::choose(set, cell, leaf, false),
        }
    }

    fn partition(&self, set: Vec<Item>, cell: &Aabb, c: &Choice) -> (Vec<Item>, Vec<Item>) {
        let (a, p) = (c.axis, c.pos);
        let (cb, ca) = cell.split(a, p);
        // Room for every triangle on each side; the spare is given back.
        let (mut below, mut above) = (Vec::with_capacity(set.len()), Vec::with_capacity(set.len()));
        for it in set {
            let (lo, hi) = (it.b.min[a], it.b.max[a]);
            if lo == p && hi == p {
                if c.planar_below {
                    below.push(it);
                } else {
                    above.push(it);
                }
                continue;
            }
            if lo < p {
                below.push(Item {
                    tri: it.tri,
                    b: it.b.intersect(&cb),
                });
            }
            if hi > p {
                above.push(Item {
                    tri: it.tri,
                    b: it.b.intersect(&ca),
                });
            }
        }
        below.shrink_to_fit();
        above.shrink_to_fit();
        (below, above)
    }
}
