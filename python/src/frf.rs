//! The FRF route: `frameid.frf` (what `frameid frf` computes: screened FRF
//! estimation from a campaign), `frameid.read_frf` (FRF files, UFF58 or
//! CSV, collated as `frameid identify` collates them), `frameid.FrfSet`
//! (FRFs from numpy arrays) and `frameid.identify_frf` (what
//! `frameid identify` runs on FRF files: checks, pLSCF, LSFD, MKR,
//! Rayleigh and the optional maximum-likelihood refinement).

use std::path::PathBuf;

use ident::frf::estimate::{Estimator, ExponentialWindow, ForceWindow};
use ident::frf::refine::FrfRefinement;
use ident::frf::{FrfIdentifier, FrfOrder, ModeSelection, Weighting};
use ident::{Frf, FrfQuantity};
use nalgebra::DMatrix;
use num_complex::Complex64;
use numpy::ndarray::{Array1, Array3};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArray3};
use pyo3::prelude::*;
use pyo3::pyclass_init::PyClassInitializer;
use pyo3::types::PyDict;
use records::consistency::{ByLine, ByPosition};
use records::frf::{AssembleOptions, FrfFile, FrfFormat, FrfPoint, FrfReadOptions};
use serde::{Deserialize, Serialize};
use study::analysis::{AnalysisSettings, Screening};
use study::frf_analysis::{FrfAnalysisSettings, analyze_frfs};
use study::frfs::{AveragingChoice, FrfSettings, estimate_frfs};
use study::scenario::ParametrizationSetting;

use crate::arrays::{self, c128_array, f64_array, matrix, vector};
use crate::campaign::Campaign;
use crate::identification::{Mode, RefinedMode, json_text, resolve_collocated};
use crate::{Reduced, error, from_state, guard, lib_error, lib_error_in, reduce, to_state};

/// A measurement point (a serializable `records::frf::FrfPoint`).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct PointState {
    name: String,
    node: Option<i64>,
    direction: Option<i32>,
}

impl PointState {
    fn of(p: &FrfPoint) -> Self {
        PointState {
            name: p.name.clone(),
            node: p.node,
            direction: p.direction,
        }
    }

    fn point(&self) -> FrfPoint {
        FrfPoint {
            name: self.name.clone(),
            node: self.node,
            direction: self.direction,
        }
    }

    /// `{"name", "node", "direction"}` (``None`` where unknown).
    fn dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        d.set_item("name", &self.name)?;
        d.set_item("node", self.node)?;
        d.set_item("direction", self.direction)?;
        Ok(d)
    }

    /// `name@node:direction` or `name`.
    fn text(&self) -> String {
        match (self.node, self.direction) {
            (Some(n), Some(d)) => format!("{}@{n}:{}", self.name, records::direction_label(d)),
            _ => self.name.clone(),
        }
    }
}

/// FRFs on one grid with their points (what `records::frf::assemble`
/// returns, serializable).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SetState {
    frf: Frf,
    responses: Vec<PointState>,
    references: Vec<PointState>,
    /// Collocated (output, reference) pairs, ordered by reference.
    collocated: Vec<(usize, usize)>,
    exponential_tau_s: Option<f64>,
    /// The files read (empty for FRFs from arrays or estimated).
    files: Vec<String>,
}

impl SetState {
    fn of(set: records::frf::FrfSet, files: Vec<String>) -> Self {
        SetState {
            responses: set.responses.iter().map(PointState::of).collect(),
            references: set.references.iter().map(PointState::of).collect(),
            collocated: set.collocated.iter().map(|c| (c.output, c.input)).collect(),
            exponential_tau_s: set.exponential_tau_s,
            frf: set.frf,
            files,
        }
    }

    /// The FRFs as the pairs of one file, the window stated on each.
    fn file(&self, path: &std::path::Path) -> FrfFile {
        let responses: Vec<FrfPoint> = self.responses.iter().map(PointState::point).collect();
        let references: Vec<FrfPoint> = self.references.iter().map(PointState::point).collect();
        let mut file = FrfFile::from_frf(path, &self.frf, &responses, &references);
        for pair in &mut file.pairs {
            pair.exponential_tau_s = self.exponential_tau_s;
        }
        file
    }
}

/// What `frameid frf` reports besides the FRFs (`frf.json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EstimateState {
    estimator: String,
    excitation: String,
    hits_used: usize,
    /// Labels (files) of the hits left out.
    dropped: Vec<String>,
    block_len: usize,
    resolution_hz: f64,
    model_checks: bool,
    /// `ident::frf::estimate::AppliedWindows` as JSON.
    windows_json: String,
    /// `Vec<records::quality::HitQuality>` as JSON (serializes only).
    hit_quality_json: String,
    warnings: Vec<String>,
}

/// FRFs: ``values[k, i, j]`` is response (output) ``i`` over reference
/// (force) ``j`` at ``frequency_hz[k]``, in the SI unit of ``quantity``
/// (``accelerance`` (m/s²)/N, ``mobility`` (m/s)/N, ``receptance`` m/N),
/// time convention ``e^{+iωt}``.
///
/// ``FrfSet(frequency_hz, values, *, quantity="accelerance",
/// coherence=None, averages=None, responses=None, references=None,
/// collocated=None, exponential_tau_s=None)`` builds one from arrays:
/// ``frequency_hz`` of shape ``(n,)`` (ascending, non-negative),
/// ``values`` complex ``(n, outputs, references)``, ``coherence`` real of
/// the same shape in [0, 1]. ``responses`` and ``references`` name the
/// points, ``"name"`` or ``"name@node:direction"`` (``"acc2@2:+X"``) or
/// ``(name, node, direction)``; defaults ``acc1, acc2, ...`` and
/// ``force1, ...`` without nodes. Collocated pairs are detected from
/// the nodes and directions, or given as ``collocated=[(output,
/// reference), ...]`` (zero-based indices or names).
/// ``exponential_tau_s``: the time constant of an exponential window the
/// FRFs were estimated with (identification removes its damping).
///
/// ``read_frf`` reads one from files, ``frf`` estimates one from a
/// campaign (a ``FrfResult``, which is a ``FrfSet``).
#[pyclass(module = "frameid", frozen, subclass)]
pub struct FrfSet {
    state: SetState,
}

impl FrfSet {
    pub fn from_state(bytes: &[u8]) -> PyResult<Self> {
        Ok(FrfSet {
            state: from_state(bytes)?,
        })
    }
}

/// A point given as `"name"`, `"name@node:dir"` or `(name, node, dir)`;
/// `what` names the argument.
fn extract_point(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<FrfPoint> {
    if let Ok(text) = obj.extract::<String>() {
        return parse_point(what, &text);
    }
    if let Ok((name, node, dir)) = obj.extract::<(String, i64, Bound<'_, PyAny>)>() {
        let direction = if let Ok(d) = dir.extract::<i32>() {
            Some(d).filter(|d| (-6..=6).contains(d))
        } else if let Ok(t) = dir.extract::<String>() {
            records::parse_direction(&t)
        } else {
            None
        };
        let direction = direction.ok_or_else(|| {
            error(format!(
                "{what}: the direction of '{name}' is not one of +X, -X, +Y, ..., +RZ (or 1..6, -1..-6)"
            ))
        })?;
        if name.trim().is_empty() {
            return Err(error(format!("{what}: empty point name")));
        }
        return Ok(FrfPoint::named_at(name.trim(), node, direction));
    }
    Err(error(format!(
        "{what}: expected a point as 'name', 'name@node:direction' (e.g. 'force@2:+X') or (name, node, direction)"
    )))
}

/// A point `NAME` or `NAME@NODE:DIR` (as the command line's `--reference`).
fn parse_point(what: &str, text: &str) -> PyResult<FrfPoint> {
    let text = text.trim();
    match text.split_once('@') {
        None if !text.is_empty() => Ok(FrfPoint::named(text)),
        None => Err(error(format!("{what}: empty point name"))),
        Some((name, at)) => {
            let (node, dir) = at.split_once(':').ok_or_else(|| {
                error(format!(
                    "{what}: expected NAME@NODE:DIR (e.g. force@2:+X), got '{text}'"
                ))
            })?;
            let node: i64 = node.trim().parse().map_err(|_| {
                error(format!(
                    "{what}: node '{node}' of '{text}' is not an integer"
                ))
            })?;
            let dir = records::parse_direction(dir.trim()).ok_or_else(|| {
                error(format!(
                    "{what}: direction '{dir}' of '{text}' is not one of +X, -X, +Y, ..., +RZ (or 1..6, -1..-6)"
                ))
            })?;
            if name.trim().is_empty() {
                return Err(error(format!("{what}: empty point name in '{text}'")));
            }
            Ok(FrfPoint::named_at(name.trim(), node, dir))
        }
    }
}

/// A sequence of points (or one comma-separated string).
fn extract_points(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<FrfPoint>> {
    if let Ok(text) = obj.extract::<String>() {
        return text.split(',').map(|p| parse_point(what, p)).collect();
    }
    let items: Vec<Bound<'_, PyAny>> = obj.extract().map_err(|_| {
        error(format!(
            "{what}: expected a sequence of points ('name', 'name@node:direction' or (name, node, direction))"
        ))
    })?;
    if items.is_empty() {
        return Err(error(format!("{what}: no point given")));
    }
    items.iter().map(|p| extract_point(p, what)).collect()
}

fn parse_quantity(text: &str) -> PyResult<FrfQuantity> {
    match text.trim().to_ascii_lowercase().as_str() {
        "accelerance" | "inertance" => Ok(FrfQuantity::Accelerance),
        "mobility" => Ok(FrfQuantity::Mobility),
        "receptance" | "compliance" => Ok(FrfQuantity::Receptance),
        other => Err(error(format!(
            "quantity: '{other}' is not one of accelerance, mobility, receptance"
        ))),
    }
}

/// A band `(low_hz, high_hz)`: finite, non-negative, low below high.
fn check_band(what: &str, band: Option<(f64, f64)>) -> PyResult<Option<(f64, f64)>> {
    if let Some((lo, hi)) = band {
        if !(lo.is_finite() && hi.is_finite() && lo >= 0.0) {
            return Err(error(format!(
                "{what}: expected (low_hz, high_hz), finite and non-negative, got ({lo}, {hi})"
            )));
        }
        if lo >= hi {
            return Err(error(format!(
                "{what}: the low edge {lo} Hz must be below the high edge {hi} Hz"
            )));
        }
    }
    Ok(band)
}

fn check_tau(what: &str, tau: Option<f64>) -> PyResult<()> {
    if let Some(t) = tau
        && !(t.is_finite() && t > 0.0)
    {
        return Err(error(format!(
            "{what}: must be a positive time constant in seconds, got {t}"
        )));
    }
    Ok(())
}

/// `collocated=[(output, reference), ...]` of the constructor, as names.
fn collocated_names(
    obj: &Bound<'_, PyAny>,
    outputs: &[String],
    references: &[String],
) -> PyResult<Vec<(String, String)>> {
    // One pair, (0, 0), ("acc1", "force") or "acc1:force", or a list of
    // pairs.
    let is_pair = |x: &Bound<'_, PyAny>| {
        x.extract::<String>().is_err() && x.extract::<Vec<Bound<'_, PyAny>>>().is_ok()
    };
    let items: Vec<Bound<'_, PyAny>> = match obj.extract::<Vec<Bound<'_, PyAny>>>() {
        Ok(list)
            if obj.extract::<String>().is_err() && !list.is_empty() && list.iter().all(is_pair) =>
        {
            list
        }
        _ => vec![obj.clone()],
    };
    items
        .iter()
        .map(|item| {
            let (o, r) = resolve_collocated(Some(item), outputs, references)?;
            Ok((outputs[o].clone(), references[r].clone()))
        })
        .collect()
}

#[pymethods]
impl FrfSet {
    #[new]
    #[pyo3(signature = (frequency_hz, values, *, quantity="accelerance", coherence=None, averages=None, responses=None, references=None, collocated=None, exponential_tau_s=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        frequency_hz: &Bound<'_, PyAny>,
        values: &Bound<'_, PyAny>,
        quantity: &str,
        coherence: Option<&Bound<'_, PyAny>>,
        averages: Option<usize>,
        responses: Option<&Bound<'_, PyAny>>,
        references: Option<&Bound<'_, PyAny>>,
        collocated: Option<&Bound<'_, PyAny>>,
        exponential_tau_s: Option<f64>,
    ) -> PyResult<Self> {
        let quantity = parse_quantity(quantity)?;
        check_tau("exponential_tau_s", exponential_tau_s)?;
        if averages == Some(0) {
            return Err(error("averages: must be at least 1"));
        }
        let f = f64_array(py, frequency_hz, "frequency_hz")?;
        if f.ndim() != 1 {
            return Err(error(format!(
                "frequency_hz: expected shape (lines,), got {:?}",
                f.shape()
            )));
        }
        let v = c128_array(py, values, "values")?;
        let shape = v.shape().to_vec();
        if shape.len() != 3 {
            return Err(error(format!(
                "values: expected an array of shape (lines, outputs, references), got {} dimension(s) of shape {shape:?}{}",
                shape.len(),
                if shape.len() == 2 {
                    "; for one reference use values[:, :, None]"
                } else {
                    ""
                }
            )));
        }
        let (n, m, r) = (shape[0], shape[1], shape[2]);
        if n != f.len() {
            return Err(error(format!(
                "values: {n} lines (shape {shape:?}) for {} frequencies in frequency_hz",
                f.len()
            )));
        }
        if n == 0 || m == 0 || r == 0 {
            return Err(error(format!(
                "values: shape {shape:?} is empty: need at least one line, one output and one reference"
            )));
        }
        let coherence = match coherence {
            None => None,
            Some(c) => {
                let c = f64_array(py, c, "coherence")?;
                if c.shape() != shape.as_slice() {
                    return Err(error(format!(
                        "coherence: shape {:?} does not match values {shape:?}",
                        c.shape()
                    )));
                }
                Some(
                    (0..n)
                        .map(|k| DMatrix::from_fn(m, r, |i, j| c[[k, i, j]]))
                        .collect(),
                )
            }
        };
        let default_points = |base: &str, count: usize| -> Vec<FrfPoint> {
            (1..=count)
                .map(|i| FrfPoint::named(format!("{base}{i}")))
                .collect()
        };
        let response_points = match responses {
            Some(p) => extract_points(p, "responses")?,
            None => default_points("acc", m),
        };
        let reference_points = match references {
            Some(p) => extract_points(p, "references")?,
            None if r == 1 => vec![FrfPoint::named("force")],
            None => default_points("force", r),
        };
        if response_points.len() != m {
            return Err(error(format!(
                "responses: {} point(s) for {m} outputs (values has shape {shape:?})",
                response_points.len()
            )));
        }
        if reference_points.len() != r {
            return Err(error(format!(
                "references: {} point(s) for {r} references (values has shape {shape:?})",
                reference_points.len()
            )));
        }
        let frf = Frf {
            frequency_hz: f.iter().copied().collect(),
            values: (0..n)
                .map(|k| DMatrix::from_fn(m, r, |i, j| v[[k, i, j]]))
                .collect(),
            quantity,
            coherence,
            averages,
            outputs: response_points.iter().map(|p| p.name.clone()).collect(),
            references: reference_points.iter().map(|p| p.name.clone()).collect(),
        };
        frf.validate().map_err(|e| lib_error_in("values", e))?;
        let collocated = collocated
            .map(|c| collocated_names(c, &frf.outputs, &frf.references))
            .transpose()?
            .unwrap_or_default();
        let mut file = FrfFile::from_frf("arrays", &frf, &response_points, &reference_points);
        for pair in &mut file.pairs {
            pair.exponential_tau_s = exponential_tau_s;
        }
        let set = records::frf::assemble(
            &[file],
            &AssembleOptions {
                quantity: None,
                collocated,
            },
        )
        .map_err(lib_error)?;
        Ok(FrfSet {
            state: SetState::of(set, Vec::new()),
        })
    }

    /// Frequency lines, Hz, shape ``(lines,)``.
    #[getter]
    fn frequency_hz<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vector(py, &self.state.frf.frequency_hz)
    }

    /// FRF values, complex, shape ``(lines, outputs, references)``, SI.
    #[getter]
    fn values<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray3<Complex64>> {
        let f = &self.state.frf;
        Array3::from_shape_fn(
            (f.lines(), f.outputs.len(), f.references.len()),
            |(k, i, j)| f.values[k][(i, j)],
        )
        .into_pyarray(py)
    }

    /// Ordinary coherence, shape ``(lines, outputs, references)``, or
    /// ``None``.
    #[getter]
    fn coherence<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray3<f64>>> {
        let f = &self.state.frf;
        f.coherence.as_ref().map(|c| {
            Array3::from_shape_fn(
                (f.lines(), f.outputs.len(), f.references.len()),
                |(k, i, j)| c[k][(i, j)],
            )
            .into_pyarray(py)
        })
    }

    /// ``"accelerance"``, ``"mobility"`` or ``"receptance"``.
    #[getter]
    fn quantity(&self) -> String {
        self.state.frf.quantity.to_string()
    }

    /// The SI unit of the values.
    #[getter]
    fn unit(&self) -> &'static str {
        self.state.frf.quantity.unit()
    }

    /// Averages behind each line, if known.
    #[getter]
    fn averages(&self) -> Option<usize> {
        self.state.frf.averages
    }

    /// Time constant of the exponential window the FRFs were estimated
    /// with, s (``None`` without one, or when the files do not state it).
    #[getter]
    fn exponential_tau_s(&self) -> Option<f64> {
        self.state.exponential_tau_s
    }

    /// Response (output) names, one per row.
    #[getter]
    fn outputs(&self) -> Vec<String> {
        self.state.frf.outputs.clone()
    }

    /// Reference (force) names, one per column.
    #[getter]
    fn references(&self) -> Vec<String> {
        self.state.frf.references.clone()
    }

    /// The response points: dicts with ``name``, ``node`` and
    /// ``direction`` (UFF: 1..6 = +X..+RZ, negative for minus; ``None``
    /// where unknown).
    #[getter]
    fn response_points<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        self.state.responses.iter().map(|p| p.dict(py)).collect()
    }

    /// The reference points, as ``response_points``.
    #[getter]
    fn reference_points<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        self.state.references.iter().map(|p| p.dict(py)).collect()
    }

    /// Collocated (driving-point) pairs, zero-based ``(output,
    /// reference)``: detected from the points' nodes and directions, or as
    /// given.
    #[getter]
    fn collocated(&self) -> Vec<(usize, usize)> {
        self.state.collocated.clone()
    }

    /// The files read (empty otherwise).
    #[getter]
    fn files(&self) -> Vec<String> {
        self.state.files.clone()
    }

    /// Number of frequency lines.
    #[getter]
    fn lines(&self) -> usize {
        self.state.frf.lines()
    }

    /// Writes the FRFs to ``path``: ``format="uff"`` (UFF58 ASCII, what
    /// ``frameid frf`` writes as ``frf.uff``), ``"uff-binary"`` (58b,
    /// exact), ``"csv"`` (header convention) or ``"csv-complex"``
    /// (headerless ``freq; H1; ...``, one reference). The UFF files state
    /// the exponential window; read back with ``read_frf``. Returns the
    /// path.
    #[pyo3(signature = (path, format="uff"))]
    fn write(&self, py: Python<'_>, path: PathBuf, format: &str) -> PyResult<PathBuf> {
        let format = match format {
            "uff" => FrfFormat::Uff58Ascii,
            "uff-binary" => FrfFormat::Uff58Binary,
            "csv" => FrfFormat::Csv,
            "csv-complex" => FrfFormat::CsvComplex,
            other => {
                return Err(error(format!(
                    "format: '{other}' is not one of uff, uff-binary, csv, csv-complex"
                )));
            }
        };
        let file = self.state.file(&path);
        py.detach(|| guard(|| records::frf::write_frf(&path, &file, format).map_err(lib_error)))?;
        Ok(path)
    }

    fn __len__(&self) -> usize {
        self.state.frf.lines()
    }

    fn __repr__(&self) -> String {
        let s = &self.state;
        let f = &s.frf;
        format!(
            "FrfSet({} of {} to {}; {} lines {}-{} Hz; {} average(s); coherence {})",
            f.quantity,
            s.responses
                .iter()
                .map(PointState::text)
                .collect::<Vec<_>>()
                .join(", "),
            s.references
                .iter()
                .map(PointState::text)
                .collect::<Vec<_>>()
                .join(", "),
            f.lines(),
            f.frequency_hz[0],
            f.frequency_hz[f.lines() - 1],
            f.averages.map_or("unknown".into(), |n| n.to_string()),
            if f.coherence.is_some() {
                "given"
            } else {
                "not given"
            }
        )
    }

    fn __eq__(slf: &Bound<'_, Self>, other: &Bound<'_, PyAny>) -> bool {
        let Ok(o) = other.cast::<FrfSet>() else {
            return false;
        };
        if o.get().state != slf.get().state {
            return false;
        }
        match (slf.cast::<FrfResult>(), o.cast::<FrfResult>()) {
            (Ok(a), Ok(b)) => a.get().state == b.get().state,
            (Err(_), Err(_)) => true,
            _ => false,
        }
    }

    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> Reduced<'py> {
        let py = slf.py();
        if let Ok(r) = slf.cast::<FrfResult>() {
            let state = ResultState {
                set: slf.get().state.clone(),
                estimate: r.get().state.clone(),
            };
            return reduce(py, "FrfResult", to_state(py, &state)?);
        }
        reduce(py, "FrfSet", to_state(py, &slf.get().state)?)
    }
}

/// The pickled form of a `FrfResult`.
#[derive(Debug, Serialize, Deserialize)]
struct ResultState {
    set: SetState,
    estimate: EstimateState,
}

/// FRFs estimated from a campaign by ``frf`` (a ``FrfSet``, with what
/// ``frameid frf`` reports in ``frf.json``): the estimator, the excitation
/// the averaging was chosen for, hits used and dropped, the windows, the
/// quality of every hit and the warnings.
#[pyclass(module = "frameid", frozen, extends = FrfSet)]
pub struct FrfResult {
    state: EstimateState,
}

impl FrfResult {
    /// The object (with its base) from its pickled state.
    pub fn restore(py: Python<'_>, bytes: &[u8]) -> PyResult<Py<FrfResult>> {
        let s: ResultState = from_state(bytes)?;
        Py::new(
            py,
            PyClassInitializer::from(FrfSet { state: s.set })
                .add_subclass(FrfResult { state: s.estimate }),
        )
    }
}

#[pymethods]
impl FrfResult {
    /// ``"H1"``, ``"H2"`` or ``"Hv"``.
    #[getter]
    fn estimator(&self) -> String {
        self.state.estimator.clone()
    }

    /// The excitation the averaging was chosen for: ``"hammer"`` (one
    /// block per hit) or ``"continuous"`` (Welch segments).
    #[getter]
    fn excitation(&self) -> String {
        self.state.excitation.clone()
    }

    /// Hits averaged.
    #[getter]
    fn hits_used(&self) -> usize {
        self.state.hits_used
    }

    /// Labels (files) of the hits left out (quality or consistency; the
    /// warnings say why).
    #[getter]
    fn dropped(&self) -> Vec<String> {
        self.state.dropped.clone()
    }

    /// FFT length, samples.
    #[getter]
    fn block_len(&self) -> usize {
        self.state.block_len
    }

    /// Line spacing, Hz.
    #[getter]
    fn resolution_hz(&self) -> f64 {
        self.state.resolution_hz
    }

    /// Whether the hits were also checked against a joint model.
    #[getter]
    fn model_checks(&self) -> bool {
        self.state.model_checks
    }

    /// The windows and blocks used (a dict, as ``windows`` of
    /// ``frf.json``).
    #[getter]
    fn windows<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        arrays::json(py, &self.state.windows_json)
    }

    /// Quality checks of every hit given (dicts, as ``hit_quality`` of
    /// ``frameid identify --json``).
    #[getter]
    fn hit_quality<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        arrays::json(py, &self.state.hit_quality_json)
    }

    /// Every warning, naming files and channels.
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.state.warnings.clone()
    }

    fn __repr__(slf: &Bound<'_, Self>) -> String {
        let s = &slf.get().state;
        let f = &slf.as_super().get().state.frf;
        format!(
            "FrfResult({} of {} hit(s) ({}), {} average(s), {} lines {}-{} Hz; {} dropped; {} warning(s))",
            s.estimator,
            s.hits_used,
            s.excitation,
            f.averages.unwrap_or(0),
            f.lines(),
            f.frequency_hz[0],
            f.frequency_hz[f.lines() - 1],
            s.dropped.len(),
            s.warnings.len()
        )
    }
}

/// FRFs of a campaign with coherence, screened as ``frameid frf`` screens
/// them (the quality of every hit, each hit against the others and against
/// the joint model; failing hits are dropped with a warning, or with
/// ``strict=True`` refused), then averaged: one block per hit for hammer
/// records, Welch segments for continuous ones.
///
/// ``estimator``: ``"H1"`` (noise on the responses), ``"H2"`` or ``"Hv"``.
/// ``averaging``: ``"auto"`` (as detected), ``"hits"`` or ``"welch"``;
/// ``segment``: the Welch segment length in samples. ``force_window_s``: a
/// force window of that half-width and taper around each hit's peak, s.
/// ``exponential_end``: an exponential window leaving this amplitude at
/// the end of the record (e.g. 0.01; its damping is stated in
/// ``exponential_tau_s`` and removed by ``identify_frf``). ``band_hz``:
/// ``(low, high)`` lines kept. ``collocated``: the collocated (output,
/// input) pair of the screening's joint model (default ``(0, 0)``), which
/// also places the force at its output's point. ``excitation``:
/// ``"auto"``, ``"hammer"`` or ``"continuous"`` (the quality checks'
/// assumption). Runs without holding the interpreter.
#[pyfunction]
#[pyo3(signature = (campaign, *, estimator="H1", averaging="auto", segment=None, force_window_s=None, exponential_end=None, band_hz=None, strict=false, collocated=None, excitation="auto"))]
#[allow(clippy::too_many_arguments)]
fn frf(
    py: Python<'_>,
    campaign: &Bound<'_, PyAny>,
    estimator: &str,
    averaging: &str,
    segment: Option<usize>,
    force_window_s: Option<f64>,
    exponential_end: Option<f64>,
    band_hz: Option<(f64, f64)>,
    strict: bool,
    collocated: Option<&Bound<'_, PyAny>>,
    excitation: &str,
) -> PyResult<Py<FrfResult>> {
    let estimator = match estimator.to_ascii_lowercase().as_str() {
        "h1" => Estimator::H1,
        "h2" => Estimator::H2,
        "hv" => Estimator::Hv,
        _ => {
            return Err(error(format!(
                "estimator: '{estimator}' is not one of H1, H2, Hv"
            )));
        }
    };
    if segment == Some(0) {
        return Err(error("segment: must be at least 1 sample"));
    }
    let averaging = match averaging {
        "auto" if segment.is_some() => AveragingChoice::Welch(segment),
        "auto" => AveragingChoice::Auto,
        "hits" if segment.is_some() => {
            return Err(error(
                "segment: applies to Welch averaging; pass averaging=\"welch\" (or \"auto\")",
            ));
        }
        "hits" => AveragingChoice::Hits,
        "welch" => AveragingChoice::Welch(segment),
        other => {
            return Err(error(format!(
                "averaging: '{other}' is not one of auto, hits, welch"
            )));
        }
    };
    if let Some(s) = force_window_s
        && !(s.is_finite() && s > 0.0)
    {
        return Err(error(format!(
            "force_window_s: must be a positive time in seconds, got {s}"
        )));
    }
    if let Some(a) = exponential_end
        && !(a > 0.0 && a < 1.0)
    {
        return Err(error(format!(
            "exponential_end: the amplitude left at the end of the record must be between 0 and 1 (e.g. 0.01), got {a}"
        )));
    }
    let band_hz = check_band("band_hz", band_hz)?;
    let excitation: records::quality::Excitation = excitation
        .parse()
        .map_err(|e: String| error(format!("excitation: {e}")))?;
    let campaign = campaign.cast::<Campaign>().map_err(|_| {
        error("campaign: expected a frameid.Campaign (from frameid.Campaign(force, acc, dt_s), read_records or simulate)")
    })?;
    let c = &campaign.get().inner;
    let files: Option<Vec<records::RecordFile>> = campaign
        .get()
        .files
        .as_ref()
        .map(|f| f.iter().map(|m| m.record_file()).collect());
    let collocated = resolve_collocated(collocated, &c.outputs, &c.inputs)?;
    let mut analysis = AnalysisSettings {
        screening: if strict {
            Screening::Strict
        } else {
            Screening::Warn
        },
        quality: records::quality::QualitySettings {
            excitation,
            ..Default::default()
        },
        uncertainty: false,
        ..AnalysisSettings::default()
    };
    analysis.identifier = analysis
        .identifier
        .clone()
        .collocated(collocated.0, collocated.1);
    let settings = FrfSettings {
        estimator,
        averaging,
        force_window: force_window_s.map(|s| ForceWindow {
            before_peak_s: s,
            after_peak_s: s,
            taper_s: s,
        }),
        exponential_window: exponential_end.map(ExponentialWindow::EndAmplitude),
        band_hz,
        analysis,
    };
    let (set, estimate) = py.detach(|| {
        guard(|| {
            let outcome = match &files {
                Some(f) => estimate_frfs(c, &ByLine(f), &settings),
                None => estimate_frfs(c, &ByPosition, &settings),
            }
            .map_err(lib_error)?;
            let (responses, references) = study::export::record_points(
                files.as_deref().unwrap_or(&[]),
                &outcome.campaign,
                collocated,
            );
            let frf = &outcome.estimate.frf;
            let windows = &outcome.estimate.windows;
            // The FRFs with their points collated as a file of them would
            // be (collocated pairs detected from the points).
            let mut file = FrfFile::from_frf("frf", frf, &responses, &references);
            for pair in &mut file.pairs {
                pair.exponential_tau_s = windows.exponential_tau_s;
            }
            let set =
                records::frf::assemble(&[file], &AssembleOptions::default()).map_err(lib_error)?;
            let estimate = EstimateState {
                estimator: outcome.estimate.estimator.to_string(),
                excitation: outcome.excitation.label().to_string(),
                hits_used: outcome.campaign.len(),
                dropped: outcome.dropped.iter().map(|&i| c.label(i)).collect(),
                block_len: windows.block_len,
                resolution_hz: 1.0 / (windows.block_len as f64 * outcome.campaign.dt_s),
                model_checks: outcome.model_checks,
                windows_json: json_text(windows)?,
                hit_quality_json: json_text(&outcome.hit_quality)?,
                warnings: outcome.warnings.clone(),
            };
            Ok((SetState::of(set, Vec::new()), estimate))
        })
    })?;
    Py::new(
        py,
        PyClassInitializer::from(FrfSet { state: set }).add_subclass(FrfResult { state: estimate }),
    )
}

/// Paths: one path-like or a sequence of them.
fn extract_paths(obj: &Bound<'_, PyAny>) -> PyResult<Vec<PathBuf>> {
    if let Ok(p) = obj.extract::<PathBuf>() {
        return Ok(vec![p]);
    }
    obj.extract::<Vec<PathBuf>>().map_err(|_| {
        error("paths: expected a path or a sequence of paths (str or os.PathLike) of FRF files")
    })
}

/// A reading error in the keywords' terms: the library names the fields
/// of `FrfReadOptions`, which are `read_frf`'s keywords.
fn keywords(message: &str) -> String {
    message
        .replace("FrfReadOptions::quantity", "quantity= (or unit=)")
        .replace("FrfReadOptions::reference", "reference=")
        .replace("FrfReadOptions::responses", "responses=")
        .replace("FrfReadOptions::unit", "unit=")
}

/// Reads FRF files (UFF58 ASCII or binary, CSV with the header convention,
/// headerless ``freq; H1; ...`` complex CSV; detected from the content) and
/// collates them into one ``FrfSet``, as ``frameid identify FILES`` does
/// with FRF files.
///
/// What a file may not state: ``quantity`` (``"accelerance"``,
/// ``"mobility"``, ``"receptance"``: values in its SI unit) or ``unit``
/// (``"g/N"``, ``"(m/s^2)/N"``, ...) of values without a unit;
/// ``reference``: the force point of a headerless file (``"f2@2:+X"``),
/// one for all files or a list with one per file; ``responses``: the
/// points of its FRF columns (a list, or ``"a@1:+X,b@2:+X"``).
#[pyfunction]
#[pyo3(signature = (paths, *, quantity=None, unit=None, reference=None, responses=None))]
fn read_frf(
    py: Python<'_>,
    paths: &Bound<'_, PyAny>,
    quantity: Option<&str>,
    unit: Option<String>,
    reference: Option<&Bound<'_, PyAny>>,
    responses: Option<&Bound<'_, PyAny>>,
) -> PyResult<FrfSet> {
    let paths = extract_paths(paths)?;
    if paths.is_empty() {
        return Err(error("no FRF files given"));
    }
    let quantity = quantity.map(parse_quantity).transpose()?;
    let references: Vec<FrfPoint> = match reference {
        None => Vec::new(),
        Some(r)
            if r.extract::<String>().is_ok()
                || r.extract::<(String, i64, Bound<'_, PyAny>)>().is_ok() =>
        {
            vec![extract_point(r, "reference")?]
        }
        Some(r) => {
            let items: Vec<Bound<'_, PyAny>> = r.extract().map_err(|_| {
                error("reference: expected a point or a list of points, one per file")
            })?;
            items
                .iter()
                .map(|p| extract_point(p, "reference"))
                .collect::<PyResult<_>>()?
        }
    };
    if references.len() > 1 && references.len() != paths.len() {
        return Err(error(format!(
            "reference: give one for every file ({} files) or one for all, got {}",
            paths.len(),
            references.len()
        )));
    }
    let responses = responses
        .map(|r| extract_points(r, "responses"))
        .transpose()?;
    py.detach(|| {
        guard(|| {
            let files = paths
                .iter()
                .enumerate()
                .map(|(k, path)| {
                    let opts = FrfReadOptions {
                        quantity,
                        unit: unit.clone(),
                        reference: references
                            .get(if references.len() == 1 { 0 } else { k })
                            .cloned(),
                        responses: responses.clone(),
                    };
                    records::frf::read_frf(path, &opts)
                })
                .collect::<Result<Vec<_>, _>>()
                .map_err(|e| error(keywords(&crate::chain(&e))))?;
            let set =
                records::frf::assemble(&files, &AssembleOptions::default()).map_err(lib_error)?;
            Ok(FrfSet {
                state: SetState::of(set, paths.iter().map(|p| p.display().to_string()).collect()),
            })
        })
    })
}

/// Everything `identify_frf` returns.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FrfIdentState {
    identification: ident::frf::FrfIdentification,
    refinement: Option<FrfRefinement>,
    uncertainty: Option<SpreadState>,
    uncertainty_skipped: Option<String>,
    /// `study::frf_analysis::FrfChecks` as JSON (serializes only).
    checks_json: String,
    warnings: Vec<String>,
    files: Vec<String>,
    responses: Vec<PointState>,
    references: Vec<PointState>,
    collocated: (usize, usize),
    /// The output at each reference's point, if any.
    reference_outputs: Vec<Option<usize>>,
    lines: usize,
    band_hz: (f64, f64),
    averages: Option<usize>,
    coherence: bool,
}

/// A serializable copy of `study::frf_analysis::FrfSpread` (which
/// serializes only).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SpreadState {
    method: String,
    resamples: usize,
    failed: usize,
    frequencies_hz_std: Vec<f64>,
    damping_ratios_std: Vec<f64>,
    mass_std: Vec<Vec<f64>>,
    stiffness_std: Vec<Vec<f64>>,
    damping_mkr_std: Vec<Vec<f64>>,
    damping_rayleigh_std: Vec<Vec<f64>>,
}

impl SpreadState {
    fn of(s: study::frf_analysis::FrfSpread) -> Self {
        SpreadState {
            method: s.method,
            resamples: s.resamples,
            failed: s.failed,
            frequencies_hz_std: s.frequencies_hz_std,
            damping_ratios_std: s.damping_ratios_std,
            mass_std: s.mass_std,
            stiffness_std: s.stiffness_std,
            damping_mkr_std: s.damping_mkr_std,
            damping_rayleigh_std: s.damping_rayleigh_std,
        }
    }
}

/// Error bars of an FRF identification by the parametric bootstrap (the
/// ``uncertainty`` of ``frameid identify --json`` on FRF files): the
/// identified modal model plus noise of each value's variance (from the
/// coherence and averages, else LSFD's residual) identified again, with
/// a fixed seed; ``*_std`` are the standard deviations over the resamples.
#[pyclass(module = "frameid", frozen)]
pub struct FrfUncertainty {
    state: SpreadState,
}

impl FrfUncertainty {
    pub fn from_state(bytes: &[u8]) -> PyResult<Self> {
        Ok(FrfUncertainty {
            state: from_state(bytes)?,
        })
    }
}

#[pymethods]
impl FrfUncertainty {
    /// How the error bars were obtained, in words.
    #[getter]
    fn method(&self) -> String {
        self.state.method.clone()
    }
    /// Resamples identified.
    #[getter]
    fn resamples(&self) -> usize {
        self.state.resamples
    }
    /// Resamples that could not be identified (left out).
    #[getter]
    fn failed(&self) -> usize {
        self.state.failed
    }
    /// Standard deviations of the frequencies of the modes used, Hz.
    #[getter]
    fn frequencies_hz_std<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vector(py, &self.state.frequencies_hz_std)
    }
    /// Standard deviations of the damping ratios of the modes used.
    #[getter]
    fn damping_ratios_std<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vector(py, &self.state.damping_ratios_std)
    }
    /// Standard deviations of M, kg.
    #[getter]
    fn mass_std<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        arrays::rows(py, &self.state.mass_std)
    }
    /// Standard deviations of K, N/m.
    #[getter]
    fn stiffness_std<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        arrays::rows(py, &self.state.stiffness_std)
    }
    #[getter]
    fn damping_mkr_std<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        arrays::rows(py, &self.state.damping_mkr_std)
    }
    #[getter]
    fn damping_rayleigh_std<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        arrays::rows(py, &self.state.damping_rayleigh_std)
    }
    /// Everything as a dict (the ``uncertainty`` of the command line's JSON).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        arrays::to_python(py, &self.state)
    }
    fn __repr__(&self) -> String {
        format!(
            "FrfUncertainty({} resamples, {} failed)",
            self.state.resamples, self.state.failed
        )
    }
    fn __reduce__<'py>(&self, py: Python<'py>) -> Reduced<'py> {
        reduce(py, "FrfUncertainty", to_state(py, &self.state)?)
    }
}

/// The result of ``identify_frf``: modes, M, K and damping from FRFs, with
/// the fields of ``frameid identify --json`` on FRF files (same names as
/// ``Identification`` where they mean the same): ``mass``, ``stiffness``,
/// ``damping_mkr``, ``damping_rayleigh``, ``frequencies_hz``,
/// ``damping_ratios``, ``mode_shapes`` (of the modes used), ``modes`` (all
/// identified, ``Mode.used``), ``out_of_model_modes``, ``warnings``,
/// ``refined`` (``refine=True``), plus the checks of the FRFs (coherence,
/// reciprocity), the pLSCF ``model_order``, the ``stabilization`` diagram
/// and the ``rejected_modes``.
#[pyclass(module = "frameid", frozen)]
pub struct FrfIdentification {
    state: FrfIdentState,
}

impl FrfIdentification {
    pub fn from_state(bytes: &[u8]) -> PyResult<Self> {
        Ok(FrfIdentification {
            state: from_state(bytes)?,
        })
    }
}

#[pymethods]
impl FrfIdentification {
    /// Mass matrix M, kg.
    #[getter]
    fn mass<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        matrix(py, &self.state.identification.mass)
    }

    /// Stiffness matrix K, N/m.
    #[getter]
    fn stiffness<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        matrix(py, &self.state.identification.stiffness)
    }

    /// Damping matrix from MKR, N s/m.
    #[getter]
    fn damping_mkr<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        matrix(py, &self.state.identification.damping_mkr)
    }

    /// Rayleigh damping ``alpha M + beta K``, N s/m.
    #[getter]
    fn damping_rayleigh<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        matrix(py, &self.state.identification.damping_rayleigh)
    }

    /// Every identified mode (stable, physical, in the band), ascending
    /// frequency (``emac`` is ``None`` on this route).
    #[getter]
    fn modes(&self) -> Vec<Mode> {
        let id = &self.state.identification;
        id.modes
            .iter()
            .enumerate()
            .map(|(i, m)| Mode::new(m.clone(), id.mkr_modes.contains(&i)))
            .collect()
    }

    /// Indices into ``modes`` of the modes used by MKR and the Rayleigh fit.
    #[getter]
    fn used_modes(&self) -> Vec<usize> {
        self.state.identification.mkr_modes.clone()
    }

    /// Indices into ``modes`` of the modes outside the model.
    #[getter]
    fn out_of_model_modes(&self) -> Vec<usize> {
        self.state.identification.out_of_model.clone()
    }

    /// Natural frequencies of the modes used, Hz.
    #[getter]
    fn frequencies_hz<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vector(py, &self.state.identification.frequencies_hz)
    }

    /// Damping ratios of the modes used (an exponential window's damping
    /// removed).
    #[getter]
    fn damping_ratios<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vector(py, &self.state.identification.damping_ratios)
    }

    /// Complex shapes of the modes used, outputs × modes (largest
    /// component 1).
    #[getter]
    fn mode_shapes<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<Complex64>> {
        arrays::complex_matrix(py, &self.state.identification.mode_shapes)
    }

    /// Rayleigh coefficient alpha, 1/s.
    #[getter]
    fn rayleigh_alpha(&self) -> f64 {
        self.state.identification.rayleigh.alpha
    }

    /// Rayleigh coefficient beta, s.
    #[getter]
    fn rayleigh_beta(&self) -> f64 {
        self.state.identification.rayleigh.beta
    }

    /// ``||W Wᵀ|| / ||W Λ Wᵀ||``: 0 for an exact second-order system.
    #[getter]
    fn consistency(&self) -> f64 {
        self.state.identification.consistency
    }

    /// Whether the input polarity was found inverted and flipped.
    #[getter]
    fn polarity_flipped(&self) -> bool {
        self.state.identification.polarity_flipped
    }

    /// The pLSCF model order used.
    #[getter]
    fn model_order(&self) -> usize {
        self.state.identification.order
    }

    /// Time constant of the exponential window taken out of the modes, s.
    #[getter]
    fn exponential_tau_s(&self) -> Option<f64> {
        self.state.identification.exponential_tau_s
    }

    /// Quantity of the FRFs identified.
    #[getter]
    fn quantity(&self) -> String {
        self.state.identification.quantity.to_string()
    }

    /// The stabilization diagram: a dict of arrays, one entry per pole of
    /// every order: ``order``, ``frequency_hz``, ``damping_ratio``,
    /// ``status`` (``"new"``, ``"frequency"``, ``"damping"``,
    /// ``"stable"``) and ``physical`` (damping in range, frequency in the
    /// band).
    #[getter]
    fn stabilization<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let poles = &self.state.identification.diagram.poles;
        let d = PyDict::new(py);
        d.set_item(
            "order",
            Array1::from_iter(poles.iter().map(|p| p.order as i64)).into_pyarray(py),
        )?;
        d.set_item(
            "frequency_hz",
            Array1::from_iter(poles.iter().map(|p| p.frequency_hz)).into_pyarray(py),
        )?;
        d.set_item(
            "damping_ratio",
            Array1::from_iter(poles.iter().map(|p| p.damping_ratio)).into_pyarray(py),
        )?;
        d.set_item(
            "status",
            poles
                .iter()
                .map(|p| format!("{:?}", p.status).to_ascii_lowercase())
                .collect::<Vec<_>>(),
        )?;
        d.set_item(
            "physical",
            Array1::from_iter(poles.iter().map(|p| p.physical)).into_pyarray(py),
        )?;
        Ok(d)
    }

    /// Stable physical pLSCF poles left out of the modal model: dicts with
    /// ``frequency_hz``, ``damping_ratio`` and ``reason``.
    #[getter]
    fn rejected_modes<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        self.state
            .identification
            .rejected
            .iter()
            .map(|r| {
                let d = PyDict::new(py);
                d.set_item("frequency_hz", r.frequency_hz)?;
                d.set_item("damping_ratio", r.damping_ratio)?;
                d.set_item(
                    "reason",
                    match r.reason {
                        ident::frf::RejectReason::LeftPhysicalRange { .. } => {
                            "left the band or damping range when refined".to_string()
                        }
                        ident::frf::RejectReason::Insignificant { contribution } => format!(
                            "peak contribution {} of the largest",
                            records::numfmt::sig(contribution, 2)
                        ),
                    },
                )?;
                Ok(d)
            })
            .collect()
    }

    /// The checks of the FRFs, as ``checks`` of ``frameid identify
    /// --json``: ``coherence`` (per pair: ``output``, ``reference``,
    /// ``median``, ``below_half``; empty without coherence) and
    /// ``reciprocity`` (per pair of references at response points: ``a``,
    /// ``b``, ``relative_difference``).
    #[getter]
    fn checks<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        arrays::json(py, &self.state.checks_json)
    }

    /// Warnings: the checks', the identification's and the refinement's.
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.state.warnings.clone()
    }

    /// Error bars by the parametric bootstrap, or ``None`` (with
    /// ``uncertainty=False``, or when they could not be made: then
    /// ``uncertainty_skipped`` says why).
    #[getter]
    fn uncertainty(&self) -> Option<FrfUncertainty> {
        self.state
            .uncertainty
            .clone()
            .map(|state| FrfUncertainty { state })
    }

    /// Why there are no error bars, if there are none though asked for.
    #[getter]
    fn uncertainty_skipped(&self) -> Option<String> {
        self.state.uncertainty_skipped.clone()
    }

    /// The maximum-likelihood refinement on the FRFs (``refine=True``), or
    /// ``None``.
    #[getter]
    fn refined(&self) -> Option<FrfRefined> {
        self.state
            .refinement
            .clone()
            .map(|state| FrfRefined { state })
    }

    /// The files identified (empty for FRFs not read from files).
    #[getter]
    fn files(&self) -> Vec<String> {
        self.state.files.clone()
    }

    /// Response names, in DOF order.
    #[getter]
    fn outputs(&self) -> Vec<String> {
        self.state
            .responses
            .iter()
            .map(|p| p.name.clone())
            .collect()
    }

    /// Reference names.
    #[getter]
    fn references(&self) -> Vec<String> {
        self.state
            .references
            .iter()
            .map(|p| p.name.clone())
            .collect()
    }

    /// The collocated pair used, zero-based ``(output, reference)``.
    #[getter]
    fn collocated(&self) -> (usize, usize) {
        self.state.collocated
    }

    /// Lines of the FRFs given.
    #[getter]
    fn lines(&self) -> usize {
        self.state.lines
    }

    /// First and last line of the FRFs given, Hz.
    #[getter]
    fn band_hz(&self) -> (f64, f64) {
        self.state.band_hz
    }

    /// Writes the modes used as UFF dataset 55 (``modes.uff`` of
    /// ``frameid identify --export``: shapes rotated real, modal A from the
    /// identified (or refined) mass). Returns the path.
    fn write_modes(&self, py: Python<'_>, path: PathBuf) -> PyResult<PathBuf> {
        let s = &self.state;
        let id = &s.identification;
        let mass = s.refinement.as_ref().map_or(&id.mass, |r| &r.mass);
        let points: Vec<FrfPoint> = s.responses.iter().map(PointState::point).collect();
        let modes = study::export::modes(
            &points,
            &id.frequencies_hz,
            &id.damping_ratios,
            &id.mode_shapes,
            mass,
        );
        py.detach(|| guard(|| records::frf::write_uff55(&path, &modes).map_err(lib_error)))?;
        Ok(path)
    }

    /// The identified model's FRFs (``model_frf.uff`` of ``--export``):
    /// accelerance of M, K and the Rayleigh damping (the refined model's
    /// with ``refine=True``) on ``frequency_hz``, for each reference placed
    /// at a floor, as a ``FrfSet`` with the measured points.
    fn model_frf(&self, py: Python<'_>, frequency_hz: &Bound<'_, PyAny>) -> PyResult<FrfSet> {
        let grid = f64_array(py, frequency_hz, "frequency_hz")?;
        if grid.ndim() != 1 || grid.is_empty() {
            return Err(error(format!(
                "frequency_hz: expected a non-empty array of shape (lines,), got shape {:?}",
                grid.shape()
            )));
        }
        let grid: Vec<f64> = grid.iter().copied().collect();
        let s = &self.state;
        let id = &s.identification;
        let placed: Vec<(FrfPoint, usize)> = match &s.refinement {
            Some(r) => s
                .references
                .iter()
                .map(PointState::point)
                .zip(r.reference_dofs.iter().copied())
                .collect(),
            None => s
                .references
                .iter()
                .map(PointState::point)
                .zip(&s.reference_outputs)
                .filter_map(|(p, d)| d.map(|d| (p, d)))
                .collect(),
        };
        let model = match &s.refinement {
            Some(r) => (&r.mass, &r.stiffness, &r.damping),
            None => (&id.mass, &id.stiffness, &id.damping_rayleigh),
        };
        let responses: Vec<FrfPoint> = s.responses.iter().map(PointState::point).collect();
        let names: Vec<String> = responses.iter().map(|p| p.name.clone()).collect();
        let refs: Vec<String> = placed.iter().map(|(p, _)| p.name.clone()).collect();
        let dofs: Vec<usize> = placed.iter().map(|(_, d)| *d).collect();
        if dofs.is_empty() {
            return Err(error(
                "model_frf: no reference is placed at a floor (no response point at a reference point)",
            ));
        }
        let frf = study::export::model_frf(model, &dofs, &grid, &names, &refs);
        frf.validate()
            .map_err(|e| lib_error_in("frequency_hz", e))?;
        let points: Vec<FrfPoint> = placed.into_iter().map(|(p, _)| p).collect();
        let file = FrfFile::from_frf("model", &frf, &responses, &points);
        let set =
            records::frf::assemble(&[file], &AssembleOptions::default()).map_err(lib_error)?;
        Ok(FrfSet {
            state: SetState::of(set, Vec::new()),
        })
    }

    fn __repr__(&self) -> String {
        let id = &self.state.identification;
        let modes: Vec<String> = id
            .frequencies_hz
            .iter()
            .zip(&id.damping_ratios)
            .map(|(f, xi)| format!("{f:.4} Hz ({:.3} %)", 100.0 * xi))
            .collect();
        format!(
            "FrfIdentification(modes used: {}; pLSCF order {}; {} warning(s){}{})",
            modes.join(", "),
            id.order,
            self.state.warnings.len(),
            if self.state.uncertainty.is_some() {
                "; error bars"
            } else {
                ""
            },
            if self.state.refinement.is_some() {
                "; refined"
            } else {
                ""
            }
        )
    }

    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other
            .cast::<FrfIdentification>()
            .is_ok_and(|o| o.get().state == self.state)
    }

    fn __reduce__<'py>(&self, py: Python<'py>) -> Reduced<'py> {
        reduce(py, "FrfIdentification", to_state(py, &self.state)?)
    }
}

/// The maximum-likelihood refinement of M, K and the damping matrix on the
/// FRFs, with standard errors (``*_std``) from the Fisher information:
/// variances from the coherence and the number of averages when the FRFs
/// carry them, else estimated (``noise_model`` says which).
#[pyclass(module = "frameid", frozen)]
pub struct FrfRefined {
    state: FrfRefinement,
}

impl FrfRefined {
    pub fn from_state(bytes: &[u8]) -> PyResult<Self> {
        Ok(FrfRefined {
            state: from_state(bytes)?,
        })
    }
}

#[pymethods]
impl FrfRefined {
    /// Refined mass matrix, kg.
    #[getter]
    fn mass<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        matrix(py, &self.state.mass)
    }
    /// Refined stiffness matrix, N/m.
    #[getter]
    fn stiffness<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        matrix(py, &self.state.stiffness)
    }
    /// Refined damping matrix, N s/m.
    #[getter]
    fn damping<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        matrix(py, &self.state.damping)
    }
    /// Standard errors of M (0 where the parametrization fixes an entry).
    #[getter]
    fn mass_std<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        matrix(py, &self.state.uncertainty.mass_std)
    }
    #[getter]
    fn stiffness_std<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        matrix(py, &self.state.uncertainty.stiffness_std)
    }
    #[getter]
    fn damping_std<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        matrix(py, &self.state.uncertainty.damping_std)
    }
    /// Modes of the refined model with standard errors.
    #[getter]
    fn modes(&self) -> Vec<RefinedMode> {
        self.state
            .uncertainty
            .modes
            .iter()
            .map(|m| RefinedMode::new(m.clone()))
            .collect()
    }
    /// Where the variances came from (``Coherence { averages: 10 }``,
    /// ``CoherenceScaled``, ``PerOutput``, ``PerPair``, ``Known``).
    #[getter]
    fn noise_model(&self) -> String {
        format!("{:?}", self.state.noise.source)
    }
    /// Floor (zero-based DOF) each reference force acts on.
    #[getter]
    fn reference_dofs(&self) -> Vec<usize> {
        self.state.reference_dofs.clone()
    }
    /// Levenberg–Marquardt steps over all runs.
    #[getter]
    fn iterations(&self) -> usize {
        self.state.iterations
    }
    /// Why the optimizer stopped (``Gradient``, ``Step``, ``Cost``,
    /// ``MaxIterations``, ``NoProgress``).
    #[getter]
    fn stop(&self) -> String {
        format!("{:?}", self.state.stop)
    }
    /// Whether the stop reason is a convergence test.
    #[getter]
    fn converged(&self) -> bool {
        self.state.stop.converged()
    }
    #[getter]
    fn initial_cost(&self) -> f64 {
        self.state.initial_cost
    }
    /// Final cost (about ``observations - unknowns`` when model and
    /// variances are right).
    #[getter]
    fn cost(&self) -> f64 {
        self.state.cost
    }
    #[getter]
    fn observations(&self) -> usize {
        self.state.observations
    }
    #[getter]
    fn unknowns(&self) -> usize {
        self.state.unknowns
    }
    /// First and last line used, Hz.
    #[getter]
    fn band_hz(&self) -> (f64, f64) {
        self.state.band_hz
    }
    /// Lines used.
    #[getter]
    fn lines(&self) -> usize {
        self.state.lines
    }
    /// Names of the physical parameters estimated.
    #[getter]
    fn parameter_labels(&self) -> Vec<String> {
        self.state.uncertainty.labels.clone()
    }
    /// The parameters' values (in the order of ``parameter_labels``).
    #[getter]
    fn parameters<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        arrays::dvector(py, &self.state.parameters)
    }
    /// Their covariance (inverse Fisher information).
    #[getter]
    fn covariance<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        matrix(py, &self.state.uncertainty.covariance)
    }
    fn __repr__(&self) -> String {
        format!(
            "FrfRefined({} parameters, {} iterations, stopped on {:?}, noise {:?})",
            self.state.parameters.len(),
            self.state.iterations,
            self.state.stop,
            self.state.noise.source
        )
    }
    fn __reduce__<'py>(&self, py: Python<'py>) -> Reduced<'py> {
        reduce(py, "FrfRefined", to_state(py, &self.state)?)
    }
}

/// Identifies modes and M, K and damping from FRFs (a ``FrfSet`` from
/// ``read_frf``, ``frf`` or arrays), as ``frameid identify`` does given FRF
/// files: the checks of the FRFs (coherence per pair, reciprocity between
/// references at response points; ``strict=True`` refuses FRFs a check
/// warns about), pLSCF with its stabilization diagram, LSFD, MKR and the
/// Rayleigh fit, and with ``refine=True`` the maximum-likelihood refinement
/// on the FRFs (``parametrization``: ``"full"`` or ``"shear-frame"``).
///
/// ``band_hz``: ``(low, high)`` lines identified. ``order``: a fixed pLSCF
/// order (default automatic). ``modes``: one frequency per output (Hz), the
/// modes nearest them (within 10 %) form the model. ``collocated``: the
/// collocated (output, reference) pair, zero-based indices or names
/// (default: the first detected from the points; an error if none).
/// ``exponential_tau_s``: the time constant of an exponential window behind
/// the FRFs (default the one they state). Lines are weighted by the
/// coherence when the FRFs carry it. ``uncertainty``: error bars by the
/// parametric bootstrap (40 resamples, as the command line's default; off
/// as ``--no-uncertainty``). Runs without holding the interpreter.
#[pyfunction]
#[pyo3(signature = (frfs, *, band_hz=None, order=None, modes=None, collocated=None, exponential_tau_s=None, uncertainty=true, refine=false, parametrization="full", strict=false))]
#[allow(clippy::too_many_arguments)]
fn identify_frf(
    py: Python<'_>,
    frfs: &Bound<'_, PyAny>,
    band_hz: Option<(f64, f64)>,
    order: Option<usize>,
    modes: Option<Vec<f64>>,
    collocated: Option<&Bound<'_, PyAny>>,
    exponential_tau_s: Option<f64>,
    uncertainty: bool,
    refine: bool,
    parametrization: &str,
    strict: bool,
) -> PyResult<FrfIdentification> {
    let set = frfs.cast::<FrfSet>().map_err(|_| {
        error("frfs: expected a frameid.FrfSet (from frameid.read_frf, frameid.frf or frameid.FrfSet(frequency_hz, values))")
    })?;
    let set = &set.get().state;
    let frf = &set.frf;
    let band_hz = check_band("band_hz", band_hz)?;
    check_tau("exponential_tau_s", exponential_tau_s)?;
    if order == Some(0) {
        return Err(error("order: must be at least 1"));
    }
    if let Some(m) = &modes {
        if let Some(f) = m.iter().find(|f| !(f.is_finite() && **f > 0.0)) {
            return Err(error(format!("modes: {f} Hz is not a natural frequency")));
        }
        if m.is_empty() {
            return Err(error("modes: give one frequency per output"));
        }
    }
    let parametrization: ParametrizationSetting = parametrization
        .parse()
        .map_err(|e: String| error(format!("parametrization: {e}")))?;
    if parametrization != ParametrizationSetting::Full && !refine {
        return Err(error(
            "parametrization: applies to the refinement; pass refine=True",
        ));
    }
    let collocated = match collocated {
        Some(c) => resolve_collocated(Some(c), &frf.outputs, &frf.references)?,
        None => set.collocated.first().copied().ok_or_else(|| {
            error(format!(
                "collocated: no response point is at a reference point (node and direction), so the collocated pair is unknown; give it as collocated=(output, reference) (outputs: {}; references: {})",
                frf.outputs.join(", "),
                frf.references.join(", ")
            ))
        })?,
    };
    let mut identifier = FrfIdentifier::default().collocated(collocated.0, collocated.1);
    if let Some((lo, hi)) = band_hz {
        identifier = identifier.band_hz(lo, hi);
    }
    if let Some(order) = order {
        identifier = identifier.order(FrfOrder::Fixed(order));
    }
    if let Some(frequency_hz) = modes {
        // A target names the mode within 10 % of it (as `--modes`): modes
        // of a frame are further apart than that, a target off by more is
        // a mistake.
        identifier = identifier.selection(ModeSelection::Nearest {
            frequency_hz,
            tolerance: 0.1,
        });
    }
    if frf.coherence.is_some() {
        identifier = identifier.weighting(Weighting::Coherence);
    }
    if let Some(tau) = exponential_tau_s.or(set.exponential_tau_s) {
        identifier = identifier.exponential_window(tau);
    }
    // Where each reference acts: the floor of the response at its point.
    let points = |p: &[PointState]| p.iter().map(PointState::point).collect::<Vec<_>>();
    let reference_outputs = study::frf_analysis::reference_outputs(
        &points(&set.responses),
        &points(&set.references),
        collocated,
    );
    let settings = FrfAnalysisSettings {
        identifier,
        strict,
        uncertainty,
        refine: refine.then_some(parametrization),
    };
    let state = py.detach(|| {
        guard(|| {
            let a = analyze_frfs(frf, &reference_outputs, &settings).map_err(lib_error)?;
            Ok(FrfIdentState {
                checks_json: json_text(&a.checks)?,
                warnings: a.warnings,
                refinement: a.refinement,
                uncertainty: a.uncertainty.map(SpreadState::of),
                uncertainty_skipped: a.uncertainty_skipped,
                identification: a.identification,
                files: set.files.clone(),
                responses: set.responses.clone(),
                references: set.references.clone(),
                collocated,
                reference_outputs,
                lines: frf.lines(),
                band_hz: (frf.frequency_hz[0], frf.frequency_hz[frf.lines() - 1]),
                averages: frf.averages,
                coherence: frf.coherence.is_some(),
            })
        })
    })?;
    Ok(FrfIdentification { state })
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<FrfSet>()?;
    m.add_class::<FrfResult>()?;
    m.add_class::<FrfIdentification>()?;
    m.add_class::<FrfRefined>()?;
    m.add_class::<FrfUncertainty>()?;
    m.add_function(wrap_pyfunction!(frf, m)?)?;
    m.add_function(wrap_pyfunction!(read_frf, m)?)?;
    m.add_function(wrap_pyfunction!(identify_frf, m)?)?;
    Ok(())
}
