//! The kernel's layers only look down (docs/architecture.md): a module may
//! name `crate::X` only for an `X` in a lower layer, or its own top module.
//! Read from the sources, so a new upward import fails here.

use std::path::Path;

/// The kernel's top modules, lowest layer first; modules on one line are
/// siblings that may not import each other.
const LAYERS: &[&[&str]] = &[
    &["geometry"],
    &["lanes"],
    &["triangle"],
    &["blob"],
    &["triangle_tree", "points"],
    &["scene"],
];

fn layer(module: &str) -> Option<usize> {
    LAYERS.iter().position(|l| l.contains(&module))
}

fn rust_files(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// Every `crate::NAME` in `text`.
fn crate_refs(text: &str) -> Vec<&str> {
    text.match_indices("crate::")
        .filter(|(i, _)| !text[..*i].ends_with('$'))
        .map(|(i, m)| {
            let rest = &text[i + m.len()..];
            let end = rest
                .find(|c: char| !(c.is_alphanumeric() || c == '_'))
                .unwrap_or(rest.len());
            &rest[..end]
        })
        .collect()
}

#[test]
fn kernel_modules_import_only_from_lower_layers() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("kernel/src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let mut checked = 0;
    let mut wrong = Vec::new();
    for f in &files {
        let rel = f.strip_prefix(&src).unwrap();
        let top = rel.iter().next().unwrap().to_str().unwrap();
        let top = top.strip_suffix(".rs").unwrap_or(top);
        let Some(own) = layer(top) else {
            continue; // lib.rs and test_rng.rs: the root and a test helper
        };
        checked += 1;
        for name in crate_refs(&std::fs::read_to_string(f).unwrap()) {
            // The crate root's re-exports (in doc links) and the test RNG.
            let Some(theirs) = layer(name) else { continue };
            if name != top && theirs >= own {
                wrong.push(format!("{} uses crate::{name}", rel.display()));
            }
        }
    }
    assert!(checked > 20, "only {checked} kernel files found");
    assert!(
        wrong.is_empty(),
        "upward or sideways imports:\n{}",
        wrong.join("\n")
    );
}

#[test]
fn the_check_sees_an_upward_import() {
    assert_eq!(crate_refs("use crate::blob::Node; $crate::x"), ["blob"]);
    assert!(layer("blob") > layer("triangle"));
}
