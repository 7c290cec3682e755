//! Wavefront OBJ through `tobj`, with line numbers for its errors.

use super::MeshError;
use kdray_kernel::Triangle;
use std::io::{BufRead, Read};
use std::path::Path;

/// A reader that hands out at most one line per `fill_buf`, counting the
/// lines consumed, so that when `tobj` stops at a bad line we can say which.
struct LineCounting<R> {
    inner: R,
    /// Newlines consumed.
    lines: usize,
    /// Bytes of a line consumed after the last newline.
    mid_line: bool,
}

impl<R> LineCounting<R> {
    /// The 1-based number of the line being read (or just read).
    fn current_line(&self) -> usize {
        self.lines + usize::from(self.mid_line)
    }
}

impl<R: BufRead> Read for LineCounting<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let avail = self.fill_buf()?;
        let n = avail.len().min(buf.len());
        buf[..n].copy_from_slice(&avail[..n]);
        self.consume(n);
        Ok(n)
    }
}

impl<R: BufRead> BufRead for LineCounting<R> {
    fn fill_buf(&mut self) -> std::io::Result<&[u8]> {
        let buf = self.inner.fill_buf()?;
        let end = buf
            .iter()
            .position(|&b| b == b'\n')
            .map_or(buf.len(), |i| i + 1);
        Ok(&buf[..end])
    }

    fn consume(&mut self, amt: usize) {
        if let Ok(buf) = self.inner.fill_buf() {
            let used = &buf[..amt.min(buf.len())];
            self.lines += used.iter().filter(|&&b| b == b'\n').count();
            if let Some(&last) = used.last() {
                self.mid_line = last != b'\n';
            }
        }
        self.inner.consume(amt);
    }
}

/// Refuses a face (`f` line) of fewer than three corners, which `tobj`
/// would drop silently, naming its line.
fn check_faces(path: &Path, text: &[u8]) -> Result<(), MeshError> {
    for (i, mut words) in line_words(text) {
        if words.next() != Some(b"f") {
            continue;
        }
        let corners = words.count();
        if corners < 3 {
            return Err(MeshError::new(
                path,
                Some(i + 1),
                format!("a face needs at least 3 corners, this one has {corners}"),
            ));
        }
    }
    Ok(())
}

/// The first vertex (`v` line) whose position is a number but not a
/// finite `f32` (`1e39`, `nan`), as an error naming its line: `tobj` keeps
/// such a vertex, and the mesh check would refuse it without a line. Read
/// only once the loaded positions hold one (a second parse of every
/// vertex would slow each load).
fn non_finite_vertex(path: &Path, text: &[u8]) -> Option<MeshError> {
    // A word that is no number at all is tobj's to report.
    let coordinate = |w: &[u8]| std::str::from_utf8(w).ok()?.parse::<f32>().ok();
    line_words(text).find_map(|(i, mut words)| {
        if words.next() != Some(b"v") {
            return None;
        }
        let w = words
            .take(3)
            .find(|&w| coordinate(w).is_some_and(|x| !x.is_finite()))?;
        Some(MeshError::new(
            path,
            Some(i + 1),
            format!(
                "non-finite vertex coordinate {} (NaN, or past f32's range)",
                String::from_utf8_lossy(w)
            ),
        ))
    })
}

/// Each line's index and its whitespace-separated words.
fn line_words(text: &[u8]) -> impl Iterator<Item = (usize, impl Iterator<Item = &[u8]>)> {
    text.split(|&b| b == b'\n').enumerate().map(|(i, line)| {
        (
            i,
            line.split(|b| b.is_ascii_whitespace())
                .filter(|w| !w.is_empty()),
        )
    })
}

/// Loads the triangles of an OBJ file: every face of every object, in file
/// order, polygons fanned. Materials are ignored (a missing `mtllib` is fine).
///
/// # Errors
/// A [`MeshError`] for a missing or unreadable file, or a malformed line
/// (with its number): a bad number, a vertex coordinate beyond `f32`'s
/// range or NaN, a vertex cut short, a face of fewer than three corners.
pub fn load_obj(path: &Path) -> Result<Vec<Triangle>, MeshError> {
    let text =
        std::fs::read(path).map_err(|e| MeshError::new(path, None, format!("cannot open: {e}")))?;
    check_faces(path, &text)?;
    let mut reader = LineCounting {
        inner: text.as_slice(),
        lines: 0,
        mid_line: false,
    };
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
    };
    let (models, _materials) =
        tobj::load_obj_buf(&mut reader, &opts, |_| Err(tobj::LoadError::OpenFileFailed)).map_err(
            |e| {
                MeshError::new(
                    path,
                    Some(reader.current_line()),
                    format!("malformed OBJ: {e}"),
                )
            },
        )?;
    let mut positions = models.iter().flat_map(|m| &m.mesh.positions);
    if positions.any(|x| !x.is_finite()) {
        if let Some(e) = non_finite_vertex(path, &text) {
            return Err(e);
        }
    }
    let mut tris = Vec::new();
    for model in &models {
        let m = &model.mesh;
        let vertex = |i: u32| -> Option<[f32; 3]> {
            let i = i as usize * 3;
            Some([
                *m.positions.get(i)?,
                *m.positions.get(i + 1)?,
                *m.positions.get(i + 2)?,
            ])
        };
        for (f, face) in m.indices.chunks_exact(3).enumerate() {
            let (Some(a), Some(b), Some(c)) = (vertex(face[0]), vertex(face[1]), vertex(face[2]))
            else {
                return Err(MeshError::new(
                    path,
                    None,
                    format!(
                        "object {:?}: face {f} names a vertex that does not exist",
                        model.name
                    ),
                ));
            };
            tris.push(Triangle { v: [a, b, c] });
        }
    }
    Ok(tris)
}

/// `tris` as OBJ text: three vertices per triangle, face `i` is triangle
/// `i`; `{:?}` prints the shortest decimal that reads back as the same
/// `f32`, so [`load_obj`] gives back the same triangles.
#[must_use]
pub fn obj_text(tris: &[Triangle]) -> Vec<u8> {
    use std::fmt::Write as _;
    let mut text = String::with_capacity(tris.len() * 100);
    let _ = writeln!(text, "# {} triangles", tris.len());
    for t in tris {
        for p in &t.v {
            let _ = writeln!(text, "v {:?} {:?} {:?}", p[0], p[1], p[2]);
        }
    }
    for i in 0..tris.len() {
        let _ = writeln!(text, "f {} {} {}", 3 * i + 1, 3 * i + 2, 3 * i + 3);
    }
    text.into_bytes()
}
