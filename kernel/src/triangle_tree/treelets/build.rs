//! Writing the treelets: the tree's nodes regrouped breadth first, three
//! levels to a 64-byte line (the module docs of `treelets`).

use super::{Treelet, TreeletBufferTooSmall, DEAD, LEAF};
use crate::blob::{Node, MAX_DEPTH};
use crate::triangle_tree::{TreeletTree, TriangleTree};

/// What a slot holds.
#[derive(Clone, Copy)]
enum Slot {
    Interior(Node, u32),
    Leaf(u32),
    Dead,
}

impl<'a> TriangleTree<'a> {
    /// The slot node `i` makes (`Dead` for an index out of range).
    fn slot(&self, i: usize) -> Slot {
        match self.nodes.get(i) {
            Some(n) if !n.is_leaf() => Slot::Interior(*n, i as u32),
            Some(n) if !n.is_empty_leaf() => Slot::Leaf(i as u32),
            _ => Slot::Dead,
        }
    }

    /// The below and above slots under `s`.
    fn children_slots(&self, s: Slot) -> (Slot, Slot) {
        match s {
            Slot::Interior(n, _) => {
                let c = n.upper() as usize;
                (self.slot(c), self.slot(c + 1))
            }
            Slot::Leaf(l) => (Slot::Leaf(l), Slot::Dead),
            Slot::Dead => (Slot::Dead, Slot::Dead),
        }
    }

    /// How many treelets [`TriangleTree::treelets_into`] writes: one per
    /// interior node at a depth divisible by 3. O(nodes), no allocation.
    #[must_use]
    pub fn treelet_count(&self) -> usize {
        if !matches!(self.slot(0), Slot::Interior(..)) {
            return 0;
        }
        // Depth first on a fixed stack of (node, depth); at most one visit
        // a node (a valid tree is a tree; an unchecked one is cut short).
        let mut stack = [(0u32, 0u32); MAX_DEPTH as usize + 2];
        let (mut sp, mut count, mut visits) = (1usize, 0usize, 0usize);
        while sp > 0 && visits < self.nodes.len() {
            sp -= 1;
            visits += 1;
            let Some(&(i, depth)) = stack.get(sp) else {
                break;
            };
            if let Slot::Interior(n, _) = self.slot(i as usize) {
                count += usize::from(depth % 3 == 0);
                for c in [n.upper(), n.upper().wrapping_add(1)] {
                    if let Some(e) = stack.get_mut(sp) {
                        *e = (c, depth + 1);
                        sp += 1;
                    }
                }
            }
        }
        count
    }

    /// Writes the tree's treelets into `buf` and returns the tree that
    /// walks scattered rays through them (its batch calls,
    /// [`TreeletTree::closest_hits`]; single rays, packets and coherent
    /// blocks keep the one-plane walk). A tree whose root is a leaf has none.
    ///
    /// # Errors
    /// [`TreeletBufferTooSmall`] for a buffer shorter than
    /// [`TriangleTree::treelet_count`].
    ///
    /// # Example
    /// ```
    /// use glam::Vec3;
    /// use kdray_kernel::{Batch, Hit, Ray, Treelet, TriangleTree};
    /// static CUBE: &kdray_kernel::Aligned<[u8]> =
    ///     kdray_kernel::include_aligned!("../../../golden/cube-v3.kdt");
    /// let tree = TriangleTree::from_bytes(&CUBE.bytes)?;
    /// let mut lines = vec![Treelet::default(); tree.treelet_count()];
    /// let lined = tree.treelets_into(&mut lines).expect("room for every treelet");
    ///
    /// // Bounces: rays from scattered points inside the cube, every which way.
    /// let rays: Vec<Ray> = (0..64)
    ///     .map(|i| {
    ///         let f = i as f32;
    ///         let p = Vec3::new(0.1 + (f * 0.37) % 0.8, 0.1 + (f * 0.61) % 0.8, 0.5);
    ///         Ray::new(p, Vec3::new((f * 1.3).sin(), (f * 0.7).cos(), (f * 0.11) % 1.0 - 0.5))
    ///     })
    ///     .collect();
    /// let mut hits = vec![Hit::MISS; rays.len()];
    /// lined.closest_hits(&rays, &mut hits, Batch::default());
    /// for (ray, hit) in rays.iter().zip(&hits) {
    ///     assert!(hit.is_hit()); // the cube is closed
    ///     assert_eq!(hit.bits(), tree.closest_hit(ray).bits());
    /// }
    /// # Ok::<(), kdray_kernel::BlobError>(())
    /// ```
    pub fn treelets_into<'t>(
        &self,
        buf: &'t mut [Treelet],
    ) -> Result<TreeletTree<'t>, TreeletBufferTooSmall>
    where
        'a: 't,
    {
        let needed = self.treelet_count();
        let have = buf.len();
        let Some(lines) = buf.get_mut(..needed) else {
            return Err(TreeletBufferTooSmall { needed, have });
        };
        // Breadth first: a treelet's children come after it, so each is
        // written when its turn comes; until then its first exit holds
        // its root node.
        let mut next = usize::from(needed > 0);
        if let Some(first) = lines.first_mut() {
            first.exit[0] = 0;
        }
        // Only the treelets written as some exit's child (all of them, in
        // a valid tree); the loop never reads a line it did not write.
        let mut i = 0;
        while i < next {
            let Some(root) = lines.get(i).map(|t| t.exit[0]) else {
                break;
            };
            let mut slots = [Slot::Dead; 7];
            slots[0] = self.slot(root as usize);
            for s in 0..3 {
                (slots[2 * s + 1], slots[2 * s + 2]) = self.children_slots(slots[s]);
            }
            let mut t = Treelet {
                split: [f32::INFINITY; 7],
                axes: 0,
                exit: [DEAD; 8],
            };
            for (s, slot) in slots.iter().enumerate() {
                if let Slot::Interior(n, _) = *slot {
                    t.split[s] = n.split();
                    t.axes |= (n.axis_bits() as u32) << (2 * s);
                }
            }
            for (b, &bottom) in slots.iter().skip(3).enumerate() {
                let (below, above) = self.children_slots(bottom);
                for (e, c) in [(2 * b, below), (2 * b + 1, above)] {
                    t.exit[e] = match c {
                        Slot::Interior(_, n) => match lines.get_mut(next) {
                            Some(child) => {
                                child.exit[0] = n;
                                next += 1;
                                (next - 1) as u32
                            }
                            // Only an unchecked tree with a cycle.
                            None => DEAD,
                        },
                        Slot::Leaf(l) => LEAF | l,
                        Slot::Dead => DEAD,
                    };
                }
            }
            if let Some(line) = lines.get_mut(i) {
                *line = t;
            }
            i += 1;
        }
        Ok(TreeletTree::new(TriangleTree {
            lines: &*lines,
            ..*self
        }))
    }
}
