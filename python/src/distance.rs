//! Distance queries on a triangle tree: query points in, Open3D's
//! `compute_*` arrays out, each by one of the tools' `distance` batch
//! calls (the kernel's closest-point walk and inside test) on the
//! `nthreads` pool, so every answer is the kernel's bit for bit.

use crate::arrays::{rows, table};
use crate::pools;
use crate::rays::{map_all, unit_normal};
use kdray_kernel::TriangleTree;
use kdray_tools::distance::{self, DistanceRecord, InsideRule};
use numpy::{PyArray1, PyReadonlyArray2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// The most rays `nsamples` may vote with (`contains_voting`'s limit).
const MAX_SAMPLES: u32 = 7;

/// The query points of a C-contiguous `(N, 3)` `float32` array, in place.
pub(crate) fn point_slice<'a>(points: &'a PyReadonlyArray2<'_, f32>) -> PyResult<&'a [[f32; 3]]> {
    rows(points, "query_points", "(N, 3)")
}

/// Open3D's `nsamples` as the inside rule: 1 is the parity of one ray,
/// an odd count up to 7 the majority of that many rays; `winding` (with
/// `nsamples` 1) the generalized winding number, for open meshes.
pub(crate) fn inside_rule(nsamples: u32, winding: bool) -> PyResult<InsideRule> {
    match (nsamples, winding) {
        (1, true) => Ok(InsideRule::Winding),
        (_, true) => Err(PyValueError::new_err(format!(
            "winding=True decides by the winding number, not by rays: nsamples must be 1, not {nsamples}"
        ))),
        (1, false) => Ok(InsideRule::Parity),
        (3..=MAX_SAMPLES, false) if nsamples % 2 == 1 => Ok(InsideRule::Vote(nsamples)),
        _ => Err(PyValueError::new_err(format!(
            "nsamples must be an odd number from 1 to {MAX_SAMPLES}, not {nsamples}"
        ))),
    }
}

/// `(points, primitive_ids, primitive_uvs, primitive_normals)` of
/// `compute_closest_points`: `(N, 3)`, `(N,)`, `(N, 2)`, `(N, 3)`.
pub(crate) type ClosestArrays<'py> = (
    Bound<'py, PyAny>,
    Bound<'py, PyArray1<u32>>,
    Bound<'py, PyAny>,
    Bound<'py, PyAny>,
);

/// The closest point of every query ([`distance::distance_records`]):
/// where there is none (a query with a NaN or infinite coordinate), a
/// NaN point and barycentrics, [`kdray_kernel::MISS`] and a zero normal.
pub(crate) fn closest_points<'py>(
    py: Python<'py>,
    tree: &TriangleTree<'_>,
    queries: &[[f32; 3]],
    nthreads: usize,
) -> PyResult<ClosestArrays<'py>> {
    let (records, normals) = py.detach(|| {
        let mut out = vec![DistanceRecord::new(None, true); queries.len()];
        pools::install_sized(queries.len(), nthreads, || {
            distance::distance_records(tree, queries, f32::INFINITY, None, &mut out);
        })?;
        let tris = tree.triangles();
        let normals = map_all(&out, nthreads, |r| unit_normal(tris, r.prim))?;
        Ok::<_, PyErr>((out, normals))
    })?;
    let points: Vec<[f32; 3]> = records.iter().map(|r| r.point).collect();
    let uvs: Vec<[f32; 2]> = records.iter().map(|r| [r.u, r.v]).collect();
    Ok((
        table(py, points)?,
        PyArray1::from_vec(py, records.iter().map(|r| r.prim).collect()),
        table(py, uvs)?,
        table(py, normals)?,
    ))
}

/// One answer per query point of `points` by `fill(tree, queries, out)`
/// (one of the tools' batch calls) on the `nthreads` pool, the GIL
/// released.
pub(crate) fn answers<'py, T: Copy + Send + numpy::Element>(
    py: Python<'py>,
    tree: &TriangleTree<'_>,
    points: &PyReadonlyArray2<'py, f32>,
    nthreads: usize,
    zero: T,
    fill: impl FnOnce(&TriangleTree<'_>, &[[f32; 3]], &mut [T]) + Send,
) -> PyResult<Bound<'py, PyArray1<T>>> {
    let queries = point_slice(points)?;
    let out = py.detach(|| {
        let mut out = vec![zero; queries.len()];
        pools::install_sized(queries.len(), nthreads, || fill(tree, queries, &mut out))?;
        Ok::<_, PyErr>(out)
    })?;
    Ok(PyArray1::from_vec(py, out))
}
