//! numpy arrays in and out: C-contiguous `float32` rows read in place as
//! the kernel's records (rays, query points), and per-item results handed
//! back as `(N, K)` arrays allocated once.

use numpy::{Element, PyArray1, PyArrayMethods, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// The rows of a C-contiguous `(N, W)` `float32` array read in place as
/// records `T` of `W` floats each (`shape`: how the error message names
/// the expected shape, e.g. `"(N, 3)"`). `name` is the argument the errors
/// name.
pub(crate) fn rows<'a, T: bytemuck::Pod>(
    array: &'a PyReadonlyArray2<'_, f32>,
    name: &str,
    shape: &str,
) -> PyResult<&'a [T]> {
    let width = std::mem::size_of::<T>() / std::mem::size_of::<f32>();
    let got = array.shape();
    if got[1] != width {
        return Err(PyValueError::new_err(format!(
            "{name}: expected shape {shape}, got {got:?}"
        )));
    }
    let floats = array
        .as_slice()
        .map_err(|_| PyValueError::new_err(format!("{name}: expected a C-contiguous array")))?;
    bytemuck::try_cast_slice(floats)
        .map_err(|e| PyValueError::new_err(format!("{name}: not in the {shape} layout: {e}")))
}

/// `items` as an `(N, K)` array (one allocation: the vector's own).
pub(crate) fn table<'py, T: Element, const K: usize>(
    py: Python<'py>,
    items: Vec<[T; K]>,
) -> PyResult<Bound<'py, PyAny>> {
    let n = items.len();
    Ok(PyArray1::from_vec(py, items.into_flattened())
        .reshape([n, K])?
        .into_any())
}
