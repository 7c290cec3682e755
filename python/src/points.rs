//! `PointTree`: a point k-d tree over D-dimensional `float32` or `float64`
//! points (D = 1..[`MAX_DIM`]), built from an array or loaded from a
//! blob, with the k-nearest and within-radius queries (the compiled layer
//! of `kdray.KDTree`, which adds scipy's conventions).

use crate::held::{blob_error, Bytes};
use crate::pools;
use crate::rays::map_all;
use kdray_kernel::{Neighbour, PointShape, PointTreeN, Scalar};
use kdray_tools::blob::write_point_tree;
use kdray_tools::points::{build_points, PointParams};
use numpy::PyUntypedArrayMethods;
use numpy::{Element, PyArray1, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use rayon::prelude::*;
use std::path::PathBuf;

/// The scalar types' conversion from a Python float (exact for a value
/// the Python layer computed in the tree's dtype).
trait FromF64 {
    /// `v` rounded to `Self`.
    fn from_f64(v: f64) -> Self;
}

impl FromF64 for f32 {
    fn from_f64(v: f64) -> f32 {
        v as f32
    }
}

impl FromF64 for f64 {
    fn from_f64(v: f64) -> f64 {
        v
    }
}

/// The largest dimension a tree is compiled for.
pub(crate) const MAX_DIM: usize = 16;

/// A blob's alignment for a point tree (8 covers `f64` coordinates).
const ALIGN: usize = 8;

/// Queries per parallel task of `knn` (as the tools' `knn_all`).
const KNN_CHUNK: usize = 256;

/// Queries per parallel task of `within`.
const WITHIN_CHUNK: usize = 64;

/// A point k-d tree (compiled layer of `kdray.KDTree`).
#[pyclass(frozen, module = "kdray._kdray")]
pub(crate) struct PointTree {
    bytes: Bytes,
    /// D.
    dim: usize,
    /// `float64` coordinates (else `float32`).
    f64: bool,
    /// How many points.
    n: usize,
}

/// Runs `$body` with `D` and `S` bound to the tree's compiled shape.
macro_rules! shaped {
    ($dim:expr, $f64:expr, $body:ident $args:tt) => {
        shaped!(@ $dim, $f64, $body $args; 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16)
    };
    (@ $dim:expr, $f64:expr, $body:ident $args:tt; $($d:literal)*) => {
        match ($dim, $f64) {
            $(($d, false) => $body::<$d, f32> $args,
              ($d, true) => $body::<$d, f64> $args,)*
            (d, _) => Err(PyValueError::new_err(format!(
                "data: {d}-dimensional points: kdray's trees take 1 to {MAX_DIM} dimensions"
            ))),
        }
    };
}

/// Builds the blob of `data` (`(N, D)`, C-contiguous, of `S`).
fn build<const D: usize, S: Scalar + Element + FromF64>(
    data: &Bound<'_, PyAny>,
    leaf_size: Option<usize>,
) -> PyResult<kdray_tools::blob::Blob> {
    let data = data.extract::<PyReadonlyArray2<'_, S>>()?;
    let flat = data
        .as_slice()
        .map_err(|_| PyValueError::new_err("data: expected a C-contiguous array"))?;
    let points: &[[S; D]] =
        bytemuck::try_cast_slice(flat).map_err(|e| PyValueError::new_err(format!("data: {e}")))?;
    let params = PointParams {
        leaf_size,
        ..PointParams::default()
    };
    data.py()
        .detach(|| {
            let built = build_points(points, &params).map_err(|e| e.to_string())?;
            write_point_tree(&built).map_err(|e| e.to_string())
        })
        .map_err(|e| PyValueError::new_err(format!("data: {e}")))
}

/// Validates `bytes` as a tree of D-dimensional `S` points; their count.
fn validate<const D: usize, S: Scalar>(bytes: &[u8]) -> PyResult<usize> {
    PointTreeN::<D, S>::from_bytes(bytes)
        .map(|t| t.len())
        .map_err(blob_error("point tree"))
}

/// The tree over `bytes` (validated when the tree was made).
fn view<const D: usize, S: Scalar>(bytes: &[u8]) -> PyResult<PointTreeN<'_, D, S>> {
    PointTreeN::<D, S>::from_bytes_unchecked(bytes).map_err(blob_error("point tree"))
}

/// The `k` nearest neighbours of each query within squared distance
/// `max_d2`: `(d2 (M, k), index (M, k))`, `index` = `n` and `d2` = inf
/// where fewer exist.
type Knn<'py> = (Bound<'py, PyAny>, Bound<'py, PyAny>);

fn knn<'py, const D: usize, S: Scalar + Element + FromF64>(
    tree: &PointTree,
    x: &Bound<'py, PyAny>,
    k: usize,
    max_d2: f64,
    workers: usize,
) -> PyResult<Knn<'py>> {
    let py = x.py();
    let x = x.extract::<PyReadonlyArray2<'py, S>>()?;
    let flat = x
        .as_slice()
        .map_err(|_| PyValueError::new_err("x: expected a C-contiguous array"))?;
    let queries: &[[S; D]] =
        bytemuck::try_cast_slice(flat).map_err(|e| PyValueError::new_err(format!("x: {e}")))?;
    let t = view::<D, S>(tree.bytes.as_slice())?;
    let m = queries.len();
    let len = m
        .checked_mul(k)
        .ok_or_else(|| PyValueError::new_err(format!("k: {m} queries x {k} overflows")))?;
    let max_d2 = S::from_f64(max_d2);
    let n = tree.n as i64;
    let (d2, index) = py.detach(|| {
        let mut out = Vec::new();
        out.try_reserve_exact(len).map_err(|_| {
            PyValueError::new_err(format!("k: no memory for {m} queries x {k} neighbours"))
        })?;
        out.resize(len, Neighbour::<S>::NONE);
        // `knn_all`'s loop (the tools'), over `knn_within` for the bound;
        // on the calling thread for one worker or one task's worth.
        let answer = |out: &mut [Neighbour<S>], qs: &[[S; D]]| {
            for (o, q) in out.chunks_exact_mut(k).zip(qs) {
                let found = t.knn_within(*q, max_d2, o);
                o[found..].fill(Neighbour::NONE);
            }
        };
        if workers == 1 || m <= KNN_CHUNK {
            answer(&mut out, queries);
        } else {
            pools::install(workers, || {
                out.par_chunks_mut(k * KNN_CHUNK)
                    .zip(queries.par_chunks(KNN_CHUNK))
                    .for_each(|(o, qs)| answer(o, qs));
            })?;
        }
        // Split on the global pool (small batches on this thread).
        let d2: Vec<S> = map_all(&out, 0, |nb| nb.d2)?;
        let index: Vec<i64> = map_all(&out, 0, |nb| {
            if nb.index == u32::MAX {
                n
            } else {
                i64::from(nb.index)
            }
        })?;
        Ok::<_, PyErr>((d2, index))
    })?;
    Ok((
        PyArray1::from_vec(py, d2).reshape([m, k])?.into_any(),
        PyArray1::from_vec(py, index).reshape([m, k])?.into_any(),
    ))
}

/// The points within squared distance `r2[i]` of each query `x[i]`, in
/// CSR form: `(splits (M + 1,), indices)`, each query's indices ascending.
type Within<'py> = (Bound<'py, PyArray1<u64>>, Bound<'py, PyArray1<i64>>);

fn within<'py, const D: usize, S: Scalar + Element + FromF64>(
    tree: &PointTree,
    x: &Bound<'py, PyAny>,
    r2: &Bound<'py, PyAny>,
    workers: usize,
) -> PyResult<Within<'py>> {
    let py = x.py();
    let x = x.extract::<PyReadonlyArray2<'py, S>>()?;
    let r2 = r2.extract::<PyReadonlyArray1<'py, S>>()?;
    let flat = x
        .as_slice()
        .map_err(|_| PyValueError::new_err("x: expected a C-contiguous array"))?;
    let queries: &[[S; D]] =
        bytemuck::try_cast_slice(flat).map_err(|e| PyValueError::new_err(format!("x: {e}")))?;
    let r2 = r2
        .as_slice()
        .map_err(|_| PyValueError::new_err("r: expected a C-contiguous array"))?;
    if r2.len() != queries.len() {
        return Err(PyValueError::new_err(format!(
            "r: {} radii for {} queries",
            r2.len(),
            queries.len()
        )));
    }
    let t = view::<D, S>(tree.bytes.as_slice())?;
    let (splits, indices) = py.detach(|| {
        // Each query's indices, ascending, after the chunk's earlier ones.
        let answer = |(qs, rs): (&[[S; D]], &[S])| {
            let (mut counts, mut found) = (Vec::with_capacity(qs.len()), Vec::new());
            for (q, &r) in qs.iter().zip(rs) {
                let start = found.len();
                t.for_each_within(*q, r, |nb| found.push(i64::from(nb.index)));
                found[start..].sort_unstable();
                counts.push((found.len() - start) as u64);
            }
            (counts, found)
        };
        let parts: Vec<(Vec<u64>, Vec<i64>)> = if workers == 1 || queries.len() <= WITHIN_CHUNK {
            vec![answer((queries, r2))]
        } else {
            pools::install(workers, || {
                queries
                    .par_chunks(WITHIN_CHUNK)
                    .zip(r2.par_chunks(WITHIN_CHUNK))
                    .map(answer)
                    .collect()
            })?
        };
        let mut splits = Vec::with_capacity(queries.len() + 1);
        splits.push(0u64);
        let mut indices = Vec::new();
        for (counts, found) in parts {
            for c in counts {
                let last = splits.last().copied().unwrap_or(0);
                splits.push(last + c);
            }
            indices.extend_from_slice(&found);
        }
        Ok::<_, PyErr>((splits, indices))
    })?;
    Ok((
        PyArray1::from_vec(py, splits),
        PyArray1::from_vec(py, indices),
    ))
}

/// The points, `(N, D)`, in input order.
fn data<'py, const D: usize, S: Scalar + Element + FromF64>(
    py: Python<'py>,
    tree: &PointTree,
) -> PyResult<Bound<'py, PyAny>> {
    let t = view::<D, S>(tree.bytes.as_slice())?;
    let mut out = vec![S::default(); t.len() * D];
    for (position, &index) in t.indices().iter().enumerate() {
        if let (Some(p), Some(slot)) = (
            t.point(position),
            out.get_mut(index as usize * D..index as usize * D + D),
        ) {
            slot.copy_from_slice(&p);
        }
    }
    Ok(PyArray1::from_vec(py, out)
        .reshape([t.len(), D])?
        .into_any())
}

impl PointTree {
    /// A tree over `bytes`, validated.
    fn over(bytes: Bytes) -> PyResult<PointTree> {
        let slice = bytes.as_slice();
        let shape = PointShape::of_blob(slice).map_err(blob_error("point tree"))?;
        let (dim, f64) = (shape.dim as usize, shape.scalar_bytes == 8);
        if !matches!(shape.scalar_bytes, 4 | 8) {
            return Err(crate::BlobError::new_err(format!(
                "buffer: not a valid point tree blob: {}-byte coordinates",
                shape.scalar_bytes
            )));
        }
        if !(1..=MAX_DIM).contains(&dim) {
            return Err(crate::BlobError::new_err(format!(
                "buffer: not a valid point tree blob: {dim}-dimensional points (1 to {MAX_DIM})"
            )));
        }
        let n = shaped!(dim, f64, validate(slice))?;
        Ok(PointTree { bytes, dim, f64, n })
    }
}

#[pymethods]
impl PointTree {
    /// Builds a tree over `data`, a C-contiguous `(N, D)` float32 or
    /// float64 array (kept in its type), `leaf_size` points a leaf at most.
    #[staticmethod]
    #[pyo3(signature = (data, leaf_size=None))]
    fn build(data: &Bound<'_, PyAny>, leaf_size: Option<usize>) -> PyResult<PointTree> {
        let py = data.py();
        let (dim, f64) = shape_of(data)?;
        let blob = shaped!(dim, f64, build(data, leaf_size))?;
        PointTree::over(Bytes::from_blob(py, blob, ALIGN))
    }

    /// Validates a point blob held by `buffer` (borrowed when read-only,
    /// C-contiguous and 8-byte aligned and `copy` is false).
    #[staticmethod]
    fn from_buffer(buffer: &Bound<'_, PyAny>, copy: bool) -> PyResult<PointTree> {
        PointTree::over(Bytes::from_buffer(buffer, ALIGN, copy)?)
    }

    /// Reads and validates a point blob file.
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<PointTree> {
        PointTree::over(Bytes::read(py, &path)?)
    }

    /// The blob, as a `bytes` object.
    fn to_bytes<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        self.bytes.to_pybytes(py)
    }

    /// Writes the blob to `path` (the tools' atomic writer).
    fn save(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        self.bytes.save(py, &path)
    }

    /// D.
    #[getter]
    fn dim(&self) -> usize {
        self.dim
    }

    /// How many points.
    #[getter]
    fn n(&self) -> usize {
        self.n
    }

    /// `"float32"` or `"float64"`.
    #[getter]
    fn dtype(&self) -> &'static str {
        if self.f64 {
            "float64"
        } else {
            "float32"
        }
    }

    /// The points, `(N, D)`, in input order.
    fn data<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        shaped!(self.dim, self.f64, data(py, self))
    }

    /// The `k` nearest points of each row of `x` (`(M, D)`, C-contiguous,
    /// the tree's dtype) at squared distance `<= max_d2`.
    fn knn<'py>(
        &self,
        x: &Bound<'py, PyAny>,
        k: usize,
        max_d2: f64,
        workers: usize,
    ) -> PyResult<Knn<'py>> {
        shaped!(self.dim, self.f64, knn(self, x, k, max_d2, workers))
    }

    /// The points at squared distance `<= r2[i]` of each row `x[i]`.
    fn within<'py>(
        &self,
        x: &Bound<'py, PyAny>,
        r2: &Bound<'py, PyAny>,
        workers: usize,
    ) -> PyResult<Within<'py>> {
        shaped!(self.dim, self.f64, within(self, x, r2, workers))
    }
}

/// `(D, is float64)` of a 2-D float32 or float64 array.
fn shape_of(data: &Bound<'_, PyAny>) -> PyResult<(usize, bool)> {
    if let Ok(a) = data.cast::<numpy::PyArray2<f32>>() {
        return Ok((a.shape()[1], false));
    }
    if let Ok(a) = data.cast::<numpy::PyArray2<f64>>() {
        return Ok((a.shape()[1], true));
    }
    Err(PyValueError::new_err(
        "data: expected a 2-D float32 or float64 array",
    ))
}
