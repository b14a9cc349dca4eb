//! `frameid.simulate` (`frameid simulate`: a campaign with known truth) and
//! `frameid.bound` (the Cramér–Rao bound of a scenario, as sweeps compute
//! it at every noise level).

use std::path::{Path, PathBuf};

use num_complex::Complex64;
use numpy::IntoPyArray;
use numpy::ndarray::Array2;
use numpy::{PyArray1, PyArray2};
use pyo3::prelude::*;
use serde::{Deserialize, Serialize};
use sim::{Acquisition, AnalyzerSettings};
use study::experiment::{TrueModel, cramer_rao_bound, noise_at};
use study::truth::HitTruth;
use study::{LoadedScenario, Scenario};

use crate::arrays::{self, rows, vector};
use crate::campaign::Campaign;
use crate::{Reduced, error, from_state, guard, lib_error, lib_error_in, reduce, to_state};

/// Largest record output written without ``force=True``, bytes (as the
/// command line's `MAX_OUTPUT_BYTES`).
pub const MAX_OUTPUT_BYTES: u128 = 1 << 30;

/// Refuses an output estimated above [`MAX_OUTPUT_BYTES`] unless forced
/// (the command line's message, with the keyword for its flag).
pub fn check_output_size(what: &str, bytes: u128, force: bool) -> PyResult<()> {
    if bytes > MAX_OUTPUT_BYTES && !force {
        return Err(error(format!(
            "{what} would take about {:.1} GiB (more than {} GiB); pass force=True to write it anyway",
            bytes as f64 / (1u64 << 30) as f64,
            MAX_OUTPUT_BYTES >> 30
        )));
    }
    Ok(())
}

/// Loads a scenario file with the GIL released.
pub fn load_scenario(py: Python<'_>, path: &Path) -> PyResult<LoadedScenario> {
    py.detach(|| guard(|| LoadedScenario::load(path).map_err(lib_error)))
}

fn check_noise(noise: f64) -> PyResult<()> {
    if !(noise.is_finite() && noise >= 0.0) {
        return Err(error(format!(
            "noise: must be a fraction >= 0, got {noise}"
        )));
    }
    Ok(())
}

fn check_hits(hits: usize) -> PyResult<()> {
    if hits == 0 {
        return Err(error("hits: must be at least 1"));
    }
    Ok(())
}

/// Known truth of a simulated campaign (the contents of ``truth.json``).
///
/// Matrices in kg, N/m, N s/m; ``mode_shapes`` has one column per mode
/// (floors × modes, largest component 1) like ``Identification.mode_shapes``.
#[pyclass(module = "frameid", frozen)]
pub struct Truth {
    state: study::truth::Truth,
}

impl Truth {
    pub fn from_state(bytes: &[u8]) -> PyResult<Self> {
        Ok(Truth {
            state: from_state(bytes)?,
        })
    }
}

#[pymethods]
impl Truth {
    /// Mass matrix with the sensors, as simulated, kg.
    #[getter]
    fn mass<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        rows(py, &self.state.mass)
    }
    /// Mass matrix without the sensors, kg.
    #[getter]
    fn bare_mass<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        rows(py, &self.state.bare_mass)
    }
    /// Sensor mass on each floor, kg.
    #[getter]
    fn sensor_masses_kg<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vector(py, &self.state.sensor_masses_kg)
    }
    /// Stiffness matrix, N/m.
    #[getter]
    fn stiffness<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        rows(py, &self.state.stiffness)
    }
    /// Damping matrix, N s/m.
    #[getter]
    fn damping<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        rows(py, &self.state.damping)
    }
    /// Natural frequencies, Hz, ascending.
    #[getter]
    fn frequencies_hz<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vector(py, &self.state.frequencies_hz)
    }
    /// Damping ratios.
    #[getter]
    fn damping_ratios<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vector(py, &self.state.damping_ratios)
    }
    /// Mode shapes, floors × modes (column j is mode j), largest component 1.
    #[getter]
    fn mode_shapes<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<Complex64>> {
        let s = &self.state.mode_shapes;
        let floors = s.first().map_or(0, Vec::len);
        Array2::from_shape_fn((floors, s.len()), |(i, j)| {
            Complex64::new(s[j][i][0], s[j][i][1])
        })
        .into_pyarray(py)
    }
    /// Sampling interval, s.
    #[getter]
    fn dt_s(&self) -> f64 {
        self.state.dt_s
    }
    /// Floor hit by the hammer, 1-based (the force is collocated with
    /// acceleration channel ``hit_floor``, zero-based ``hit_floor - 1``).
    #[getter]
    fn hit_floor(&self) -> usize {
        self.state.hit_floor
    }
    /// Degrees of freedom (floors).
    #[getter]
    fn dofs(&self) -> usize {
        self.state.dofs
    }
    /// Seed of the campaign.
    #[getter]
    fn seed(&self) -> u64 {
        self.state.seed
    }
    /// Scenario name.
    #[getter]
    fn scenario(&self) -> String {
        self.state.scenario.clone()
    }
    /// Per hit: ``file`` and the ``pulses`` applied (dicts).
    #[getter]
    fn hits<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        arrays::to_python(py, &self.state.hits)
    }
    /// The scenario as used, overrides applied (a dict).
    #[getter]
    fn settings<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        arrays::to_python(py, &self.state.settings)
    }
    /// The text of ``truth.json`` (as ``frameid simulate`` writes it).
    fn to_json(&self) -> PyResult<String> {
        let mut text = serde_json::to_string_pretty(&self.state)
            .map_err(|e| error(format!("cannot serialize to JSON: {e}")))?;
        text.push('\n');
        Ok(text)
    }
    fn __repr__(&self) -> String {
        let s = &self.state;
        let f: Vec<String> = s.frequencies_hz.iter().map(|f| format!("{f:.4}")).collect();
        format!(
            "Truth({}: {} floors, {} Hz, seed {})",
            s.scenario,
            s.dofs,
            f.join(", "),
            s.seed
        )
    }
    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other
            .cast::<Truth>()
            .is_ok_and(|o| o.get().state == self.state)
    }
    fn __reduce__<'py>(&self, py: Python<'py>) -> Reduced<'py> {
        reduce(py, "Truth", to_state(py, &self.state)?)
    }
}

/// Bytes a value takes in a record file (as the command line estimates
/// them): up to 24 in CSV, 21 in UFF ASCII, 8 in binary UFF.
fn bytes_per_value(format: records::Format) -> u128 {
    match format {
        records::Format::Csv { .. } => 24,
        records::Format::Uff58Ascii => 21,
        records::Format::Uff58Binary => 8,
    }
}

fn parse_format(text: &str) -> PyResult<records::Format> {
    match text {
        "csv" => Ok(records::Format::Csv { delimiter: b',' }),
        "uff" => Ok(records::Format::Uff58Ascii),
        "uff-binary" => Ok(records::Format::Uff58Binary),
        other => Err(error(format!(
            "format: expected `csv`, `uff` or `uff-binary`, got `{other}`"
        ))),
    }
}

/// Simulates a hammer campaign of a scenario file, as ``frameid simulate``
/// does: returns ``(campaign, truth)``.
///
/// ``hits``, ``noise`` (a fraction of each channel's RMS) and
/// ``acquisition`` (``"analyzer"`` or ``"held"``) override the scenario.
/// With ``out`` the records (``format``: ``"csv"``, ``"uff"``,
/// ``"uff-binary"``) and ``truth.json`` are also written there, replacing
/// an earlier campaign; ``force=True`` writes more than 1 GiB.
#[pyfunction]
#[pyo3(signature = (scenario, *, hits=None, noise=None, seed=1, acquisition=None, out=None, format="csv", force=false))]
#[allow(clippy::too_many_arguments)]
fn simulate(
    py: Python<'_>,
    scenario: PathBuf,
    hits: Option<usize>,
    noise: Option<f64>,
    seed: u64,
    acquisition: Option<&str>,
    out: Option<PathBuf>,
    format: &str,
    force: bool,
) -> PyResult<(Campaign, Truth)> {
    if let Some(h) = hits {
        check_hits(h)?;
    }
    if let Some(n) = noise {
        check_noise(n)?;
    }
    let format = parse_format(format)?;
    let loaded = load_scenario(py, &scenario)?;
    let mut s: Scenario = loaded.scenario.clone();
    if let Some(h) = hits {
        s.campaign.hits = h;
    }
    if let Some(n) = noise {
        s.campaign.noise.fraction = n;
    }
    match acquisition {
        None => {}
        Some("held") => s.campaign.acquisition = Acquisition::Held,
        Some("analyzer") => {
            if matches!(s.campaign.acquisition, Acquisition::Held) {
                s.campaign.acquisition = Acquisition::Analyzer(AnalyzerSettings::default());
            }
        }
        Some(other) => {
            return Err(error(format!(
                "acquisition: expected `analyzer` or `held`, got `{other}`"
            )));
        }
    }
    let (campaign, truth) = py.detach(|| {
        guard(|| {
            let simulator = s.simulator(loaded.model.clone()).map_err(|e| match e {
                // The hit count may come from `hits`: name the argument.
                sim::SimError::Invalid { field, problem }
                    if field == "campaign.hits" && hits.is_some() =>
                {
                    error(format!("hits: {problem}"))
                }
                other => lib_error_in(&scenario.display().to_string(), other),
            })?;
            if let Some(out) = &out {
                let c = &s.campaign;
                check_output_size(
                    &out.display().to_string(),
                    c.hits as u128
                        * c.sampling.samples as u128
                        * (loaded.model.dofs() as u128 + 1)
                        * bytes_per_value(format),
                    force,
                )?;
            }
            let campaign = simulator.simulate(seed);
            let files: Vec<String> = match &out {
                Some(dir) => {
                    study::campaign_dir::write_campaign(dir, &loaded, &s, seed, &campaign, format)
                        .map_err(lib_error)?
                        .iter()
                        .map(|p| {
                            p.file_name()
                                .map(|n| n.to_string_lossy().into_owned())
                                .unwrap_or_default()
                        })
                        .collect()
                }
                None => (1..=campaign.hits.len())
                    .map(|h| format!("hit {h}"))
                    .collect(),
            };
            let hit_truth = files
                .into_iter()
                .zip(&campaign.hits)
                .map(|(file, h)| HitTruth {
                    file,
                    pulses: h.pulses.clone(),
                })
                .collect();
            let truth = study::truth::Truth::new(&loaded.model, &s, seed, hit_truth)
                .map_err(|e| lib_error_in(&scenario.display().to_string(), e))?;
            Ok((campaign.to_ident(), truth))
        })
    })?;
    Ok((Campaign::from_ident(campaign), Truth { state: truth }))
}

/// The Cramér–Rao bound as relative standard deviations: per mode of the
/// natural frequency and the damping ratio, and of M, K and the damping
/// matrix as ``sqrt(sum of entry variances) / ||true||_F`` (the RMS
/// relative Frobenius error of an efficient unbiased estimator).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct BoundState {
    bound: study::experiment::Bound,
    noise: f64,
    seed: u64,
    scenario: String,
}

/// The Cramér–Rao bound of a scenario at one noise level (see ``bound``).
#[pyclass(module = "frameid", name = "Bound", frozen)]
pub struct CramerRao {
    state: BoundState,
}

impl CramerRao {
    pub fn from_state(bytes: &[u8]) -> PyResult<Self> {
        Ok(CramerRao {
            state: from_state(bytes)?,
        })
    }
}

#[pymethods]
impl CramerRao {
    /// Per mode: relative standard deviation of the natural frequency.
    #[getter]
    fn frequencies<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vector(py, &self.state.bound.frequencies)
    }
    /// Per mode: relative standard deviation of the damping ratio.
    #[getter]
    fn damping_ratios<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vector(py, &self.state.bound.damping_ratios)
    }
    /// Mass matrix, relative (Frobenius).
    #[getter]
    fn mass(&self) -> f64 {
        self.state.bound.mass
    }
    /// Stiffness matrix, relative (Frobenius).
    #[getter]
    fn stiffness(&self) -> f64 {
        self.state.bound.stiffness
    }
    /// Damping matrix, relative (Frobenius).
    #[getter]
    fn damping(&self) -> f64 {
        self.state.bound.damping
    }
    /// The noise level, a fraction of each channel's RMS.
    #[getter]
    fn noise(&self) -> f64 {
        self.state.noise
    }
    /// The sweep seed whose campaign's pulses the bound is for.
    #[getter]
    fn seed(&self) -> u64 {
        self.state.seed
    }
    /// As a dict (the ``bound`` of a sweep's ``summary.json``).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        arrays::to_python(py, &self.state.bound)
    }
    fn __repr__(&self) -> String {
        let b = &self.state.bound;
        format!(
            "Bound({} at noise {}: M {:.3e}, K {:.3e}, damping {:.3e})",
            self.state.scenario, self.state.noise, b.mass, b.stiffness, b.damping
        )
    }
    fn __reduce__<'py>(&self, py: Python<'py>) -> Reduced<'py> {
        reduce(py, "Bound", to_state(py, &self.state)?)
    }
}

/// The Cramér–Rao bound of a scenario at noise level ``noise`` (a fraction
/// of each channel's RMS, plus the scenario's absolute noise), for records
/// as acquired and the scenario's refinement parametrization: the best
/// accuracy any unbiased estimator can reach. It is the bound a sweep with
/// seed ``seed`` reports at that level (same campaign pulses, noise free).
/// ``hits`` overrides the scenario's.
#[pyfunction]
#[pyo3(signature = (scenario, noise, *, seed=1, hits=None))]
fn bound(
    py: Python<'_>,
    scenario: PathBuf,
    noise: f64,
    seed: u64,
    hits: Option<usize>,
) -> PyResult<CramerRao> {
    check_noise(noise)?;
    if let Some(h) = hits {
        check_hits(h)?;
    }
    let loaded = load_scenario(py, &scenario)?;
    let mut s = loaded.scenario.clone();
    if let Some(h) = hits {
        s.campaign.hits = h;
    }
    let b = py.detach(|| {
        guard(|| {
            let context = scenario.display().to_string();
            let truth = TrueModel::new(loaded.model.clone()).map_err(|e| lib_error_in(&context, e))?;
            let simulator = s
                .simulator(truth.model.clone())
                .map_err(|e| match e {
                    sim::SimError::Invalid { field, problem }
                        if field == "campaign.hits" && hits.is_some() =>
                    {
                        error(format!("hits: {problem}"))
                    }
                    other => lib_error_in(&context, other),
                })?;
            let levels = noise_at(&s.campaign.noise, noise);
            if levels.sigma(1.0, true) == 0.0 && levels.sigma(1.0, false) == 0.0 {
                return Err(error(format!(
                    "noise: {context} has no noise at level {noise}: noise-free records bound nothing (sweeps report no bound there)"
                )));
            }
            cramer_rao_bound(
                &simulator,
                &s.refiner(),
                s.acquisition_intersample(),
                &truth,
                &levels,
                sim::derive_seed(seed, study::sweep::BOUND_TAG),
            )
            .map_err(|e| lib_error_in(&context, e))
        })
    })?;
    Ok(CramerRao {
        state: BoundState {
            bound: b,
            noise,
            seed,
            scenario: s.name,
        },
    })
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Truth>()?;
    m.add_class::<CramerRao>()?;
    m.add_function(wrap_pyfunction!(simulate, m)?)?;
    m.add_function(wrap_pyfunction!(bound, m)?)?;
    Ok(())
}
