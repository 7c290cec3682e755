//! Mesh loaders on small files written here: PLY (ASCII, binary little
//! and big endian) and glTF (embedded, external buffer, GLB) give the
//! triangles the same mesh gives as OBJ; malformed files (truncated, bad
//! index, wrong counts) get errors naming the file and the place.

use base64::Engine as _;
use kdray_kernel::Triangle;
use kdray_tools::mesh::{load, MeshError};
use std::path::PathBuf;

fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("kdray-loaders-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

fn write(name: &str, bytes: &[u8]) -> PathBuf {
    let p = tmp(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

/// The error loading `bytes` as `name`, as the user sees it.
fn error(name: &str, bytes: &[u8]) -> String {
    let p = write(name, bytes);
    let e: MeshError = load(&p).expect_err("malformed file loaded");
    let msg = e.to_string();
    eprintln!("{msg}");
    assert!(msg.contains(name), "the message names the file: {msg}");
    msg
}

/// A unit square (quad 0 1 2 3) and a triangle (0 1 4) above it.
const VERTS: [[f32; 3]; 5] = [
    [0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [1.0, 1.0, 0.0],
    [0.0, 1.0, 0.0],
    [0.0, 0.0, 1.0],
];
const FACES: [&[u32]; 2] = [&[0, 1, 2, 3], &[0, 1, 4]];

fn expected() -> Vec<Triangle> {
    // One file per test thread: tests run in parallel, and a reader must
    // not see another thread's half-written copy.
    let p = tmp(&format!("ref-{:?}.obj", std::thread::current().id()));
    let mut obj = String::new();
    for v in VERTS {
        obj += &format!("v {} {} {}\n", v[0], v[1], v[2]);
    }
    for f in FACES {
        obj += "f";
        for i in f {
            obj += &format!(" {}", i + 1);
        }
        obj += "\n";
    }
    std::fs::write(&p, obj).unwrap();
    let tris = load(&p).unwrap();
    assert_eq!(tris.len(), 3);
    tris
}

fn ply_ascii() -> String {
    let mut s = String::from(
        "ply\nformat ascii 1.0\ncomment made by hand\nelement vertex 5\nproperty float x\nproperty float y\nproperty float z\nproperty uchar red\nelement face 2\nproperty list uchar int vertex_indices\nproperty int flags\nelement edge 1\nproperty int vertex1\nproperty int vertex2\nend_header\n",
    );
    for v in VERTS {
        s += &format!("{} {} {} 255\n", v[0], v[1], v[2]);
    }
    for f in FACES {
        s += &format!("{}", f.len());
        for i in f {
            s += &format!(" {i}");
        }
        s += " 7\n";
    }
    s + "0 1\n"
}

/// Binary PLY: double (big) or float (little) vertices, uint or int indices.
fn ply_binary(big: bool) -> Vec<u8> {
    let (fmt, vty, ity) = if big {
        ("binary_big_endian", "double", "uint")
    } else {
        ("binary_little_endian", "float", "int")
    };
    let mut b = format!(
        "ply\r\nformat {fmt} 1.0\r\nelement vertex 5\r\nproperty {vty} x\r\nproperty {vty} y\r\nproperty {vty} z\r\nelement face 2\r\nproperty uchar flags\r\nproperty list uchar {ity} vertex_indices\r\nend_header\r\n"
    )
    .into_bytes();
    let put = |b: &mut Vec<u8>, le: [u8; 8], n: usize| {
        let mut x = le[..n].to_vec();
        if big {
            x.reverse();
        }
        b.extend(x);
    };
    for v in VERTS {
        for c in v {
            if big {
                put(&mut b, f64::from(c).to_le_bytes(), 8);
            } else {
                let mut le = [0; 8];
                le[..4].copy_from_slice(&c.to_le_bytes());
                put(&mut b, le, 4);
            }
        }
    }
    for f in FACES {
        b.push(9);
        b.push(f.len() as u8);
        for &i in f {
            let mut le = [0; 8];
            le[..4].copy_from_slice(&i.to_le_bytes());
            put(&mut b, le, 4);
        }
    }
    b
}

#[test]
fn ply_ascii_and_binary_match_obj() {
    let want = expected();
    assert_eq!(load(&write("a.ply", ply_ascii().as_bytes())).unwrap(), want);
    assert_eq!(load(&write("le.ply", &ply_binary(false))).unwrap(), want);
    assert_eq!(load(&write("be.PLY", &ply_binary(true))).unwrap(), want);
}

#[test]
fn ply_errors_name_the_place() {
    let ascii = ply_ascii();
    // Truncated: the last face line and the edge are gone.
    let cut = &ascii[..ascii.find("3 0 1 4").unwrap()];
    let e = error("cut.ply", cut.as_bytes());
    assert!(e.contains("truncated") && e.contains("face 1"), "{e}");
    // A bad index on line 22 (header 15 lines, vertices 16..20, faces 21..22).
    let bad = ascii.replace("3 0 1 4 7", "3 0 1 5 7");
    let e = error("badindex.ply", bad.as_bytes());
    assert!(
        e.contains(":22:") && e.contains("face 1") && e.contains("out of range"),
        "{e}"
    );
    // Wrong counts: the header declares 4 vertices, so the fifth is read as a face.
    let wrong = ascii.replace("element vertex 5", "element vertex 4");
    let e = error("count.ply", wrong.as_bytes());
    assert!(e.contains(":20:") && e.contains("face 0"), "{e}");
    // Too few values on a vertex line.
    let short = ascii.replace("1 1 0 255", "1 1");
    let e = error("short.ply", short.as_bytes());
    assert!(
        e.contains(":18:") && e.contains("vertex 2") && e.contains("too few"),
        "{e}"
    );
    // Binary, cut inside the last face.
    let bin = ply_binary(false);
    let e = error("cut-le.ply", &bin[..bin.len() - 3]);
    assert!(e.contains("face 1") && e.contains("truncated"), "{e}");
    // Binary with a bad index.
    let mut bad = ply_binary(true);
    let n = bad.len();
    bad[n - 1] = 77;
    let e = error("bad-be.ply", &bad);
    assert!(
        e.contains("face 1") && e.contains("77") && e.contains("out of range"),
        "{e}"
    );
    // Header problems, with their line.
    let e = error("magic.ply", b"plx\nformat ascii 1.0\nend_header\n");
    assert!(e.contains(":1:") && e.contains("not a PLY"), "{e}");
    let e = error(
        "type.ply",
        b"ply\nformat ascii 1.0\nelement vertex 1\nproperty quad x\nend_header\n",
    );
    assert!(e.contains(":4:") && e.contains("quad"), "{e}");
    let e = error("noend.ply", b"ply\nformat ascii 1.0\nelement vertex 1\n");
    assert!(e.contains("end_header"), "{e}");
    let e = error(
        "nox.ply",
        b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float y\nend_header\n1\n",
    );
    assert!(e.contains(":3:") && e.contains("x, y or z"), "{e}");
}

/// The mesh's bytes for glTF: float positions, then u16 indices of the
/// quad's two triangles and the third.
fn gltf_bin() -> (Vec<u8>, usize) {
    let mut b: Vec<u8> = VERTS
        .iter()
        .flatten()
        .flat_map(|f| f.to_le_bytes())
        .collect();
    let pos_len = b.len();
    for i in [0u16, 1, 2, 0, 2, 3, 0, 1, 4] {
        b.extend(i.to_le_bytes());
    }
    (b, pos_len)
}

/// A glTF document: mesh 0 indexed, mesh 1 the same positions unindexed
/// (one triangle strip), node 0 (translated, mesh 0) with child node 1
/// (scaled, mesh 0), node 2 (mesh 1) outside the scene.
fn gltf_json(uri: Option<&str>, byte_len: usize, pos_len: usize) -> String {
    let uri = uri.map_or(String::new(), |u| format!("\"uri\": \"{u}\", "));
    format!(
        r#"{{
  "asset": {{"version": "2.0"}},
  "scene": 0,
  "scenes": [{{"nodes": [0]}}],
  "nodes": [
    {{"mesh": 0, "translation": [10, 0, 0], "children": [1]}},
    {{"mesh": 0, "scale": [2, 2, 2]}},
    {{"mesh": 0}}
  ],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}, "indices": 1}}]}}],
  "buffers": [{{{uri}"byteLength": {byte_len}}}],
  "bufferViews": [
    {{"buffer": 0, "byteOffset": 0, "byteLength": {pos_len}}},
    {{"buffer": 0, "byteOffset": {pos_len}, "byteLength": 18}}
  ],
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": 5, "type": "VEC3", "min": [0,0,0], "max": [1,1,1]}},
    {{"bufferView": 1, "componentType": 5123, "count": 9, "type": "SCALAR"}}
  ]
}}"#
    )
}

/// What the glTF scene holds: the mesh moved by 10 in x, then scaled by 2
/// and moved by 10.
fn gltf_expected() -> Vec<Triangle> {
    let base = expected();
    let moved = |s: f32| {
        base.iter()
            .map(|t| Triangle {
                v: t.v.map(|p| [p[0] * s + 10.0, p[1] * s, p[2] * s]),
            })
            .collect::<Vec<_>>()
    };
    [moved(1.0), moved(2.0)].concat()
}

fn data_uri(bytes: &[u8]) -> String {
    format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(bytes)
    )
}

fn glb(json: &str, bin: &[u8]) -> Vec<u8> {
    let mut j = json.as_bytes().to_vec();
    while !j.len().is_multiple_of(4) {
        j.push(b' ');
    }
    let mut b = bin.to_vec();
    while !b.len().is_multiple_of(4) {
        b.push(0);
    }
    let total = 12 + 8 + j.len() + 8 + b.len();
    let mut out = Vec::new();
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend((total as u32).to_le_bytes());
    out.extend((j.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(j);
    out.extend((b.len() as u32).to_le_bytes());
    out.extend(b"BIN\0");
    out.extend(b);
    out
}

#[test]
fn gltf_embedded_external_and_glb_apply_node_transforms() {
    let want = gltf_expected();
    let (bin, pos_len) = gltf_bin();
    let embedded = gltf_json(Some(&data_uri(&bin)), bin.len(), pos_len);
    assert_eq!(
        load(&write("embedded.gltf", embedded.as_bytes())).unwrap(),
        want
    );
    write("mesh.bin", &bin);
    let external = gltf_json(Some("mesh.bin"), bin.len(), pos_len);
    assert_eq!(
        load(&write("external.gltf", external.as_bytes())).unwrap(),
        want
    );
    let json = gltf_json(None, bin.len(), pos_len);
    assert_eq!(load(&write("binary.glb", &glb(&json, &bin))).unwrap(), want);
}

#[test]
fn gltf_unindexed_and_strip_primitives() {
    let (bin, pos_len) = gltf_bin();
    let json = gltf_json(Some(&data_uri(&bin)), bin.len(), pos_len)
        .replace(r#", "indices": 1}"#, r#", "mode": 5}"#)
        .replace(
            r#""translation": [10, 0, 0], "children": [1]"#,
            r#""children": []"#,
        );
    let tris = load(&write("strip.gltf", json.as_bytes())).unwrap();
    let v = VERTS;
    assert_eq!(
        tris,
        vec![
            Triangle {
                v: [v[0], v[1], v[2]]
            },
            Triangle {
                v: [v[2], v[1], v[3]]
            },
            Triangle {
                v: [v[2], v[3], v[4]]
            },
        ]
    );
}

#[test]
fn gltf_errors_name_the_place() {
    let (bin, pos_len) = gltf_bin();
    let good = gltf_json(Some(&data_uri(&bin)), bin.len(), pos_len);
    // Truncated JSON: serde's line and column.
    let e = error("cut.gltf", &good.as_bytes()[..good.len() / 2]);
    assert!(e.contains("malformed glTF") && e.contains("line"), "{e}");
    // An index out of range, naming the accessor and the index's position.
    let mut bad = bin.clone();
    bad[pos_len + 16..pos_len + 18].copy_from_slice(&9u16.to_le_bytes());
    let json = gltf_json(Some(&data_uri(&bad)), bad.len(), pos_len);
    let e = error("badindex.gltf", json.as_bytes());
    assert!(
        e.contains("mesh 0 primitive 0") && e.contains("accessor 1") && e.contains("index 8 is 9"),
        "{e}"
    );
    // Wrong counts: more positions than the buffer view holds.
    let json = good.replace(r#""count": 5"#, r#""count": 6"#);
    let e = error("count.gltf", json.as_bytes());
    assert!(
        e.contains("accessor 0") && e.contains("buffer view 0"),
        "{e}"
    );
    // A buffer shorter than its byteLength.
    let json = gltf_json(Some(&data_uri(&bin[..40])), bin.len(), pos_len);
    let e = error("short.gltf", json.as_bytes());
    assert!(e.contains("buffer 0") && e.contains("byteLength"), "{e}");
    // A missing external buffer.
    let json = gltf_json(Some("nowhere.bin"), bin.len(), pos_len);
    let e = error("missing.gltf", json.as_bytes());
    assert!(e.contains("buffer 0") && e.contains("nowhere.bin"), "{e}");
    // A cycle in the node hierarchy.
    let json = good.replace(
        r#"{"mesh": 0, "scale": [2, 2, 2]}"#,
        r#"{"mesh": 0, "children": [0]}"#,
    );
    let e = error("cycle.gltf", json.as_bytes());
    assert!(e.contains("node 0 appears twice"), "{e}");
    // A truncated GLB: the length its header gives and the file's.
    let glb = glb(&gltf_json(None, bin.len(), pos_len), &bin);
    let cut = glb.len() - 20;
    let e = error("cut.glb", &glb[..cut]);
    assert!(
        e.contains(&format!(
            "truncated GLB: its header (byte 8) gives {} bytes, the file has {cut}",
            glb.len()
        )),
        "{e}"
    );
    // Hostile GLB headers: a length under the header's own (a debug
    // build's panic inside the gltf crate), a JSON chunk past the end, a
    // file shorter than a header, another version.
    let with_word = |at: usize, v: u32| {
        let mut g = glb.clone();
        g[at..at + 4].copy_from_slice(&v.to_le_bytes());
        g
    };
    for (name, bytes, want) in [
        (
            "short-length.glb",
            with_word(8, 4),
            "the GLB header's length (byte 8) is 4 bytes".to_string(),
        ),
        (
            "long-json.glb",
            with_word(12, 1 << 30),
            format!(
                "JSON chunk (length at byte 12) gives {} bytes, past the {}",
                1 << 30,
                glb.len()
            ),
        ),
        (
            "stub.glb",
            glb[..7].to_vec(),
            "truncated GLB: 7 bytes, less than its 12-byte header".to_string(),
        ),
        (
            "v1.glb",
            with_word(4, 1),
            "GLB version 1 (byte 4)".to_string(),
        ),
    ] {
        let e = error(name, &bytes);
        assert!(e.contains(&want), "{name}: {e}");
    }
}

#[test]
fn ply_data_after_the_last_element_is_refused() {
    let ascii = ply_ascii() + "1 2 3\n";
    let e = error("junk.ply", ascii.as_bytes());
    assert!(
        e.contains(":24:") && e.contains("after the last element"),
        "{e}"
    );
    let mut bin = ply_binary(false);
    bin.extend(b"junk");
    let e = error("junk-le.ply", &bin);
    assert!(
        e.contains("4 bytes") && e.contains("after the last element"),
        "{e}"
    );
    // Blank lines at the end of an ASCII body are not data.
    let blank = ply_ascii() + "\n\n";
    assert_eq!(
        load(&write("blank.ply", blank.as_bytes())).unwrap(),
        expected()
    );
}

#[test]
fn gltf_buffers_stay_in_the_gltf_folder_unless_allowed() {
    use kdray_tools::mesh::{load_with, LoadOptions};
    let (bin, pos_len) = gltf_bin();
    let inner = tmp("inner");
    std::fs::create_dir_all(&inner).unwrap();
    write("outside.bin", &bin);
    let outside = tmp("outside.bin").display().to_string();
    for uri in [
        "../outside.bin",
        outside.as_str(),
        "file:///etc/passwd",
        "%2E%2E/outside.bin",
    ] {
        let json = gltf_json(Some(uri), bin.len(), pos_len);
        let p = inner.join("escape.gltf");
        std::fs::write(&p, &json).unwrap();
        let e = load(&p).expect_err(uri).to_string();
        assert!(
            e.contains("buffer 0")
                && (e.contains("outside the glTF's folder") || e.contains("only relative")),
            "{uri}: {e}"
        );
        if !uri.starts_with("file:") {
            let allowed = LoadOptions {
                allow_outside_uris: true,
            };
            assert_eq!(
                load_with(&p, &allowed).unwrap().triangles,
                gltf_expected(),
                "{uri}"
            );
        }
    }
    // A symlink in the folder that leads out of it.
    #[cfg(unix)]
    {
        let link = inner.join("link.bin");
        let _ = std::fs::remove_file(&link);
        std::os::unix::fs::symlink(tmp("outside.bin"), &link).unwrap();
        let p = inner.join("link.gltf");
        std::fs::write(&p, gltf_json(Some("link.bin"), bin.len(), pos_len)).unwrap();
        let e = load(&p).unwrap_err().to_string();
        assert!(e.contains("outside the glTF's folder"), "{e}");
    }
    // Inside, with an escaped name.
    std::fs::write(inner.join("my mesh.bin"), &bin).unwrap();
    let p = inner.join("spaced.gltf");
    std::fs::write(&p, gltf_json(Some("my%20mesh.bin"), bin.len(), pos_len)).unwrap();
    assert_eq!(load(&p).unwrap(), gltf_expected());
}

#[test]
fn gltf_points_and_lines_are_reported() {
    use kdray_tools::mesh::{load_with, LoadOptions};
    let (bin, pos_len) = gltf_bin();
    let json = gltf_json(Some(&data_uri(&bin)), bin.len(), pos_len).replace(
        r#""primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]"#,
        r#""primitives": [{"attributes": {"POSITION": 0}, "indices": 1}, {"attributes": {"POSITION": 0}, "mode": 0}, {"attributes": {"POSITION": 0}, "mode": 1}]"#,
    );
    let m = load_with(
        &write("mixed.gltf", json.as_bytes()),
        &LoadOptions::default(),
    )
    .unwrap();
    assert_eq!(m.triangles, gltf_expected());
    let all = m.skipped.join("\n");
    assert!(
        all.contains("mesh 0 primitive 1: a POINTS primitive (5 vertices)"),
        "{all}"
    );
    assert!(
        all.contains("mesh 0 primitive 2: a LINES primitive"),
        "{all}"
    );
    // Two nodes use mesh 0: each skipped primitive is reported once.
    assert_eq!(m.skipped.len(), 2, "{all}");
    // A file of points only has no triangles: an error.
    let only = gltf_json(Some(&data_uri(&bin)), bin.len(), pos_len)
        .replace(r#", "indices": 1}"#, r#", "mode": 0}"#);
    let e = error("points.gltf", only.as_bytes());
    assert!(e.contains("no triangles"), "{e}");
}

#[test]
fn gltf_buffers_must_be_regular_files_of_their_byte_length() {
    use kdray_tools::mesh::{load_with, LoadOptions};
    let (bin, pos_len) = gltf_bin();
    let dir = tmp("special");
    std::fs::create_dir_all(dir.join("folder.bin")).unwrap();
    let load_uri = |uri: &str, byte_len: usize, allow: bool| {
        let p = dir.join("special.gltf");
        std::fs::write(&p, gltf_json(Some(uri), byte_len, pos_len)).unwrap();
        let options = LoadOptions {
            allow_outside_uris: allow,
        };
        // On a thread: a loader that blocks on a FIFO fails here, not hangs.
        let (send, recv) = std::sync::mpsc::channel();
        std::thread::spawn(move || send.send(load_with(&p, &options).map(|m| m.triangles)));
        recv.recv_timeout(std::time::Duration::from_secs(20))
            .unwrap_or_else(|_| panic!("{uri}: the loader hangs"))
    };
    let refused = |uri: &str, byte_len: usize, allow: bool, what: &str| {
        let e = load_uri(uri, byte_len, allow).expect_err(uri).to_string();
        eprintln!("{e}");
        assert!(
            e.contains("special.gltf")
                && e.contains("buffer 0")
                && e.contains(uri)
                && e.contains(what),
            "{uri}: {e}"
        );
    };
    refused(
        "folder.bin",
        bin.len(),
        false,
        "is a folder, not a regular file",
    );
    #[cfg(unix)]
    {
        let fifo = dir.join("pipe.bin");
        let _ = std::fs::remove_file(&fifo);
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        if made.is_ok_and(|s| s.success()) {
            refused(
                "pipe.bin",
                bin.len(),
                false,
                "is a FIFO, not a regular file",
            );
        }
        if std::path::Path::new("/dev/zero").exists() {
            refused("/dev/zero", bin.len(), true, "is a character device");
        }
    }
    // A file longer than its byteLength: refused after byteLength + 1 bytes.
    let mut long = bin.clone();
    long.extend([0u8; 100]);
    std::fs::write(dir.join("long.bin"), &long).unwrap();
    refused(
        "long.bin",
        bin.len(),
        false,
        "more than the buffer's byteLength",
    );
    // Exactly byteLength, and shorter (the old rule), still as before.
    std::fs::write(dir.join("exact.bin"), &bin).unwrap();
    assert_eq!(
        load_uri("exact.bin", bin.len(), false).unwrap(),
        gltf_expected()
    );
    refused("exact.bin", bin.len() + 4, false, "declares byteLength");
}

#[test]
fn unsupported_gltf_features_are_called_unsupported() {
    let (bin, pos_len) = gltf_bin();
    let base = gltf_json(Some(&data_uri(&bin)), bin.len(), pos_len);
    for ext in ["KHR_draco_mesh_compression", "KHR_mesh_quantization"] {
        let json = base.replacen(
            "{\n  \"asset\"",
            &format!("{{\n  \"extensionsUsed\": [\"{ext}\"], \"extensionsRequired\": [\"{ext}\"],\n  \"asset\""),
            1,
        );
        let e = error("ext.gltf", json.as_bytes());
        assert!(
            e.contains(&format!("requires the glTF extension {ext}")) && e.contains("unsupported"),
            "{e}"
        );
        assert!(!e.contains("malformed"), "{e}");
    }
    // A sparse accessor (index 1 of the positions replaced).
    let sparse = base.replace(
        r#""count": 5, "type": "VEC3", "min": [0,0,0], "max": [1,1,1]}"#,
        r#""count": 5, "type": "VEC3", "min": [0,0,0], "max": [1,1,1], "sparse": {"count": 1, "indices": {"bufferView": 1, "componentType": 5123}, "values": {"bufferView": 0}}}"#,
    );
    assert_ne!(sparse, base);
    let e = error("sparse.gltf", sparse.as_bytes());
    assert!(e.contains("sparse accessors are unsupported"), "{e}");
}

#[test]
fn a_ply_double_past_f32_is_out_of_range() {
    let ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty double x\nproperty double y\nproperty double z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1e300 0 0\n0 1 0\n3 0 1 2\n";
    let e = error("huge.ply", ply.as_bytes());
    assert!(
        e.contains("huge.ply:") && e.contains("1e300 is out of f32 range"),
        "{e}"
    );
}
