//! numpy in and out: anything array-like into `f64` arrays (with messages
//! naming the argument), and matrices, vectors and complex shapes out.

use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;
use numpy::ndarray::{Array1, Array2, ArrayD};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArrayDyn, PyArrayMethods};
use pyo3::prelude::*;

use crate::error;

/// `obj` as an owned `f64` array (through `numpy.asarray(obj, dtype=float)`);
/// `what` names the argument in messages.
pub fn f64_array(py: Python<'_>, obj: &Bound<'_, PyAny>, what: &str) -> PyResult<ArrayD<f64>> {
    let np = py.import("numpy")?;
    let converted = np
        .call_method1("asarray", (obj, np.getattr("float64")?))
        .map_err(|e| error(format!("{what}: not an array of numbers ({e})")))?;
    let array = converted
        .cast_into::<PyArrayDyn<f64>>()
        .map_err(|e| error(format!("{what}: not an array of numbers ({e})")))?;
    Ok(array.readonly().as_array().to_owned())
}

/// A matrix as a 2-D array.
pub fn matrix<'py>(py: Python<'py>, m: &DMatrix<f64>) -> Bound<'py, PyArray2<f64>> {
    Array2::from_shape_fn((m.nrows(), m.ncols()), |(i, j)| m[(i, j)]).into_pyarray(py)
}

/// An array of rows (all of one length) as a 2-D array.
pub fn rows<'py>(py: Python<'py>, rows: &[Vec<f64>]) -> Bound<'py, PyArray2<f64>> {
    let cols = rows.first().map_or(0, Vec::len);
    Array2::from_shape_fn((rows.len(), cols), |(i, j)| rows[i][j]).into_pyarray(py)
}

/// A vector as a 1-D array.
pub fn vector<'py>(py: Python<'py>, v: &[f64]) -> Bound<'py, PyArray1<f64>> {
    Array1::from(v.to_vec()).into_pyarray(py)
}

/// A nalgebra vector as a 1-D array.
pub fn dvector<'py>(py: Python<'py>, v: &DVector<f64>) -> Bound<'py, PyArray1<f64>> {
    vector(py, v.as_slice())
}

/// A complex vector as a 1-D complex array.
pub fn complex<'py>(py: Python<'py>, v: &[Complex64]) -> Bound<'py, PyArray1<Complex64>> {
    Array1::from(v.to_vec()).into_pyarray(py)
}

/// A complex matrix as a 2-D complex array.
pub fn complex_matrix<'py>(
    py: Python<'py>,
    m: &DMatrix<Complex64>,
) -> Bound<'py, PyArray2<Complex64>> {
    Array2::from_shape_fn((m.nrows(), m.ncols()), |(i, j)| m[(i, j)]).into_pyarray(py)
}

/// A JSON document as Python objects (`json.loads`): dicts, lists, numbers,
/// strings and `None` (for JSON's `null`, which is also how the command
/// line writes a NaN).
pub fn json<'py>(py: Python<'py>, text: &str) -> PyResult<Bound<'py, PyAny>> {
    py.import("json")?.call_method1("loads", (text,))
}

/// A serializable value as Python objects, through its JSON form (the
/// command line's `--json` fields).
pub fn to_python<'py, T: serde::Serialize>(
    py: Python<'py>,
    value: &T,
) -> PyResult<Bound<'py, PyAny>> {
    let text = serde_json::to_string(value).map_err(|e| error(format!("cannot convert: {e}")))?;
    json(py, &text)
}

/// `obj` as an owned complex array (through
/// `numpy.asarray(obj, dtype=complex)`); `what` names the argument in
/// messages.
pub fn c128_array(
    py: Python<'_>,
    obj: &Bound<'_, PyAny>,
    what: &str,
) -> PyResult<ArrayD<Complex64>> {
    let np = py.import("numpy")?;
    let converted = np
        .call_method1("asarray", (obj, np.getattr("complex128")?))
        .map_err(|e| error(format!("{what}: not an array of (complex) numbers ({e})")))?;
    let array = converted
        .cast_into::<PyArrayDyn<Complex64>>()
        .map_err(|e| error(format!("{what}: not an array of (complex) numbers ({e})")))?;
    Ok(array.readonly().as_array().to_owned())
}
