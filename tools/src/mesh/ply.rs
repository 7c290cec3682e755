//! Stanford PLY: ASCII, binary little-endian and binary big-endian. Vertex
//! `x y z` of any numeric type; faces as a list property
//! (`vertex_indices` or `vertex_index`) of integer indices, polygons fanned
//! like OBJ's. Other elements and properties are read past and ignored.

use super::{fan, MeshError};
use kdray_kernel::Triangle;
use std::path::Path;

/// A PLY scalar type.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(name: &str) -> Option<Scalar> {
        Some(match name {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    fn is_integer(self) -> bool {
        !matches!(self, Scalar::F32 | Scalar::F64)
    }
}

/// A property: a scalar, or a list (count type, item type).
#[derive(Clone, Debug)]
struct Property {
    name: String,
    kind: Kind,
}

#[derive(Clone, Copy, Debug)]
enum Kind {
    Scalar(Scalar),
    List(Scalar, Scalar),
}

#[derive(Clone, Debug)]
struct Element {
    name: String,
    count: usize,
    properties: Vec<Property>,
    /// The header line that declared it.
    line: usize,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Format {
    Ascii,
    Little,
    Big,
}

/// Where the values of element instances come from.
enum Body<'a> {
    /// Whitespace-separated numbers, one element instance a line.
    Ascii {
        lines: std::iter::Enumerate<std::str::Lines<'a>>,
        /// The 1-based line number of the first body line.
        first_line: usize,
        /// The values left on the current instance's line.
        words: std::str::SplitWhitespace<'a>,
    },
    /// Packed values.
    Binary {
        bytes: &'a [u8],
        at: usize,
        big: bool,
    },
}

/// Loads the triangles of a PLY file: faces in file order, polygons
/// fanned as `(v0, v[i], v[i+1])`.
///
/// # Errors
/// A [`MeshError`] naming the file and the header line, or the element and
/// its index (and the line for ASCII), for a malformed header, a truncated
/// body, a value of the wrong type or an index out of range.
pub fn load_ply(path: &Path) -> Result<Vec<Triangle>, MeshError> {
    let bytes =
        std::fs::read(path).map_err(|e| MeshError::new(path, None, format!("cannot open: {e}")))?;
    parse_ply(path, &bytes)
}

fn parse_ply(path: &Path, bytes: &[u8]) -> Result<Vec<Triangle>, MeshError> {
    let err = |line: Option<usize>, msg: String| MeshError::new(path, line, msg);
    let (format, elements, body_start, header_lines) = parse_header(path, bytes)?;
    let mut body = match format {
        Format::Ascii => {
            let text = std::str::from_utf8(&bytes[body_start..])
                .map_err(|e| err(None, format!("ASCII PLY body is not text: {e}")))?;
            Body::Ascii {
                lines: text.lines().enumerate(),
                first_line: header_lines + 1,
                words: "".split_whitespace(),
            }
        }
        Format::Little | Format::Big => Body::Binary {
            bytes,
            at: body_start,
            big: format == Format::Big,
        },
    };
    let mut vertices: Vec<[f32; 3]> = Vec::new();
    let mut tris = Vec::new();
    let mut saw_vertices = false;
    for el in &elements {
        let xyz = ["x", "y", "z"].map(|n| el.properties.iter().position(|p| p.name == n));
        let faces = el
            .properties
            .iter()
            .position(|p| p.name == "vertex_indices" || p.name == "vertex_index");
        let is_vertex = el.name == "vertex";
        let is_face = el.name == "face";
        if is_vertex {
            if xyz.iter().any(Option::is_none) {
                return Err(err(Some(el.line), "element vertex lacks x, y or z".into()));
            }
            saw_vertices = true;
            // A hostile count must not reserve more than the file could hold.
            vertices.reserve(el.count.min(bytes.len()));
        }
        if is_face {
            let Some(f) = faces else {
                return Err(err(
                    Some(el.line),
                    "element face has no vertex_indices list".into(),
                ));
            };
            if !matches!(el.properties[f].kind, Kind::List(_, t) if t.is_integer()) {
                return Err(err(
                    Some(el.line),
                    "vertex_indices must be a list of integers".into(),
                ));
            }
            if !saw_vertices {
                return Err(err(Some(el.line), "faces come before the vertices".into()));
            }
        }
        let mut poly: Vec<u32> = Vec::new();
        for i in 0..el.count {
            let line = body.next_instance().ok_or_else(|| {
                err(
                    None,
                    format!(
                        "truncated: {} {i} of {} is missing (file ends early)",
                        el.name, el.count
                    ),
                )
            })?;
            let at =
                |line: Option<usize>, what: String| err(line, format!("{} {i}: {what}", el.name));
            let mut p = [0.0f64; 3];
            for (k, prop) in el.properties.iter().enumerate() {
                match prop.kind {
                    Kind::Scalar(ty) => {
                        let v = body.value(ty).map_err(|e| at(line, e))?;
                        if let Some(c) = xyz.iter().position(|&c| c == Some(k)) {
                            p[c] = v;
                        }
                    }
                    Kind::List(count_ty, item_ty) => {
                        let n = body.value(count_ty).map_err(|e| at(line, e))?;
                        let n = n as usize;
                        let keep = is_face && faces == Some(k);
                        poly.clear();
                        for _ in 0..n {
                            let v = body.value(item_ty).map_err(|e| at(line, e))?;
                            if keep {
                                if v < 0.0 || v >= vertices.len() as f64 {
                                    return Err(at(
                                        line,
                                        format!(
                                            "vertex index {v} out of range ({} vertices)",
                                            vertices.len()
                                        ),
                                    ));
                                }
                                poly.push(v as u32);
                            }
                        }
                    }
                }
            }
            if let Some(extra) = body.leftover() {
                return Err(at(
                    line,
                    format!("unexpected extra value {extra:?} (the header declares fewer)"),
                ));
            }
            if is_vertex {
                // A finite double past f32's range would become infinite:
                // named here, not as a "non-finite" triangle later.
                if let Some(c) = p
                    .iter()
                    .find(|c| c.is_finite() && !(**c as f32).is_finite())
                {
                    return Err(at(
                        line,
                        format!(
                            "vertex coordinate {c:e} is out of f32 range (at most {:e} in size)",
                            f32::MAX
                        ),
                    ));
                }
                vertices.push(p.map(|c| c as f32));
            }
            if is_face {
                fan(&poly, |t| {
                    tris.push(Triangle {
                        v: t.map(|i| vertices[i as usize]),
                    })
                });
            }
        }
    }
    if !saw_vertices {
        return Err(err(None, "no vertex element".into()));
    }
    if let Some((line, what)) = body.rest() {
        return Err(err(
            line,
            format!("{what} after the last element the header declares"),
        ));
    }
    Ok(tris)
}

/// The header: format, elements, where the body starts, the header's line count.
fn parse_header(
    path: &Path,
    bytes: &[u8],
) -> Result<(Format, Vec<Element>, usize, usize), MeshError> {
    let err = |line: usize, msg: String| MeshError::new(path, Some(line), msg);
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    let mut at = 0;
    let mut line_no = 0;
    loop {
        let Some(len) = bytes[at..].iter().position(|&b| b == b'\n') else {
            return Err(err(line_no + 1, "header has no end_header line".into()));
        };
        line_no += 1;
        let raw = &bytes[at..at + len];
        at += len + 1;
        let line = std::str::from_utf8(raw)
            .map_err(|_| err(line_no, "header line is not text".into()))?
            .trim_end_matches('\r');
        let words: Vec<&str> = line.split_whitespace().collect();
        match words[..] {
            ["ply"] if line_no == 1 => {}
            _ if line_no == 1 => return Err(err(1, "not a PLY file (no 'ply' magic)".into())),
            ["format", f, version] => {
                if version != "1.0" {
                    return Err(err(line_no, format!("unsupported PLY version {version}")));
                }
                format = Some(match f {
                    "ascii" => Format::Ascii,
                    "binary_little_endian" => Format::Little,
                    "binary_big_endian" => Format::Big,
                    _ => return Err(err(line_no, format!("unknown format {f:?}"))),
                });
            }
            ["comment", ..] | ["obj_info", ..] | [] => {}
            ["element", name, count] => {
                let count = count
                    .parse()
                    .map_err(|_| err(line_no, format!("bad element count {count:?}")))?;
                elements.push(Element {
                    name: name.to_string(),
                    count,
                    properties: Vec::new(),
                    line: line_no,
                });
            }
            ["property", "list", count_ty, item_ty, name] => {
                let ty = |t: &str| {
                    Scalar::parse(t).ok_or_else(|| err(line_no, format!("unknown type {t:?}")))
                };
                let (c, i) = (ty(count_ty)?, ty(item_ty)?);
                if !c.is_integer() {
                    return Err(err(line_no, "a list count must be an integer type".into()));
                }
                push_property(&mut elements, name, Kind::List(c, i))
                    .ok_or_else(|| err(line_no, "property before any element".into()))?;
            }
            ["property", ty, name] => {
                let ty = Scalar::parse(ty)
                    .ok_or_else(|| err(line_no, format!("unknown type {ty:?}")))?;
                push_property(&mut elements, name, Kind::Scalar(ty))
                    .ok_or_else(|| err(line_no, "property before any element".into()))?;
            }
            ["end_header"] => break,
            _ => return Err(err(line_no, format!("malformed header line {line:?}"))),
        }
    }
    let format = format.ok_or_else(|| err(line_no, "header has no format line".into()))?;
    Ok((format, elements, at, line_no))
}

fn push_property(elements: &mut [Element], name: &str, kind: Kind) -> Option<()> {
    elements.last_mut()?.properties.push(Property {
        name: name.to_string(),
        kind,
    });
    Some(())
}

impl<'a> Body<'a> {
    /// Starts the next element instance: `None` when an ASCII body has no
    /// more lines, else `Some(its line)` (`Some(None)` for binary, where a
    /// short body shows as a truncated value).
    fn next_instance(&mut self) -> Option<Option<usize>> {
        match self {
            Body::Ascii {
                lines,
                first_line,
                words,
            } => {
                let (i, l) = lines.find(|(_, l)| !l.trim().is_empty())?;
                *words = l.split_whitespace();
                Some(Some(*first_line + i))
            }
            Body::Binary { .. } => Some(None),
        }
    }

    /// What is left after the last element, if anything: the line of the
    /// first non-blank ASCII line, or the count of binary bytes.
    fn rest(&mut self) -> Option<(Option<usize>, String)> {
        match self {
            Body::Ascii {
                lines, first_line, ..
            } => {
                let (i, l) = lines.find(|(_, l)| !l.trim().is_empty())?;
                Some((
                    Some(*first_line + i),
                    format!("unexpected data {:?}", l.trim()),
                ))
            }
            Body::Binary { bytes, at, .. } => {
                let left = bytes.len().saturating_sub(*at);
                (left > 0).then(|| (None, format!("{left} bytes of unexpected data")))
            }
        }
    }

    /// A value left over on an ASCII instance's line.
    fn leftover(&mut self) -> Option<&'a str> {
        match self {
            Body::Ascii { words, .. } => words.next(),
            Body::Binary { .. } => None,
        }
    }

    /// The next value, of type `ty`, as `f64` (exact for every PLY type but
    /// `double`, which is kept).
    fn value(&mut self, ty: Scalar) -> Result<f64, String> {
        match self {
            Body::Ascii { words, .. } => {
                let w = words
                    .next()
                    .ok_or("too few values (the header declares more)")?;
                let v: f64 = w.parse().map_err(|_| format!("{w:?} is not a number"))?;
                if ty.is_integer() && v.fract() != 0.0 {
                    return Err(format!("{w:?} is not an integer"));
                }
                Ok(v)
            }
            Body::Binary { bytes, at, big } => {
                let n = ty.size();
                let raw = bytes
                    .get(*at..*at + n)
                    .ok_or_else(|| format!("truncated at byte {at} (file ends early)"))?;
                *at += n;
                let mut b = [0u8; 8];
                b[..n].copy_from_slice(raw);
                if *big {
                    b[..n].reverse();
                }
                Ok(match ty {
                    Scalar::I8 => f64::from(b[0] as i8),
                    Scalar::U8 => f64::from(b[0]),
                    Scalar::I16 => f64::from(i16::from_le_bytes([b[0], b[1]])),
                    Scalar::U16 => f64::from(u16::from_le_bytes([b[0], b[1]])),
                    Scalar::I32 => f64::from(i32::from_le_bytes([b[0], b[1], b[2], b[3]])),
                    Scalar::U32 => f64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
                    Scalar::F32 => f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]])),
                    Scalar::F64 => f64::from_le_bytes(b),
                })
            }
        }
    }
}
