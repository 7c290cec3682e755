//! `TriangleTree`: a triangle k-d tree built from arrays or a mesh file,
//! or loaded from a blob, its ray queries on the tools' batch paths and
//! its distance queries ([`crate::distance`]).

use crate::arrays::table;
use crate::distance::{self, answers, inside_rule, point_slice, ClosestArrays};
use crate::held::{Bytes, Held, HeldTree};
use crate::pools;
use crate::rays::{cast_arrays, hit_lists, ray_slice, unit_normal, CastArrays, SERIAL_MAX};
use kdray_kernel::{
    any_hit_brute, closest_hit_brute, closest_point_brute, first_hits_brute, ClosestPoint, Hit,
    Ray, Triangle, MISS,
};
use kdray_tools::blob::write_triangle_tree;
use kdray_tools::builders::{build, BuildParams, BuilderKind};
use kdray_tools::distance as tools;
use kdray_tools::trace::{trace_into, trace_serial, Order, PacketWidth, Query};
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray2, PyReadonlyArray3, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use std::path::PathBuf;

/// The builder's options as Python passes them (`None`: the default).
#[derive(FromPyObject)]
#[pyo3(from_item_all)]
pub(crate) struct BuildOptions {
    builder: String,
    max_depth: Option<u32>,
    traversal_cost: Option<f32>,
    intersection_cost: Option<f32>,
    empty_bonus: Option<f32>,
    threads: Option<usize>,
}

impl BuildOptions {
    /// The builder and its parameters, checked by the tools' own
    /// [`BuildParams::check`], as `kdray build` checks them.
    pub(crate) fn params(&self) -> PyResult<(BuilderKind, BuildParams)> {
        let kind = BuilderKind::parse(&self.builder)
            .map_err(|e| PyValueError::new_err(format!("builder: {e}")))?;
        let d = BuildParams::default();
        let params = BuildParams {
            threads: self.threads.filter(|&t| t > 0),
            traversal_cost: self.traversal_cost.unwrap_or(d.traversal_cost),
            intersection_cost: self.intersection_cost.unwrap_or(d.intersection_cost),
            empty_bonus: self.empty_bonus.unwrap_or(d.empty_bonus),
            max_depth: self.max_depth.or(d.max_depth),
            ..d
        };
        params
            .check(str::to_string)
            .map_err(PyValueError::new_err)?;
        Ok((kind, params))
    }
}

/// A triangle k-d tree (compiled layer of `kdray.TriangleTree`).
#[pyclass(frozen, module = "kdray._kdray")]
pub(crate) struct TriangleTree {
    held: HeldTree,
}

/// Builds and writes the blob of `tris`, with the GIL released.
fn build_blob(
    py: Python<'_>,
    tris: &[Triangle],
    options: &BuildOptions,
    what: &str,
) -> PyResult<TriangleTree> {
    let (kind, params) = options.params()?;
    let blob = py
        .detach(|| {
            let built = build(tris, kind, &params).map_err(|e| e.to_string())?;
            write_triangle_tree(&built, tris).map_err(|e| e.to_string())
        })
        .map_err(|e| PyValueError::new_err(format!("{what}: {e}")))?;
    let bytes = Bytes::from_blob(py, blob, HeldTree::ALIGN);
    let held = py.detach(|| HeldTree::new(bytes))?;
    Ok(TriangleTree { held })
}

/// Traces `rays` for `query` on `nthreads` threads (0: all cores) into
/// fresh hit records: small batches on the calling thread, larger ones by
/// [`trace_into`] (Morton order for large scattered shadow batches).
fn trace(
    tree: &impl kdray_kernel::TraceBatch,
    rays: &[Ray],
    query: Query,
    width: Option<PacketWidth>,
    nthreads: usize,
) -> PyResult<Vec<Hit>> {
    let mut hits = vec![Hit::MISS; rays.len()];
    if rays.len() <= SERIAL_MAX {
        trace_serial(tree, rays, &mut hits, query, width);
    } else {
        pools::install(nthreads, || {
            trace_into(tree, rays, &mut hits, query, width, Order::Auto);
        })?;
    }
    Ok(hits)
}

/// `packet`: `None` (each block's walk timed on the batch), 1, 4, 8 or 16.
fn width(packet: Option<usize>) -> PyResult<Option<PacketWidth>> {
    packet
        .map(|n| {
            PacketWidth::from_lanes(n).ok_or_else(|| {
                PyValueError::new_err(format!("packet must be None, 1, 4, 8 or 16, not {n}"))
            })
        })
        .transpose()
}

#[pymethods]
impl TriangleTree {
    /// Builds a tree over `triangles`, a C-contiguous `(F, 3, 3)` float32
    /// array (triangle, vertex, axis).
    #[staticmethod]
    fn build(
        py: Python<'_>,
        triangles: PyReadonlyArray3<'_, f32>,
        options: BuildOptions,
    ) -> PyResult<TriangleTree> {
        if triangles.shape()[1..] != [3, 3] {
            return Err(PyValueError::new_err(format!(
                "triangles: expected shape (F, 3, 3), got {:?}",
                triangles.shape()
            )));
        }
        let floats = triangles
            .as_slice()
            .map_err(|_| PyValueError::new_err("triangles: expected a C-contiguous array"))?;
        let tris: &[Triangle] = bytemuck::try_cast_slice(floats)
            .map_err(|e| PyValueError::new_err(format!("triangles: {e}")))?;
        build_blob(py, tris, &options, "triangles")
    }

    /// Loads a mesh file (OBJ, PLY, glTF/GLB) with the tools' loaders and
    /// builds a tree over its triangles.
    #[staticmethod]
    fn from_mesh_file(
        py: Python<'_>,
        path: PathBuf,
        options: BuildOptions,
    ) -> PyResult<TriangleTree> {
        let tris = py
            .detach(|| kdray_tools::mesh::load(&path))
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        build_blob(py, &tris, &options, &path.display().to_string())
    }

    /// Validates a blob held by `buffer` (borrowed when read-only, C-contiguous
    /// and aligned and `copy` is false; copied otherwise).
    #[staticmethod]
    fn from_buffer(buffer: &Bound<'_, PyAny>, copy: bool) -> PyResult<TriangleTree> {
        let held = HeldTree::from_buffer(buffer, copy)?;
        Ok(TriangleTree { held })
    }

    /// Reads and validates a blob file.
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<TriangleTree> {
        let held = HeldTree::load(py, &path)?;
        Ok(TriangleTree { held })
    }

    /// The blob, as a `bytes` object.
    fn to_bytes<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        self.held.bytes().to_pybytes(py)
    }

    /// Writes the blob to `path` (the tools' writer: a temporary file
    /// renamed into place).
    fn save(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        self.held.bytes().save(py, &path)
    }

    /// The triangles, `(F, 3, 3)` float32, in mesh order.
    fn triangles<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let tris = self.held.tree().tree().triangles();
        let floats: Vec<f32> = bytemuck::cast_slice(tris).to_vec();
        Ok(PyArray1::from_vec(py, floats)
            .reshape([tris.len(), 3, 3])?
            .into_any())
    }

    /// How many triangles.
    #[getter]
    fn triangle_count(&self) -> usize {
        self.held.tree().tree().triangles().len()
    }

    /// How many nodes.
    #[getter]
    fn node_count(&self) -> usize {
        self.held.tree().tree().nodes().len()
    }

    /// The depth of the deepest node.
    #[getter]
    fn depth(&self) -> u32 {
        self.held.tree().tree().max_depth()
    }

    /// The root cell's `(min, max)`.
    #[getter]
    fn bounds(&self) -> ([f32; 3], [f32; 3]) {
        let b = self.held.tree().tree().bounds();
        (b.min, b.max)
    }

    /// The closest hit of each ray: `(t_hit, primitive_ids, primitive_uvs,
    /// primitive_normals)`.
    fn cast<'py>(
        &self,
        py: Python<'py>,
        rays: PyReadonlyArray2<'py, f32>,
        nthreads: usize,
        packet: Option<usize>,
    ) -> PyResult<CastArrays<'py>> {
        let rays = ray_slice(&rays)?;
        let (tree, width) = (self.held.tree(), width(packet)?);
        let hits = py.detach(|| trace(tree, rays, Query::Closest, width, nthreads))?;
        cast_arrays(py, &hits, nthreads, |p| {
            unit_normal(tree.tree().triangles(), p)
        })
    }

    /// Whether each ray hits anything in its `[tnear, tfar]`.
    fn occluded<'py>(
        &self,
        py: Python<'py>,
        rays: PyReadonlyArray2<'py, f32>,
        nthreads: usize,
        packet: Option<usize>,
    ) -> PyResult<Bound<'py, PyArray1<bool>>> {
        let rays = ray_slice(&rays)?;
        let (tree, width) = (self.held.tree(), width(packet)?);
        let hits = py.detach(|| trace(tree, rays, Query::Any, width, nthreads))?;
        let occluded: Vec<bool> = hits.iter().map(Hit::is_hit).collect();
        Ok(PyArray1::from_vec(py, occluded))
    }

    /// Every hit of each ray, each triangle once, by `t` then triangle
    /// index: `(ray_splits, t_hit, primitive_ids, primitive_uvs)`.
    fn hits<'py>(
        &self,
        py: Python<'py>,
        rays: PyReadonlyArray2<'py, f32>,
        nthreads: usize,
    ) -> PyResult<HitArrays<'py>> {
        let rays = ray_slice(&rays)?;
        let tree = self.held.tree();
        let max = tree.tree().triangles().len();
        let lists = py.detach(|| {
            pools::install(nthreads, || {
                hit_lists(rays, max, Hit::MISS, |r, out| tree.first_hits(r, out))
            })
        })?;
        hit_arrays(py, lists.splits, &lists.hits)
    }

    /// The closest point of each query: `(points, primitive_ids,
    /// primitive_uvs, primitive_normals)`.
    fn closest_points<'py>(
        &self,
        py: Python<'py>,
        points: PyReadonlyArray2<'py, f32>,
        nthreads: usize,
    ) -> PyResult<ClosestArrays<'py>> {
        let queries = point_slice(&points)?;
        distance::closest_points(py, &self.held.tree().tree(), queries, nthreads)
    }

    /// The distance of each query to the mesh (NaN for a query with a NaN
    /// or infinite coordinate).
    fn distances<'py>(
        &self,
        py: Python<'py>,
        points: PyReadonlyArray2<'py, f32>,
        nthreads: usize,
    ) -> PyResult<Bound<'py, PyArray1<f32>>> {
        let tree = self.held.tree().tree();
        answers(py, &tree, &points, nthreads, 0.0, tools::distances)
    }

    /// The signed distance of each query: negative inside by the rule of
    /// `nsamples` (1: one ray's parity; 3, 5, 7: their majority) or of
    /// `winding` (the generalized winding number).
    fn signed_distances<'py>(
        &self,
        py: Python<'py>,
        points: PyReadonlyArray2<'py, f32>,
        nthreads: usize,
        nsamples: u32,
        winding: bool,
    ) -> PyResult<Bound<'py, PyArray1<f32>>> {
        let rule = inside_rule(nsamples, winding)?;
        let tree = self.held.tree().tree();
        answers(py, &tree, &points, nthreads, 0.0, |t, q, out| {
            tools::signed_distances(t, q, rule, out);
        })
    }

    /// Whether each query is inside by the rule of `nsamples` or `winding`.
    fn occupancy<'py>(
        &self,
        py: Python<'py>,
        points: PyReadonlyArray2<'py, f32>,
        nthreads: usize,
        nsamples: u32,
        winding: bool,
    ) -> PyResult<Bound<'py, PyArray1<bool>>> {
        let rule = inside_rule(nsamples, winding)?;
        let tree = self.held.tree().tree();
        answers(py, &tree, &points, nthreads, false, |t, q, out| {
            tools::occupancy(t, q, rule, out);
        })
    }

    /// The oracle of `closest_points`: every triangle tested
    /// ([`closest_point_brute`]), as `(points, primitive_ids,
    /// primitive_uvs, squared distances)`, for tests.
    fn closest_points_brute<'py>(
        &self,
        py: Python<'py>,
        points: PyReadonlyArray2<'py, f32>,
    ) -> PyResult<ClosestBrute<'py>> {
        let queries = point_slice(&points)?;
        let tris = self.held.tree().tree().triangles();
        let found: Vec<Option<ClosestPoint>> = py.detach(|| {
            queries
                .iter()
                .map(|q| closest_point_brute(tris, *q, f32::INFINITY))
                .collect()
        });
        closest_brute_arrays(py, &found)
    }

    /// The oracle of `cast`: every triangle tested
    /// ([`closest_hit_brute`]), for tests.
    fn cast_brute<'py>(
        &self,
        py: Python<'py>,
        rays: PyReadonlyArray2<'py, f32>,
    ) -> PyResult<CastArrays<'py>> {
        let rays = ray_slice(&rays)?;
        let tris = self.held.tree().tree().triangles();
        let hits: Vec<Hit> =
            py.detach(|| rays.iter().map(|r| closest_hit_brute(tris, r)).collect());
        cast_arrays(py, &hits, 0, |p| unit_normal(tris, p))
    }

    /// The oracle of `occluded` ([`any_hit_brute`]), for tests.
    fn occluded_brute<'py>(
        &self,
        py: Python<'py>,
        rays: PyReadonlyArray2<'py, f32>,
    ) -> PyResult<Bound<'py, PyArray1<bool>>> {
        let rays = ray_slice(&rays)?;
        let tris = self.held.tree().tree().triangles();
        let occluded: Vec<bool> =
            py.detach(|| rays.iter().map(|r| any_hit_brute(tris, r)).collect());
        Ok(PyArray1::from_vec(py, occluded))
    }

    /// The oracle of `hits` ([`first_hits_brute`]), for tests.
    fn hits_brute<'py>(
        &self,
        py: Python<'py>,
        rays: PyReadonlyArray2<'py, f32>,
    ) -> PyResult<HitArrays<'py>> {
        let rays = ray_slice(&rays)?;
        let tris = self.held.tree().tree().triangles();
        let max = tris.len();
        let lists = py.detach(|| {
            hit_lists(rays, max, Hit::MISS, |r, out| {
                first_hits_brute(tris, r, out)
            })
        });
        hit_arrays(py, lists.splits, &lists.hits)
    }
}

/// `(points, primitive_ids, primitive_uvs, distance2)` of
/// `closest_points_brute`.
pub(crate) type ClosestBrute<'py> = (
    Bound<'py, PyAny>,
    Bound<'py, PyArray1<u32>>,
    Bound<'py, PyAny>,
    Bound<'py, PyArray1<f64>>,
);

/// The arrays of [`ClosestBrute`] (a missing point: NaN, [`MISS`], NaN).
pub(crate) fn closest_brute_arrays<'py>(
    py: Python<'py>,
    found: &[Option<ClosestPoint>],
) -> PyResult<ClosestBrute<'py>> {
    let none = [f32::NAN; 3];
    Ok((
        table(
            py,
            found.iter().map(|c| c.map_or(none, |c| c.point)).collect(),
        )?,
        PyArray1::from_vec(
            py,
            found.iter().map(|c| c.map_or(MISS, |c| c.prim)).collect(),
        ),
        table(
            py,
            found
                .iter()
                .map(|c| c.map_or([f32::NAN; 2], |c| [c.u, c.v]))
                .collect(),
        )?,
        PyArray1::from_vec(
            py,
            found
                .iter()
                .map(|c| c.map_or(f64::NAN, |c| c.distance2))
                .collect(),
        ),
    ))
}

/// `(ray_splits, t_hit, primitive_ids, primitive_uvs)` of `hits`.
pub(crate) type HitArrays<'py> = (
    Bound<'py, PyArray1<u64>>,
    Bound<'py, PyArray1<f32>>,
    Bound<'py, PyArray1<u32>>,
    Bound<'py, PyAny>,
);

/// The arrays of a hit list.
fn hit_arrays<'py>(py: Python<'py>, splits: Vec<u64>, hits: &[Hit]) -> PyResult<HitArrays<'py>> {
    let t: Vec<f32> = hits.iter().map(|h| h.t).collect();
    let ids: Vec<u32> = hits.iter().map(|h| h.prim).collect();
    let uvs: Vec<[f32; 2]> = hits.iter().map(|h| [h.u, h.v]).collect();
    Ok((
        PyArray1::from_vec(py, splits),
        PyArray1::from_vec(py, t),
        PyArray1::from_vec(py, ids),
        table(py, uvs)?,
    ))
}
