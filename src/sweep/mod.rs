//! Monte Carlo sweeps: many simulated campaigns per noise level (and per
//! value of an optional second axis), identified and scored, in parallel.
//!
//! Reproducibility: trial t at noise level x uses the seed
//! `derive(derive(seed, bits(x)), t)`, independent of the axis value (so
//! axis values are compared on the same random campaigns), of the thread
//! count and of the shard split. Trials are kept in a fixed order (axis
//! value, noise level, trial), and summaries are computed from the rows in
//! that order, so one run, any thread count, and merged shards give
//! byte-identical `trials.csv` and `summary.json`.

pub mod stats;

use std::collections::BTreeMap;
use std::io::IsTerminal;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::Path;

use anyhow::{Context, Result, anyhow, bail};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use sim::{Simulator, derive_seed};

use crate::experiment::{
    Bound, TrueModel, cramer_rao_bound, noise_at, run_trial, score, score_names,
};
use crate::fsutil::{write_atomic, write_json};
use crate::scenario::{AxisSetting, AxisValue, Scenario, SweepAxis};
use stats::Stats;

/// What a sweep runs: the scenario (overrides applied), noise levels,
/// trials, seed and the optional second axis.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Plan {
    pub scenario: Scenario,
    pub noise_levels: Vec<f64>,
    pub trials: usize,
    pub seed: u64,
    pub axis: Option<SweepAxis>,
}

/// Position of a trial in the plan.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
pub struct TrialKey {
    pub axis: usize,
    pub noise: usize,
    pub trial: usize,
}

/// A part `index` of `count` of a sweep (1-based index, as in `--shard 2/4`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shard {
    pub index: usize,
    pub count: usize,
}

impl std::str::FromStr for Shard {
    type Err = anyhow::Error;

    fn from_str(s: &str) -> Result<Shard> {
        let (k, n) = s
            .split_once('/')
            .ok_or_else(|| anyhow!("--shard: expected K/N (e.g. 2/4), got '{s}'"))?;
        let k: usize = k
            .trim()
            .parse()
            .map_err(|_| anyhow!("--shard: '{k}' is not a shard number"))?;
        let n: usize = n
            .trim()
            .parse()
            .map_err(|_| anyhow!("--shard: '{n}' is not a shard count"))?;
        if n == 0 || k == 0 || k > n {
            bail!("--shard: need 1 <= K <= N, got {k}/{n}");
        }
        Ok(Shard { index: k, count: n })
    }
}

/// Outcome of one trial.
#[derive(Debug, Clone, PartialEq)]
pub enum Outcome {
    /// Scores aligned with the sweep's score names; `note` says why the
    /// refinement failed (its scores are then NaN), as (reason, message).
    Ok {
        scores: Vec<f64>,
        note: Option<(String, String)>,
    },
    /// The identification failed: a short reason (category) and the message.
    Failed { reason: String, message: String },
}

/// One row of `trials.csv`.
#[derive(Debug, Clone, PartialEq)]
pub struct TrialRow {
    pub key: TrialKey,
    pub seed: u64,
    pub outcome: Outcome,
}

impl Plan {
    /// Values of the second axis (one `None` if there is no axis).
    pub fn axis_values(&self) -> Vec<Option<AxisValue>> {
        match &self.axis {
            Some(a) => a.values.iter().cloned().map(Some).collect(),
            None => vec![None],
        }
    }

    /// Every trial in canonical order.
    pub fn keys(&self) -> Vec<TrialKey> {
        let mut keys = Vec::new();
        for axis in 0..self.axis_values().len() {
            for noise in 0..self.noise_levels.len() {
                for trial in 0..self.trials {
                    keys.push(TrialKey { axis, noise, trial });
                }
            }
        }
        keys
    }

    /// Seed of a trial.
    pub fn trial_seed(&self, key: TrialKey) -> u64 {
        derive_seed(
            derive_seed(self.seed, self.noise_levels[key.noise].to_bits()),
            key.trial as u64,
        )
    }

    /// The scenario as used for an axis value.
    pub fn scenario_at(&self, axis: usize) -> Scenario {
        let mut s = self.scenario.clone();
        if let (Some(a), Some(v)) = (&self.axis, &self.axis_values()[axis]) {
            match (a.setting, v) {
                (AxisSetting::Hits, AxisValue::Number(x)) => s.campaign.hits = *x as usize,
                (AxisSetting::PulseDurationS, AxisValue::Number(x)) => {
                    s.campaign.hammer.duration_s = *x
                }
                (AxisSetting::Intersample, AxisValue::Text(t)) => {
                    s.identification.intersample = Some(if t == "zoh" {
                        crate::scenario::IntersampleSetting::Zoh
                    } else {
                        crate::scenario::IntersampleSetting::Bandlimited
                    })
                }
                _ => unreachable!("axis values are checked when the scenario is loaded"),
            }
        }
        s
    }

    /// Label of an axis value ("" without an axis).
    pub fn axis_label(&self, axis: usize) -> String {
        self.axis_values()[axis]
            .as_ref()
            .map(ToString::to_string)
            .unwrap_or_default()
    }
}

/// A short, stable failure category for counting (the full message is
/// kept beside it).
pub fn failure_reason(e: &ident::Error) -> String {
    use ident::Error as E;
    match e {
        E::InvalidParams { .. } => "invalid parameters",
        E::Data(_) => "unusable data",
        E::Okid(_) => "OKID failed",
        E::Era(_) => "ERA failed",
        E::Modal(_) => "modal analysis failed",
        E::Mkr(m) => match m {
            ident::MkrError::NotPositiveDefinite { .. } => "MKR: not positive definite",
            ident::MkrError::InconsistentPolarity { .. } => "MKR: inconsistent polarity",
            _ => "MKR failed",
        },
        E::Rayleigh(_) => "Rayleigh fit failed",
        E::OutputsFewerThanDofs { .. } => "fewer outputs than DOFs",
        E::OrderNotIdentifiable { .. } => "order not identifiable",
        E::NonFiniteResult { .. } => "non-finite result",
    }
    .to_string()
}

/// A short, stable category of a refinement failure.
pub fn refine_failure_reason(e: &ident::RefineError) -> String {
    use ident::RefineError as E;
    let what = match e {
        E::InvalidParams { .. } => "invalid parameters",
        E::Data(_) => "unusable data",
        E::NotPositiveDefinite { .. } => "not positive definite",
        E::NonFiniteModel => "non-finite model",
        E::SingularModel => "singular model",
        E::NotRepresentable { .. } => "not representable",
        E::TooFewBins { .. } => "too few bins",
        E::NotIdentifiable { .. } => "not identifiable",
        E::ModalAnalysis => "modal analysis failed",
    };
    format!("refinement: {what}")
}

/// Runs the trials of `shard` (all if `None`) on `threads` threads.
pub fn run(
    plan: &Plan,
    truth: &TrueModel,
    shard: Option<Shard>,
    threads: usize,
    progress: bool,
) -> Result<Vec<TrialRow>> {
    let simulators: Vec<Simulator> = (0..plan.axis_values().len())
        .map(|a| {
            plan.scenario_at(a)
                .simulator(truth.model.clone())
                .map_err(|e| anyhow!("sweep axis value {}: {e}", plan.axis_label(a)))
        })
        .collect::<Result<_>>()?;
    let identifiers: Vec<ident::Identifier> = (0..plan.axis_values().len())
        .map(|a| plan.scenario_at(a).identifier())
        .collect();
    let refiners: Vec<Option<ident::refine::Refiner>> = (0..plan.axis_values().len())
        .map(|a| {
            let s = plan.scenario_at(a);
            s.identification.refine.then(|| s.refiner())
        })
        .collect();
    let keys: Vec<TrialKey> = plan
        .keys()
        .into_iter()
        .enumerate()
        .filter(|(i, _)| shard.is_none_or(|s| i % s.count == s.index - 1))
        .map(|(_, k)| k)
        .collect();
    let bar = if progress && std::io::stderr().is_terminal() {
        let b =
            ProgressBar::with_draw_target(Some(keys.len() as u64), ProgressDrawTarget::stderr());
        b.set_style(
            ProgressStyle::with_template("{prefix} [{bar:30}] {pos}/{len} trials, {eta} left")
                .expect("valid template")
                .progress_chars("=> "),
        );
        b.set_prefix(plan.scenario.name.clone());
        b
    } else {
        ProgressBar::hidden()
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .context("cannot start the worker threads")?;
    let rows = pool.install(|| {
        keys.par_iter()
            .map(|&key| {
                let seed = plan.trial_seed(key);
                let noise = noise_at(&plan.scenario.campaign.noise, plan.noise_levels[key.noise]);
                let outcome = catch_unwind(AssertUnwindSafe(|| {
                    let trial = run_trial(
                        &simulators[key.axis],
                        &identifiers[key.axis],
                        refiners[key.axis].as_ref(),
                        &noise,
                        seed,
                    );
                    match trial.identification {
                        Ok(id) => Outcome::Ok {
                            scores: score(&id, trial.refinement.as_ref(), truth),
                            note: match &trial.refinement {
                                Some(Err(e)) => Some((refine_failure_reason(e), e.to_string())),
                                _ => None,
                            },
                        },
                        Err(e) => Outcome::Failed {
                            reason: failure_reason(&e),
                            message: e.to_string(),
                        },
                    }
                }))
                .unwrap_or_else(|panic| Outcome::Failed {
                    reason: "panic".into(),
                    message: panic
                        .downcast_ref::<String>()
                        .cloned()
                        .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                        .unwrap_or_default(),
                });
                bar.inc(1);
                TrialRow { key, seed, outcome }
            })
            .collect::<Vec<_>>()
    });
    bar.finish_and_clear();
    Ok(rows)
}

const FIXED_COLUMNS: [&str; 7] = [
    "axis", "noise", "trial", "seed", "status", "reason", "message",
];

/// Writes `trials.csv`: one row per trial in canonical order; scores in
/// shortest round-trip form (empty for failed trials).
pub fn write_trials(path: &Path, plan: &Plan, names: &[String], rows: &[TrialRow]) -> Result<()> {
    let mut w = csv::Writer::from_writer(Vec::new());
    let header: Vec<&str> = FIXED_COLUMNS
        .iter()
        .copied()
        .chain(names.iter().map(String::as_str))
        .collect();
    w.write_record(&header)?;
    for r in rows {
        let mut rec = vec![
            plan.axis_label(r.key.axis),
            plan.noise_levels[r.key.noise].to_string(),
            r.key.trial.to_string(),
            r.seed.to_string(),
        ];
        match &r.outcome {
            Outcome::Ok { scores, note } => {
                let (reason, message) = note.clone().unwrap_or_default();
                rec.extend(["ok".to_string(), reason, message]);
                rec.extend(scores.iter().map(|x| x.to_string()));
            }
            Outcome::Failed { reason, message } => {
                rec.extend(["failed".to_string(), reason.clone(), message.clone()]);
                rec.extend(names.iter().map(|_| String::new()));
            }
        }
        w.write_record(&rec)?;
    }
    let bytes = w
        .into_inner()
        .map_err(|e| anyhow!("cannot format trials: {e}"))?;
    write_atomic(path, &bytes)
}

/// Reads a `trials.csv` written for `plan`; checks header and keys.
pub fn read_trials(path: &Path, plan: &Plan, names: &[String]) -> Result<Vec<TrialRow>> {
    let mut r =
        csv::Reader::from_path(path).with_context(|| format!("{}: cannot read", path.display()))?;
    let expected: Vec<&str> = FIXED_COLUMNS
        .iter()
        .copied()
        .chain(names.iter().map(String::as_str))
        .collect();
    let header = r
        .headers()
        .with_context(|| format!("{}: no header", path.display()))?
        .clone();
    if header.iter().collect::<Vec<_>>() != expected {
        bail!(
            "{}: the columns do not match this sweep's scores",
            path.display()
        );
    }
    let labels: Vec<String> = (0..plan.axis_values().len())
        .map(|a| plan.axis_label(a))
        .collect();
    let mut rows = Vec::new();
    for (i, rec) in r.records().enumerate() {
        let line = i + 2;
        let rec = rec.with_context(|| format!("{}: line {line}", path.display()))?;
        let field = |k: usize| rec.get(k).unwrap_or("");
        let bad = |what: &str| anyhow!("{}: line {line}: {what}", path.display());
        let axis = labels
            .iter()
            .position(|l| l == field(0))
            .ok_or_else(|| bad("unknown axis value"))?;
        let noise_value: f64 = field(1).parse().map_err(|_| bad("noise is not a number"))?;
        let noise = plan
            .noise_levels
            .iter()
            .position(|&x| x.to_bits() == noise_value.to_bits())
            .ok_or_else(|| bad("noise level not in the sweep"))?;
        let trial: usize = field(2).parse().map_err(|_| bad("trial is not a number"))?;
        if trial >= plan.trials {
            return Err(bad("trial index beyond the sweep's trials"));
        }
        let seed: u64 = field(3).parse().map_err(|_| bad("seed is not a number"))?;
        let key = TrialKey { axis, noise, trial };
        if seed != plan.trial_seed(key) {
            return Err(bad("seed does not match the sweep's seed for this trial"));
        }
        let outcome = match field(4) {
            "ok" => Outcome::Ok {
                scores: (0..names.len())
                    .map(|k| {
                        field(FIXED_COLUMNS.len() + k)
                            .parse::<f64>()
                            .map_err(|_| bad("score is not a number"))
                    })
                    .collect::<Result<_>>()?,
                note: (!field(5).is_empty()).then(|| (field(5).to_string(), field(6).to_string())),
            },
            "failed" => Outcome::Failed {
                reason: field(5).to_string(),
                message: field(6).to_string(),
            },
            _ => return Err(bad("status must be ok or failed")),
        };
        rows.push(TrialRow { key, seed, outcome });
    }
    Ok(rows)
}

/// Summary of one cell (axis value, noise level).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LevelSummary {
    pub axis_value: Option<AxisValue>,
    pub noise: f64,
    pub trials: usize,
    pub failures: usize,
    pub failure_rate: f64,
    pub failure_reasons: BTreeMap<String, usize>,
    /// Trials whose identification succeeded but whose refinement failed.
    pub refine_failures: BTreeMap<String, usize>,
    pub scores: BTreeMap<String, Stats>,
    /// The Cramér–Rao bound at this level (none at zero noise, or if it
    /// could not be computed).
    pub bound: Option<Bound>,
    /// Per score with a bound: bound / RMS error over the successful trials
    /// (1 = efficient).
    pub efficiency: BTreeMap<String, f64>,
    /// Refined M, K, damping: mean standard error reported by a single
    /// refinement over the RMS error across trials (1 = honest error bars).
    pub standard_error_ratio: BTreeMap<String, f64>,
}

/// Contents of `summary.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    pub frameid_version: String,
    pub plan: Plan,
    pub score_names: Vec<String>,
    pub levels: Vec<LevelSummary>,
}

/// Stream tag of the campaign whose (noise-free) pulses the bound is
/// computed for; the representative campaign of the report uses the same.
pub const BOUND_TAG: u64 = 0x5245_5052;

/// The Cramér–Rao bound of every cell (axis value, noise level): for the
/// pulses of the campaign drawn with the sweep's seed and [`BOUND_TAG`],
/// records as acquired, and the scenario's parametrization. Deterministic,
/// so one run and merged shards agree.
pub fn bounds(plan: &Plan, truth: &TrueModel) -> Vec<Vec<Option<Bound>>> {
    let seed = derive_seed(plan.seed, BOUND_TAG);
    (0..plan.axis_values().len())
        .map(|a| {
            let s = plan.scenario_at(a);
            let simulator = s.simulator(truth.model.clone()).ok();
            let refiner = s.refiner();
            plan.noise_levels
                .iter()
                .map(|&level| {
                    let noise = noise_at(&s.campaign.noise, level);
                    if noise.sigma(1.0, true) == 0.0 && noise.sigma(1.0, false) == 0.0 {
                        return None;
                    }
                    let simulator = simulator.as_ref()?;
                    cramer_rao_bound(
                        simulator,
                        &refiner,
                        s.acquisition_intersample(),
                        truth,
                        &noise,
                        seed,
                    )
                    .ok()
                })
                .collect()
        })
        .collect()
}

/// Summarizes rows (all trials of the plan, canonical order).
pub fn summarize(plan: &Plan, truth: &TrueModel, names: &[String], rows: &[TrialRow]) -> Summary {
    let bounds = bounds(plan, truth);
    let mut levels = Vec::new();
    for (a, axis_value) in plan.axis_values().into_iter().enumerate() {
        for (ni, &noise) in plan.noise_levels.iter().enumerate() {
            let cell: Vec<&TrialRow> = rows
                .iter()
                .filter(|r| r.key.axis == a && r.key.noise == ni)
                .collect();
            let mut reasons = BTreeMap::new();
            let mut refine_reasons = BTreeMap::new();
            let mut columns: Vec<Vec<f64>> = vec![Vec::new(); names.len()];
            for r in &cell {
                match &r.outcome {
                    Outcome::Ok { scores, note } => {
                        for (c, x) in columns.iter_mut().zip(scores) {
                            c.push(*x);
                        }
                        if let Some((reason, _)) = note {
                            *refine_reasons.entry(reason.clone()).or_insert(0) += 1;
                        }
                    }
                    Outcome::Failed { reason, .. } => {
                        *reasons.entry(reason.clone()).or_insert(0) += 1
                    }
                }
            }
            let failures: usize = reasons.values().sum();
            let column = |name: &str| names.iter().position(|n| n == name).map(|i| &columns[i]);
            let rms = |v: &[f64]| {
                let finite: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
                (!finite.is_empty()).then(|| {
                    (finite.iter().map(|x| x * x).sum::<f64>() / finite.len() as f64).sqrt()
                })
            };
            let bound = bounds[a][ni].clone();
            let efficiency = match &bound {
                Some(b) => names
                    .iter()
                    .filter_map(|n| {
                        let (bound, rms) = (b.for_score(n)?, rms(column(n)?)?);
                        (rms > 0.0).then(|| (n.clone(), bound / rms))
                    })
                    .collect(),
                None => BTreeMap::new(),
            };
            // Meaningless without noise (errors at round-off level).
            let standard_error_ratio = crate::experiment::REFINED
                .iter()
                .filter(|_| bound.is_some())
                .filter_map(|m| {
                    let se = column(&format!("{m}_refined_se"))?;
                    let err = rms(column(&format!("{m}_refined_err"))?)?;
                    let mean_se = Stats::of(se).mean?;
                    (err > 0.0).then(|| (m.to_string(), mean_se / err))
                })
                .collect();
            levels.push(LevelSummary {
                axis_value: axis_value.clone(),
                noise,
                trials: cell.len(),
                failures,
                failure_rate: if cell.is_empty() {
                    0.0
                } else {
                    failures as f64 / cell.len() as f64
                },
                failure_reasons: reasons,
                refine_failures: refine_reasons,
                scores: names
                    .iter()
                    .cloned()
                    .zip(columns.iter().map(|c| Stats::of(c)))
                    .collect(),
                bound,
                efficiency,
                standard_error_ratio,
            });
        }
    }
    Summary {
        frameid_version: env!("CARGO_PKG_VERSION").into(),
        plan: plan.clone(),
        score_names: names.to_vec(),
        levels,
    }
}

/// `sweep.json`: what a directory holds (the plan and which shard).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    pub frameid_version: String,
    pub scenario_path: String,
    pub plan: Plan,
    pub shard: Option<Shard>,
}

/// Writes a sweep directory: `trials.csv`, `summary.json` (complete runs
/// only: pass their summary) and `sweep.json`.
pub fn write_dir(
    dir: &Path,
    manifest: &Manifest,
    names: &[String],
    rows: &[TrialRow],
    summary: Option<&Summary>,
) -> Result<()> {
    std::fs::create_dir_all(dir)
        .with_context(|| format!("{}: cannot create directory", dir.display()))?;
    write_trials(&dir.join("trials.csv"), &manifest.plan, names, rows)?;
    if let Some(summary) = summary {
        write_json(&dir.join("summary.json"), summary)?;
    } else {
        // A shard's summary would be partial: remove a stale one.
        let stale = dir.join("summary.json");
        if stale.exists() {
            std::fs::remove_file(&stale)
                .with_context(|| format!("{}: cannot remove", stale.display()))?;
        }
    }
    write_json(&dir.join("sweep.json"), manifest)
}

/// Reads `sweep.json` of a directory.
pub fn read_manifest(dir: &Path) -> Result<Manifest> {
    let path = dir.join("sweep.json");
    let text = std::fs::read_to_string(&path)
        .with_context(|| format!("{}: cannot read (not a sweep directory?)", path.display()))?;
    serde_json::from_str(&text).with_context(|| format!("{}: not a sweep manifest", path.display()))
}

/// Joins shard directories into what one run gives.
pub fn merge(dirs: &[&Path], out: &Path) -> Result<Summary> {
    if dirs.is_empty() {
        bail!("merge: no directories given");
    }
    let manifests: Vec<Manifest> = dirs
        .iter()
        .map(|d| read_manifest(d))
        .collect::<Result<_>>()?;
    let first = &manifests[0];
    for (m, d) in manifests.iter().zip(dirs).skip(1) {
        if m.plan != first.plan {
            bail!(
                "{}: a different sweep than {} (scenario, noise levels, trials, seed or axis differ)",
                d.display(),
                dirs[0].display()
            );
        }
    }
    let model = first.plan.scenario.model().map_err(|e| anyhow!("{e}"))?;
    let truth = TrueModel::new(model).map_err(|e| anyhow!("{e}"))?;
    let names = score_names(truth.dofs(), first.plan.scenario.identification.refine);
    let mut rows: BTreeMap<TrialKey, TrialRow> = BTreeMap::new();
    for d in dirs {
        for r in read_trials(&d.join("trials.csv"), &first.plan, &names)? {
            if rows.insert(r.key, r.clone()).is_some() {
                bail!(
                    "{}: trial {} at noise {} appears in more than one directory",
                    d.display(),
                    r.key.trial,
                    first.plan.noise_levels[r.key.noise]
                );
            }
        }
    }
    let expected = first.plan.keys();
    if let Some(missing) = expected.iter().find(|k| !rows.contains_key(k)) {
        bail!(
            "merge: trial {} at noise {}{} is missing: are all shards given?",
            missing.trial,
            first.plan.noise_levels[missing.noise],
            match first.plan.axis_label(missing.axis).as_str() {
                "" => String::new(),
                l => format!(", axis value {l}"),
            }
        );
    }
    let rows: Vec<TrialRow> = rows.into_values().collect();
    let manifest = Manifest {
        shard: None,
        ..first.clone()
    };
    let summary = summarize(&manifest.plan, &truth, &names, &rows);
    write_dir(out, &manifest, &names, &rows, Some(&summary))?;
    Ok(summary)
}
