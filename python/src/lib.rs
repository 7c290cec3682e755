//! `kdray._kdray`: the compiled layer of kdray's Python package.
//!
//! A thin layer: it takes numpy arrays already shaped and typed by the
//! Python package (`kdray/__init__.py`, which owns the public API, its
//! argument checks and scipy's and Open3D's conventions), releases the GIL,
//! and runs the tools' batch paths on all cores.
//!
//! - [`triangles`]: `TriangleTree` (build, load, blobs, ray and distance
//!   queries);
//! - [`distance`]: the distance queries' arguments and result arrays;
//! - [`arrays`]: numpy rows read in place as the kernel's records, and
//!   results handed back shaped;
//! - [`scene`]: `Scene` (scene blobs of instanced meshes);
//! - [`points`]: `PointTree` (build, load, k nearest and within-radius
//!   queries for D = 1..16, `f32` or `f64`);
//! - [`held`]: the blob bytes a tree reads, owned or borrowed from a
//!   Python buffer;
//! - [`pools`]: the rayon pools behind `nthreads` / `workers`.

use pyo3::prelude::*;

mod arrays;
mod distance;
mod held;
mod points;
mod pools;
mod rays;
mod scene;
mod triangles;

pyo3::create_exception!(
    _kdray,
    BlobError,
    pyo3::exceptions::PyValueError,
    "A tree or scene blob that does not validate (ValueError)."
);

/// The extension module.
#[pymodule]
fn _kdray(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<triangles::TriangleTree>()?;
    m.add_class::<scene::Scene>()?;
    m.add_class::<points::PointTree>()?;
    m.add("BlobError", m.py().get_type::<BlobError>())?;
    m.add("MAX_COORD", kdray_kernel::MAX_COORD)?;
    m.add("MAX_DIM", points::MAX_DIM)?;
    Ok(())
}
