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

use crate::experiment::{TrueModel, noise_at, run_trial, score, score_names};
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
    /// Scores aligned with the sweep's score names.
    Ok(Vec<f64>),
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
                    let (_, result) =
                        run_trial(&simulators[key.axis], &identifiers[key.axis], &noise, seed);
                    match result {
                        Ok(id) => Outcome::Ok(score(&id, truth)),
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
            Outcome::Ok(v) => {
                rec.extend(["ok".to_string(), String::new(), String::new()]);
                rec.extend(v.iter().map(|x| x.to_string()));
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
            "ok" => Outcome::Ok(
                (0..names.len())
                    .map(|k| {
                        field(FIXED_COLUMNS.len() + k)
                            .parse::<f64>()
                            .map_err(|_| bad("score is not a number"))
                    })
                    .collect::<Result<_>>()?,
            ),
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
    pub scores: BTreeMap<String, Stats>,
}

/// Contents of `summary.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    pub frameid_version: String,
    pub plan: Plan,
    pub score_names: Vec<String>,
    pub levels: Vec<LevelSummary>,
}

/// Summarizes rows (all trials of the plan, canonical order).
pub fn summarize(plan: &Plan, names: &[String], rows: &[TrialRow]) -> Summary {
    let mut levels = Vec::new();
    for (a, axis_value) in plan.axis_values().into_iter().enumerate() {
        for (ni, &noise) in plan.noise_levels.iter().enumerate() {
            let cell: Vec<&TrialRow> = rows
                .iter()
                .filter(|r| r.key.axis == a && r.key.noise == ni)
                .collect();
            let mut reasons = BTreeMap::new();
            let mut columns: Vec<Vec<f64>> = vec![Vec::new(); names.len()];
            for r in &cell {
                match &r.outcome {
                    Outcome::Ok(v) => {
                        for (c, x) in columns.iter_mut().zip(v) {
                            c.push(*x);
                        }
                    }
                    Outcome::Failed { reason, .. } => {
                        *reasons.entry(reason.clone()).or_insert(0) += 1
                    }
                }
            }
            let failures: usize = reasons.values().sum();
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
                scores: names
                    .iter()
                    .cloned()
                    .zip(columns.iter().map(|c| Stats::of(c)))
                    .collect(),
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
/// only) and `sweep.json`.
pub fn write_dir(
    dir: &Path,
    manifest: &Manifest,
    names: &[String],
    rows: &[TrialRow],
) -> Result<()> {
    std::fs::create_dir_all(dir)
        .with_context(|| format!("{}: cannot create directory", dir.display()))?;
    write_trials(&dir.join("trials.csv"), &manifest.plan, names, rows)?;
    if manifest.shard.is_none() {
        write_json(
            &dir.join("summary.json"),
            &summarize(&manifest.plan, names, rows),
        )?;
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
    let dofs = first
        .plan
        .scenario
        .model()
        .map_err(|e| anyhow!("{e}"))?
        .dofs();
    let names = score_names(dofs);
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
    write_dir(out, &manifest, &names, &rows)?;
    Ok(summarize(&manifest.plan, &names, &rows))
}
