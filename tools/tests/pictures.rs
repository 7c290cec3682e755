//! The committed pictures are what the tool draws today: every PNG in
//! `docs/` is redrawn by the command the README gives for it (`kdray demo
//! --out-dir docs`, whose pictures do not depend on `--size` or
//! `--brute-sample`) and must equal it pixel for pixel. The renderer is
//! deterministic (exact hits, a fixed sub-pixel pattern, sums in a fixed
//! order), so no tolerance: a difference means the pictures are stale.
//! Regenerate them with `cargo run --release --bin kdray -- demo --out-dir docs`.

mod common;

use common::{kdray, stderr, tmp_in};
use std::path::Path;

/// The pictures in `docs/`, each drawn by `kdray demo` under this name.
const PICTURES: [&str; 2] = ["teapot-stadium-heatmap.png", "teapot-stadium.png"];

/// A PNG's width, height and 8-bit RGB pixels.
fn decode(path: &Path) -> (u32, u32, Vec<u8>) {
    let file = std::fs::File::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut reader = png::Decoder::new(std::io::BufReader::new(file))
        .read_info()
        .unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!(
        (info.color_type, info.bit_depth),
        (png::ColorType::Rgb, png::BitDepth::Eight),
        "{}",
        path.display()
    );
    buf.truncate(info.buffer_size());
    (info.width, info.height, buf)
}

#[test]
fn committed_pictures_are_what_the_demo_draws() {
    let docs = Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs");
    // A new picture needs a line here (and a command that redraws it).
    let mut committed: Vec<String> = std::fs::read_dir(&docs)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".png"))
        .collect();
    committed.sort();
    assert_eq!(committed, PICTURES, "the pictures in docs/");

    let out = tmp_in("pictures", "demo");
    let out_arg = out.display().to_string();
    let o = kdray(&[
        "demo",
        "--size",
        "8",
        "--brute-sample",
        "0",
        "--out-dir",
        &out_arg,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    for name in PICTURES {
        let (w, h, fresh) = decode(&out.join(name));
        let (cw, ch, old) = decode(&docs.join(name));
        assert_eq!((cw, ch), (w, h), "{name}: size");
        let differ = fresh
            .chunks(3)
            .zip(old.chunks(3))
            .filter(|(a, b)| a != b)
            .count();
        assert_eq!(
            differ,
            0,
            "docs/{name}: {differ} of {} pixels differ from a fresh `kdray demo`; regenerate: cargo run --release --bin kdray -- demo --out-dir docs",
            w * h
        );
    }
}
