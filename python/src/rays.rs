//! Ray batches in and hit arrays out: the layouts the Python package and
//! the kernel share.
//!
//! The Python layer hands rays over as a C-contiguous `(N, 8)` `float32`
//! array in the kernel's [`Ray`] layout (origin, `tnear`, direction,
//! `tfar`), which is read in place; hits come back as the Open3D-named
//! arrays, each allocated once.

use crate::arrays::{rows, table};
use crate::pools;
use kdray_kernel::{Hit, Ray, Triangle};
use numpy::{PyArray1, PyReadonlyArray2};
use pyo3::prelude::*;
use rayon::prelude::*;

/// Batches of at most this many rays are traced on the calling thread:
/// handing them to the pool costs more than it saves.
pub(crate) const SERIAL_MAX: usize = 1024;

/// The rays of a `(N, 8)` C-contiguous `float32` array, in place.
pub(crate) fn ray_slice<'a>(rays: &'a PyReadonlyArray2<'_, f32>) -> PyResult<&'a [Ray]> {
    rows(rays, "rays", "(N, 8) in the kernel's layout")
}

/// The arrays of `cast_rays`: `t_hit`, `primitive_ids`, `primitive_uvs`
/// (`(N, 2)`) and `primitive_normals` (`(N, 3)`, unit length; zero for a
/// miss), from closest-hit records over `triangles`.
pub(crate) type CastArrays<'py> = (
    Bound<'py, PyArray1<f32>>,
    Bound<'py, PyArray1<u32>>,
    Bound<'py, PyAny>,
    Bound<'py, PyAny>,
);

/// `f` of every item: on the calling thread for a batch of at most
/// [`SERIAL_MAX`], else on `nthreads` threads (0: all cores).
pub(crate) fn map_all<T: Sync, R: Send>(
    items: &[T],
    nthreads: usize,
    f: impl Fn(&T) -> R + Sync + Send,
) -> PyResult<Vec<R>> {
    if items.len() <= SERIAL_MAX {
        return Ok(items.iter().map(f).collect());
    }
    pools::install(nthreads, || {
        items.par_iter().with_min_len(SERIAL_MAX).map(f).collect()
    })
}

/// Splits closest-hit records into the arrays of `cast_rays` on `nthreads`
/// threads, the normal of each hit read from `normal_of(prim)`.
pub(crate) fn cast_arrays<'py>(
    py: Python<'py>,
    hits: &[Hit],
    nthreads: usize,
    normal_of: impl Fn(u32) -> [f32; 3] + Sync + Send,
) -> PyResult<CastArrays<'py>> {
    let (t, ids, uvs, normals) = py.detach(|| {
        let t = map_all(hits, nthreads, |h| h.t)?;
        let ids = map_all(hits, nthreads, |h| h.prim)?;
        let uvs = map_all(hits, nthreads, |h| [h.u, h.v])?;
        let normals = map_all(hits, nthreads, |h| {
            if h.is_hit() {
                normal_of(h.prim)
            } else {
                [0.0; 3]
            }
        })?;
        Ok::<_, PyErr>((t, ids, uvs, normals))
    })?;
    Ok((
        PyArray1::from_vec(py, t),
        PyArray1::from_vec(py, ids),
        table(py, uvs)?,
        table(py, normals)?,
    ))
}

/// The unit geometric normal `(v1 - v0) × (v2 - v0)` of `triangles[prim]`
/// (Open3D's `primitive_normals`); zero for a degenerate triangle or an
/// index past the end.
pub(crate) fn unit_normal(triangles: &[Triangle], prim: u32) -> [f32; 3] {
    let Some(tri) = triangles.get(prim as usize) else {
        return [0.0; 3];
    };
    let n = tri.normal();
    let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    if len > 0.0 && len.is_finite() {
        n.map(|c| c / len)
    } else {
        [0.0; 3]
    }
}

/// Every hit of every ray, in Open3D's CSR form: per ray its hits by `t`
/// then triangle index (each triangle once), from `all_hits(ray, out)`,
/// which writes up to `out.len()` of them and returns how many.
pub(crate) struct HitLists<R> {
    /// Where each ray's hits start; `N + 1` entries.
    pub(crate) splits: Vec<u64>,
    /// Every hit, ray by ray.
    pub(crate) hits: Vec<R>,
}

/// Rays per task of [`hit_lists`].
const LIST_CHUNK: usize = 256;

/// The first slots a ray's hits get; doubled for a ray that fills them.
const FIRST_SLOTS: usize = 16;

/// Every hit of each ray ([`HitLists`]) on the current rayon pool, by a
/// first-hits query (`first(ray, out) -> written`) into a buffer that
/// doubles until a ray's hits no longer fill it (or reach `max_hits`, the
/// triangle count, past which none can be left).
pub(crate) fn hit_lists<R: Copy + Send + Sync>(
    rays: &[Ray],
    max_hits: usize,
    miss: R,
    first: impl Fn(&Ray, &mut [R]) -> usize + Sync,
) -> HitLists<R> {
    let parts: Vec<(Vec<u64>, Vec<R>)> = rays
        .par_chunks(LIST_CHUNK)
        .map(|chunk| {
            let mut counts = Vec::with_capacity(chunk.len());
            let mut hits = Vec::new();
            let mut buf = vec![miss; FIRST_SLOTS.min(max_hits.max(1))];
            for ray in chunk {
                let n = loop {
                    let n = first(ray, &mut buf);
                    if n < buf.len() || buf.len() >= max_hits {
                        break n;
                    }
                    buf.resize((buf.len() * 2).min(max_hits), miss);
                };
                counts.push(n as u64);
                hits.extend_from_slice(&buf[..n]);
            }
            (counts, hits)
        })
        .collect();
    let mut splits = Vec::with_capacity(rays.len() + 1);
    splits.push(0u64);
    let total: usize = parts.iter().map(|(_, h)| h.len()).sum();
    let mut hits = Vec::with_capacity(total);
    for (counts, h) in parts {
        for c in counts {
            let last = splits.last().copied().unwrap_or(0);
            splits.push(last + c);
        }
        hits.extend_from_slice(&h);
    }
    HitLists { splits, hits }
}
