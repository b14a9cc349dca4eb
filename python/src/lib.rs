//! Python bindings of frameid (`import frameid`): the libraries behind the
//! command line (`records`, `ident`, `sim`, `study`, `reports`) called
//! directly, with numpy arrays in and out.
//!
//! - [`campaign`]: `Campaign` (records of hits) from numpy or from record
//!   files (`read_records`).
//! - [`identification`]: `identify` (what `frameid identify` runs), its
//!   result with modes, error bars, hit quality, warnings and the refinement.
//! - [`simulation`]: `simulate` (a campaign with its truth) and `bound`
//!   (the Cramér–Rao bound of a scenario).
//! - [`sweeps`]: `sweep`, `merge` of shards and `report`.
//! - [`frf`]: the FRF route: `frf` (FRFs of a campaign), `read_frf`,
//!   `FrfSet` (from arrays) and `identify_frf`.
//!
//! Errors raise `frameid.Error` (a `ValueError`) with the message the
//! command line prints; a panic in the libraries (a bug) is caught and
//! raised as `frameid.Error` too, never unwinds into Python. The long
//! computations run with the interpreter released (`Python::detach`).
//! Every class pickles through `__reduce__` with its Rust state in
//! MessagePack (lossless: NaN and infinities survive, unlike JSON).

use std::panic::{AssertUnwindSafe, catch_unwind};

use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyBytes;

mod arrays;
mod campaign;
mod frf;
mod identification;
mod simulation;
mod sweeps;

pyo3::create_exception!(
    frameid,
    Error,
    PyValueError,
    "A frameid error: bad input (shapes, non-finite samples, files, channel names, settings) or a failed identification. The message is the one the command line prints."
);

/// `frameid.Error` with `message`.
pub(crate) fn error(message: impl Into<String>) -> PyErr {
    Error::new_err(message.into())
}

/// An error and its sources joined by ": ", as the command line prints
/// them (anyhow's `{:#}`).
pub(crate) fn chain(e: &(dyn std::error::Error + 'static)) -> String {
    let mut text = e.to_string();
    let mut source = e.source();
    while let Some(s) = source {
        text.push_str(": ");
        text.push_str(&s.to_string());
        source = s.source();
    }
    text
}

/// `frameid.Error` from a library error.
pub(crate) fn lib_error(e: impl std::error::Error + 'static) -> PyErr {
    error(chain(&e))
}

/// `frameid.Error` from a library error with the context the command line
/// adds (`context: error`).
pub(crate) fn lib_error_in(context: &str, e: impl std::error::Error + 'static) -> PyErr {
    error(format!("{context}: {}", chain(&e)))
}

/// Runs library code, turning a panic (a bug in frameid, never expected
/// on any input) into `frameid.Error` instead of unwinding into Python.
pub(crate) fn guard<T>(f: impl FnOnce() -> PyResult<T>) -> PyResult<T> {
    catch_unwind(AssertUnwindSafe(f)).unwrap_or_else(|panic| {
        let what = panic
            .downcast_ref::<String>()
            .cloned()
            .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
            .unwrap_or_default();
        Err(error(format!(
            "internal error (a bug in frameid, please report it): {what}"
        )))
    })
}

/// Serializes a class's state for pickling (MessagePack with field names).
pub(crate) fn to_state<T: serde::Serialize>(py: Python<'_>, value: &T) -> PyResult<Py<PyBytes>> {
    let bytes = rmp_serde::to_vec_named(value).map_err(|e| error(format!("cannot pickle: {e}")))?;
    Ok(PyBytes::new(py, &bytes).unbind())
}

/// Restores a class's state from [`to_state`].
pub(crate) fn from_state<T: serde::de::DeserializeOwned>(bytes: &[u8]) -> PyResult<T> {
    rmp_serde::from_slice(bytes).map_err(|e| error(format!("cannot unpickle: {e}")))
}

/// What `__reduce__` returns: `(callable, (class name, state))`.
pub(crate) type Reduced<'py> = PyResult<(Bound<'py, PyAny>, (String, Py<PyBytes>))>;

/// The `(callable, args)` pair of `__reduce__`: `frameid._native._restore`
/// called with the class name and its state.
pub(crate) fn reduce<'py>(py: Python<'py>, class: &str, state: Py<PyBytes>) -> Reduced<'py> {
    let restore = py.import("frameid._native")?.getattr("_restore")?;
    Ok((restore, (class.to_string(), state)))
}

/// Rebuilds a pickled object (see the classes' `__reduce__`).
#[pyfunction]
fn _restore(py: Python<'_>, class: &str, state: &[u8]) -> PyResult<Py<PyAny>> {
    use campaign::Campaign;
    use identification::{Identification, Mode, Refined, RefinedMode, Uncertainty};
    use simulation::{CramerRao, Truth};
    use sweeps::Sweep;
    let obj: Py<PyAny> = match class {
        "Campaign" => Py::new(py, Campaign::from_state(state)?)?.into_any(),
        "Identification" => Py::new(py, Identification::from_state(state)?)?.into_any(),
        "Mode" => Py::new(py, Mode::from_state(state)?)?.into_any(),
        "Uncertainty" => Py::new(py, Uncertainty::from_state(state)?)?.into_any(),
        "Refined" => Py::new(py, Refined::from_state(state)?)?.into_any(),
        "RefinedMode" => Py::new(py, RefinedMode::from_state(state)?)?.into_any(),
        "Truth" => Py::new(py, Truth::from_state(state)?)?.into_any(),
        "Bound" => Py::new(py, CramerRao::from_state(state)?)?.into_any(),
        "Sweep" => Py::new(py, Sweep::from_state(state)?)?.into_any(),
        "FrfSet" => Py::new(py, frf::FrfSet::from_state(state)?)?.into_any(),
        "FrfResult" => frf::FrfResult::restore(py, state)?.into_any(),
        "FrfIdentification" => Py::new(py, frf::FrfIdentification::from_state(state)?)?.into_any(),
        "FrfRefined" => Py::new(py, frf::FrfRefined::from_state(state)?)?.into_any(),
        "FrfUncertainty" => Py::new(py, frf::FrfUncertainty::from_state(state)?)?.into_any(),
        other => return Err(error(format!("cannot unpickle: unknown class {other}"))),
    };
    Ok(obj)
}

/// Turns on or off the second thread kept awake while a call runs
/// (`ident::parallel::set_keep_awake`; on by default).
#[pyfunction]
fn set_keep_awake(on: bool) {
    ident::parallel::set_keep_awake(on);
}

/// Whether a second thread is kept awake while a call runs.
#[pyfunction]
fn keep_awake() -> bool {
    ident::parallel::keep_awake()
}

/// The native part of the `frameid` package.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    // A build for vector instructions this CPU lacks would stop the interpreter on an illegal
    // instruction later (ident::cpu): refuse to import instead.
    if let Some(message) = ident::cpu::unsupported_message() {
        return Err(pyo3::exceptions::PyImportError::new_err(message));
    }
    let py = m.py();
    m.add("Error", py.get_type::<Error>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_function(wrap_pyfunction!(_restore, m)?)?;
    m.add_function(wrap_pyfunction!(set_keep_awake, m)?)?;
    m.add_function(wrap_pyfunction!(keep_awake, m)?)?;
    campaign::register(m)?;
    frf::register(m)?;
    identification::register(m)?;
    simulation::register(m)?;
    sweeps::register(m)?;
    Ok(())
}
