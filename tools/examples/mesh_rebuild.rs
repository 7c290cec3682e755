//! Times the rebuild of a deforming mesh, one thread: each builder named
//! (default `fast` and `middle`) in turn, interleaved, best of `reps`
//! builds, the blob written each time (the tree an engine traces):
//! `taskset -c 0 target/release/examples/mesh_rebuild MESH.obj [REPS] [BUILDER...]`.
//! Prints each builder's best time, nodes, references per triangle and SAH
//! cost (the default cost model, as `kdray info` prints it). `MAX_DEPTH=N`
//! in the environment caps the trees' depth (`BuildParams::max_depth`).

use kdray_tools::blob::write_triangle_tree;
use kdray_tools::builders::{build, BuildParams, BuilderKind, CostModel};
use kdray_tools::stats::tree_stats;
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let path = args
        .get(1)
        .expect("usage: mesh_rebuild MESH.obj [REPS] [BUILDER...]");
    let reps = args.get(2).and_then(|a| a.parse().ok()).unwrap_or(20);
    let names: Vec<&str> = if args.len() > 3 {
        args[3..].iter().map(String::as_str).collect()
    } else {
        vec!["fast", "middle"]
    };
    let kinds: Vec<BuilderKind> = names
        .iter()
        .map(|n| BuilderKind::parse(n).unwrap_or_else(|e| panic!("{e}")))
        .collect();
    let tris = kdray_tools::mesh::load(std::path::Path::new(path)).expect("the mesh loads");
    let params = BuildParams {
        threads: Some(1),
        max_depth: std::env::var("MAX_DEPTH").ok().and_then(|d| d.parse().ok()),
        ..BuildParams::default()
    };
    // One pool for every build: starting threads is not the builder's cost.
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("a pool of one thread");
    let params = BuildParams {
        threads: None,
        ..params
    };
    let mut best = vec![(f64::INFINITY, f64::INFINITY); kinds.len()];
    let mut blobs = vec![None; kinds.len()];
    pool.install(|| {
        for _ in 0..reps {
            for (k, &kind) in kinds.iter().enumerate() {
                let t = Instant::now();
                let tree = build(&tris, kind, &params).expect("the mesh builds");
                let built = t.elapsed().as_secs_f64();
                let blob = write_triangle_tree(&tree, &tris).expect("the blob writes");
                let all = t.elapsed().as_secs_f64();
                best[k] = (best[k].0.min(built), best[k].1.min(all));
                blobs[k] = Some(blob);
            }
        }
    });
    let cost = CostModel::from_params(&BuildParams::default());
    for ((name, (built, all)), blob) in names.iter().zip(&best).zip(&blobs) {
        let tree = blob.as_ref().expect("built").tree().expect("valid");
        let s = tree_stats(&tree, cost);
        println!(
            "{name}: {} triangles, build {:.2} ms, with the blob {:.2} ms, {} nodes, {:.2} refs/tri, SAH cost {:.2}, best of {reps}",
            tris.len(),
            built * 1e3,
            all * 1e3,
            s.nodes,
            s.refs_per_triangle,
            s.sah_cost
        );
    }
}
