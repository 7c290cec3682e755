//! glTF 2.0 (`.gltf` with external or `data:` URI buffers, and `.glb`):
//! every triangle primitive of every mesh in the default scene (else the
//! first scene), in depth-first node order, with node transforms applied.
//! `gltf` parses and validates the JSON; the accessor bytes are read here
//! so every range is checked and a bad one is named.

use super::{fan, LoadOptions, MeshError};
use base64::Engine as _;
use glam::{Mat4, Vec3};
use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::Mode;
use gltf::Accessor;
use kdray_kernel::Triangle;
use std::path::{Component, Path, PathBuf};

/// Loads the triangles of a glTF 2.0 file (`.gltf` or `.glb`) with the
/// default [`LoadOptions`]. Points and lines are skipped
/// ([`super::load_with`] reports them); strips and fans are unrolled;
/// non-indexed primitives use their vertices in order.
///
/// # Errors
/// A [`MeshError`] naming the file and the buffer, node, mesh, primitive or
/// accessor at fault: malformed JSON (with its line), a missing buffer or
/// one outside the glTF's folder, an accessor past the end of its buffer
/// view, an index out of range, a node met twice in the hierarchy.
pub fn load_gltf(path: &Path) -> Result<Vec<Triangle>, MeshError> {
    read(path, &LoadOptions::default(), &mut Vec::new())
}

/// [`load_gltf`] with `options`, adding what is skipped to `skipped`.
pub(super) fn read(
    path: &Path,
    options: &LoadOptions,
    skipped: &mut Vec<String>,
) -> Result<Vec<Triangle>, MeshError> {
    let mut tris = Vec::new();
    walk(path, options, skipped, |_, mesh, m, buffers, skipped| {
        add_mesh(path, mesh, buffers, m, skipped, &mut tris)
    })?;
    Ok(tris)
}

/// The files a glTF's buffers name by relative URI (not `data:` URIs, not
/// a GLB's own BIN chunk), as the loader would resolve them beside the
/// glTF (inside its folder or not: the loader refuses those itself). For
/// a command's output-over-input check: `build scene.gltf -o scene.bin`
/// must not replace the buffer it reads. A file that cannot be read or
/// parsed names none (loading it reports why).
#[must_use]
pub fn buffer_files(path: &Path) -> Vec<PathBuf> {
    let Ok(bytes) = std::fs::read(path) else {
        return Vec::new();
    };
    if check_glb_frame(&bytes).is_err() {
        return Vec::new();
    }
    let Ok(g) = gltf::Gltf::from_slice_without_validation(&bytes) else {
        return Vec::new();
    };
    g.document
        .buffers()
        .filter_map(|b| match b.source() {
            gltf::buffer::Source::Uri(uri) if !uri.starts_with("data:") => {
                buffer_file(path, uri, true).ok()
            }
            _ => None,
        })
        .collect()
}

/// A glTF file with its mesh references kept: each mesh's triangles once,
/// in its own space, and one instance per node that has a mesh, in the
/// depth-first node order [`load_gltf`] flattens them in, so triangle `p` of
/// instance `i` is triangle `(triangles of instances before i) + p` of
/// [`load_gltf`]. Meshes are numbered by first use; meshes without
/// triangles are left out (they add none to the flattened order).
#[derive(Clone, Debug, Default)]
pub struct InstancedGltf {
    /// Each mesh's triangles, in mesh space.
    pub meshes: Vec<Vec<Triangle>>,
    /// Per instance: its mesh, its node's world transform (3×4 row-major)
    /// and the node's index (the instance's user id).
    pub instances: Vec<(u32, [f32; 12], u32)>,
}

/// Loads a glTF file keeping mesh references as instances ([`InstancedGltf`]).
///
/// # Errors
/// As [`load_gltf`].
pub fn load_gltf_instanced(
    path: &Path,
    options: &LoadOptions,
    skipped: &mut Vec<String>,
) -> Result<InstancedGltf, MeshError> {
    let mut out = InstancedGltf::default();
    let mut index: Vec<Option<Option<u32>>> = Vec::new();
    walk(path, options, skipped, |node, mesh, m, buffers, skipped| {
        if index.len() <= mesh.index() {
            index.resize(mesh.index() + 1, None);
        }
        let slot = match index[mesh.index()] {
            Some(slot) => slot,
            None => {
                let mut tris = Vec::new();
                add_mesh(path, mesh, buffers, Mat4::IDENTITY, skipped, &mut tris)?;
                let slot = (!tris.is_empty()).then(|| {
                    out.meshes.push(tris);
                    out.meshes.len() as u32 - 1
                });
                index[mesh.index()] = Some(slot);
                slot
            }
        };
        if let Some(slot) = slot {
            let rows: [f32; 12] = core::array::from_fn(|k| m.row(k / 4)[k % 4]);
            out.instances.push((slot, rows, node as u32));
        }
        Ok(())
    })?;
    Ok(out)
}

/// The default scene's nodes (else the first scene's), depth-first,
/// parents before children, in file order: `on_mesh(node, mesh, world
/// transform, buffers, skipped)` for each node that has a mesh.
fn walk(
    path: &Path,
    options: &LoadOptions,
    skipped: &mut Vec<String>,
    mut on_mesh: impl FnMut(
        usize,
        &gltf::Mesh<'_>,
        Mat4,
        &[Vec<u8>],
        &mut Vec<String>,
    ) -> Result<(), MeshError>,
) -> Result<(), MeshError> {
    let err = |msg: String| MeshError::new(path, None, msg);
    let bytes = std::fs::read(path).map_err(|e| err(format!("cannot open: {e}")))?;
    check_glb_frame(&bytes).map_err(err)?;
    // Extensions first: the validating parse calls a file that needs one
    // "malformed", where it is well formed and only unsupported.
    if let Ok(raw) = gltf::Gltf::from_slice_without_validation(&bytes) {
        let required: Vec<&str> = raw.document.extensions_required().collect();
        if !required.is_empty() {
            return Err(err(format!(
                "requires the glTF extension{} {}, which kdray does not read (unsupported: every extension, such as KHR_draco_mesh_compression and KHR_mesh_quantization; docs/formats.md)",
                if required.len() == 1 { "" } else { "s" },
                required.join(", ")
            )));
        }
    }
    let g = gltf::Gltf::from_slice(&bytes).map_err(|e| err(format!("malformed glTF: {e}")))?;
    let buffers = g
        .document
        .buffers()
        .map(|b| load_buffer(path, &b, g.blob.as_deref(), options))
        .collect::<Result<Vec<_>, _>>()?;
    let scene = g
        .document
        .default_scene()
        .or_else(|| g.document.scenes().next())
        .ok_or_else(|| err("no scene to load".into()))?;
    let mut seen = vec![false; g.document.nodes().len()];
    let mut stack: Vec<(gltf::Node<'_>, Mat4)> = Vec::new();
    push_reversed(&mut stack, scene.nodes(), Mat4::IDENTITY);
    while let Some((node, parent)) = stack.pop() {
        let Some(seen) = seen.get_mut(node.index()).filter(|s| !**s) else {
            return Err(err(format!(
                "node {} appears twice in scene {}'s hierarchy (a cycle or a shared child)",
                node.index(),
                scene.index()
            )));
        };
        *seen = true;
        let m = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
        if let Some(mesh) = node.mesh() {
            on_mesh(node.index(), &mesh, m, &buffers, skipped)?;
        }
        push_reversed(&mut stack, node.children(), m);
    }
    Ok(())
}

/// A binary glTF's header and first chunk header, checked before the
/// `gltf` crate reads them: it subtracts the header's size from the
/// length field unchecked (a panic in a debug build for a length under
/// 12) and calls a file cut short only "could not completely read the
/// object". A JSON glTF (no `glTF` magic) passes untouched.
fn check_glb_frame(bytes: &[u8]) -> Result<(), String> {
    if !bytes.starts_with(b"glTF") {
        return Ok(());
    }
    let word = |at: usize| {
        bytes
            .get(at..at + 4)
            .and_then(|w| <[u8; 4]>::try_from(w).ok())
            .map(u32::from_le_bytes)
    };
    let (Some(version), Some(length)) = (word(4), word(8)) else {
        return Err(format!(
            "truncated GLB: {} bytes, less than its 12-byte header",
            bytes.len()
        ));
    };
    if version != 2 {
        return Err(format!(
            "GLB version {version} (byte 4): kdray reads glTF 2.0 files"
        ));
    }
    // u32 to usize never truncates where kdray builds (32 and 64 bits).
    let length = length as usize;
    if length < 20 {
        return Err(format!(
            "the GLB header's length (byte 8) is {length} bytes, less than the 20 of a header and a JSON chunk header"
        ));
    }
    if length > bytes.len() {
        return Err(format!(
            "truncated GLB: its header (byte 8) gives {length} bytes, the file has {}",
            bytes.len()
        ));
    }
    let json = word(12).map_or(usize::MAX, |n| n as usize);
    if json > length - 20 {
        return Err(format!(
            "the GLB's JSON chunk (length at byte 12) gives {json} bytes, past the {length} the header gives the file"
        ));
    }
    Ok(())
}

/// Appends the triangles of every triangle primitive of `mesh` under `m`,
/// reporting the others in `skipped`.
fn add_mesh(
    path: &Path,
    mesh: &gltf::Mesh<'_>,
    buffers: &[Vec<u8>],
    m: Mat4,
    skipped: &mut Vec<String>,
    tris: &mut Vec<Triangle>,
) -> Result<(), MeshError> {
    for prim in mesh.primitives() {
        let at = format!("mesh {} primitive {}", mesh.index(), prim.index());
        if let Some(kind) = not_triangles(prim.mode()) {
            let n = prim
                .get(&gltf::Semantic::Positions)
                .map_or(0, |a| a.count());
            let note = format!(
                "{at}: a {kind} primitive ({n} vertices) skipped: only triangles are traced"
            );
            // Once per mesh, however many nodes use it.
            if !skipped.contains(&note) {
                skipped.push(note);
            }
            continue;
        }
        add_primitive(path, &at, &prim, buffers, m, tris)?;
    }
    Ok(())
}

/// Pushes `nodes` under transform `m` so that the first pops first.
fn push_reversed<'a>(
    stack: &mut Vec<(gltf::Node<'a>, Mat4)>,
    nodes: impl Iterator<Item = gltf::Node<'a>>,
    m: Mat4,
) {
    let start = stack.len();
    stack.extend(nodes.map(|n| (n, m)));
    stack[start..].reverse();
}

/// The glTF name of a primitive mode that is not triangles.
fn not_triangles(mode: Mode) -> Option<&'static str> {
    Some(match mode {
        Mode::Points => "POINTS",
        Mode::Lines => "LINES",
        Mode::LineLoop => "LINE_LOOP",
        Mode::LineStrip => "LINE_STRIP",
        Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan => return None,
    })
}

/// The file a relative buffer URI names, beside the glTF: percent-decoded
/// (RFC 3986), and unless `allow_outside` inside the glTF's folder (no
/// absolute path, no `..`, no symlink leading out of it).
fn buffer_file(gltf: &Path, uri: &str, allow_outside: bool) -> Result<PathBuf, String> {
    let decoded = percent_decode(uri)
        .ok_or_else(|| format!("URI {uri:?} is not valid percent-encoded UTF-8"))?;
    if decoded.contains("://") || decoded.starts_with("file:") {
        return Err(format!(
            "URI {uri:?}: only relative file paths and data: URIs are read"
        ));
    }
    let dir = match gltf.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let file = dir.join(&decoded);
    if allow_outside {
        return Ok(file);
    }
    let refuse = || {
        // The folder by its full name: "." says nothing in a message.
        let named = std::fs::canonicalize(dir).unwrap_or_else(|_| dir.to_path_buf());
        format!(
            "URI {uri:?} points outside the glTF's folder {} (pass --allow-outside-uris to read it)",
            named.display()
        )
    };
    let rel = Path::new(&decoded);
    if rel.is_absolute()
        || rel
            .components()
            .any(|c| !matches!(c, Component::Normal(_) | Component::CurDir))
    {
        return Err(refuse());
    }
    // A symlink inside the folder may still lead out of it.
    if let (Ok(real_dir), Ok(real)) = (std::fs::canonicalize(dir), std::fs::canonicalize(&file)) {
        if !real.starts_with(real_dir) {
            return Err(refuse());
        }
    }
    Ok(file)
}

/// `%XX` escapes decoded; `None` for a bad escape or non-UTF-8 bytes.
fn percent_decode(s: &str) -> Option<String> {
    let mut out = Vec::with_capacity(s.len());
    let mut bytes = s.bytes();
    while let Some(b) = bytes.next() {
        if b == b'%' {
            let hex = [bytes.next()?, bytes.next()?];
            out.push(u8::from_str_radix(std::str::from_utf8(&hex).ok()?, 16).ok()?);
        } else {
            out.push(b);
        }
    }
    String::from_utf8(out).ok()
}

/// The bytes of buffer `b`: the GLB's BIN chunk, a `data:` URI, or a file
/// in the glTF's folder.
fn load_buffer(
    path: &Path,
    b: &gltf::Buffer<'_>,
    blob: Option<&[u8]>,
    options: &LoadOptions,
) -> Result<Vec<u8>, MeshError> {
    let err = |msg: String| MeshError::new(path, None, format!("buffer {}: {msg}", b.index()));
    let data = match b.source() {
        gltf::buffer::Source::Bin => blob
            .ok_or_else(|| err("refers to the GLB BIN chunk, which is missing".into()))?
            .to_vec(),
        gltf::buffer::Source::Uri(uri) if uri.starts_with("data:") => {
            let (_, payload) = uri
                .split_once(";base64,")
                .ok_or_else(|| err("data URI is not base64".into()))?;
            base64::engine::general_purpose::STANDARD
                .decode(payload)
                .map_err(|e| err(format!("bad base64 in data URI: {e}")))?
        }
        gltf::buffer::Source::Uri(uri) => {
            let file = buffer_file(path, uri, options.allow_outside_uris).map_err(&err)?;
            read_buffer_file(&file, b.length())
                .map_err(|e| err(format!("URI {uri:?} ({}): {e}", file.display())))?
        }
    };
    if data.len() < b.length() {
        return Err(err(format!(
            "holds {} bytes but declares byteLength {}",
            data.len(),
            b.length()
        )));
    }
    Ok(data)
}

/// At most `byte_length` bytes of a buffer's file. Only a regular file is
/// read: it is opened without blocking (a FIFO with no writer would wait
/// forever) and its type checked on the open file, so a FIFO, a device
/// (`/dev/zero` never ends) or a folder is refused by name. At most
/// `byte_length + 1` bytes are read: a longer file is refused, as a PLY
/// with data after its last element is.
fn read_buffer_file(file: &Path, byte_length: usize) -> Result<Vec<u8>, String> {
    use std::io::Read as _;
    let mut options = std::fs::OpenOptions::new();
    options.read(true);
    #[cfg(unix)]
    std::os::unix::fs::OpenOptionsExt::custom_flags(&mut options, libc::O_NONBLOCK);
    let f = options
        .open(file)
        .map_err(|e| format!("cannot read: {e}"))?;
    let meta = f.metadata().map_err(|e| format!("cannot read: {e}"))?;
    if !meta.is_file() {
        return Err(format!(
            "is {}, not a regular file: a buffer must be a file",
            file_type_name(&meta.file_type())
        ));
    }
    let limit = byte_length.saturating_add(1);
    let expect = usize::try_from(meta.len()).map_or(limit, |n| n.min(limit));
    let mut data =
        crate::memory::with_capacity(expect, "buffer bytes").map_err(|e| e.to_string())?;
    f.take(limit as u64)
        .read_to_end(&mut data)
        .map_err(|e| format!("cannot read: {e}"))?;
    if data.len() > byte_length {
        return Err(format!(
            "the file holds {} bytes, more than the buffer's byteLength {byte_length}",
            meta.len()
        ));
    }
    if data.len() < byte_length {
        return Err(format!(
            "the file holds {} bytes but the buffer declares byteLength {byte_length}",
            data.len()
        ));
    }
    Ok(data)
}

/// "a folder", "a FIFO", ... for a file that is not a regular file.
fn file_type_name(t: &std::fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt as _;
        if t.is_fifo() {
            return "a FIFO";
        }
        if t.is_char_device() {
            return "a character device";
        }
        if t.is_block_device() {
            return "a block device";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    if t.is_dir() {
        "a folder"
    } else {
        "another kind of file"
    }
}

/// Appends the triangles of one primitive, transformed by `m`.
fn add_primitive(
    path: &Path,
    at: &str,
    prim: &gltf::Primitive<'_>,
    buffers: &[Vec<u8>],
    m: Mat4,
    tris: &mut Vec<Triangle>,
) -> Result<(), MeshError> {
    let err = |msg: String| MeshError::new(path, None, format!("{at}: {msg}"));
    let pos = prim
        .get(&gltf::Semantic::Positions)
        .ok_or_else(|| err("no POSITION attribute".into()))?;
    if pos.data_type() != DataType::F32 || pos.dimensions() != Dimensions::Vec3 {
        return Err(err(format!(
            "accessor {}: POSITION must be VEC3 of FLOAT",
            pos.index()
        )));
    }
    let positions: Vec<[f32; 3]> = elements(&pos, buffers, 12)
        .map_err(&err)?
        .map(|b| {
            let f = |k: usize| f32::from_le_bytes([b[k], b[k + 1], b[k + 2], b[k + 3]]);
            m.transform_point3(Vec3::new(f(0), f(4), f(8))).to_array()
        })
        .collect();
    let indices: Vec<u32> = match prim.indices() {
        None => (0..positions.len() as u32).collect(),
        Some(acc) => {
            let size = match (acc.data_type(), acc.dimensions()) {
                (DataType::U8, Dimensions::Scalar) => 1,
                (DataType::U16, Dimensions::Scalar) => 2,
                (DataType::U32, Dimensions::Scalar) => 4,
                _ => {
                    return Err(err(format!(
                        "accessor {}: indices must be SCALAR unsigned byte, short or int",
                        acc.index()
                    )))
                }
            };
            let idx: Vec<u32> = elements(&acc, buffers, size)
                .map_err(&err)?
                .map(|b| match b {
                    [x] => u32::from(*x),
                    [x, y] => u32::from(u16::from_le_bytes([*x, *y])),
                    _ => u32::from_le_bytes([b[0], b[1], b[2], b[3]]),
                })
                .collect();
            if let Some((k, &i)) = idx
                .iter()
                .enumerate()
                .find(|(_, &i)| i as usize >= positions.len())
            {
                return Err(err(format!(
                    "accessor {}: index {k} is {i}, out of range for {} vertices (accessor {})",
                    acc.index(),
                    positions.len(),
                    pos.index()
                )));
            }
            idx
        }
    };
    let mut emit = |t: [u32; 3]| {
        tris.push(Triangle {
            v: t.map(|i| positions[i as usize]),
        });
    };
    match prim.mode() {
        Mode::TriangleFan => fan(&indices, emit),
        Mode::TriangleStrip => {
            for (k, w) in indices.windows(3).enumerate() {
                // Every other triangle of a strip is reversed to keep the winding.
                emit(if k % 2 == 0 {
                    [w[0], w[1], w[2]]
                } else {
                    [w[1], w[0], w[2]]
                });
            }
        }
        _ => {
            if !indices.len().is_multiple_of(3) {
                return Err(err(format!(
                    "{} indices (accessor {}) is not a whole number of triangles",
                    indices.len(),
                    prim.indices().map_or(pos.index(), |a| a.index())
                )));
            }
            indices
                .chunks_exact(3)
                .for_each(|t| emit([t[0], t[1], t[2]]));
        }
    }
    Ok(())
}

/// The `size`-byte elements of accessor `acc`, every range checked.
fn elements<'b>(
    acc: &Accessor<'_>,
    buffers: &'b [Vec<u8>],
    size: usize,
) -> Result<impl Iterator<Item = &'b [u8]>, String> {
    let a = acc.index();
    if acc.sparse().is_some() {
        return Err(format!(
            "accessor {a}: sparse accessors are unsupported (docs/formats.md): store the values whole"
        ));
    }
    let view = acc
        .view()
        .ok_or_else(|| format!("accessor {a}: has no buffer view"))?;
    let v = view.index();
    let buffer = buffers
        .get(view.buffer().index())
        .ok_or_else(|| format!("buffer view {v}: no such buffer"))?;
    let data = view
        .offset()
        .checked_add(view.length())
        .and_then(|end| buffer.get(view.offset()..end))
        .ok_or_else(|| {
            format!(
                "buffer view {v}: bytes {}..+{} run past the end of buffer {} ({} bytes)",
                view.offset(),
                view.length(),
                view.buffer().index(),
                buffer.len()
            )
        })?;
    let stride = view.stride().unwrap_or(size);
    if stride < size {
        return Err(format!(
            "buffer view {v}: byteStride {stride} is shorter than an element ({size} bytes)"
        ));
    }
    let count = acc.count();
    let needed = match count {
        0 => Some(0),
        n => (n - 1)
            .checked_mul(stride)
            .and_then(|x| x.checked_add(acc.offset()))
            .and_then(|x| x.checked_add(size)),
    };
    if needed.is_none_or(|n| n > data.len()) {
        return Err(format!(
            "accessor {a}: {count} elements from byte {} need more than the {} bytes of buffer view {v}",
            acc.offset(),
            data.len()
        ));
    }
    let start = acc.offset();
    Ok((0..count).map(move |i| &data[start + i * stride..start + i * stride + size]))
}
