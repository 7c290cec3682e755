//! `Scene`: a scene blob of instanced meshes (`kdray build --instances`)
//! and its ray and distance queries, each answer naming its instance
//! (`geometry_ids`).

use crate::arrays::table;
use crate::distance::point_slice;
use crate::held::{Held, HeldScene};
use crate::pools;
use crate::rays::{hit_lists, map_all, ray_slice, unit_normal};
use crate::triangles::closest_brute_arrays;
use kdray_kernel::{Instance, Scene as KernelScene, SceneClosestPoint, SceneHit, Triangle, MISS};
use kdray_tools::distance::{scene_distance_records, SceneDistanceRecord};
use kdray_tools::instances::transform_point;
use numpy::{PyArray1, PyReadonlyArray2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use std::path::PathBuf;

/// Every instance: the mask that selects all.
const ALL: u32 = u32::MAX;

/// A scene of instanced meshes (compiled layer of `kdray.Scene`).
#[pyclass(frozen, module = "kdray._kdray")]
pub(crate) struct Scene {
    held: HeldScene,
}

/// `(t_hit, geometry_ids, primitive_ids, primitive_uvs, primitive_normals)`.
type SceneCast<'py> = (
    Bound<'py, PyArray1<f32>>,
    Bound<'py, PyArray1<u32>>,
    Bound<'py, PyArray1<u32>>,
    Bound<'py, PyAny>,
    Bound<'py, PyAny>,
);

/// `(ray_splits, t_hit, geometry_ids, primitive_ids, primitive_uvs)`.
type SceneHits<'py> = (
    Bound<'py, PyArray1<u64>>,
    Bound<'py, PyArray1<f32>>,
    Bound<'py, PyArray1<u32>>,
    Bound<'py, PyArray1<u32>>,
    Bound<'py, PyAny>,
);

/// `(points, geometry_ids, primitive_ids, primitive_uvs,
/// primitive_normals)` of `compute_closest_points` on a scene.
type SceneClosest<'py> = (
    Bound<'py, PyAny>,
    Bound<'py, PyArray1<u32>>,
    Bound<'py, PyArray1<u32>>,
    Bound<'py, PyAny>,
    Bound<'py, PyAny>,
);

/// `(points, geometry_ids, primitive_ids, primitive_uvs, squared
/// distances)` of the brute force, for tests.
type SceneClosestBrute<'py> = (
    Bound<'py, PyAny>,
    Bound<'py, PyArray1<u32>>,
    Bound<'py, PyArray1<u32>>,
    Bound<'py, PyAny>,
    Bound<'py, PyArray1<f64>>,
);

/// The scene `.dist` records of `queries` on the `nthreads` pool, the GIL
/// released; a scene whose instances are not all similarities is refused
/// by a `ValueError` naming the first (the kernel's message).
fn records(
    py: Python<'_>,
    scene: &KernelScene<'_>,
    queries: &[[f32; 3]],
    nthreads: usize,
) -> PyResult<Vec<SceneDistanceRecord>> {
    py.detach(|| {
        let mut out = vec![SceneDistanceRecord::new(None, true); queries.len()];
        pools::install_sized(queries.len(), nthreads, || {
            scene_distance_records(scene, queries, ALL, f32::INFINITY, &mut out)
        })?
        .map_err(|e| PyValueError::new_err(format!("scene distance: {e}")))?;
        Ok(out)
    })
}

/// The unit normal, in world space, of triangle `prim` of `instance`.
fn world_normal(scene: &KernelScene<'_>, instance: u32, prim: u32) -> [f32; 3] {
    let Some(inst) = scene.instances().get(instance as usize) else {
        return [0.0; 3];
    };
    let Some(tri) = scene
        .mesh(inst.mesh())
        .and_then(|t| t.triangles().get(prim as usize).copied())
    else {
        return [0.0; 3];
    };
    let m = inst.to_world();
    let world = Triangle {
        v: tri.v.map(|p| transform_point(&m, p)),
    };
    unit_normal(&[world], 0)
}

/// The arrays of `cast_rays` from scene hits.
fn cast_arrays<'py>(
    py: Python<'py>,
    scene: &KernelScene<'_>,
    hits: &[SceneHit],
    nthreads: usize,
) -> PyResult<SceneCast<'py>> {
    let geometry: Vec<u32> = hits
        .iter()
        .map(|h| if h.is_hit() { h.instance } else { MISS })
        .collect();
    let normals = py.detach(|| {
        map_all(hits, nthreads, |h| {
            if h.is_hit() {
                world_normal(scene, h.instance, h.prim)
            } else {
                [0.0; 3]
            }
        })
    })?;
    let uvs: Vec<[f32; 2]> = hits.iter().map(|h| [h.u, h.v]).collect();
    Ok((
        PyArray1::from_vec(py, hits.iter().map(|h| h.t).collect()),
        PyArray1::from_vec(py, geometry),
        PyArray1::from_vec(py, hits.iter().map(|h| h.prim).collect()),
        table(py, uvs)?,
        table(py, normals)?,
    ))
}

/// The arrays of `list_intersections` from scene hit lists.
fn hit_arrays<'py>(
    py: Python<'py>,
    splits: Vec<u64>,
    hits: &[SceneHit],
) -> PyResult<SceneHits<'py>> {
    let uvs: Vec<[f32; 2]> = hits.iter().map(|h| [h.u, h.v]).collect();
    Ok((
        PyArray1::from_vec(py, splits),
        PyArray1::from_vec(py, hits.iter().map(|h| h.t).collect()),
        PyArray1::from_vec(py, hits.iter().map(|h| h.instance).collect()),
        PyArray1::from_vec(py, hits.iter().map(|h| h.prim).collect()),
        table(py, uvs)?,
    ))
}

/// The most hits a ray can have in `scene`: every instance's triangles.
fn max_hits(scene: &KernelScene<'_>) -> usize {
    scene
        .instances()
        .iter()
        .map(|i: &Instance| scene.mesh(i.mesh()).map_or(0, |t| t.triangles().len()))
        .sum()
}

#[pymethods]
impl Scene {
    /// Validates a scene blob held by `buffer` (borrowed when read-only,
    /// C-contiguous, 64-byte aligned and `copy` is false; copied otherwise).
    #[staticmethod]
    fn from_buffer(buffer: &Bound<'_, PyAny>, copy: bool) -> PyResult<Scene> {
        let held = HeldScene::from_buffer(buffer, copy)?;
        Ok(Scene { held })
    }

    /// Reads and validates a scene blob file.
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Scene> {
        let held = HeldScene::load(py, &path)?;
        Ok(Scene { held })
    }

    /// The blob, as a `bytes` object.
    fn to_bytes<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        self.held.bytes().to_pybytes(py)
    }

    /// Writes the blob to `path` (the tools' atomic writer).
    fn save(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        self.held.bytes().save(py, &path)
    }

    /// How many instances.
    #[getter]
    fn instance_count(&self) -> usize {
        self.held.scene().instances().len()
    }

    /// How many meshes.
    #[getter]
    fn mesh_count(&self) -> u32 {
        self.held.scene().mesh_count()
    }

    /// The closest hit of each ray through every instance.
    fn cast<'py>(
        &self,
        py: Python<'py>,
        rays: PyReadonlyArray2<'py, f32>,
        nthreads: usize,
    ) -> PyResult<SceneCast<'py>> {
        let rays = ray_slice(&rays)?;
        let scene = self.held.scene();
        let hits = py.detach(|| map_all(rays, nthreads, |r| scene.closest_hit(r, ALL)))?;
        cast_arrays(py, scene, &hits, nthreads)
    }

    /// Whether each ray hits any instance in its `[tnear, tfar]`.
    fn occluded<'py>(
        &self,
        py: Python<'py>,
        rays: PyReadonlyArray2<'py, f32>,
        nthreads: usize,
    ) -> PyResult<Bound<'py, PyArray1<bool>>> {
        let rays = ray_slice(&rays)?;
        let scene = self.held.scene();
        let hits = py.detach(|| map_all(rays, nthreads, |r| scene.any_hit(r, ALL)))?;
        Ok(PyArray1::from_vec(py, hits))
    }

    /// Every hit of each ray by `t`, then instance, then triangle.
    fn hits<'py>(
        &self,
        py: Python<'py>,
        rays: PyReadonlyArray2<'py, f32>,
        nthreads: usize,
    ) -> PyResult<SceneHits<'py>> {
        let rays = ray_slice(&rays)?;
        let scene = self.held.scene();
        let max = max_hits(scene);
        let lists = py.detach(|| {
            pools::install(nthreads, || {
                hit_lists(rays, max, SceneHit::MISS, |r, out| {
                    scene.first_hits(r, ALL, out)
                })
            })
        })?;
        hit_arrays(py, lists.splits, &lists.hits)
    }

    /// The closest point of each query over every instance:
    /// `(points, geometry_ids, primitive_ids, primitive_uvs,
    /// primitive_normals)`, world space.
    fn closest_points<'py>(
        &self,
        py: Python<'py>,
        points: PyReadonlyArray2<'py, f32>,
        nthreads: usize,
    ) -> PyResult<SceneClosest<'py>> {
        let queries = point_slice(&points)?;
        let scene = self.held.scene();
        let recs = records(py, scene, queries, nthreads)?;
        let normals = py.detach(|| {
            map_all(&recs, nthreads, |r| {
                if r.instance == MISS {
                    [0.0; 3]
                } else {
                    world_normal(scene, r.instance, r.record.prim)
                }
            })
        })?;
        Ok((
            table(py, recs.iter().map(|r| r.record.point).collect())?,
            PyArray1::from_vec(py, recs.iter().map(|r| r.instance).collect()),
            PyArray1::from_vec(py, recs.iter().map(|r| r.record.prim).collect()),
            table(py, recs.iter().map(|r| [r.record.u, r.record.v]).collect())?,
            table(py, normals)?,
        ))
    }

    /// The distance of each query to the nearest instance (NaN for a
    /// query with a NaN or infinite coordinate).
    fn distances<'py>(
        &self,
        py: Python<'py>,
        points: PyReadonlyArray2<'py, f32>,
        nthreads: usize,
    ) -> PyResult<Bound<'py, PyArray1<f32>>> {
        let queries = point_slice(&points)?;
        let recs = records(py, self.held.scene(), queries, nthreads)?;
        Ok(PyArray1::from_vec(
            py,
            recs.iter().map(|r| r.record.distance).collect(),
        ))
    }

    /// The oracle of `closest_points` (`Scene::closest_point_brute`: every
    /// instance's every triangle), with the squared distances, for tests.
    fn closest_points_brute<'py>(
        &self,
        py: Python<'py>,
        points: PyReadonlyArray2<'py, f32>,
    ) -> PyResult<SceneClosestBrute<'py>> {
        let queries = point_slice(&points)?;
        let scene = self.held.scene();
        let found: Vec<Option<SceneClosestPoint>> = py
            .detach(|| {
                queries
                    .iter()
                    .map(|q| scene.closest_point_brute(*q, ALL))
                    .collect::<Result<_, _>>()
            })
            .map_err(|e| PyValueError::new_err(format!("scene distance: {e}")))?;
        let mesh: Vec<_> = found.iter().map(|c| c.map(|c| c.point_only())).collect();
        let (points, primitive_ids, primitive_uvs, distance2) = closest_brute_arrays(py, &mesh)?;
        let geometry_ids = found.iter().map(|c| c.map_or(MISS, |c| c.instance));
        Ok((
            points,
            PyArray1::from_vec(py, geometry_ids.collect()),
            primitive_ids,
            primitive_uvs,
            distance2,
        ))
    }

    /// The oracle of `cast` (every instance's every triangle), for tests.
    fn cast_brute<'py>(
        &self,
        py: Python<'py>,
        rays: PyReadonlyArray2<'py, f32>,
    ) -> PyResult<SceneCast<'py>> {
        let rays = ray_slice(&rays)?;
        let scene = self.held.scene();
        let hits: Vec<SceneHit> = py.detach(|| {
            rays.iter()
                .map(|r| scene.closest_hit_brute(r, ALL))
                .collect()
        });
        cast_arrays(py, scene, &hits, 0)
    }

    /// The oracle of `occluded`, for tests.
    fn occluded_brute<'py>(
        &self,
        py: Python<'py>,
        rays: PyReadonlyArray2<'py, f32>,
    ) -> PyResult<Bound<'py, PyArray1<bool>>> {
        let rays = ray_slice(&rays)?;
        let scene = self.held.scene();
        let hits: Vec<bool> =
            py.detach(|| rays.iter().map(|r| scene.any_hit_brute(r, ALL)).collect());
        Ok(PyArray1::from_vec(py, hits))
    }
}
