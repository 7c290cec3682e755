//! The fuzz targets' properties (`fuzz/src/checks.rs`, included as is)
//! replayed under plain `cargo test`: every committed seed, and every
//! crash the fuzzers found, as a named test (files in
//! `fuzz/regressions/TARGET/`).

#[path = "../fuzz/src/checks.rs"]
#[allow(dead_code, unreachable_pub)]
mod checks;

use std::path::Path;

fn replay_dir(dir: &str, check: fn(&[u8])) -> usize {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join(dir);
    let mut n = 0;
    for entry in std::fs::read_dir(&root).unwrap_or_else(|e| panic!("{}: {e}", root.display())) {
        let path = entry.unwrap().path();
        let data = std::fs::read(&path).unwrap();
        eprintln!("replaying {}", path.display());
        check(&data);
        n += 1;
    }
    n
}

#[test]
fn seed_corpora_replay() {
    assert!(replay_dir("fuzz/corpus/blob", checks::blob) >= 3);
    assert!(replay_dir("fuzz/corpus/packet_vs_single", checks::packet_vs_single) >= 3);
    assert!(replay_dir("fuzz/corpus/tree_vs_brute", checks::tree_vs_brute) >= 3);
}
