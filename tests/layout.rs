//! Blob version 2's node order: every builder's tree is in the one
//! line order the validator replays (cache-line groups, see
//! `kdray_kernel::format::place_line_groups`), and that order is the only one it
//! accepts: two pairs swapped (their parents' child indices fixed, so the
//! result is still a tree) are refused.

use kdray::kernel::format::LINE_NODES;
use kdray::kernel::{BlobError, Node, NodeKind, Triangle, TriangleTree};
use kdray::tools::builders::{build, BuildParams, BuilderKind};
use proptest::prelude::*;

fn triangle() -> impl Strategy<Value = Triangle> {
    let c = || (0u8..16).prop_map(|k| f32::from(k) / 4.0);
    proptest::array::uniform3(proptest::array::uniform3(c())).prop_map(|v| Triangle { v })
}

/// `nodes` with the pairs at `p` and `q` exchanged, every child index that
/// named one of them renumbered.
fn swap_pairs(nodes: &[Node], p: usize, q: usize) -> Vec<Node> {
    let mut out = nodes.to_vec();
    out.swap(p, q);
    out.swap(p + 1, q + 1);
    for n in &mut out {
        if let NodeKind::Interior { axis, split, child } = n.kind() {
            let c = child as usize;
            let c = if c == p {
                q
            } else if c == q {
                p
            } else {
                c
            };
            *n = Node::interior(axis, split, c as u32).unwrap();
        }
    }
    out
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 200, ..ProptestConfig::default() })]

    #[test]
    fn builders_write_the_one_line_order(
        tris in proptest::collection::vec(triangle(), 1..80),
        pick in (0usize..1000, 0usize..1000),
    ) {
        for kind in BuilderKind::ALL {
            let built = build(&tris, kind, &BuildParams::default()).unwrap();
            let nodes = &built.nodes;
            TriangleTree::from_parts(nodes, &built.prims, &tris, built.bounds).unwrap();
            prop_assert_eq!(nodes.get(1), Some(&Node::EMPTY_LEAF));
            // The root's line holds the first three pairs breadth first: the
            // root's, then its below and above children's.
            if let NodeKind::Interior { child, .. } = nodes[0].kind() {
                prop_assert_eq!(child, 2);
                let mut next = 4;
                for c in [2usize, 3] {
                    if let NodeKind::Interior { child, .. } = nodes[c].kind() {
                        prop_assert_eq!(child as usize, next);
                        next += 2;
                    }
                }
                prop_assert!(next <= LINE_NODES);
            }
            let pairs = (nodes.len() - 2) / 2;
            if pairs >= 2 {
                let p = 2 + 2 * (pick.0 % pairs);
                let q = 2 + 2 * (pick.1 % pairs);
                if p != q {
                    let swapped = swap_pairs(nodes, p, q);
                    let e = TriangleTree::from_parts(&swapped, &built.prims, &tris, built.bounds);
                    prop_assert!(matches!(e, Err(BlobError::BadChild { .. })), "{:?}", e.err());
                }
            }
        }
    }
}
