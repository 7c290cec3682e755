//! The `kdray` binary end to end: happy paths, and every bad input gets a
//! clear error naming the file, never a panic or a half-written output.

mod common;

use common::{kdray, stderr};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn tmp(name: &str) -> PathBuf {
    common::tmp_in("cli", name)
}

fn write(path: &Path, bytes: &[u8]) -> String {
    std::fs::write(path, bytes).unwrap();
    path.display().to_string()
}

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// The one JSON object `--json` printed.
fn json(o: &Output) -> serde_json::Value {
    serde_json::from_slice(&o.stdout)
        .unwrap_or_else(|e| panic!("not JSON ({e}): {}{}", stdout(o), stderr(o)))
}

const QUAD_OBJ: &[u8] =
    b"# two quads\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nf 1 2 3 4\nf 1 2 5\n";

fn ray_bytes(rays: &[[f32; 8]]) -> Vec<u8> {
    rays.iter()
        .flatten()
        .flat_map(|f| f.to_le_bytes())
        .collect()
}

#[test]
fn build_info_trace_round_trip() {
    let obj = write(&tmp("quad.obj"), QUAD_OBJ);
    let tree = tmp("quad.kdt").display().to_string();
    let o = kdray(&["build", &obj, "-o", &tree, "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j = json(&o);
    for key in [
        "build_ms",
        "nodes",
        "leaves",
        "max_depth",
        "sah_cost",
        "bytes",
    ] {
        assert!(j[key].is_number(), "{key} missing from {j}");
    }
    assert_eq!(j["triangles"], 3, "{j}");
    let o = kdray(&["info", &tree, "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(json(&o)["triangles"], 3);

    // Down onto the quad at (0.25, 0.5): the fan (v0,v1,v2),(v0,v2,v3) puts
    // it in triangle 1; a ray off to the side misses.
    let rays = ray_bytes(&[
        [0.25, 0.75, 2.0, 0.0, 0.0, 0.0, -1.0, f32::INFINITY],
        [5.0, 5.0, 2.0, 0.0, 0.0, 0.0, -1.0, f32::INFINITY],
    ]);
    let rays = write(&tmp("two.rays"), &rays);
    let hits = tmp("two.hits");
    let o = kdray(&[
        "trace",
        &tree,
        &rays,
        "-o",
        &hits.display().to_string(),
        "--threads",
        "1",
        "--json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(json(&o)["mrays_per_s"].is_number());
    let h = std::fs::read(&hits).unwrap();
    assert_eq!(h.len(), 32);
    let word = |i: usize| u32::from_le_bytes(h[i * 4..i * 4 + 4].try_into().unwrap());
    assert_eq!((f32::from_bits(word(0)), word(1)), (2.0, 1));
    assert_eq!(
        (f32::from_bits(word(4)), word(5)),
        (f32::INFINITY, u32::MAX)
    );

    let o = kdray(&[
        "trace",
        &tree,
        &rays,
        "-o",
        &hits.display().to_string(),
        "--any-hit",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let h = std::fs::read(&hits).unwrap();
    assert_eq!(u32::from_le_bytes(h[4..8].try_into().unwrap()), 0xFFFF_FFFE);
    assert_eq!(
        f32::from_le_bytes(h[0..4].try_into().unwrap()),
        f32::NEG_INFINITY
    );
}

/// `--packet auto|1|4|8|16`, with threads, JSON and any hit: the same hit
/// file bytes whatever the width (2,101 rays: several parallel chunks and
/// a last, partly empty packet); a width other than those is refused.
#[test]
fn trace_packets_match_single_rays() {
    let obj = write(&tmp("pk.obj"), QUAD_OBJ);
    let tree = tmp("pk.kdt").display().to_string();
    assert!(kdray(&["build", &obj, "-o", &tree]).status.success());
    // Rays from above and from the side, in tiles of 8 neighbours; a few
    // miss, a few are hostile (zero direction, NaN).
    let rays: Vec<[f32; 8]> = (0..2101u32)
        .map(|i| {
            let (x, y) = ((i % 50) as f32 / 40.0 - 0.1, (i / 50) as f32 / 40.0 - 0.1);
            match i % 97 {
                0 => [x, y, 2.0, 0.0, 0.0, 0.0, 0.0, f32::INFINITY],
                1 => [f32::NAN, y, 2.0, 0.0, 0.0, 0.0, -1.0, f32::INFINITY],
                _ if i % 3 == 0 => [-1.0, x, y, 0.0, 1.0, 0.01, 0.02, f32::INFINITY],
                _ => [x, y, 2.0, 0.0, 0.01, -0.02, -1.0, f32::INFINITY],
            }
        })
        .collect();
    let rays = write(&tmp("pk.rays"), &ray_bytes(&rays));
    for any in [false, true] {
        let mut reference: Option<Vec<u8>> = None;
        for (packet, threads) in [
            ("auto", "1"),
            ("1", "1"),
            ("4", "2"),
            ("8", "1"),
            ("8", "2"),
            ("16", "2"),
            ("auto", "2"),
        ] {
            let hits = tmp(&format!("pk-{packet}-{threads}-{any}.hits"));
            let hits_s = hits.display().to_string();
            let mut args = vec![
                "trace",
                &tree,
                &rays,
                "-o",
                &hits_s,
                "--packet",
                packet,
                "--threads",
                threads,
                "--json",
                "--repeat",
                "2",
            ];
            if any {
                args.push("--any-hit");
            }
            let o = kdray(&args);
            assert!(o.status.success(), "{}", stderr(&o));
            let named = match packet {
                "auto" => "\"auto\"".to_string(),
                n => n.to_string(),
            };
            assert_eq!(json(&o)["packet"].to_string(), named, "{}", stdout(&o));
            let h = std::fs::read(&hits).unwrap();
            assert_eq!(h.len(), 2101 * 16);
            match &reference {
                None => reference = Some(h),
                Some(r) => assert!(*r == h, "--packet {packet} --threads {threads} differs"),
            }
        }
        let r = reference.unwrap();
        let hit_count = r.chunks(16).filter(|h| h[4..8] != [0xFF; 4]).count();
        assert!(hit_count > 500 && hit_count < 2101, "{hit_count} hits");
    }
    let out = tmp("pk-bad.hits").display().to_string();
    let o = kdray(&["trace", &tree, &rays, "-o", &out, "--packet", "3"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("auto, 1, 4, 8 or 16"), "{}", stderr(&o));
}

/// A large batch of scattered shadow rays is traced in the Morton order
/// of its origins (`--order auto`, the default) with the hits in the
/// file's order: the same file as `--order given`.
#[test]
fn trace_sorts_scattered_shadow_rays_and_answers_in_file_order() {
    let obj = write(&tmp("so.obj"), QUAD_OBJ);
    let tree = tmp("so.kdt").display().to_string();
    assert!(kdray(&["build", &obj, "-o", &tree]).status.success());
    // 20,000 rays from scattered origins towards a light above the quad.
    let mut x = 12345u32;
    let mut next = || {
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        x as f32 / u32::MAX as f32 * 3.0 - 1.0
    };
    let rays: Vec<[f32; 8]> = (0..20_000)
        .map(|_| {
            let o = [next(), next(), next() * 0.5];
            let d = [0.3 - o[0], 0.4 - o[1], 5.0 - o[2]];
            [o[0], o[1], o[2], 1e-4, d[0], d[1], d[2], 1.0]
        })
        .collect();
    let rays = write(&tmp("so.rays"), &ray_bytes(&rays));
    let mut files = Vec::new();
    for order in ["auto", "given"] {
        let hits = tmp(&format!("so-{order}.hits")).display().to_string();
        let o = kdray(&[
            "trace",
            &tree,
            &rays,
            "-o",
            &hits,
            "--any-hit",
            "--json",
            "--order",
            order,
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        let how = if order == "auto" { "morton" } else { "given" };
        assert_eq!(json(&o)["order"], how, "{}", stdout(&o));
        files.push(std::fs::read(&hits).unwrap());
    }
    assert!(files[0] == files[1], "--order auto and given differ");
    let occluded = files[0].chunks(16).filter(|h| h[4..8] != [0xFF; 4]).count();
    assert!(occluded > 500 && occluded < 19_000, "{occluded} occluded");
    // Closest hits: `auto` keeps the order of a tree this small (it stays
    // in cache), `morton` sorts by origin and direction; the same hits.
    let mut files = Vec::new();
    for (order, how) in [("auto", "given"), ("morton", "morton"), ("given", "given")] {
        let hits = tmp(&format!("so-closest-{order}.hits"))
            .display()
            .to_string();
        let o = kdray(&["trace", &tree, &rays, "-o", &hits, "--order", order]);
        assert!(o.status.success(), "{}", stderr(&o));
        let sorted = stdout(&o).contains("in the Morton order of their origins and directions");
        assert_eq!(sorted, how == "morton", "{}", stdout(&o));
        files.push(std::fs::read(&hits).unwrap());
    }
    assert!(files[0] == files[1] && files[1] == files[2]);
    let hit = files[0].chunks(16).filter(|h| h[4..8] != [0xFF; 4]).count();
    assert!(hit > 500 && hit < 19_000, "{hit} hit");
    let out = tmp("so-bad.hits").display().to_string();
    let o = kdray(&["trace", &tree, &rays, "-o", &out, "--order", "random"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("auto, given or morton"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn trace_first_hits_writes_k_records_a_ray() {
    // Two unit quads, at z = 0 and z = 1.
    let two = b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\nf 1 2 3 4\nf 5 6 7 8\n";
    let obj = write(&tmp("fh.obj"), two);
    let tree = tmp("fh.kdt").display().to_string();
    assert!(kdray(&["build", &obj, "-o", &tree]).status.success());
    // Up through both quads, up through none (outside), and down from above.
    let rays = ray_bytes(&[
        [0.3, 0.4, -1.0, 0.0, 0.0, 0.0, 1.0, f32::INFINITY],
        [3.0, 0.4, -1.0, 0.0, 0.0, 0.0, 1.0, f32::INFINITY],
        [0.6, 0.2, 5.0, 0.0, 0.0, 0.0, -1.0, f32::INFINITY],
    ]);
    let rays = write(&tmp("fh.rays"), &rays);
    let run = |extra: &[&str], name: &str| {
        let out = tmp(name).display().to_string();
        let mut args = vec!["trace", &tree, &rays, "-o", &out];
        args.extend_from_slice(extra);
        let o = kdray(&args);
        assert!(o.status.success(), "{}", stderr(&o));
        std::fs::read(&out).unwrap()
    };
    let record = |b: &[u8], i: usize| {
        let f = |o: usize| f32::from_le_bytes(b[16 * i + o..16 * i + o + 4].try_into().unwrap());
        let prim = u32::from_le_bytes(b[16 * i + 4..16 * i + 8].try_into().unwrap());
        (f(0), prim)
    };
    let closest = run(&[], "fh-closest.hits");
    assert_eq!(run(&["--first-hits", "1"], "fh-1.hits"), closest);
    let three = run(&["--first-hits", "3"], "fh-3.hits");
    assert_eq!(three.len(), 3 * closest.len());
    // Ray 0: z = 0 at t = 1, z = 1 at t = 2, then nothing.
    assert_eq!(record(&three, 0).0, 1.0);
    assert_eq!(record(&three, 1).0, 2.0);
    assert_eq!(record(&three, 2).1, u32::MAX);
    // Ray 1 misses: three miss records. Ray 2, downwards: z = 1 first.
    assert!((3..6).all(|i| record(&three, i).1 == u32::MAX));
    assert_eq!((record(&three, 6).0, record(&three, 7).0), (4.0, 5.0));
    assert_eq!(&three[..16], &closest[..16]);
    // Bad uses: clear errors, nothing written.
    for (extra, says) in [
        (&["--first-hits", "0"][..], "must be 1 to 1024"),
        (&["--first-hits", "1025"][..], "must be 1 to 1024"),
        (&["--first-hits", "2", "--packet", "8"][..], "single rays"),
        (
            &["--first-hits", "2", "--any-hit"][..],
            "cannot be used with",
        ),
    ] {
        let out = tmp("fh-bad.hits").display().to_string();
        let mut args = vec!["trace", &tree, &rays, "-o", &out];
        args.extend_from_slice(extra);
        let o = kdray(&args);
        assert!(
            !o.status.success() && stderr(&o).contains(says),
            "{extra:?}: {}",
            stderr(&o)
        );
        assert!(
            !std::path::Path::new(&out).exists(),
            "{extra:?} wrote {out}"
        );
    }
}

#[test]
fn bad_inputs_get_clear_errors() {
    let obj = write(&tmp("ok.obj"), QUAD_OBJ);
    let tree = tmp("ok.kdt").display().to_string();
    assert!(kdray(&["build", &obj, "-o", &tree]).status.success());
    let bad_obj = write(&tmp("bad.obj"), b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n");
    let nan_obj = write(&tmp("nan.obj"), b"v 0 0 0\nv 1 0 0\nv 0 nan 0\nf 1 2 3\n");
    let odd_rays = write(&tmp("odd.rays"), &[0u8; 33]);
    let junk_tree = write(&tmp("junk.kdt"), b"not a tree at all, clearly");
    let out = tmp("never.hits").display().to_string();
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (
            vec!["build", "/nonexistent/mesh.obj", "-o", &tree],
            "/nonexistent/mesh.obj: cannot open",
        ),
        (
            vec!["build", &bad_obj, "-o", &tree],
            "bad.obj:4: malformed OBJ",
        ),
        (vec!["build", &nan_obj, "-o", &tree], "non-finite"),
        (
            vec!["build", &obj, "-o", &tree, "--builder", "bvh"],
            "unknown builder 'bvh' (expected one of sah, sweep, binned, fast, median, middle)",
        ),
        (
            vec!["bench", "needles", "--builders", "sah,kd"],
            "unknown builder 'kd'",
        ),
        (
            vec!["build", "mesh.stl", "-o", &tree],
            "unsupported mesh format",
        ),
        (
            vec!["trace", &tree, &odd_rays, "-o", &out],
            "odd.rays: size 33 bytes is not a multiple of the 32-byte ray record",
        ),
        (
            vec!["trace", &junk_tree, &odd_rays, "-o", &out],
            "junk.kdt: invalid tree blob: blob truncated in the header",
        ),
        (vec!["info", &junk_tree], "junk.kdt"),
        (
            vec!["trace", &tree, &odd_rays, "-o", &out, "--threads", "0"],
            "--threads must be at least 1",
        ),
    ];
    for (args, want) in cases {
        let o = kdray(&args);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {err}");
        assert!(
            err.contains(want),
            "{args:?}: {err:?} does not say {want:?}"
        );
        assert!(!err.contains("panicked"), "{args:?} panicked: {err}");
    }
    assert!(
        !Path::new(&out).exists(),
        "a failed trace left an output file"
    );
    // Usage errors come from clap with exit code 2.
    assert_eq!(kdray(&["trace"]).status.code(), Some(2));
    assert_eq!(kdray(&["frobnicate"]).status.code(), Some(2));
}

#[test]
fn render_writes_pictures_and_refuses_bad_flags() {
    let obj = write(&tmp("render.obj"), QUAD_OBJ);
    let png = tmp("render.png").display().to_string();
    for extra in [
        &[][..],
        &["--heatmap"],
        &["--packet", "4"],
        &["--packet", "1"],
        &["--packet", "16"],
    ] {
        let _ = std::fs::remove_file(&png);
        let mut args = vec![
            "render", &obj, "-o", &png, "--width", "33", "--height", "17",
        ];
        args.extend_from_slice(extra);
        let o = kdray(&args);
        assert!(o.status.success(), "{extra:?}: {}", stderr(&o));
        assert!(stdout(&o).contains("wrote"), "{}", stdout(&o));
        let bytes = std::fs::read(&png).unwrap();
        assert_eq!(&bytes[1..4], b"PNG");
    }
    let o = kdray(&["render", &obj, "-o", &png, "--packet", "3"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("1, 4, 8 or 16"), "{}", stderr(&o));
    for (samples, says) in [
        ("0", "between 1 and 64 rays a pixel, not 0"),
        ("65", "between 1 and 64 rays a pixel, not 65"),
    ] {
        let o = kdray(&["render", &obj, "-o", &png, "--samples", samples]);
        assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
        assert!(stderr(&o).contains(says), "{}", stderr(&o));
    }
    // A heatmap is the picture asked for with the legend strip under it,
    // as --help says.
    let o = kdray(&[
        "render",
        &obj,
        "-o",
        &png,
        "--width",
        "33",
        "--height",
        "17",
        "--heatmap",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let legend = kdray_tools::render::LEGEND_HEIGHT;
    let bytes = std::fs::read(&png).unwrap();
    let size = |at: usize| u32::from_be_bytes(bytes[at..at + 4].try_into().unwrap());
    assert_eq!((size(16), size(20)), (33, 17 + legend), "the PNG's IHDR");
    assert!(
        stdout(&o).contains(&format!(
            "the legend adds {legend} rows under the 33x17 picture"
        )),
        "{}",
        stdout(&o)
    );
    let help = stdout(&kdray(&["render", "--help"]));
    assert!(
        help.contains(&format!("{legend} pixels taller than --height")),
        "{help}"
    );
    let o = kdray(&[
        "render", &obj, "-o", &png, "--camera", "inside", "--eye", "0,0,5",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("cannot be used with"), "{}", stderr(&o));
    let o = kdray(&["render", &obj, "-o", &png, "--samples", "4", "--heatmap"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("one ray a pixel"), "{}", stderr(&o));
    let o = kdray(&[
        "render",
        &obj,
        "-o",
        &png,
        "--width",
        "9",
        "--height",
        "7",
        "--samples",
        "4",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("4 rays a pixel"), "{}", stdout(&o));
    let o = kdray(&["render", &obj, "-o", &png, "--eye", "1,2"]);
    assert!(stderr(&o).contains("x,y,z"), "{}", stderr(&o));
    let bad = write(&tmp("bad.kdt"), b"not a tree");
    let o = kdray(&["render", &bad, "-o", &png]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("bad.kdt"), "{}", stderr(&o));
}

#[test]
fn demo_writes_both_pictures() {
    let dir = tmp("demo-out");
    let o = kdray(&[
        "demo",
        "--size",
        "32",
        "--brute-sample",
        "10",
        "--out-dir",
        &dir.display().to_string(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    for name in ["teapot-stadium.png", "teapot-stadium-heatmap.png"] {
        assert!(dir.join(name).exists(), "{name}");
        assert!(stdout(&o).contains(name), "{}", stdout(&o));
    }
}

/// The files in `dir` whose names say they are kdray's temporaries.
fn temporaries(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".tmp"))
        .collect()
}

/// A fresh folder of its own for a test that counts temporaries.
fn folder(name: &str) -> PathBuf {
    let dir = tmp(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Devices and pipes are written through, a symlink stays a symlink with
/// its target replaced, and a replaced file keeps its permissions.
#[cfg(unix)]
#[test]
fn outputs_are_written_through_or_replaced_keeping_links_and_modes() {
    use std::os::unix::fs::{FileTypeExt, PermissionsExt};
    let dir = folder("outputs");
    let obj = write(&dir.join("q.obj"), QUAD_OBJ);
    let s = |p: &Path| p.display().to_string();
    // A pipe stands for every non-regular output (`/dev/null` itself would
    // be destroyed, for everyone, by a regression run as root).
    let fifo = dir.join("pipe.kdt");
    assert!(Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .unwrap()
        .success());
    // Our end is opened first, without blocking, so kdray's open does not
    // wait, and a kdray that never opens the pipe leaves it empty instead
    // of hanging the test. The tree is far smaller than a pipe's buffer.
    let mut reader = {
        use std::os::unix::fs::OpenOptionsExt;
        const O_NONBLOCK: i32 = 0o4000;
        std::fs::OpenOptions::new()
            .read(true)
            .custom_flags(O_NONBLOCK)
            .open(&fifo)
            .unwrap()
    };
    let o = kdray(&["build", &obj, "-o", &s(&fifo)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let mut through = Vec::new();
    let _ = std::io::Read::read_to_end(&mut reader, &mut through);
    let kind = std::fs::symlink_metadata(&fifo).unwrap().file_type();
    assert!(kind.is_fifo(), "the pipe was replaced by a file");

    let target = dir.join("target.kdt");
    std::fs::write(&target, b"old").unwrap();
    std::fs::set_permissions(&target, std::fs::Permissions::from_mode(0o640)).unwrap();
    let link = dir.join("link.kdt");
    std::os::unix::fs::symlink("target.kdt", &link).unwrap();
    let o = kdray(&["build", &obj, "-o", &s(&link)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(link.symlink_metadata().unwrap().file_type().is_symlink());
    let blob = std::fs::read(&target).unwrap();
    let direct = dir.join("direct.kdt");
    assert!(kdray(&["build", &obj, "-o", &s(&direct)]).status.success());
    assert_eq!(
        blob,
        std::fs::read(&direct).unwrap(),
        "the link's target holds the tree"
    );
    assert_eq!(through, blob, "the pipe's reader got the tree");
    let mode = std::fs::metadata(&target).unwrap().permissions().mode() & 0o777;
    assert_eq!(mode, 0o640);

    let ro = dir.join("ro.kdt");
    std::fs::write(&ro, b"old").unwrap();
    std::fs::set_permissions(&ro, std::fs::Permissions::from_mode(0o444)).unwrap();
    let o = kdray(&["build", &obj, "-o", &s(&ro)]);
    let mode = std::fs::metadata(&ro).unwrap().permissions().mode() & 0o777;
    assert_eq!(mode, 0o444, "{}", stderr(&o));
    assert!(temporaries(&dir).is_empty(), "{:?}", temporaries(&dir));
}

/// SIGTERM while the output's temporary exists: the temporary is removed,
/// the old file stays, and the process dies of the signal.
#[cfg(unix)]
#[test]
fn a_signal_removes_the_temporary_and_keeps_the_old_output() {
    use std::os::unix::process::ExitStatusExt;
    // A test run started as a background job of a non-interactive shell
    // ignores SIGINT, and so does the `kdray` it starts (it keeps an
    // inherited ignore, as a background job should): INT is then tested
    // by the runs that can send it.
    let signals: &[&str] = if sigint_ignored() {
        eprintln!("SIGINT is ignored by this test run: only TERM is sent");
        &["TERM"]
    } else {
        &["TERM", "INT"]
    };
    for &signal in signals {
        let dir = folder(&format!("signal-{signal}"));
        let obj = write(&dir.join("q.obj"), QUAD_OBJ);
        let out = dir.join("q.kdt");
        std::fs::write(&out, b"the old tree").unwrap();
        let mut child = Command::new(env!("CARGO_BIN_EXE_kdray"))
            .args(["build", &obj, "-o", &out.display().to_string()])
            .env("KDRAY_TEST_HOLD_OUTPUT_MS", "20000")
            .stdout(std::process::Stdio::null())
            .spawn()
            .unwrap();
        let start = std::time::Instant::now();
        while temporaries(&dir).is_empty() {
            assert!(start.elapsed().as_secs() < 60, "no temporary appeared");
            std::thread::sleep(std::time::Duration::from_millis(20));
        }
        let killed = Command::new("kill")
            .args([&format!("-{signal}"), &child.id().to_string()])
            .status()
            .unwrap();
        assert!(killed.success());
        let status = child.wait().unwrap();
        assert!(status.signal().is_some(), "{signal}: {status:?}");
        assert!(temporaries(&dir).is_empty(), "{:?}", temporaries(&dir));
        assert_eq!(std::fs::read(&out).unwrap(), b"the old tree");
    }
}

/// A write that fails part way (the file size limit) keeps the previous
/// picture and leaves no temporary.
#[cfg(unix)]
#[test]
fn a_failed_write_keeps_the_previous_picture() {
    let dir = folder("fsize");
    let obj = write(&dir.join("q.obj"), QUAD_OBJ);
    let png = dir.join("q.png");
    std::fs::write(&png, b"the previous picture").unwrap();
    // bash counts the limit in 1024-byte blocks: 1 KiB, far less than a
    // 600x600 PNG (10 KB).
    let o = Command::new("bash")
        .args([
            "-c",
            "ulimit -f 1 && exec \"$0\" render \"$1\" -o \"$2\" --width 600 --height 600",
            env!("CARGO_BIN_EXE_kdray"),
            &obj,
            &png.display().to_string(),
        ])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("q.png"), "{}", stderr(&o));
    assert_eq!(std::fs::read(&png).unwrap(), b"the previous picture");
    assert!(temporaries(&dir).is_empty(), "{:?}", temporaries(&dir));
}

/// Bad arguments are refused before the input is even read: each case
/// names a mesh that does not exist, and the error is about the argument.
#[test]
fn arguments_are_checked_before_the_work() {
    let tree = tmp("first.kdt").display().to_string();
    let missing = "/nonexistent/mesh.obj";
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (
            vec!["build", missing, "-o", "/nonexistent-folder/x.kdt"],
            "the folder /nonexistent-folder does not exist",
        ),
        (
            vec!["build", missing, "-o", &tree, "--builder", "sha"],
            "unknown builder 'sha'",
        ),
        (vec!["build", missing, "-o", "/tmp"], "is a folder"),
        (
            vec!["render", missing, "-o", "/nonexistent-folder/x.png"],
            "does not exist",
        ),
        (
            vec![
                "trace",
                missing,
                missing,
                "-o",
                "/nonexistent-folder/x.hits",
            ],
            "does not exist",
        ),
        (
            vec!["knn", missing, missing, "-o", "/nonexistent-folder/x.knn"],
            "does not exist",
        ),
        (
            vec!["build-points", missing, "-o", "/nonexistent-folder/x.kdt"],
            "does not exist",
        ),
        (
            vec!["rays", missing, "-o", "/nonexistent-folder/x.rays"],
            "does not exist",
        ),
        (
            vec!["demo", "--out-dir", "/dev/null/out"],
            "/dev/null/out: cannot create",
        ),
    ];
    for (args, want) in cases {
        let o = kdray(&args);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(want), "{args:?}: {}", stderr(&o));
        assert!(
            !stdout(&o).contains("built-in scene"),
            "{args:?} did the work"
        );
    }
}

/// Sizes from the command line are checked: a clear error (exit 1 or 2),
/// never an abort (134) or a panic (101).
#[test]
fn sizes_are_checked() {
    let obj = write(&tmp("sizes.obj"), QUAD_OBJ);
    let pts: Vec<u8> = (0..30u32)
        .flat_map(|i| [i as f32, 0.5, 0.25])
        .flat_map(f32::to_le_bytes)
        .collect();
    let pts = write(&tmp("sizes.pts"), &pts);
    let out = tmp("sizes.out").display().to_string();
    let png = tmp("sizes.png").display().to_string();
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (
            vec!["knn", &pts, &pts, "-k", "1000000000000", "-o", &out],
            "more than the 30 points",
        ),
        (
            vec![
                "render", &obj, "-o", &png, "--width", "100000", "--height", "100000",
            ],
            "16384 x 16384",
        ),
        (
            vec!["render", &obj, "-o", &png, "--width", "4294967295"],
            "16384 x 16384",
        ),
        (
            vec!["render", &obj, "-o", &png, "--width", "0"],
            "at least 1",
        ),
        (
            vec!["render", &obj, "-o", &png, "--threads", "100000"],
            "more than 1024",
        ),
        (
            vec!["build", &obj, "-o", &out, "--threads", "100000"],
            "more than 1024",
        ),
        (
            vec!["render", &obj, "-o", &png, "--threads", "0"],
            "at least 1",
        ),
        (
            vec!["build", &obj, "-o", &out, "--threads", "0"],
            "at least 1",
        ),
        (
            vec!["knn", &pts, &pts, "-o", &out, "--threads", "0"],
            "at least 1",
        ),
        (
            vec!["knn", &pts, &pts, "-o", &out, "--leaf-size", "0"],
            "--leaf-size",
        ),
        (
            vec!["build-points", &pts, "-o", &out, "--leaf-size", "0"],
            "--leaf-size",
        ),
        (vec!["demo", "--size", "100000"], "16384 x 16384"),
        (vec!["bench", "needles", "--rays", "100000000000"], "--rays"),
        (vec!["rays", &obj, "-o", &out, "--count", "0"], "--count"),
        (vec!["render", &obj, "-o", &png, "--fov", "200"], "--fov"),
    ];
    for (args, want) in cases {
        let o = kdray(&args);
        let err = stderr(&o);
        assert!(
            matches!(o.status.code(), Some(1 | 2)),
            "{args:?}: {:?} {err}",
            o.status
        );
        assert!(
            err.contains(want),
            "{args:?}: {err:?} does not say {want:?}"
        );
        assert!(!err.contains("panicked"), "{args:?}: {err}");
    }
    // bench refuses --threads 0 as every other command does, and a bad
    // scene before it prints the table's header.
    let o = kdray(&["bench", "needles", "--rays", "64", "--threads", "0"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("--threads must be at least 1"),
        "{}",
        stderr(&o)
    );
    let o = kdray(&["bench", "needles", "/nonexistent/mesh.obj", "--rays", "64"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stdout(&o).is_empty(), "{}", stdout(&o));
    assert!(
        stderr(&o).contains("/nonexistent/mesh.obj"),
        "{}",
        stderr(&o)
    );
}

/// Mesh problems through the binary: a vertex past `f32`'s range or NaN,
/// faces of fewer than three corners, an empty file, a file cut inside its
/// vertices: errors with the line.
#[test]
fn bad_meshes_are_refused_with_the_line() {
    let out = tmp("badmesh.kdt").display().to_string();
    let cases: [(&str, &[u8], &str); 6] = [
        (
            "huge.obj",
            b"v 0 0 0\nv 1 0 1e39\nv 0 1 0\nf 1 2 3\n",
            "huge.obj:2: non-finite vertex coordinate 1e39",
        ),
        (
            "nan.obj",
            b"v 0 0 0\nv 1 0 0\n\nv nan 1 0\nf 1 2 3\n",
            "nan.obj:4: non-finite vertex coordinate nan",
        ),
        (
            "two.obj",
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n",
            "two.obj:4: a face needs at least 3 corners, this one has 2",
        ),
        (
            "one.obj",
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 4\n",
            "one.obj:5: a face needs at least 3 corners, this one has 1",
        ),
        ("empty.obj", b"", "empty.obj: the mesh has no triangles"),
        (
            "cut.obj",
            b"v 0 0 0\nv 1 0 0\nv 0 1",
            "cut.obj:3: malformed OBJ",
        ),
    ];
    for (name, bytes, want) in cases {
        let obj = write(&tmp(name), bytes);
        let o = kdray(&["build", &obj, "-o", &out]);
        assert_eq!(o.status.code(), Some(1), "{name}: {}", stderr(&o));
        assert!(stderr(&o).contains(want), "{name}: {}", stderr(&o));
    }
}

/// `kdray rays` makes every kind; camera-tiled holds the camera rays in
/// tile order; the hits of both are the same per pixel; shadow rays trace.
#[test]
fn rays_makes_files_the_other_commands_read() {
    let obj = write(&tmp("rays.obj"), QUAD_OBJ);
    let tree = tmp("rays.kdt").display().to_string();
    assert!(kdray(&["build", &obj, "-o", &tree]).status.success());
    let file = |kind: &str| tmp(&format!("rays-{kind}.rays"));
    for (kind, count) in [
        ("camera", 24 * 10),
        ("camera-tiled", 24 * 10),
        ("random", 77),
    ] {
        let out = file(kind).display().to_string();
        let o = kdray(&[
            "rays", &obj, "-o", &out, "--kind", kind, "--width", "24", "--height", "10", "--count",
            "77",
        ]);
        assert!(o.status.success(), "{kind}: {}", stderr(&o));
        assert_eq!(std::fs::read(&out).unwrap().len(), count * 32, "{kind}");
    }
    let records = |p: &Path| -> Vec<Vec<u8>> {
        std::fs::read(p)
            .unwrap()
            .chunks(32)
            .map(<[u8]>::to_vec)
            .collect()
    };
    let (row, tiled) = (records(&file("camera")), records(&file("camera-tiled")));
    assert_ne!(row, tiled);
    // The first 4x2 tile: pixels (0..4, 0) then (0..4, 1).
    assert_eq!(tiled[..4], row[..4]);
    assert_eq!(tiled[4..8], row[24..28]);
    let (mut a, mut b) = (row.clone(), tiled.clone());
    a.sort();
    b.sort();
    assert_eq!(a, b, "the same rays in another order");

    let shadow = file("shadow").display().to_string();
    let o = kdray(&[
        "rays", &obj, "-o", &shadow, "--kind", "shadow", "--width", "24", "--height", "10",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let n = std::fs::read(&shadow).unwrap().len() / 32;
    assert!(n > 0 && n <= 240, "{n} shadow rays");
    let hits = tmp("rays-shadow.hits").display().to_string();
    let o = kdray(&[
        "trace",
        &tree,
        &shadow,
        "-o",
        &hits,
        "--any-hit",
        "--threads",
        "1",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("on 1 thread,"), "{}", stdout(&o));

    // sort-rays: the same records in another order.
    let random = file("random");
    let sorted = tmp("rays-sorted.rays");
    let o = kdray(&[
        "sort-rays",
        &random.display().to_string(),
        "-o",
        &sorted.display().to_string(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let (mut a, mut b) = (records(&random), records(&sorted));
    assert_ne!(a, b, "77 random rays come out reordered");
    a.sort();
    b.sort();
    assert_eq!(a, b, "the same rays in another order");
    let s = sorted.display().to_string();
    let junk = write(&tmp("rays-junk.rays"), &[0u8; 33]);
    let o = kdray(&["sort-rays", &junk, "-o", &s]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("not a multiple"), "{}", stderr(&o));
    assert_eq!(records(&sorted).len(), 77, "a failed sort keeps the output");
}

/// `info --json` says `"valid": true` as a boolean, and on failure prints
/// `"valid": false` with the error; `trace --counts --json` has the counts.
#[test]
fn json_outputs_say_everything() {
    let obj = write(&tmp("json.obj"), QUAD_OBJ);
    let tree = tmp("json.kdt").display().to_string();
    assert!(kdray(&["build", &obj, "-o", &tree]).status.success());
    let o = kdray(&["info", &tree, "--json"]);
    assert_eq!(json(&o)["valid"], true, "{}", stdout(&o));
    let junk = write(&tmp("json-junk.kdt"), b"junk");
    let o = kdray(&["info", &junk, "--json"]);
    assert_eq!(o.status.code(), Some(1));
    let j = json(&o);
    assert!(j["valid"] == false && j["error"].is_string(), "{j}");
    let rays = tmp("json.rays").display().to_string();
    assert!(
        kdray(&["rays", &obj, "-o", &rays, "--width", "8", "--height", "8"])
            .status
            .success()
    );
    let hits = tmp("json.hits").display().to_string();
    let o = kdray(&["trace", &tree, &rays, "-o", &hits, "--counts", "--json"]);
    let j = json(&o);
    assert!(
        j["nodes_per_ray"].is_number() && j["triangles_per_ray"].is_number(),
        "{j}"
    );
}

#[test]
fn point_commands_take_any_dimension_and_f64() {
    use kdray_kernel::{knn_brute, Neighbour};
    // 200 2-D f64 points on a jittered grid, 7 queries.
    let points: Vec<[f64; 2]> = (0..200)
        .map(|i| {
            [
                (i % 20) as f64 * 0.1 + 1e-9 * i as f64,
                (i / 20) as f64 * 0.3,
            ]
        })
        .collect();
    let queries: Vec<[f64; 2]> = (0..7)
        .map(|i| [i as f64 * 0.31, 1.0 - i as f64 * 0.2])
        .collect();
    let p = write(&tmp("p2.pts"), bytemuck::cast_slice(&points));
    let q = write(&tmp("q2.pts"), bytemuck::cast_slice(&queries));
    let out = tmp("out2.knn").display().to_string();
    let o = kdray(&["knn", &p, &q, "-k", "3", "-o", &out, "--dim", "2", "--f64"]);
    assert!(o.status.success(), "{}", stderr(&o));
    // 12-byte records: u32 index, f64 squared distance; as brute force.
    let bytes = std::fs::read(&out).unwrap();
    assert_eq!(bytes.len(), 7 * 3 * 12);
    for (qi, q) in queries.iter().enumerate() {
        let mut want = [Neighbour::<f64>::NONE; 3];
        knn_brute(&points, *q, f64::INFINITY, &mut want);
        for (j, w) in want.iter().enumerate() {
            let r = &bytes[(qi * 3 + j) * 12..][..12];
            let index = u32::from_le_bytes(r[..4].try_into().unwrap());
            let d2 = f64::from_le_bytes(r[4..].try_into().unwrap());
            assert_eq!((index, d2.to_bits()), (w.index, w.d2.to_bits()));
        }
    }
    // An 8-D f32 tree blob loads as 8-D f32 only.
    let p8 = write(&tmp("p8.pts"), &[0u8; 32 * 50]);
    let blob = tmp("p8.kdp");
    let o = kdray(&[
        "build-points",
        &p8,
        "-o",
        &blob.display().to_string(),
        "--dim",
        "8",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let words = kdray_tools::blob::Blob::read(&blob).unwrap();
    assert_eq!(words.point_tree::<8, f32>().unwrap().len(), 50);
    let e = words.point_tree::<3, f32>().unwrap_err();
    assert!(e.to_string().contains("8-dimensional"), "{e}");
    // A file that is not whole records of the shape, and a D not compiled.
    let o = kdray(&["knn", &p, &q, "-o", &out, "--dim", "3", "--f64"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("24-byte 3-D f64 point record"),
        "{}",
        stderr(&o)
    );
    let o = kdray(&["knn", &p, &q, "-o", &out, "--dim", "17"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("--dim 17 is not supported"),
        "{}",
        stderr(&o)
    );
}

/// Does this process ignore SIGINT (`SigIgn` in `/proc/self/status`,
/// bit 1)? `false` where that file does not exist.
#[cfg(unix)]
fn sigint_ignored() -> bool {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|status| {
            let mask = status.lines().find_map(|l| l.strip_prefix("SigIgn:"))?;
            u64::from_str_radix(mask.trim(), 16).ok()
        })
        .is_some_and(|mask| mask & (1 << 1) != 0)
}

/// `kdray args` with its address space limited to `kib` KiB (`ulimit -v`).
#[cfg(unix)]
fn kdray_limited(kib: u64, args: &[&str]) -> Output {
    Command::new("sh")
        .arg("-c")
        .arg(format!("ulimit -v {kib} && exec \"$0\" \"$@\""))
        .arg(env!("CARGO_BIN_EXE_kdray"))
        .args(args)
        .output()
        .expect("run kdray")
}

/// A binary PLY grid of `n` x `n` vertices, 2 (n-1)^2 triangles.
fn grid_ply(n: u32) -> Vec<u8> {
    let mut b = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nelement face {}\nproperty list uchar int vertex_indices\nend_header\n",
        n * n,
        2 * (n - 1) * (n - 1)
    )
    .into_bytes();
    for i in 0..n {
        for j in 0..n {
            for c in [i as f32, j as f32, ((i * j) % 7) as f32] {
                b.extend(c.to_le_bytes());
            }
        }
    }
    for i in 0..n - 1 {
        for j in 0..n - 1 {
            let a = i * n + j;
            for t in [[a, a + 1, a + n], [a + 1, a + n + 1, a + n]] {
                b.push(3);
                t.iter().for_each(|v| b.extend(v.to_le_bytes()));
            }
        }
    }
    b
}

/// Memory that runs out (under `ulimit -v`) is an error naming what did
/// not fit, status 1: never Rust's abort (134, "memory allocation of N
/// bytes failed").
#[cfg(unix)]
#[test]
fn memory_that_runs_out_is_an_error_not_an_abort() {
    let dir = folder("oom");
    let obj = write(&dir.join("q.obj"), QUAD_OBJ);
    let out = dir.join("out.rays").display().to_string();
    let big = ["--width", "16384", "--height", "16384"];
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (
            [&["rays", &obj, "-o", &out][..], &big].concat(),
            "camera rays",
        ),
        (
            [
                &["rays", &obj, "-o", &out, "--kind", "camera-tiled"][..],
                &big,
            ]
            .concat(),
            "pixel coordinates",
        ),
        (
            [&["rays", &obj, "-o", &out, "--kind", "shadow"][..], &big].concat(),
            "camera rays",
        ),
        (
            vec![
                "rays",
                &obj,
                "-o",
                &out,
                "--kind",
                "random",
                "--count",
                "268435456",
            ],
            "random rays",
        ),
    ];
    for (args, what) in cases {
        let o = kdray_limited(1_000_000, &args);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {e}");
        assert!(
            e.contains("out of memory") && e.contains(what),
            "{args:?}: {e}"
        );
        assert!(!Path::new(&out).exists(), "{args:?}");
    }
    // A mesh whose build needs more than the limit (1.6 million
    // triangles: about 440 MB resident at the build's peak on two
    // threads, beside the ~300 MB of address space the process starts
    // with): whichever allocation fails, the same clean error.
    let ply = dir.join("grid.ply");
    std::fs::write(&ply, grid_ply(901)).unwrap();
    let tree = dir.join("grid.kdt").display().to_string();
    // Two threads: on a machine of many cores, their stacks alone would
    // take a share of the limit.
    let o = kdray_limited(
        500_000,
        &[
            "build",
            &ply.display().to_string(),
            "-o",
            &tree,
            "--threads",
            "2",
        ],
    );
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(e.contains("kdray: error: out of memory"), "{e}");
    assert!(!e.contains("memory allocation of"), "{e}");
    assert!(temporaries(&dir).is_empty(), "{:?}", temporaries(&dir));
}

/// `trace --first-hits K` writes K records a ray a part at a time: K x
/// rays records (1.3 GB here) need not fit in memory (1 GB here).
#[cfg(unix)]
#[test]
fn first_hits_stream_past_the_memory_limit() {
    let dir = folder("stream");
    let obj = write(&dir.join("q.obj"), QUAD_OBJ);
    let tree = dir.join("q.kdt").display().to_string();
    assert!(kdray(&["build", &obj, "-o", &tree]).status.success());
    let n = 80_000;
    let rays: Vec<[f32; 8]> = (0..n)
        .map(|i| {
            let x = ((i % 400) as f32 + 0.5) / 400.0;
            [x, 0.3, 2.0, 0.0, 0.0, 0.0, -1.0, f32::INFINITY]
        })
        .collect();
    let rays = write(&dir.join("many.rays"), &ray_bytes(&rays));
    let o = kdray_limited(
        1_000_000,
        &[
            "trace",
            &tree,
            &rays,
            "-o",
            "/dev/null",
            "--first-hits",
            "1024",
            "--json",
            "--threads",
            "2",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let j = json(&o);
    assert_eq!(j["rays"], n);
    assert_eq!(j["first_hits"], 1024);
    assert_eq!(j["hits"], n, "every ray hits the quad");
    // The same records as in one part: a small run compared record by record.
    let few = write(
        &dir.join("few.rays"),
        &std::fs::read(&rays).unwrap()[..32 * 3000],
    );
    let (a, b) = (dir.join("a.hits"), dir.join("b.hits"));
    let run = |k: &str, out: &Path| {
        let o = kdray(&[
            "trace",
            &tree,
            &few,
            "-o",
            &out.display().to_string(),
            "--first-hits",
            k,
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        std::fs::read(out).unwrap()
    };
    let one = run("1", &a);
    let many = run("1024", &b);
    assert_eq!(many.len(), 3000 * 1024 * 16);
    for (r, first) in one.chunks(16).enumerate() {
        assert_eq!(first, &many[r * 1024 * 16..r * 1024 * 16 + 16], "ray {r}");
    }
}

/// An output that is one of the command's inputs (the same file, also
/// through a symlink or a hard link) is refused, and the input kept.
#[test]
fn an_output_over_an_input_is_refused() {
    let dir = folder("apart");
    let obj = write(&dir.join("victim.obj"), QUAD_OBJ);
    let tree = dir.join("q.kdt").display().to_string();
    assert!(kdray(&["build", &obj, "-o", &tree]).status.success());
    let rays = write(
        &dir.join("keep.rays"),
        &ray_bytes(&[[0.25, 0.75, 2.0, 0.0, 0.0, 0.0, -1.0, f32::INFINITY]]),
    );
    let pts = write(&dir.join("p.pts"), &[0u8; 12 * 4]);
    let (gltf, bin) = quad_gltf_with_buffer_file(&dir);
    let gltf_tree = dir.join("gltf.kdt").display().to_string();
    assert!(kdray(&["build", &gltf, "-o", &gltf_tree]).status.success());
    let mut names = vec![obj.clone(), rays.clone(), tree.clone(), pts.clone()];
    #[cfg(unix)]
    {
        let link = dir.join("link.obj");
        let _ = std::fs::remove_file(&link);
        std::os::unix::fs::symlink(&obj, &link).unwrap();
        let hard = dir.join("hard.rays");
        let _ = std::fs::remove_file(&hard);
        std::fs::hard_link(&rays, &hard).unwrap();
        names.push(link.display().to_string());
        names.push(hard.display().to_string());
    }
    names.push(bin.clone());
    let before: Vec<Vec<u8>> = names.iter().map(|n| std::fs::read(n).unwrap()).collect();
    let link_obj = names.get(4).cloned().unwrap_or(obj.clone());
    let hard_rays = names.get(5).cloned().unwrap_or(rays.clone());
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["build", &obj, "-o", &obj], &obj),
        (vec!["build", &obj, "-o", &link_obj], &obj),
        (vec!["trace", &tree, &rays, "-o", &rays], &rays),
        (vec!["trace", &tree, &rays, "-o", &hard_rays], &rays),
        (vec!["trace", &tree, &rays, "-o", &tree], &tree),
        (vec!["render", &tree, "-o", &tree], &tree),
        (vec!["rays", &obj, "-o", &obj], &obj),
        (vec!["export-obj", &obj, "-o", &obj], &obj),
        (vec!["build-points", &pts, "-o", &pts], &pts),
        (vec!["knn", &pts, &pts, "-o", &pts], &pts),
        (vec!["sort-rays", &rays, "-o", &rays], &rays),
        (vec!["sort-rays", &rays, "-o", &hard_rays], &rays),
        // A glTF's external buffer is an input too.
        (vec!["build", &gltf, "-o", &bin], &bin),
        (vec!["render", &gltf, "-o", &bin], &bin),
        (vec!["rays", &gltf, "-o", &bin], &bin),
        (vec!["export-obj", &gltf, "-o", &bin], &bin),
    ];
    for (args, input) in cases {
        let o = kdray(&args);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {e}");
        assert!(
            e.contains(&format!("is the input {input} (the same file)")),
            "{args:?}: {e}"
        );
    }
    let after: Vec<Vec<u8>> = names.iter().map(|n| std::fs::read(n).unwrap()).collect();
    assert!(before == after, "an input changed");
}

/// [`quad_gltf`] with its buffer in the file `quad.bin` beside it, in
/// `dir`: the glTF's path and the buffer's.
fn quad_gltf_with_buffer_file(dir: &Path) -> (String, String) {
    use base64::Engine as _;
    let text = String::from_utf8(quad_gltf()).unwrap();
    let start = text.find("data:").unwrap();
    let end = start + text[start..].find('"').unwrap();
    let payload = text[start..end].split_once(";base64,").unwrap().1;
    let bytes = base64::engine::general_purpose::STANDARD
        .decode(payload)
        .unwrap();
    let bin = write(&dir.join("quad.bin"), &bytes);
    let text = format!("{}quad.bin{}", &text[..start], &text[end..]);
    (write(&dir.join("quad.gltf"), text.as_bytes()), bin)
}

/// A glTF (buffer in a data: URI) whose mesh, the unit quad in z = 0, two
/// nodes place: as is, and moved by 2 in x.
fn quad_gltf() -> Vec<u8> {
    use base64::Engine as _;
    let mut bin: Vec<u8> = [0f32, 0., 0., 1., 0., 0., 1., 1., 0., 0., 1., 0.]
        .iter()
        .flat_map(|f| f.to_le_bytes())
        .collect();
    for i in [0u16, 1, 2, 0, 2, 3] {
        bin.extend(i.to_le_bytes());
    }
    let uri = base64::engine::general_purpose::STANDARD.encode(&bin);
    format!(
        r#"{{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": [0, 1]}}],
  "nodes": [{{"mesh": 0}}, {{"mesh": 0, "translation": [2, 0, 0]}}],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}, "indices": 1}}]}}],
  "buffers": [{{"uri": "data:application/octet-stream;base64,{uri}", "byteLength": 60}}],
  "bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": 48}}, {{"buffer": 0, "byteOffset": 48, "byteLength": 12}}],
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0,0,0], "max": [1,1,0]}},
    {{"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"}}]}}"#
    )
    .into_bytes()
}

/// Each command reads the blob kinds it can and names the kind it
/// cannot: never "invalid" for a valid blob of another kind.
#[test]
fn every_blob_kind_is_read_or_named() {
    let dir = folder("kinds");
    let gltf = write(&dir.join("quad.gltf"), &quad_gltf());
    let scene = dir.join("scene.kdt").display().to_string();
    let o = kdray(&["build", &gltf, "-o", &scene, "--instances"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let pts = write(&dir.join("p.pts"), &[0u8; 12 * 40]);
    let cloud = dir.join("cloud.kdt").display().to_string();
    assert!(kdray(&["build-points", &pts, "-o", &cloud])
        .status
        .success());
    let rays = dir.join("s.rays").display().to_string();
    let png = dir.join("s.png").display().to_string();

    // info reads a point blob and prints its statistics.
    let o = kdray(&["info", &cloud, "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j = json(&o);
    assert_eq!(
        (j["valid"].clone(), j["kind"].clone()),
        (true.into(), "points".into())
    );
    assert_eq!(
        (j["points"].clone(), j["dim"].clone()),
        (40.into(), 3.into())
    );
    let o = kdray(&["info", &cloud]);
    assert!(
        stdout(&o).contains("valid kdray point tree"),
        "{}",
        stdout(&o)
    );

    // rays reads a scene (camera and random rays)...
    for kind in ["camera", "camera-tiled", "random"] {
        let o = kdray(&[
            "rays", &scene, "-o", &rays, "--kind", kind, "--width", "8", "--height", "8",
        ]);
        assert!(o.status.success(), "{kind}: {}", stderr(&o));
    }
    // ... and the others name what they were given.
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (
            vec!["rays", &scene, "-o", &rays, "--kind", "shadow"],
            "this is a scene (instanced triangle trees); `kdray rays --kind shadow` takes a triangle tree",
        ),
        (
            vec!["rays", &cloud, "-o", &rays],
            "this is a point tree; `kdray rays` takes a mesh, a triangle tree or a scene",
        ),
        (
            vec!["trace", &cloud, &rays, "-o", &png],
            "this is a point tree; `kdray trace` takes a triangle tree or a scene",
        ),
        (
            vec!["render", &cloud, "-o", &png],
            "this is a point tree; `kdray render` takes a mesh, a triangle tree or a scene",
        ),
        (
            vec!["render", &scene, "-o", &png, "--camera", "inside"],
            "--camera inside probes one tree: render the flattened scene",
        ),
        (
            vec!["rays", &scene, "-o", &rays, "--camera", "inside"],
            "--camera inside probes one tree: render the flattened scene",
        ),
    ];
    for (args, want) in cases {
        let o = kdray(&args);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {e}");
        assert!(e.contains(want) && !e.contains("invalid"), "{args:?}: {e}");
    }
}

/// `trace` on a scene blob refuses the options it cannot honour, and its
/// JSON has the fields of the mesh path's.
#[test]
fn trace_of_a_scene_honours_or_refuses_every_option() {
    let dir = folder("scene-trace");
    let gltf = write(&dir.join("quad.gltf"), &quad_gltf());
    let scene = dir.join("scene.kdt").display().to_string();
    let flat = dir.join("flat.kdt").display().to_string();
    assert!(kdray(&["build", &gltf, "-o", &scene, "--instances"])
        .status
        .success());
    assert!(kdray(&["build", &gltf, "-o", &flat]).status.success());
    let rays = write(
        &dir.join("r.rays"),
        &ray_bytes(&[
            [0.25, 0.75, 2.0, 0.0, 0.0, 0.0, -1.0, f32::INFINITY],
            [2.5, 0.5, 2.0, 0.0, 0.0, 0.0, -1.0, f32::INFINITY],
        ]),
    );
    let hits = dir.join("r.hits").display().to_string();
    for (extra, want) in [
        (&["--counts"][..], "no --counts"),
        (&["--packet", "8"][..], "leave --packet at auto or 1"),
        (&["--order", "morton"][..], "instead of --order morton"),
    ] {
        let o = kdray(&[&["trace", &scene, &rays, "-o", &hits][..], extra].concat());
        assert_eq!(o.status.code(), Some(1), "{extra:?}");
        assert!(stderr(&o).contains(want), "{extra:?}: {}", stderr(&o));
    }
    let o = kdray(&["trace", &flat, &rays, "-o", &hits, "--json"]);
    let mesh = json(&o);
    let o = kdray(&["trace", &scene, &rays, "-o", &hits, "--json"]);
    let scene_json = json(&o);
    for key in mesh.as_object().unwrap().keys() {
        assert!(
            scene_json.get(key).is_some(),
            "{key} missing from {scene_json}"
        );
    }
    assert_eq!(scene_json["hits"], 2);
    assert_eq!(scene_json["order"], "given");
}

/// The smaller rough edges: negative numbers as values, --max-depth past
/// the kernel's stack, the fast builder's peak memory, demo's sample and
/// folder, the top-level help, the glTF folder by name.
#[test]
fn small_rough_edges_are_smoothed() {
    let dir = folder("rough");
    let obj = write(&dir.join("q.obj"), QUAD_OBJ);
    let png = dir.join("q.png").display().to_string();
    let tree = dir.join("q.kdt").display().to_string();
    // A negative number is a value, not a flag: refused for its range.
    let o = kdray(&["render", &obj, "-o", &png, "--fov", "-10"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("--fov must be between 0 and 180 degrees, not -10"),
        "{}",
        stderr(&o)
    );
    let o = kdray(&["build", &obj, "-o", &tree, "--traversal-cost", "-1"]);
    assert!(
        stderr(&o).contains("--traversal-cost must be a positive number, not -1"),
        "{}",
        stderr(&o)
    );
    let o = kdray(&["build", &obj, "-o", &tree, "--max-depth", "65"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("--max-depth 65 is more than 64"),
        "{}",
        stderr(&o)
    );
    // Every builder reports the memory it worked in.
    for builder in ["fast", "sah", "median"] {
        let o = kdray(&["build", &obj, "-o", &tree, "--builder", builder, "--json"]);
        let peak = json(&o)["peak_build_bytes_per_triangle"].as_f64().unwrap();
        assert!(peak > 0.0, "{builder}: {peak}");
    }
    // demo: exactly the sample asked for (or none), one speed on one
    // thread, and an --out-dir that is a file named as such.
    let out = dir.join("demo").display().to_string();
    let o = kdray(&[
        "demo",
        "--size",
        "16",
        "--brute-sample",
        "200",
        "--out-dir",
        &out,
    ]);
    assert!(
        stdout(&o).contains("brute force on 200 of those rays"),
        "{}",
        stdout(&o)
    );
    let o = kdray(&[
        "demo",
        "--size",
        "16",
        "--brute-sample",
        "0",
        "--out-dir",
        &out,
    ]);
    assert!(
        o.status.success() && stdout(&o).contains("skipped (--brute-sample 0)"),
        "{}",
        stdout(&o)
    );
    // On one core (taskset, where there is one) one speed, not the same twice.
    let one_core = Command::new("taskset")
        .args([
            "-c",
            "0",
            env!("CARGO_BIN_EXE_kdray"),
            "demo",
            "--size",
            "16",
        ])
        .args(["--brute-sample", "5", "--out-dir", &out])
        .output();
    if let Some(o) = one_core.ok().filter(|o| o.status.success()) {
        let line = stdout(&o)
            .lines()
            .find(|l| l.starts_with("traced"))
            .unwrap_or("")
            .to_string();
        assert_eq!(line.matches("Mrays/s").count(), 1, "{line}");
    }
    let o = kdray(&["demo", "--size", "16", "--out-dir", &obj]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("is a file, not a folder"),
        "{}",
        stderr(&o)
    );
    // The help's first line describes the tool, not the crate.
    let o = kdray(&["--help"]);
    let help = stdout(&o);
    assert!(help.starts_with("kdray: build k-d trees"), "{help}");
    let o = kdray(&["build-points", "--help"]);
    assert!(!stdout(&o).contains("lecture"), "{}", stdout(&o));
    // A glTF beside the working folder names its folder in full.
    let gltf = br#"{"asset": {"version": "2.0"}, "scenes": [{"nodes": []}], "buffers": [{"uri": "../x.bin", "byteLength": 4}]}"#;
    write(&dir.join("out.gltf"), gltf);
    let o = Command::new(env!("CARGO_BIN_EXE_kdray"))
        .args(["build", "out.gltf", "-o", "out.kdt"])
        .current_dir(&dir)
        .output()
        .unwrap();
    let canonical = std::fs::canonicalize(&dir).unwrap();
    assert!(
        stderr(&o).contains(&format!(
            "outside the glTF's folder {} ",
            canonical.display()
        )),
        "{}",
        stderr(&o)
    );
}

/// A closed unit cube, [0, 1]^3, as OBJ quads.
const CUBE_OBJ: &[u8] = b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
f 1 2 3 4\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";

fn point_bytes(points: &[[f32; 3]]) -> Vec<u8> {
    points
        .iter()
        .flatten()
        .flat_map(|f| f.to_le_bytes())
        .collect()
}

/// The `.dist` records: point, triangle, u, v, distance.
fn dist_records(bytes: &[u8]) -> Vec<([f32; 3], u32, f32, f32, f32)> {
    let f = |c: &[u8], i: usize| f32::from_le_bytes(c[i * 4..i * 4 + 4].try_into().unwrap());
    bytes
        .chunks_exact(28)
        .map(|c| {
            let prim = u32::from_le_bytes(c[12..16].try_into().unwrap());
            ([f(c, 0), f(c, 1), f(c, 2)], prim, f(c, 4), f(c, 5), f(c, 6))
        })
        .collect()
}

#[test]
fn distance_writes_closest_points_and_signed_distances() {
    let obj = write(&tmp("dcube.obj"), CUBE_OBJ);
    let tree = tmp("dcube.kdt").display().to_string();
    assert!(kdray(&["build", &obj, "-o", &tree]).status.success());
    let pts = write(
        &tmp("d.pts"),
        &point_bytes(&[[0.5, 0.5, -2.0], [0.5, 0.5, 0.25], [3.0, 0.5, 0.5]]),
    );
    let out = tmp("d.dist");
    let o = kdray(&["distance", &tree, &pts, "-o", &out.display().to_string()]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("3 queries"), "{}", stdout(&o));
    let r = dist_records(&std::fs::read(&out).unwrap());
    assert_eq!(r.len(), 3);
    assert_eq!((r[0].0, r[0].4), ([0.5, 0.5, 0.0], 2.0));
    assert_eq!(r[1].4, 0.25);
    assert_eq!((r[2].0, r[2].4), ([1.0, 0.5, 0.5], 2.0));
    // Signed: the middle point is inside.
    let o = kdray(&[
        "distance",
        &tree,
        &pts,
        "-o",
        &out.display().to_string(),
        "--signed",
        "--threads",
        "1",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let r = dist_records(&std::fs::read(&out).unwrap());
    assert_eq!([r[0].4, r[1].4, r[2].4], [2.0, -0.25, 2.0]);
    // By the winding number: the same on the cube with every face turned
    // out. This cube's floor faces in, so its winding number just above
    // the floor is near 0: outside by that rule. Not with --votes.
    let turned = String::from_utf8_lossy(CUBE_OBJ).replace("f 1 2 3 4", "f 1 4 3 2");
    let oriented = write(&tmp("dcube-out.obj"), turned.as_bytes());
    let oriented_tree = tmp("dcube-out.kdt").display().to_string();
    assert!(kdray(&["build", &oriented, "-o", &oriented_tree])
        .status
        .success());
    let signed_by = |tree: &str, rule: &[&str]| {
        let out = out.display().to_string();
        let mut args = vec!["distance", tree, &pts, "-o", &out, "--signed"];
        args.extend(rule);
        let o = kdray(&args);
        o.status.success().then(|| {
            let r = dist_records(&std::fs::read(&out).unwrap());
            [r[0].4, r[1].4, r[2].4]
        })
    };
    assert_eq!(
        signed_by(&oriented_tree, &["--winding"]),
        Some([2.0, -0.25, 2.0])
    );
    assert_eq!(signed_by(&tree, &["--winding"]), Some([2.0, 0.25, 2.0]));
    assert_eq!(signed_by(&tree, &["--winding", "--votes", "3"]), None);
    // Within 1: the first and last have no point.
    let o = kdray(&[
        "distance",
        &tree,
        &pts,
        "-o",
        &out.display().to_string(),
        "--max-distance",
        "1",
        "--signed",
        "--votes",
        "3",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let r = dist_records(&std::fs::read(&out).unwrap());
    assert_eq!((r[0].1, r[0].4), (u32::MAX, f32::INFINITY));
    assert!(r[0].0[0].is_nan());
    assert_eq!((r[1].4, r[2].4), (-0.25, f32::INFINITY));
}

#[test]
fn distance_refuses_bad_input_by_name() {
    let obj = write(&tmp("dcube2.obj"), CUBE_OBJ);
    let tree = tmp("dcube2.kdt").display().to_string();
    assert!(kdray(&["build", &obj, "-o", &tree]).status.success());
    let out = tmp("bad.dist").display().to_string();
    let good = write(&tmp("good.pts"), &point_bytes(&[[0.5; 3]]));
    let nan = write(
        &tmp("nan.pts"),
        &point_bytes(&[[0.5; 3], [f32::NAN, 0.0, 0.0]]),
    );
    let short = write(&tmp("short.pts"), &[0u8; 13]);
    let cases: [(&[&str], &str); 5] = [
        (&[&tree, &nan, "-o", &out], "point 1"),
        (&[&tree, &short, "-o", &out], "not a multiple"),
        (
            &[&tree, &good, "-o", &out, "--max-distance=-1"],
            "--max-distance",
        ),
        (
            &[&tree, &good, "-o", &out, "--max-distance", "NaN"],
            "--max-distance",
        ),
        (
            &[&tree, &good, "-o", &out, "--signed", "--votes", "9"],
            "--votes 9",
        ),
    ];
    for (args, want) in cases {
        let mut all = vec!["distance"];
        all.extend_from_slice(args);
        let o = kdray(&all);
        assert!(!o.status.success(), "{args:?} succeeded");
        assert!(stderr(&o).contains(want), "{args:?}: {}", stderr(&o));
        assert!(!stderr(&o).contains("panicked"), "{}", stderr(&o));
    }
    assert!(!Path::new(&out).exists(), "a refused run wrote {out}");
    // Not a tree.
    let o = kdray(&["distance", &good, &good, "-o", &out]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("good.pts"), "{}", stderr(&o));
}

/// `distance` on a scene blob: every instance, each record naming its
/// instance (32 bytes), bit for bit the kernel's brute force; `--signed`
/// refused by name.
#[test]
fn distance_on_a_scene_names_the_instance() {
    let dir = folder("dscene");
    let gltf = write(&dir.join("quad.gltf"), &quad_gltf());
    let scene = dir.join("scene.kdt").display().to_string();
    let o = kdray(&["build", &gltf, "-o", &scene, "--instances"]);
    assert!(o.status.success(), "{}", stderr(&o));
    // Above the first quad, below the second, and halfway between them
    // (a tie: the lower instance wins).
    let queries = [
        [0.5, 0.5, 1.0],
        [2.5, 0.5, -1.0],
        [1.5, 0.5, 0.0],
        [9.0, 9.0, 9.0],
    ];
    let pts = write(&dir.join("q.pts"), &point_bytes(&queries));
    let out = dir.join("s.dist").display().to_string();
    let o = kdray(&[
        "distance",
        &scene,
        &pts,
        "-o",
        &out,
        "--json",
        "--max-distance",
        "5",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j = json(&o);
    assert_eq!(
        (j["instances"].clone(), j["beyond_max_distance"].clone()),
        (2.into(), 1.into())
    );
    let bytes = std::fs::read(&out).unwrap();
    assert_eq!(bytes.len(), 32 * queries.len());
    let blob = kdray_tools::blob::Blob::read(Path::new(&scene)).unwrap();
    let s = blob.scene().unwrap();
    for (q, rec) in queries.iter().zip(bytes.chunks_exact(32)) {
        let want = s
            .closest_point_brute(*q, u32::MAX)
            .unwrap()
            .filter(|c| c.distance2 <= 25.0);
        let r = kdray_tools::distance::SceneDistanceRecord::new(want, true);
        assert_eq!(rec, bytemuck::bytes_of(&r), "{q:?}");
    }
    let inst = |k: usize| u32::from_le_bytes(bytes[32 * k + 28..32 * k + 32].try_into().unwrap());
    assert_eq!([inst(0), inst(1), inst(2), inst(3)], [0, 1, 0, u32::MAX]);
    let d = |k: usize| f32::from_le_bytes(bytes[32 * k + 24..32 * k + 28].try_into().unwrap());
    assert_eq!([d(0), d(1), d(2), d(3)], [1.0, 1.0, 0.5, f32::INFINITY]);
    // Signed: refused, naming why; nothing written.
    let refused = dir.join("r.dist").display().to_string();
    let o = kdray(&["distance", &scene, &pts, "-o", &refused, "--signed"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("--signed on a scene"), "{}", stderr(&o));
    assert!(!Path::new(&refused).exists());
}

/// What a new user trips on, each refused by name before any work: a
/// camera with no direction, a typo of a billion timed passes, a
/// generated scene's name misspelt, a tree blob given where its point
/// file goes, a GLB whose header's length is shorter than the header.
#[test]
fn a_new_users_slips_are_named() {
    let dir = folder("slips");
    let obj = write(&dir.join("q.obj"), QUAD_OBJ);
    let png = dir.join("q.png").display().to_string();
    let refused = |args: &[&str], want: &str| {
        let o = kdray(args);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(want), "{args:?}: {}", stderr(&o));
    };
    // The eye on the target: no direction to look (the old picture kept).
    std::fs::write(&png, b"the old picture").unwrap();
    refused(
        &[
            "render", &obj, "-o", &png, "--eye", "0,0,0", "--target", "0,0,0",
        ],
        "--eye [0, 0, 0] and --target [0, 0, 0] are the same point",
    );
    refused(
        &["render", &obj, "-o", &png, "--eye", "0.5,0.5,0.5"],
        "(--target defaults to the scene's centre)",
    );
    assert_eq!(std::fs::read(&png).unwrap(), b"the old picture");
    let rays = dir.join("q.rays").display().to_string();
    refused(
        &[
            "rays", &obj, "-o", &rays, "--eye", "1,1,1", "--target", "1,1,1",
        ],
        "are the same point",
    );
    // Endless timing passes, and none.
    let tree = dir.join("q.kdt").display().to_string();
    assert!(kdray(&["build", &obj, "-o", &tree]).status.success());
    write(
        &dir.join("q.rays"),
        &ray_bytes(&[[0.2, 0.3, -1.0, 0.0, 0.0, 0.0, 1.0, f32::INFINITY]]),
    );
    let hits = dir.join("q.hits").display().to_string();
    refused(
        &["trace", &tree, &rays, "-o", &hits, "--repeat", "1000000000"],
        "--repeat 1000000000 is more than the 1000 timed passes",
    );
    refused(
        &["bench", &obj, "--repeat", "0"],
        "--repeat must be at least 1",
    );
    let pts = write(&dir.join("p.pts"), &[0u8; 24]);
    let knn = dir.join("p.knn").display().to_string();
    refused(
        &["knn", &pts, &pts, "-k", "1", "-o", &knn, "--reps", "5000"],
        "--reps 5000 is more than the 1000 timed passes",
    );
    // A generated scene's name misspelt is neither a file nor a scene.
    refused(
        &["bench", "stadum", "--rays", "16"],
        "stadum: no such file, and not a generated scene (stadium, teapot-stadium:MESH, needles)",
    );
    // A point tree blob where its points go: named as a blob, whatever its size.
    let blob = dir.join("p.kdt").display().to_string();
    assert!(kdray(&["build-points", &pts, "-o", &blob]).status.success());
    refused(
        &["knn", &blob, &pts, "-k", "1", "-o", &knn],
        "p.kdt: this is a kdray tree blob, not a file of 3-D f32 point records",
    );
    refused(
        &["trace", &tree, &tree, "-o", &hits],
        "q.kdt: this is a kdray tree blob, not a file of ray records",
    );
    // A device that never ends is refused, not read until memory runs out.
    if Path::new("/dev/zero").exists() {
        refused(
            &["trace", &tree, "/dev/zero", "-o", &hits],
            "/dev/zero: is a character device (such as /dev/zero or a terminal), not a file of ray records",
        );
    }
    // A GLB header whose length is shorter than the header (inside the
    // gltf crate, a subtraction that panicked in debug builds).
    let mut glb = b"glTF".to_vec();
    glb.extend(2u32.to_le_bytes());
    glb.extend(4u32.to_le_bytes());
    glb.extend([0u8; 20]);
    let glb = write(&dir.join("short.glb"), &glb);
    refused(
        &["build", &glb, "-o", &tree],
        "the GLB header's length (byte 8) is 4 bytes",
    );
}
