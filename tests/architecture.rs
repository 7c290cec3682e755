//! The kernel's layers only look down (docs/architecture.md): a module may
//! name `crate::X` only for an `X` in a lower layer, or its own top module.
//! The layers are read from the drawing in docs/architecture.md, and the
//! imports from the sources (grouped `crate::{..}` imports and names the
//! crate root re-exports included), so a new upward import, or a module the
//! drawing leaves out, fails here.

use std::path::{Path, PathBuf};

/// The repository's root.
fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// The drawing's layers, lowest first: each line of the drawing that starts
/// with a layer number names that layer's modules, `name/` for a folder and
/// `name.rs` for a file.
fn drawn_layers(doc: &str) -> Vec<(usize, Vec<String>)> {
    let start = doc
        .find("## The kernel's layers")
        .expect("the layers section");
    let drawing = &doc[start..];
    let drawing = &drawing[drawing.find("```text").expect("a drawing") + 7..];
    let drawing = &drawing[..drawing.find("```").expect("the drawing's end")];
    let mut layers = Vec::new();
    for line in drawing.lines() {
        let mut words = line.split_whitespace();
        let Some(n) = words.next().and_then(|w| w.parse::<usize>().ok()) else {
            continue;
        };
        let names = words
            .filter_map(|w| w.strip_suffix('/').or_else(|| w.strip_suffix(".rs")))
            .filter(|w| !w.is_empty() && w.chars().all(|c| c.is_ascii_lowercase() || c == '_'))
            .map(str::to_owned)
            .collect();
        layers.push((n, names));
    }
    layers.sort();
    layers
}

fn layer(layers: &[(usize, Vec<String>)], module: &str) -> Option<usize> {
    layers
        .iter()
        .find(|(_, names)| names.iter().any(|n| n == module))
        .map(|(n, _)| *n)
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// The name at the start of `rest` (letters, digits, `_`).
fn ident(rest: &str) -> &str {
    let end = rest
        .find(|c: char| !(c.is_alphanumeric() || c == '_'))
        .unwrap_or(rest.len());
    &rest[..end]
}

/// Every first name after `crate::` in the code of `text` (comments and
/// `$crate` left out), each name of a grouped `crate::{a::.., b}` import
/// counted.
fn crate_refs(text: &str) -> Vec<&str> {
    let mut refs = Vec::new();
    for line in text.lines().filter(|l| !l.trim_start().starts_with("//")) {
        for (i, m) in line.match_indices("crate::") {
            if line[..i].ends_with('$') {
                continue;
            }
            let rest = &line[i + m.len()..];
            match rest.strip_prefix('{') {
                Some(group) => {
                    let group = &group[..group.find('}').unwrap_or(group.len())];
                    refs.extend(group.split(',').map(|g| ident(g.trim())));
                }
                None => refs.push(ident(rest)),
            }
        }
    }
    refs.retain(|r| !r.is_empty());
    refs
}

/// The module a name of the crate root comes from: `lib.rs`'s
/// `pub use MODULE::...` that names it.
fn root_owner<'a>(lib: &'a str, name: &str) -> Option<&'a str> {
    lib.split(';').find_map(|stmt| {
        let path = stmt.trim().strip_prefix("pub use ")?;
        let named = path
            .split(|c: char| !(c.is_alphanumeric() || c == '_'))
            .any(|w| w == name);
        named.then(|| ident(path))
    })
}

/// Each use of a lower-or-equal layer from a kernel file, as "FILE uses crate::NAME".
fn wrong_imports(layers: &[(usize, Vec<String>)]) -> (usize, Vec<String>) {
    let src = root().join("kernel/src");
    let lib = std::fs::read_to_string(src.join("lib.rs")).unwrap();
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let mut checked = 0;
    let mut wrong = Vec::new();
    for f in &files {
        let rel = f.strip_prefix(&src).unwrap();
        let top = rel.iter().next().unwrap().to_str().unwrap();
        let top = top.strip_suffix(".rs").unwrap_or(top);
        let Some(own) = layer(layers, top) else {
            continue; // lib.rs and test_rng.rs: the root and a test helper
        };
        checked += 1;
        for name in crate_refs(&std::fs::read_to_string(f).unwrap()) {
            // A module by its name, or a name the root re-exports.
            let module = match layer(layers, name) {
                Some(_) => name,
                None => match root_owner(&lib, name) {
                    Some(m) => m,
                    None => continue, // the test RNG
                },
            };
            let Some(theirs) = layer(layers, module) else {
                continue;
            };
            if module != top && theirs >= own {
                wrong.push(format!("{} uses crate::{name} ({module})", rel.display()));
            }
        }
    }
    (checked, wrong)
}

#[test]
fn kernel_modules_import_only_from_lower_layers() {
    let doc = std::fs::read_to_string(root().join("docs/architecture.md")).unwrap();
    let layers = drawn_layers(&doc);
    assert_eq!(layers.len(), 6, "the drawing's layers: {layers:?}");
    let (checked, wrong) = wrong_imports(&layers);
    assert!(checked > 20, "only {checked} kernel files found");
    assert!(
        wrong.is_empty(),
        "upward or sideways imports:\n{}",
        wrong.join("\n")
    );
}

#[test]
fn the_drawing_names_every_top_module_once() {
    let doc = std::fs::read_to_string(root().join("docs/architecture.md")).unwrap();
    let layers = drawn_layers(&doc);
    let mut drawn: Vec<&str> = layers
        .iter()
        .flat_map(|(_, n)| n.iter().map(String::as_str))
        .collect();
    drawn.sort_unstable();
    let mut modules: Vec<String> = std::fs::read_dir(root().join("kernel/src"))
        .unwrap()
        .map(|e| {
            e.unwrap()
                .file_name()
                .to_str()
                .unwrap()
                .trim_end_matches(".rs")
                .to_owned()
        })
        .filter(|m| m != "lib" && m != "test_rng")
        .collect();
    modules.sort_unstable();
    assert_eq!(
        drawn, modules,
        "docs/architecture.md's drawing against kernel/src"
    );
}

#[test]
fn the_check_sees_upward_imports_of_every_form() {
    assert_eq!(crate_refs("use crate::blob::Node; $crate::x"), ["blob"]);
    assert_eq!(
        crate_refs("use crate::{scene::Scene, geometry::Ray};\n// crate::points"),
        ["scene", "geometry"]
    );
    let lib = "pub use scene::{Instance, Scene};\npub use glam;";
    assert_eq!(root_owner(lib, "Scene"), Some("scene"));
    assert_eq!(root_owner(lib, "Ray"), None);
    let layers = vec![
        (1, vec!["geometry".to_owned()]),
        (6, vec!["scene".to_owned()]),
    ];
    assert!(layer(&layers, "scene") > layer(&layers, "geometry"));
}
