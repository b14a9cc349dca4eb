//! `frameid.sweep` (`frameid sweep`), `frameid.merge` (`frameid merge`)
//! and `frameid.report` (`frameid report`), with the `Sweep` result.
//!
//! A sweep runs in memory, or, given `out`, writes its directory as the
//! command line does. Shards merge in memory (from `Sweep` objects, e.g.
//! returned by Dask workers) or from directories; either way the result is
//! byte for byte what one run gives (`trials_csv()`, `summary_json()` and
//! the files `write` puts in a directory).

use std::path::{Path, PathBuf};

use numpy::IntoPyArray;
use numpy::PyArray1;
use numpy::PyArray2;
use numpy::ndarray::Array2;
use pyo3::prelude::*;
use serde::{Deserialize, Serialize};
use study::sweep::{self as lib, Manifest, Outcome, Plan, Shard, TrialRow};

use crate::arrays::{self, vector};
use crate::simulation::{check_output_size, load_scenario};
use crate::{Reduced, error, from_state, guard, lib_error, reduce, to_state};

/// Most worker threads (as the command line's `MAX_THREADS`).
const MAX_THREADS: usize = 1024;

/// A sweep or one shard of it, in memory.
#[derive(Debug, Clone, PartialEq)]
struct SweepData {
    manifest: Manifest,
    rows: Vec<TrialRow>,
    /// `summary.json` as written (complete sweeps only).
    summary_json: Option<String>,
    /// Where it was written, if it was.
    path: Option<PathBuf>,
    /// Things the user should know (no representative campaign).
    warnings: Vec<String>,
}

/// The pickled form: the manifest as in `sweep.json`, the rows as in
/// `trials.csv` (shortest round-trip numbers: lossless), the summary's text.
#[derive(Debug, Serialize, Deserialize)]
struct SweepState {
    manifest_json: String,
    trials_csv: String,
    summary_json: Option<String>,
    path: Option<PathBuf>,
    warnings: Vec<String>,
}

/// `summary.json`'s text (as `study::write_json` writes it: pretty, final
/// newline).
fn summary_text(summary: &lib::Summary) -> PyResult<String> {
    let mut text = serde_json::to_string_pretty(summary)
        .map_err(|e| error(format!("cannot serialize the summary: {e}")))?;
    text.push('\n');
    Ok(text)
}

fn trials_text(m: &Manifest, rows: &[TrialRow]) -> PyResult<String> {
    let bytes = lib::format_trials(Path::new("trials.csv"), &m.plan, &m.plan.score_keys(), rows)
        .map_err(lib_error)?;
    String::from_utf8(bytes).map_err(|e| error(format!("trials.csv is not UTF-8: {e}")))
}

/// Reads a sweep directory (written by a sweep, a shard or a merge).
fn read_dir(dir: &Path) -> PyResult<SweepData> {
    let manifest = lib::read_manifest(dir).map_err(lib_error)?;
    let rows = lib::read_trials(
        &dir.join("trials.csv"),
        &manifest.plan,
        &manifest.plan.score_keys(),
    )
    .map_err(lib_error)?;
    let summary_path = dir.join("summary.json");
    let summary_json = if manifest.shard.is_none() {
        Some(
            std::fs::read_to_string(&summary_path)
                .map_err(|e| error(format!("{}: cannot read: {e}", summary_path.display())))?,
        )
    } else {
        None
    };
    Ok(SweepData {
        manifest,
        rows,
        summary_json,
        path: Some(dir.to_path_buf()),
        warnings: Vec::new(),
    })
}

/// Writes a sweep's directory as the command line does (`trials.csv`,
/// `sweep.json`, and for a whole sweep `summary.json` and
/// `representative.json`), whole or not at all; returns the warnings.
fn write_dir(out: &Path, data: &SweepData) -> PyResult<Vec<String>> {
    let plan = &data.manifest.plan;
    let keys = plan.score_keys();
    let dir = fsio::OutputDir::create(out, "sweep.json").map_err(lib_error)?;
    let mut warnings = Vec::new();
    if data.manifest.shard.is_none() {
        let truth = lib::plan_truth(plan).map_err(lib_error)?;
        let summary = lib::summarize(plan, &truth, &keys, &data.rows);
        lib::write_dir(
            dir.path(),
            &data.manifest,
            &keys,
            &data.rows,
            Some(&summary),
        )
        .map_err(lib_error)?;
        warnings = lib::write_representative(&plan.scenario, &truth, plan.seed, dir.path())
            .map_err(lib_error)?;
    } else {
        lib::write_dir(dir.path(), &data.manifest, &keys, &data.rows, None).map_err(lib_error)?;
    }
    dir.commit().map_err(lib_error)?;
    Ok(warnings)
}

/// The result of ``sweep`` or ``merge``: one row per trial in canonical
/// order (axis value, noise level, trial) with its scores, and for a whole
/// sweep the summary (medians, percentiles, failure rates, the Cramér–Rao
/// bound and efficiencies per noise level, as ``summary.json``).
///
/// ``trials_csv()`` and ``summary_json()`` are the bytes of the files the
/// command line writes; ``write(out)`` writes the directory.
#[pyclass(module = "frameid", frozen)]
pub struct Sweep {
    data: SweepData,
}

impl Sweep {
    pub fn from_state(bytes: &[u8]) -> PyResult<Self> {
        let s: SweepState = from_state(bytes)?;
        let manifest: Manifest = serde_json::from_str(&s.manifest_json)
            .map_err(|e| error(format!("cannot unpickle the sweep: {e}")))?;
        let rows = lib::parse_trials(
            s.trials_csv.as_bytes(),
            Path::new("trials.csv"),
            &manifest.plan,
            &manifest.plan.score_keys(),
        )
        .map_err(lib_error)?;
        Ok(Sweep {
            data: SweepData {
                manifest,
                rows,
                summary_json: s.summary_json,
                path: s.path,
                warnings: s.warnings,
            },
        })
    }

    fn plan(&self) -> &Plan {
        &self.data.manifest.plan
    }

    /// A name for messages: the directory, or the shard.
    fn name(&self) -> String {
        match (&self.data.path, self.data.manifest.shard) {
            (Some(p), _) => p.display().to_string(),
            (None, Some(s)) => format!("shard {}/{}", s.index, s.count),
            (None, None) => "a whole sweep".to_string(),
        }
    }
}

#[pymethods]
impl Sweep {
    /// Scenario name.
    #[getter]
    fn scenario(&self) -> String {
        self.plan().scenario.name.clone()
    }
    /// The scenario file as given.
    #[getter]
    fn scenario_path(&self) -> String {
        self.data.manifest.scenario_path.clone()
    }
    /// Noise levels, fractions of each channel's RMS.
    #[getter]
    fn noise_levels(&self) -> Vec<f64> {
        self.plan().noise_levels.clone()
    }
    /// Trials per noise level (and axis value).
    #[getter]
    fn trials(&self) -> usize {
        self.plan().trials
    }
    /// Base seed.
    #[getter]
    fn seed(&self) -> u64 {
        self.plan().seed
    }
    /// ``(k, n)`` for shard k of n, ``None`` for a whole sweep.
    #[getter]
    fn shard(&self) -> Option<(usize, usize)> {
        self.data.manifest.shard.map(|s| (s.index, s.count))
    }
    /// Whether this is a whole sweep (a run without shard, or a merge).
    #[getter]
    fn complete(&self) -> bool {
        self.data.manifest.shard.is_none()
    }
    /// The plan (scenario as used, noise levels, trials, seed, axis) as a dict.
    #[getter(plan)]
    fn plan_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        arrays::to_python(py, self.plan())
    }
    /// Score names, the columns of ``scores`` (as in ``trials.csv``).
    #[getter]
    fn score_names(&self) -> Vec<String> {
        self.plan()
            .score_keys()
            .iter()
            .map(ToString::to_string)
            .collect()
    }
    /// Scores, trials × ``score_names`` (NaN for failed trials).
    #[getter]
    fn scores<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let keys = self.plan().score_keys().len();
        let rows = &self.data.rows;
        Array2::from_shape_fn((rows.len(), keys), |(r, k)| match &rows[r].outcome {
            Outcome::Ok { scores, .. } => scores[k],
            Outcome::Failed { .. } => f64::NAN,
        })
        .into_pyarray(py)
    }
    /// One score column by name (NaN for failed trials).
    fn column<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let names = self.score_names();
        let k = names.iter().position(|n| n == name).ok_or_else(|| {
            error(format!(
                "no score named '{name}'; scores: {}",
                names.join(", ")
            ))
        })?;
        let v: Vec<f64> = self
            .data
            .rows
            .iter()
            .map(|r| match &r.outcome {
                Outcome::Ok { scores, .. } => scores[k],
                Outcome::Failed { .. } => f64::NAN,
            })
            .collect();
        Ok(vector(py, &v))
    }
    /// Noise level of every trial.
    #[getter]
    fn noise<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        let levels = &self.plan().noise_levels;
        let v: Vec<f64> = self.data.rows.iter().map(|r| levels[r.key.noise]).collect();
        vector(py, &v)
    }
    /// Trial number (within its cell) of every trial.
    #[getter]
    fn trial(&self) -> Vec<usize> {
        self.data.rows.iter().map(|r| r.key.trial).collect()
    }
    /// Axis value label of every trial (``""`` without an axis).
    #[getter]
    fn axis(&self) -> Vec<String> {
        self.data
            .rows
            .iter()
            .map(|r| self.plan().axis_label(r.key.axis))
            .collect()
    }
    /// Seed of every trial.
    #[getter]
    fn seeds(&self) -> Vec<u64> {
        self.data.rows.iter().map(|r| r.seed).collect()
    }
    /// ``"ok"`` or ``"failed"`` per trial.
    #[getter]
    fn status(&self) -> Vec<&'static str> {
        self.data
            .rows
            .iter()
            .map(|r| match r.outcome {
                Outcome::Ok { .. } => "ok",
                Outcome::Failed { .. } => "failed",
            })
            .collect()
    }
    /// Why a trial failed (or its refinement did), ``""`` otherwise.
    #[getter]
    fn reason(&self) -> Vec<String> {
        self.data
            .rows
            .iter()
            .map(|r| match &r.outcome {
                Outcome::Ok { note, .. } => note.clone().unwrap_or_default().0,
                Outcome::Failed { reason, .. } => reason.clone(),
            })
            .collect()
    }
    /// The full message of a failure, ``""`` otherwise.
    #[getter]
    fn message(&self) -> Vec<String> {
        self.data
            .rows
            .iter()
            .map(|r| match &r.outcome {
                Outcome::Ok { note, .. } => note.clone().unwrap_or_default().1,
                Outcome::Failed { message, .. } => message.clone(),
            })
            .collect()
    }
    /// The summary as a dict (``summary.json``), ``None`` for a shard.
    #[getter]
    fn summary<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        self.data
            .summary_json
            .as_deref()
            .map(|t| arrays::json(py, t))
            .transpose()
    }
    /// The text of ``summary.json`` (``None`` for a shard).
    fn summary_json(&self) -> Option<String> {
        self.data.summary_json.clone()
    }
    /// The text of ``trials.csv``.
    fn trials_csv(&self) -> PyResult<String> {
        trials_text(&self.data.manifest, &self.data.rows)
    }
    /// The text of ``sweep.json``.
    fn manifest_json(&self) -> PyResult<String> {
        let mut text = serde_json::to_string_pretty(&self.data.manifest)
            .map_err(|e| error(format!("cannot serialize: {e}")))?;
        text.push('\n');
        Ok(text)
    }
    /// Where it was written (``None`` if only in memory).
    #[getter]
    fn path(&self) -> Option<String> {
        self.data.path.as_ref().map(|p| p.display().to_string())
    }
    /// Things to know (e.g. no representative campaign for the report).
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.data.warnings.clone()
    }
    /// Writes the directory ``out`` as ``frameid sweep`` (or ``merge``)
    /// does, replacing an earlier sweep there; returns a ``Sweep`` with
    /// ``path`` set.
    fn write(&self, py: Python<'_>, out: PathBuf) -> PyResult<Sweep> {
        let mut data = self.data.clone();
        let warnings = py.detach(|| guard(|| write_dir(&out, &data)))?;
        data.path = Some(out);
        data.warnings = warnings;
        Ok(Sweep { data })
    }
    fn __len__(&self) -> usize {
        self.data.rows.len()
    }
    fn __repr__(&self) -> String {
        let failed = self
            .data
            .rows
            .iter()
            .filter(|r| matches!(r.outcome, Outcome::Failed { .. }))
            .count();
        format!(
            "Sweep({}: {} trials at noise {:?}{}, {} failed{})",
            self.plan().scenario.name,
            self.data.rows.len(),
            self.plan().noise_levels,
            match self.data.manifest.shard {
                Some(s) => format!(", shard {}/{}", s.index, s.count),
                None => String::new(),
            },
            failed,
            match &self.data.path {
                Some(p) => format!(", in {}", p.display()),
                None => String::new(),
            }
        )
    }
    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other.cast::<Sweep>().is_ok_and(|o| {
            let o = &o.get().data;
            o.manifest == self.data.manifest
                && o.rows == self.data.rows
                && o.summary_json == self.data.summary_json
        })
    }
    fn __reduce__<'py>(&self, py: Python<'py>) -> Reduced<'py> {
        let manifest_json = serde_json::to_string(&self.data.manifest)
            .map_err(|e| error(format!("cannot pickle: {e}")))?;
        let state = SweepState {
            manifest_json,
            trials_csv: trials_text(&self.data.manifest, &self.data.rows)?,
            summary_json: self.data.summary_json.clone(),
            path: self.data.path.clone(),
            warnings: self.data.warnings.clone(),
        };
        reduce(py, "Sweep", to_state(py, &state)?)
    }
}

/// `shard` as `(k, n)` or `"k/n"`.
fn extract_shard(obj: &Bound<'_, PyAny>) -> PyResult<Shard> {
    let text = if let Ok((k, n)) = obj.extract::<(i64, i64)>() {
        format!("{k}/{n}")
    } else if let Ok(s) = obj.extract::<String>() {
        s
    } else {
        return Err(error("shard: expected (k, n) or \"k/n\""));
    };
    text.parse::<Shard>()
        .map_err(|e| error(format!("shard: {e}")))
}

/// Noise levels: fractions >= 0, each once (as `--noise`).
fn check_noise_levels(levels: &[f64]) -> PyResult<()> {
    if levels.is_empty() {
        return Err(error("noise: give at least one level"));
    }
    for (i, &n) in levels.iter().enumerate() {
        if !(n.is_finite() && n >= 0.0) {
            return Err(error(format!(
                "noise: level {} must be a fraction >= 0, got {n}",
                i + 1
            )));
        }
        if levels[..i].contains(&n) {
            return Err(error(format!("noise: level {n} appears twice")));
        }
    }
    Ok(())
}

/// Runs a Monte Carlo sweep of a scenario file, as ``frameid sweep`` does:
/// for every noise level (and axis value) ``trials`` simulated campaigns,
/// each identified (and refined if the scenario says so) and scored against
/// the truth.
///
/// ``noise``, ``trials`` and ``seed`` override the scenario's ``[sweep]``.
/// Results are bit-identical for any ``threads`` (default: every core) and
/// shard split: ``shard=(k, n)`` (or ``"k/n"``) runs part k of n, and
/// ``merge`` joins the parts into what one run gives. With ``out`` the
/// directory is written as the command line writes it (``force=True``
/// writes a ``trials.csv`` of more than 1 GiB). Runs without holding the
/// interpreter.
#[pyfunction]
#[pyo3(signature = (scenario, *, noise=None, trials=None, seed=None, shard=None, threads=None, out=None, force=false))]
#[allow(clippy::too_many_arguments)]
fn sweep(
    py: Python<'_>,
    scenario: PathBuf,
    noise: Option<&Bound<'_, PyAny>>,
    trials: Option<usize>,
    seed: Option<u64>,
    shard: Option<&Bound<'_, PyAny>>,
    threads: Option<usize>,
    out: Option<PathBuf>,
    force: bool,
) -> PyResult<Sweep> {
    let noise: Option<Vec<f64>> = noise
        .map(|n| {
            n.extract::<f64>().map(|x| vec![x]).or_else(|_| {
                n.extract::<Vec<f64>>()
                    .map_err(|_| error("noise: expected a level or a sequence of levels (fractions of each channel's RMS)"))
            })
        })
        .transpose()?;
    if let Some(levels) = &noise {
        check_noise_levels(levels)?;
    }
    if trials == Some(0) {
        return Err(error("trials: must be at least 1"));
    }
    let shard = shard.map(extract_shard).transpose()?;
    let threads = match threads {
        Some(0) => return Err(error("threads: must be at least 1")),
        Some(n) if n > MAX_THREADS => {
            return Err(error(format!("threads: {n} is more than {MAX_THREADS}")));
        }
        Some(n) => n,
        None => std::thread::available_parallelism().map_or(1, |n| n.get()),
    };
    let loaded = load_scenario(py, &scenario)?;
    let plan = Plan::new(&loaded, noise.as_deref(), trials, seed).map_err(lib_error)?;
    if let Some(out) = &out {
        check_output_size(
            &format!("{}/trials.csv", out.display()),
            plan.output_bytes(shard),
            force,
        )?;
    }
    let data = py.detach(|| {
        guard(|| match &out {
            Some(dir) => {
                let done = lib::execute(&loaded.path, &plan, dir, shard, threads, &|| {})
                    .map_err(lib_error)?;
                let mut data = read_dir(dir)?;
                data.warnings = done.warnings;
                Ok(data)
            }
            None => {
                let truth = lib::plan_truth(&plan).map_err(lib_error)?;
                let rows = lib::run(&plan, &truth, shard, threads, &|| {}).map_err(lib_error)?;
                let summary_json = match shard {
                    Some(_) => None,
                    None => Some(summary_text(&lib::summarize(
                        &plan,
                        &truth,
                        &plan.score_keys(),
                        &rows,
                    ))?),
                };
                Ok(SweepData {
                    manifest: Manifest {
                        frameid_version: env!("CARGO_PKG_VERSION").into(),
                        scenario_path: loaded.path.display().to_string(),
                        plan: plan.clone(),
                        shard,
                    },
                    rows,
                    summary_json,
                    path: None,
                    warnings: Vec::new(),
                })
            }
        })
    })?;
    Ok(Sweep { data })
}

/// A part of a merge: a `Sweep` or a directory.
enum Part {
    Memory(Box<SweepData>, String),
    Dir(PathBuf),
}

/// Joins the shards of a sweep into what one run gives, as ``frameid
/// merge`` does: ``parts`` are ``Sweep`` objects (e.g. returned by Dask
/// workers) or shard directories, in any order. Refuses shards of different
/// sweeps and reports a missing or repeated trial. With ``out`` the merged
/// directory is written (with the representative campaign of the report).
#[pyfunction]
#[pyo3(signature = (parts, *, out=None))]
fn merge(py: Python<'_>, parts: Vec<Bound<'_, PyAny>>, out: Option<PathBuf>) -> PyResult<Sweep> {
    let parts: Vec<Part> = parts
        .iter()
        .map(|p| {
            if let Ok(s) = p.cast::<Sweep>() {
                let s = s.get();
                Ok(Part::Memory(Box::new(s.data.clone()), s.name()))
            } else if let Ok(path) = p.extract::<PathBuf>() {
                Ok(Part::Dir(path))
            } else {
                Err(error(
                    "parts: expected frameid.Sweep objects or shard directories",
                ))
            }
        })
        .collect::<PyResult<_>>()?;
    let data = py.detach(|| {
        guard(|| {
            // Directories only, written out: exactly `frameid merge`.
            if let Some(dir) = &out
                && parts.iter().all(|p| matches!(p, Part::Dir(_)))
            {
                let dirs: Vec<&Path> = parts
                    .iter()
                    .map(|p| match p {
                        Part::Dir(d) => d.as_path(),
                        Part::Memory(..) => unreachable!("all parts are directories"),
                    })
                    .collect();
                let merged = lib::merge(&dirs, dir).map_err(lib_error)?;
                let mut data = read_dir(dir)?;
                data.warnings = merged.warnings;
                return Ok(data);
            }
            if parts.is_empty() {
                return Err(error("merge: no directories given"));
            }
            let mut named: Vec<(String, SweepData)> = Vec::new();
            for p in parts {
                match p {
                    Part::Memory(d, name) => named.push((name, *d)),
                    Part::Dir(d) => named.push((d.display().to_string(), read_dir(&d)?)),
                }
            }
            let (first_name, first) = (&named[0].0, &named[0].1);
            // The command line's checks and messages (version, plan, shard split).
            for (name, d) in named.iter().skip(1) {
                if let Some(problem) = lib::manifest_mismatch(
                    (Path::new(name), &d.manifest),
                    (Path::new(first_name), &first.manifest),
                ) {
                    return Err(error(problem));
                }
            }
            let manifest = Manifest {
                shard: None,
                ..first.manifest.clone()
            };
            let plan = manifest.plan.clone();
            let rows = lib::join_rows(&plan, named.into_iter().map(|(n, d)| (n, d.rows)).collect())
                .map_err(lib_error)?;
            let truth = lib::plan_truth(&plan).map_err(lib_error)?;
            let summary = lib::summarize(&plan, &truth, &plan.score_keys(), &rows);
            let mut data = SweepData {
                manifest,
                rows,
                summary_json: Some(summary_text(&summary)?),
                path: None,
                warnings: Vec::new(),
            };
            if let Some(dir) = &out {
                data.warnings = write_dir(dir, &data)?;
                data.path = Some(dir.clone());
            }
            Ok(data)
        })
    })?;
    Ok(Sweep { data })
}

/// Renders the HTML accuracy report of sweep directories (or ``Sweep``
/// objects that were written, see ``Sweep.write``), one study each, as
/// ``frameid report`` does; writes ``out`` and returns its path.
#[pyfunction]
#[pyo3(signature = (sweeps, out, *, title="frameid accuracy report"))]
fn report(
    py: Python<'_>,
    sweeps: Vec<Bound<'_, PyAny>>,
    out: PathBuf,
    title: &str,
) -> PyResult<String> {
    let dirs: Vec<PathBuf> = sweeps
        .iter()
        .map(|s| {
            if let Ok(s) = s.cast::<Sweep>() {
                s.get().data.path.clone().ok_or_else(|| {
                    error("sweeps: a sweep held in memory has no directory; write it first (Sweep.write(out)) or run it with out=")
                })
            } else {
                s.extract::<PathBuf>()
                    .map_err(|_| error("sweeps: expected sweep directories or written frameid.Sweep objects"))
            }
        })
        .collect::<PyResult<_>>()?;
    if dirs.is_empty() {
        return Err(error("sweeps: give at least one sweep directory"));
    }
    let command = format!(
        "frameid.report([{}], out={:?})",
        dirs.iter()
            .map(|d| format!("{:?}", d.display().to_string()))
            .collect::<Vec<_>>()
            .join(", "),
        out.display().to_string()
    );
    py.detach(|| {
        guard(|| {
            let refs: Vec<&Path> = dirs.iter().map(PathBuf::as_path).collect();
            let report = study::report::build(title, &command, &refs).map_err(lib_error)?;
            reports::render_to_file(&report, &out).map_err(lib_error)?;
            Ok(out.display().to_string())
        })
    })
}

/// The summary of a complete `Sweep` or sweep directory, and its name for
/// messages.
fn summary_of(obj: &Bound<'_, PyAny>) -> PyResult<(String, lib::Summary)> {
    if let Ok(s) = obj.cast::<Sweep>() {
        let s = s.get();
        let text = s.data.summary_json.as_deref().ok_or_else(|| {
            error(format!(
                "{}: a shard has no summary; merge the shards first",
                s.name()
            ))
        })?;
        let summary =
            serde_json::from_str(text).map_err(|e| error(format!("{}: summary: {e}", s.name())))?;
        Ok((s.name(), summary))
    } else if let Ok(dir) = obj.extract::<PathBuf>() {
        let summary = lib::compare::read_summary(&dir).map_err(lib_error)?;
        Ok((dir.display().to_string(), summary))
    } else {
        Err(error(
            "compare: expected frameid.Sweep objects or sweep directories",
        ))
    }
}

/// Compares two complete sweeps (``Sweep`` objects or directories) median
/// by median and efficiency by efficiency in units of their combined Monte
/// Carlo standard errors, as ``frameid compare --json`` does; returns that
/// dict (``cells``, ``compared``, ``without_error``, ``largest``,
/// ``changed``: every value beyond ``threshold``, largest first,
/// ``threshold``, ``ignored``). ``ignore`` names scores to leave out (e.g.
/// ``refine_iterations``). The sweeps agree when ``changed`` is empty.
#[pyfunction]
#[pyo3(signature = (first, second, *, threshold=lib::compare::DEFAULT_THRESHOLD, ignore=Vec::new()))]
fn compare<'py>(
    py: Python<'py>,
    first: &Bound<'py, PyAny>,
    second: &Bound<'py, PyAny>,
    threshold: f64,
    ignore: Vec<String>,
) -> PyResult<Bound<'py, PyAny>> {
    let ((na, a), (nb, b)) = (summary_of(first)?, summary_of(second)?);
    let c = lib::compare::compare(&a, &b, threshold, &ignore)
        .map_err(|problem| error(format!("cannot compare {na} with {nb}: {problem}")))?;
    let text = serde_json::to_string(&c).map_err(|e| error(e.to_string()))?;
    arrays::json(py, &text)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Sweep>()?;
    m.add_function(wrap_pyfunction!(sweep, m)?)?;
    m.add_function(wrap_pyfunction!(merge, m)?)?;
    m.add_function(wrap_pyfunction!(compare, m)?)?;
    m.add_function(wrap_pyfunction!(report, m)?)?;
    Ok(())
}
