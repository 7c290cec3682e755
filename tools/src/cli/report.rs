//! Tree statistics as a human summary or JSON fields (shared by build,
//! info and demo).

use super::json::JsonObject;
use kdray_tools::stats::TreeStats;

/// Adds the statistics to a JSON object.
pub(crate) fn stats_json(j: JsonObject, s: &TreeStats) -> JsonObject {
    j.with("triangles", s.triangles)
        .with("nodes", s.nodes)
        .with("leaves", s.leaves)
        .with("empty_leaves", s.empty_leaves)
        .with("max_depth", s.max_depth)
        .with("mean_leaf_depth", s.mean_leaf_depth)
        .with("mean_leaf_lines", s.mean_leaf_lines)
        .with("refs_per_triangle", s.refs_per_triangle)
        .with("mean_leaf_size", s.mean_leaf_size)
        .with("sah_cost", s.sah_cost)
        .with("bytes", s.bytes)
        .with("bytes_per_triangle", s.bytes_per_triangle)
}

/// Prints the statistics for a person.
pub(crate) fn print_stats(s: &TreeStats) {
    say!("  triangles          {}", s.triangles);
    say!(
        "  nodes              {} ({} leaves, {} empty)",
        s.nodes,
        s.leaves,
        s.empty_leaves
    );
    say!(
        "  depth              max {}, mean leaf {:.1}",
        s.max_depth,
        s.mean_leaf_depth
    );
    say!(
        "  lines to a leaf    {:.2} (64-byte lines read root to leaf, mean)",
        s.mean_leaf_lines
    );
    say!("  refs per triangle  {:.2}", s.refs_per_triangle);
    say!("  tris per full leaf {:.2}", s.mean_leaf_size);
    say!("  SAH cost           {:.2}", s.sah_cost);
    say!(
        "  size               {} bytes ({:.1} per triangle)",
        s.bytes,
        s.bytes_per_triangle
    );
}
