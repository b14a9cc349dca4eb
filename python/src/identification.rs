//! `frameid.identify` (what `frameid identify` runs on records) and
//! `identify_realization` (`frameid identify --realization`), with their
//! result: modes, M, K, damping, hit quality, warnings, error bars and the
//! maximum-likelihood refinement.

use std::path::PathBuf;

use ident::refine::{ModalEstimate, Refinement};
use ident::{Intersample, Jackknife};
use num_complex::Complex64;
use numpy::{PyArray1, PyArray2};
use pyo3::prelude::*;
use records::consistency::ByLine;
use serde::{Deserialize, Serialize};
use study::analysis::{AnalysisSettings, Screening, analyze, analyze_located, identifier};
use study::scenario::ParametrizationSetting;

use crate::arrays::{self, matrix, rows, vector};
use crate::campaign::Campaign;
use crate::{Reduced, error, from_state, guard, lib_error, lib_error_in, reduce, to_state};

/// Where an identification came from (the `source` of the command line's
/// JSON).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Source {
    files: Vec<String>,
    realization: bool,
    dt_s: f64,
    hits: usize,
    samples: usize,
    inputs: Vec<String>,
    outputs: Vec<String>,
    collocated: (usize, usize),
}

/// Everything an identification returns (what `frameid identify --json`
/// prints), kept as the libraries' types.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct IdentState {
    identification: ident::Identification,
    source: Source,
    /// `Vec<records::quality::HitQuality>` as JSON (that type serializes
    /// only): what the command line prints.
    hit_quality_json: String,
    /// `Vec<records::consistency::ConsistencyFlag>` as JSON.
    inconsistent_hits_json: String,
    /// `study::decimate::Decimation` as JSON, when the records were decimated.
    decimation_json: Option<String>,
    /// `study::analysis::InitialStateReport` as JSON, when it was judged.
    initial_state_json: Option<String>,
    consistency_notes: Vec<String>,
    dropped_hits: Vec<String>,
    uncertainty: Option<Jackknife>,
    uncertainty_skipped: Option<String>,
    refinement: Option<Refinement>,
    warnings: Vec<String>,
}

/// The result of ``identify``: modal parameters and M, K and damping, with
/// the diagnostics of ``frameid identify --json`` (same names, same values).
///
/// ``modes`` lists every oscillatory mode of the realization in ascending
/// frequency (``Mode.used`` marks those behind MKR and the Rayleigh fit);
/// ``frequencies_hz``, ``damping_ratios`` and ``mode_shapes`` are those of
/// the modes used. ``uncertainty`` holds the jackknife error bars (``None``
/// with ``uncertainty=False``, fewer than 3 hits or a realization: then
/// ``uncertainty_skipped`` says why), ``refined`` the maximum-likelihood
/// refinement (``refine=True``).
#[pyclass(module = "frameid", frozen)]
pub struct Identification {
    state: IdentState,
}

impl Identification {
    pub fn from_state(bytes: &[u8]) -> PyResult<Self> {
        Ok(Identification {
            state: from_state(bytes)?,
        })
    }
}

#[pymethods]
impl Identification {
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

    /// Damping matrix from MKR (the paper's eq. 30), N s/m.
    #[getter]
    fn damping_mkr<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        matrix(py, &self.state.identification.damping_mkr)
    }

    /// Rayleigh damping ``alpha M + beta K``, N s/m.
    #[getter]
    fn damping_rayleigh<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        matrix(py, &self.state.identification.damping_rayleigh)
    }

    /// Every oscillatory mode, ascending frequency.
    #[getter]
    fn modes(&self) -> Vec<Mode> {
        let id = &self.state.identification;
        id.modes
            .iter()
            .enumerate()
            .map(|(i, m)| Mode {
                state: ModeState {
                    mode: m.clone(),
                    used: id.mkr_modes.contains(&i),
                },
            })
            .collect()
    }

    /// Indices into ``modes`` of the modes used by MKR and the Rayleigh fit.
    #[getter]
    fn used_modes(&self) -> Vec<usize> {
        self.state.identification.mkr_modes.clone()
    }

    /// Natural frequencies of the modes used, Hz.
    #[getter]
    fn frequencies_hz<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vector(py, &self.state.identification.frequencies_hz)
    }

    /// Damping ratios of the modes used.
    #[getter]
    fn damping_ratios<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vector(py, &self.state.identification.damping_ratios)
    }

    /// Complex output shapes of the modes used, one column per mode
    /// (largest component 1).
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

    /// State dimension of the realization.
    #[getter]
    fn model_order(&self) -> usize {
        self.state.identification.model_order
    }

    /// The intersample assumption used (``"bandlimited"`` or ``"zoh"``).
    #[getter]
    fn intersample(&self) -> &'static str {
        self.state.identification.intersample.name()
    }

    /// Whether the input polarity was found inverted and flipped.
    #[getter]
    fn polarity_flipped(&self) -> bool {
        self.state.identification.polarity_flipped
    }

    /// Warnings, naming the files: failed quality checks, dropped hits,
    /// the identification's and the error bars'.
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.state.warnings.clone()
    }

    /// Quality checks of every hit given (dicts, as ``hit_quality`` of the
    /// command line's JSON; empty for a realization).
    #[getter]
    fn hit_quality<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        arrays::json(py, &self.state.hit_quality_json)
    }

    /// Hits inconsistent with the others (dead, copied or spiked channels,
    /// duplicates, level, spectrum or residual against the joint model):
    /// dicts with ``record`` (zero-based position in the campaign given),
    /// ``file``, ``channel``, ``kind`` and ``message``, as
    /// ``inconsistent_hits`` of the command line's JSON.
    #[getter]
    fn inconsistent_hits<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        arrays::json(py, &self.state.inconsistent_hits_json)
    }

    /// The decimation before identification (a dict as ``decimation`` of
    /// the command line's JSON: ``factor``, ``chosen``, ``original_rate_hz``,
    /// ``rate_hz``, ``reason``, ``filter``...), or ``None`` when the records
    /// were identified at their own rate.
    #[getter]
    fn decimation<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        self.state
            .decimation_json
            .as_deref()
            .map(|j| arrays::json(py, j))
            .transpose()
    }

    /// The initial state assumed and why (a dict as ``initial_state`` of
    /// the command line's JSON: ``assumed``, ``chosen``, ``reason``), or
    /// ``None`` when nothing was judged (hammer records under ``"auto"``).
    #[getter]
    fn initial_state<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        self.state
            .initial_state_json
            .as_deref()
            .map(|j| arrays::json(py, j))
            .transpose()
    }

    /// Findings of the consistency checks that flag no hit.
    #[getter]
    fn consistency_notes(&self) -> Vec<String> {
        self.state.consistency_notes.clone()
    }

    /// How the modes of the model were chosen: ``"all-structural"``,
    /// ``"shear-frame"``, ``"significance"``, ``"band"`` or ``"near"``.
    #[getter]
    fn mode_selection(&self) -> String {
        serde_json::to_value(self.state.identification.mode_selection)
            .ok()
            .and_then(|v| v.as_str().map(str::to_string))
            .unwrap_or_default()
    }

    /// Indices into ``modes`` of the structural modes the model does not use
    /// (``out_of_model_modes`` of the command line's JSON lists the modes).
    #[getter]
    fn out_of_model_modes(&self) -> Vec<usize> {
        self.state.identification.out_of_model_modes()
    }

    /// Labels (files) of the hits left out: inconsistent ones, and with
    /// ``drop_bad_hits=True`` those failing a quality check.
    #[getter]
    fn dropped_hits(&self) -> Vec<String> {
        self.state.dropped_hits.clone()
    }

    /// Jackknife error bars over the hits, or ``None``.
    #[getter]
    fn uncertainty(&self) -> Option<Uncertainty> {
        self.state
            .uncertainty
            .clone()
            .map(|state| Uncertainty { state })
    }

    /// Why there are no error bars, if there are none.
    #[getter]
    fn uncertainty_skipped(&self) -> Option<String> {
        self.state.uncertainty_skipped.clone()
    }

    /// The maximum-likelihood refinement (``refine=True``), or ``None``.
    #[getter]
    fn refined(&self) -> Option<Refined> {
        self.state.refinement.clone().map(|state| Refined { state })
    }

    /// Singular values of the Hankel matrix (empty for a realization).
    #[getter]
    fn hankel_singular_values<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        arrays::dvector(py, &self.state.identification.hankel_singular_values)
    }

    /// What OKID did (a dict: ``order``, ``leads``, ``rcond``, ``rank``,
    /// ``unknowns``, ``spectral_radius``, ``relative_residual``...), or
    /// ``None`` for a realization.
    #[getter]
    fn observer<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        arrays::to_python(py, &self.state.identification.observer)
    }

    /// The discrete realization ``x[k+1] = A x[k] + B u[k]``,
    /// ``y[k] = C x[k] + D u[k]`` as a dict of arrays ``a``, ``b``, ``c``,
    /// ``d`` and ``dt_s`` (polarity corrected if it was flipped).
    #[getter]
    fn realization<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, pyo3::types::PyDict>> {
        let r = &self.state.identification.realization;
        let d = pyo3::types::PyDict::new(py);
        d.set_item("a", matrix(py, &r.a))?;
        d.set_item("b", matrix(py, &r.b))?;
        d.set_item("c", matrix(py, &r.c))?;
        d.set_item("d", matrix(py, &r.d))?;
        d.set_item("dt_s", r.dt_s)?;
        Ok(d)
    }

    /// Labels (files) of the hits identified, or the realization file.
    #[getter]
    fn files(&self) -> Vec<String> {
        self.state.source.files.clone()
    }

    /// Whether this is the identification of a given realization.
    #[getter(from_realization)]
    fn is_realization(&self) -> bool {
        self.state.source.realization
    }

    /// Sampling interval, s.
    #[getter]
    fn dt_s(&self) -> f64 {
        self.state.source.dt_s
    }

    /// Hits identified (0 for a realization).
    #[getter]
    fn hits(&self) -> usize {
        self.state.source.hits
    }

    /// Samples per hit (0 for a realization).
    #[getter]
    fn samples(&self) -> usize {
        self.state.source.samples
    }

    /// Input channel names.
    #[getter]
    fn inputs(&self) -> Vec<String> {
        self.state.source.inputs.clone()
    }

    /// Output channel names, in DOF order.
    #[getter]
    fn outputs(&self) -> Vec<String> {
        self.state.source.outputs.clone()
    }

    /// The collocated pair used, zero-based ``(output, input)``.
    #[getter]
    fn collocated(&self) -> (usize, usize) {
        self.state.source.collocated
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
            "Identification(modes used: {}; model order {}; {} warning(s){}{})",
            modes.join(", "),
            id.model_order,
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
            .cast::<Identification>()
            .is_ok_and(|o| o.get().state == self.state)
    }

    fn __reduce__<'py>(&self, py: Python<'py>) -> Reduced<'py> {
        reduce(py, "Identification", to_state(py, &self.state)?)
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct ModeState {
    mode: ident::Mode,
    used: bool,
}

/// One identified mode (a complex-conjugate pair) with its accuracy
/// indicators.
#[pyclass(module = "frameid", frozen)]
pub struct Mode {
    state: ModeState,
}

impl Mode {
    /// One mode of an identification (either route); `used` by MKR.
    pub fn new(mode: ident::Mode, used: bool) -> Self {
        Mode {
            state: ModeState { mode, used },
        }
    }

    pub fn from_state(bytes: &[u8]) -> PyResult<Self> {
        Ok(Mode {
            state: from_state(bytes)?,
        })
    }
}

#[pymethods]
impl Mode {
    /// Natural frequency ``|λ| / 2π``, Hz.
    #[getter]
    fn frequency_hz(&self) -> f64 {
        self.state.mode.frequency_hz
    }

    /// Damping ratio ``-Re(λ) / |λ|``.
    #[getter]
    fn damping_ratio(&self) -> f64 {
        self.state.mode.damping_ratio
    }

    /// Complex output shape (one entry per output), largest component 1.
    #[getter]
    fn mode_shape<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<Complex64>> {
        arrays::complex(py, self.state.mode.shape.as_slice())
    }

    /// Continuous pole λ, rad/s (``Im > 0``).
    #[getter]
    fn pole(&self) -> Complex64 {
        self.state.mode.pole
    }

    /// Output EMAC × input EMAC (``None`` for a realization).
    #[getter]
    fn emac(&self) -> Option<f64> {
        let i = &self.state.mode.indicators;
        i.emac_output.zip(i.emac_input).map(|(o, i)| o * i)
    }

    /// Output EMAC (``None`` for a realization).
    #[getter]
    fn emac_output(&self) -> Option<f64> {
        self.state.mode.indicators.emac_output
    }

    /// Input EMAC (``None`` for a realization).
    #[getter]
    fn emac_input(&self) -> Option<f64> {
        self.state.mode.indicators.emac_input
    }

    /// Modal phase collinearity in [0, 1].
    #[getter]
    fn mpc(&self) -> f64 {
        self.state.mode.indicators.mpc
    }

    /// Modal singular value.
    #[getter]
    fn msv(&self) -> f64 {
        self.state.mode.indicators.msv
    }

    /// Consistent-mode indicator in [0, 1].
    #[getter]
    fn cmi(&self) -> f64 {
        self.state.mode.indicators.cmi
    }

    /// Whether the structural-mode rule accepts it.
    #[getter]
    fn structural(&self) -> bool {
        self.state.mode.structural
    }

    /// Whether MKR and the Rayleigh fit use it.
    #[getter]
    fn used(&self) -> bool {
        self.state.used
    }

    fn __repr__(&self) -> String {
        let m = &self.state.mode;
        format!(
            "Mode({:.6} Hz, damping ratio {:.6}, structural {}, used {})",
            m.frequency_hz, m.damping_ratio, m.structural, self.state.used
        )
    }

    fn __reduce__<'py>(&self, py: Python<'py>) -> Reduced<'py> {
        reduce(py, "Mode", to_state(py, &self.state)?)
    }
}

/// Jackknife error bars (delete-one over the hits): for every quantity the
/// mean of the leave-one-out results (``*_mean``) and the standard error of
/// the joint result (``*_std``). Per-mode lists follow the modes used.
#[pyclass(module = "frameid", frozen)]
pub struct Uncertainty {
    state: Jackknife,
}

impl Uncertainty {
    pub fn from_state(bytes: &[u8]) -> PyResult<Self> {
        Ok(Uncertainty {
            state: from_state(bytes)?,
        })
    }
}

#[pymethods]
impl Uncertainty {
    /// ``"jackknife"`` (one hit left out per resample) or ``"grouped jackknife"`` (more
    /// than 20 hits: one group of hits left out per resample).
    #[getter]
    fn method(&self) -> String {
        self.state.method.clone()
    }
    /// Hits in the joint identification.
    #[getter]
    fn hits(&self) -> usize {
        self.state.hits
    }
    /// Groups of hits, one left out per resample (the hits, up to 20).
    #[getter]
    fn groups(&self) -> usize {
        self.state.groups
    }
    /// Resamples identified.
    #[getter]
    fn resamples(&self) -> usize {
        self.state.resamples
    }
    /// Resamples that failed (dicts with ``left_out`` and ``error``).
    #[getter]
    fn failed<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        arrays::to_python(py, &self.state.failed)
    }
    /// Model order of every resample.
    #[getter]
    fn model_order(&self) -> usize {
        self.state.model_order
    }
    /// Observer order of every resample.
    #[getter]
    fn observer_order(&self) -> Option<usize> {
        self.state.observer_order
    }
    #[getter]
    fn frequencies_hz_mean<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vector(py, &self.state.frequencies_hz.mean)
    }
    /// Standard errors of the frequencies of the modes used, Hz.
    #[getter]
    fn frequencies_hz_std<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vector(py, &self.state.frequencies_hz.std)
    }
    #[getter]
    fn damping_ratios_mean<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vector(py, &self.state.damping_ratios.mean)
    }
    /// Standard errors of the damping ratios of the modes used.
    #[getter]
    fn damping_ratios_std<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vector(py, &self.state.damping_ratios.std)
    }
    #[getter]
    fn rayleigh_alpha_mean(&self) -> f64 {
        self.state.rayleigh_alpha.mean
    }
    #[getter]
    fn rayleigh_alpha_std(&self) -> f64 {
        self.state.rayleigh_alpha.std
    }
    #[getter]
    fn rayleigh_beta_mean(&self) -> f64 {
        self.state.rayleigh_beta.mean
    }
    #[getter]
    fn rayleigh_beta_std(&self) -> f64 {
        self.state.rayleigh_beta.std
    }
    #[getter]
    fn mass_mean<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        rows(py, &self.state.mass.mean)
    }
    /// Standard errors of M, kg.
    #[getter]
    fn mass_std<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        rows(py, &self.state.mass.std)
    }
    #[getter]
    fn stiffness_mean<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        rows(py, &self.state.stiffness.mean)
    }
    /// Standard errors of K, N/m.
    #[getter]
    fn stiffness_std<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        rows(py, &self.state.stiffness.std)
    }
    #[getter]
    fn damping_mkr_mean<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        rows(py, &self.state.damping_mkr.mean)
    }
    #[getter]
    fn damping_mkr_std<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        rows(py, &self.state.damping_mkr.std)
    }
    #[getter]
    fn damping_rayleigh_mean<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        rows(py, &self.state.damping_rayleigh.mean)
    }
    #[getter]
    fn damping_rayleigh_std<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        rows(py, &self.state.damping_rayleigh.std)
    }
    /// Everything as a dict (the ``uncertainty`` of the command line's JSON).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        arrays::to_python(py, &self.state)
    }
    fn __repr__(&self) -> String {
        format!(
            "Uncertainty({} over {} hits, {} resamples, {} failed)",
            self.state.method,
            self.state.hits,
            self.state.resamples,
            self.state.failed.len()
        )
    }
    fn __reduce__<'py>(&self, py: Python<'py>) -> Reduced<'py> {
        reduce(py, "Uncertainty", to_state(py, &self.state)?)
    }
}

/// The maximum-likelihood refinement of M, K and the damping matrix over
/// all hits, with standard errors from the Fisher information (``*_std``).
#[pyclass(module = "frameid", frozen)]
pub struct Refined {
    state: Refinement,
}

impl Refined {
    pub fn from_state(bytes: &[u8]) -> PyResult<Self> {
        Ok(Refined {
            state: from_state(bytes)?,
        })
    }
}

#[pymethods]
impl Refined {
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
            .map(|m| RefinedMode { state: m.clone() })
            .collect()
    }
    /// Estimated noise standard deviation per output, m/s².
    #[getter]
    fn noise_outputs<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vector(py, &self.state.noise.outputs)
    }
    /// Estimated noise standard deviation per input, N.
    #[getter]
    fn noise_inputs<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vector(py, &self.state.noise.inputs)
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
    #[getter]
    fn cost(&self) -> f64 {
        self.state.cost
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
            "Refined({} parameters, {} iterations, stopped on {:?})",
            self.state.parameters.len(),
            self.state.iterations,
            self.state.stop
        )
    }
    fn __reduce__<'py>(&self, py: Python<'py>) -> Reduced<'py> {
        reduce(py, "Refined", to_state(py, &self.state)?)
    }
}

/// A mode of the refined model with standard errors (delta method).
#[pyclass(module = "frameid", frozen)]
pub struct RefinedMode {
    state: ModalEstimate,
}

impl RefinedMode {
    /// A refined mode (either route).
    pub fn new(state: ModalEstimate) -> Self {
        RefinedMode { state }
    }

    pub fn from_state(bytes: &[u8]) -> PyResult<Self> {
        Ok(RefinedMode {
            state: from_state(bytes)?,
        })
    }
}

#[pymethods]
impl RefinedMode {
    #[getter]
    fn frequency_hz(&self) -> f64 {
        self.state.frequency_hz
    }
    #[getter]
    fn frequency_std_hz(&self) -> f64 {
        self.state.frequency_std_hz
    }
    #[getter]
    fn damping_ratio(&self) -> f64 {
        self.state.damping_ratio
    }
    #[getter]
    fn damping_ratio_std(&self) -> f64 {
        self.state.damping_ratio_std
    }
    /// Complex output shape, largest component 1.
    #[getter]
    fn mode_shape<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<Complex64>> {
        arrays::complex(py, self.state.shape.as_slice())
    }
    /// Standard deviations of the real and imaginary parts of the shape.
    #[getter]
    fn mode_shape_std<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<Complex64>> {
        let v: Vec<Complex64> = self
            .state
            .shape_std_re
            .iter()
            .zip(self.state.shape_std_im.iter())
            .map(|(re, im)| Complex64::new(*re, *im))
            .collect();
        arrays::complex(py, &v)
    }
    /// Continuous pole, rad/s.
    #[getter]
    fn pole(&self) -> Complex64 {
        self.state.pole
    }
    fn __repr__(&self) -> String {
        format!(
            "RefinedMode({:.6} ± {:.2e} Hz, damping ratio {:.6} ± {:.2e})",
            self.state.frequency_hz,
            self.state.frequency_std_hz,
            self.state.damping_ratio,
            self.state.damping_ratio_std
        )
    }
    fn __reduce__<'py>(&self, py: Python<'py>) -> Reduced<'py> {
        reduce(py, "RefinedMode", to_state(py, &self.state)?)
    }
}

/// One index or channel name of `collocated`.
enum Pick {
    Index(usize),
    Name(String),
}

fn extract_pick(obj: &Bound<'_, PyAny>) -> PyResult<Pick> {
    if let Ok(k) = obj.extract::<i64>() {
        return usize::try_from(k)
            .map(Pick::Index)
            .map_err(|_| error(format!("collocated: index {k} is negative")));
    }
    obj.extract::<String>().map(Pick::Name).map_err(|_| {
        error("collocated: expected (output, input) as zero-based indices or channel names")
    })
}

/// `collocated` as `(output, input)` indices among the names (as the
/// command line's `--collocated OUT:IN`): a pair of zero-based indices or
/// channel names, or the text `"OUT:IN"`.
pub fn resolve_collocated(
    collocated: Option<&Bound<'_, PyAny>>,
    outputs: &[String],
    inputs: &[String],
) -> PyResult<(usize, usize)> {
    let Some(given) = collocated else {
        return Ok((0, 0));
    };
    let (o, i) = if let Ok(text) = given.extract::<String>() {
        let (o, i) = text.split_once(':').ok_or_else(|| {
            error(format!(
                "collocated: expected (output, input) or 'OUT:IN' (e.g. (0, 0) or 'acc1:force'), got '{text}'"
            ))
        })?;
        let pick = |t: &str| match t.trim().parse::<usize>() {
            Ok(k) => Pick::Index(k),
            Err(_) => Pick::Name(t.to_string()),
        };
        (pick(o), pick(i))
    } else {
        let pair: Vec<Bound<'_, PyAny>> = given.extract().map_err(|_| {
            error("collocated: expected (output, input) as zero-based indices or channel names")
        })?;
        let [o, i] = pair.as_slice() else {
            return Err(error(format!(
                "collocated: expected 2 entries (output, input), got {}",
                pair.len()
            )));
        };
        (extract_pick(o)?, extract_pick(i)?)
    };
    let find = |what: &str, pick: Pick, names: &[String]| -> PyResult<usize> {
        match pick {
            Pick::Index(k) if k < names.len() => Ok(k),
            Pick::Index(k) => Err(error(format!(
                "collocated: {what} index {k} is out of range; there are {} {what}s (zero-based)",
                names.len()
            ))),
            Pick::Name(token) => names
                .iter()
                .position(|n| n.eq_ignore_ascii_case(token.trim()))
                .ok_or_else(|| {
                    error(format!(
                        "collocated: no {what} named '{}'; {what}s: {}",
                        token.trim(),
                        names.join(", ")
                    ))
                }),
        }
    };
    Ok((find("output", o, outputs)?, find("input", i, inputs)?))
}

/// A value's JSON text (for the fields kept as the command line prints them).
/// ``decimate=``: ``"auto"``, ``"off"`` or a factor (int, or its text), as
/// ``--decimate``.
#[derive(FromPyObject)]
pub(crate) enum DecimateArg {
    /// A factor given as an int.
    Factor(usize),
    /// ``"auto"``, ``"off"`` or a factor as text.
    Text(String),
}

pub(crate) fn json_text<T: Serialize>(value: &T) -> PyResult<String> {
    serde_json::to_string(value).map_err(|e| error(format!("cannot convert to JSON: {e}")))
}

fn parse_intersample(text: &str) -> PyResult<Intersample> {
    text.parse()
        .map_err(|e: String| error(format!("intersample: {e}")))
}

fn check_observer_order(observer_order: Option<usize>) -> PyResult<()> {
    if observer_order == Some(0) {
        return Err(error("observer_order: must be at least 1"));
    }
    Ok(())
}

/// Identifies modal parameters and M, K and damping from a campaign, as
/// ``frameid identify FILES`` does with the same defaults: quality checks of
/// every hit, the joint identification (OKID, ERA/DC, MKR, Rayleigh), error
/// bars by the jackknife over the hits, and with ``refine=True`` the
/// maximum-likelihood refinement.
///
/// ``collocated``: the collocated (output, input) pair, zero-based indices
/// or channel names (default ``(0, 0)``). ``order``, ``observer_order``:
/// fixed orders (default automatic). ``intersample``: ``"bandlimited"``
/// (analyzer records, default) or ``"zoh"`` (force held per sample).
/// ``strict``: refuse the campaign if any hit fails a check;
/// ``drop_bad_hits``: identify without those hits. ``uncertainty``: the
/// jackknife error bars. ``parametrization`` of the refinement: ``"full"``
/// or ``"shear-frame"``. ``excitation``: ``"auto"`` (default), ``"hammer"``
/// or ``"continuous"`` (shaker records), as ``--excitation``. ``modes``: one
/// frequency per output (Hz), the structural modes nearest them form the
/// model (``--modes``); ``band``: ``(low_hz, high_hz)``, only structural modes
/// inside (``--band``). ``decimate``: ``"auto"`` (default: records sampled
/// far above the modes' band are decimated), ``"off"`` or a factor, as
/// ``--decimate`` (``Identification.decimation`` says what was done).
/// ``initial_state``: ``"auto"`` (default), ``"at-rest"`` or ``"unknown"``
/// (records that do not start at rest), as ``--initial-state``
/// (``Identification.initial_state`` says what was assumed and why).
/// Runs without holding the interpreter.
#[pyfunction]
#[pyo3(signature = (campaign, collocated=None, *, order=None, observer_order=None, intersample="bandlimited", strict=false, drop_bad_hits=false, uncertainty=true, refine=false, parametrization="full", excitation="auto", modes=None, band=None, decimate=DecimateArg::Text("auto".into()), initial_state="auto"))]
#[allow(clippy::too_many_arguments)]
fn identify(
    py: Python<'_>,
    campaign: &Bound<'_, PyAny>,
    collocated: Option<&Bound<'_, PyAny>>,
    order: Option<usize>,
    observer_order: Option<usize>,
    intersample: &str,
    strict: bool,
    drop_bad_hits: bool,
    uncertainty: bool,
    refine: bool,
    parametrization: &str,
    excitation: &str,
    modes: Option<Vec<f64>>,
    band: Option<(f64, f64)>,
    decimate: DecimateArg,
    initial_state: &str,
) -> PyResult<Identification> {
    let excitation: records::quality::Excitation = excitation
        .parse()
        .map_err(|e: String| error(format!("excitation: {e}")))?;
    let decimation: study::decimate::DecimationSetting = match decimate {
        DecimateArg::Factor(n) => n.to_string(),
        DecimateArg::Text(t) => t,
    }
    .parse()
    .map_err(|e: String| error(format!("decimate: {e}")))?;
    let initial_state: study::analysis::InitialStateSetting = initial_state
        .parse()
        .map_err(|e: String| error(format!("initial_state: {e}")))?;
    let mode_selection = match (modes, band) {
        (Some(_), Some(_)) => {
            return Err(error("modes and band: choose one (as --modes and --band)"));
        }
        (Some(frequencies_hz), None) => ident::ModeSelection::Near { frequencies_hz },
        (None, Some((low_hz, high_hz))) => ident::ModeSelection::Band { low_hz, high_hz },
        (None, None) => ident::ModeSelection::Auto,
    };
    let campaign = campaign.cast::<Campaign>().map_err(|_| {
        error("campaign: expected a frameid.Campaign (from frameid.Campaign(force, acc, dt_s), read_records or simulate)")
    })?;
    let c = &campaign.get().inner;
    let files: Option<Vec<records::RecordFile>> = campaign
        .get()
        .files
        .as_ref()
        .map(|f| f.iter().map(|m| m.record_file()).collect());
    check_observer_order(observer_order)?;
    let intersample = parse_intersample(intersample)?;
    let parametrization: ParametrizationSetting = parametrization
        .parse()
        .map_err(|e: String| error(format!("parametrization: {e}")))?;
    if parametrization != ParametrizationSetting::Full && !refine {
        return Err(error(
            "parametrization: applies to the refinement; pass refine=True",
        ));
    }
    if strict && drop_bad_hits {
        return Err(error(
            "strict and drop_bad_hits: choose one (refuse the campaign, or identify without the failing hits)",
        ));
    }
    let collocated = resolve_collocated(collocated, &c.outputs, &c.inputs)?;
    let settings = AnalysisSettings {
        identifier: identifier(intersample, collocated, order, observer_order)
            .mode_selection(mode_selection),
        quality: records::quality::QualitySettings {
            excitation,
            ..Default::default()
        },
        screening: if strict {
            Screening::Strict
        } else if drop_bad_hits {
            Screening::DropBad
        } else {
            Screening::Warn
        },
        uncertainty,
        refine: refine.then_some(parametrization),
        decimation,
        initial_state,
        ..AnalysisSettings::default()
    };
    let state = py.detach(|| {
        guard(|| {
            // Records from files: messages name the line of a sample.
            let a = match &files {
                Some(files) => analyze_located(c, &ByLine(files), &settings),
                None => analyze(c, &settings),
            }
            .map_err(lib_error)?;
            let hit_quality_json = json_text(&a.hit_quality)?;
            // As the command line's JSON: absent when the records were
            // identified at their own rate, or nothing was judged.
            let decimation_json = (a.decimation.factor > 1 || a.decimation.chosen == "given")
                .then(|| json_text(&a.decimation))
                .transpose()?;
            let initial_state_json = a.initial_state.as_ref().map(json_text).transpose()?;
            let inconsistent_hits_json = json_text(&a.consistency.flags)?;
            let ac = &a.campaign;
            Ok(IdentState {
                source: Source {
                    files: ac.labels.clone(),
                    realization: false,
                    dt_s: ac.dt_s,
                    hits: ac.len(),
                    samples: ac.longest(),
                    inputs: ac.inputs.clone(),
                    outputs: ac.outputs.clone(),
                    collocated: (a.collocated.output, a.collocated.input),
                },
                dropped_hits: a
                    .dropped
                    .iter()
                    .map(|&i| a.hit_quality[i].file.clone())
                    .collect(),
                hit_quality_json,
                inconsistent_hits_json,
                decimation_json,
                initial_state_json,
                consistency_notes: a.consistency.notes,
                uncertainty: a.uncertainty,
                uncertainty_skipped: a.uncertainty_skipped,
                refinement: a.refinement,
                warnings: a.warnings,
                identification: a.identification,
            })
        })
    })?;
    Ok(Identification { state })
}

/// Identifies modal parameters and M, K and damping from a discrete
/// realization, as ``frameid identify --realization FILE`` does: a JSON
/// file with ``dt`` (or ``dt_s``), ``A``, ``B``, ``C``, ``D`` as arrays of
/// rows (the paper's published realizations: use ``intersample="zoh"``).
#[pyfunction]
#[pyo3(signature = (path, collocated=None, *, order=None, intersample="bandlimited"))]
fn identify_realization(
    py: Python<'_>,
    path: PathBuf,
    collocated: Option<&Bound<'_, PyAny>>,
    order: Option<usize>,
    intersample: &str,
) -> PyResult<Identification> {
    let intersample = parse_intersample(intersample)?;
    let (realization, names) = py
        .detach(|| records::realization::read_realization(&path))
        .map_err(lib_error)?;
    let collocated = resolve_collocated(collocated, &names.0, &names.1)?;
    let id = identifier(intersample, collocated, order, None);
    let result = py.detach(|| {
        guard(|| {
            id.from_state_space(&realization)
                .map_err(|e| lib_error_in(&path.display().to_string(), e))
        })
    })?;
    let warnings = result.warnings.iter().map(ToString::to_string).collect();
    Ok(Identification {
        state: IdentState {
            source: Source {
                files: vec![path.display().to_string()],
                realization: true,
                dt_s: realization.dt_s,
                hits: 0,
                samples: 0,
                inputs: names.1,
                outputs: names.0,
                collocated,
            },
            identification: result,
            hit_quality_json: "[]".into(),
            decimation_json: None,
            initial_state_json: None,
            inconsistent_hits_json: "[]".into(),
            consistency_notes: Vec::new(),
            dropped_hits: Vec::new(),
            uncertainty: None,
            uncertainty_skipped: None,
            refinement: None,
            warnings,
        },
    })
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Identification>()?;
    m.add_class::<Mode>()?;
    m.add_class::<Uncertainty>()?;
    m.add_class::<Refined>()?;
    m.add_class::<RefinedMode>()?;
    m.add_function(wrap_pyfunction!(identify, m)?)?;
    m.add_function(wrap_pyfunction!(identify_realization, m)?)?;
    Ok(())
}
