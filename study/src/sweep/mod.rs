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

pub mod compare;
pub mod stats;

use std::collections::BTreeMap;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::Path;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use sim::{Simulator, derive_seed};

use crate::error::StudyError;
use crate::experiment::{
    Bound, FrfRoute, FrfRouteError, Routes, TrialResult, TrueModel, cramer_rao_bound, noise_at,
    run_trial,
};
use crate::fsutil::{read_json, write_json};
use crate::scenario::{AxisSetting, AxisValue, Scenario, SweepAxis};
use crate::score::{MatrixEstimate, Route, ScoreKey, missing, score, score_frf};
use stats::Stats;

/// What a sweep runs: the scenario (overrides applied), noise levels,
/// trials, seed and the optional second axis.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Plan {
    /// The scenario, command-line overrides applied.
    pub scenario: Scenario,
    /// Noise levels, fractions of each channel's RMS.
    pub noise_levels: Vec<f64>,
    /// Trials per noise level and axis value.
    pub trials: usize,
    /// Base seed.
    pub seed: u64,
    /// The optional second axis.
    pub axis: Option<SweepAxis>,
}

/// Position of a trial in the plan.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
pub struct TrialKey {
    /// Index of the axis value (0 without an axis).
    pub axis: usize,
    /// Index of the noise level.
    pub noise: usize,
    /// Trial number within the cell.
    pub trial: usize,
}

/// A part `index` of `count` of a sweep (1-based index, as in `--shard 2/4`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shard {
    /// 1-based index of this part.
    pub index: usize,
    /// Number of parts.
    pub count: usize,
}

impl Shard {
    /// Whether the trial at `position` in the plan's canonical order belongs
    /// to this shard (trials are dealt round-robin).
    pub fn contains(self, position: usize) -> bool {
        position % self.count == self.index - 1
    }
}

impl std::str::FromStr for Shard {
    type Err = String;

    /// Parses `K/N` with `1 <= K <= N`.
    fn from_str(s: &str) -> Result<Shard, String> {
        let (k, n) = s
            .split_once('/')
            .ok_or_else(|| format!("expected K/N (e.g. 2/4), got '{s}'"))?;
        let k: usize = k
            .trim()
            .parse()
            .map_err(|_| format!("'{k}' is not a shard number"))?;
        let n: usize = n
            .trim()
            .parse()
            .map_err(|_| format!("'{n}' is not a shard count"))?;
        if n == 0 || k == 0 || k > n {
            return Err(format!("need 1 <= K <= N, got {k}/{n}"));
        }
        Ok(Shard { index: k, count: n })
    }
}

/// Outcome of one trial.
#[derive(Debug, Clone, PartialEq)]
pub enum Outcome {
    /// The identification succeeded.
    Ok {
        /// Scores aligned with the sweep's score keys.
        scores: Vec<f64>,
        /// Why the refinement failed (its scores are then NaN), as
        /// (reason, message).
        note: Option<(String, String)>,
    },
    /// The identification failed.
    Failed {
        /// A short, stable category.
        reason: String,
        /// The full message.
        message: String,
    },
}

/// One row of `trials.csv`.
#[derive(Debug, Clone, PartialEq)]
pub struct TrialRow {
    /// Where the trial is in the plan.
    pub key: TrialKey,
    /// Its seed.
    pub seed: u64,
    /// What happened.
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

    /// Number of trials: axis values x noise levels x trials (`None` if it
    /// overflows).
    pub fn trial_count(&self) -> Option<usize> {
        self.axis_values()
            .len()
            .checked_mul(self.noise_levels.len())?
            .checked_mul(self.trials)
    }

    /// The trial at `position` in canonical order (axis value, noise level,
    /// trial).
    pub fn key_at(&self, position: usize) -> TrialKey {
        let per_axis = self.noise_levels.len() * self.trials;
        TrialKey {
            axis: position / per_axis,
            noise: position % per_axis / self.trials,
            trial: position % self.trials,
        }
    }

    /// Every trial in canonical order, generated as needed (a plan of a
    /// billion trials allocates nothing here).
    pub fn keys(&self) -> impl Iterator<Item = TrialKey> + '_ {
        (0..self
            .trial_count()
            .expect("trial count checked with the plan"))
            .map(|p| self.key_at(p))
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
                    s.identification.intersample =
                        Some(t.parse().expect("axis values are checked when loaded"))
                }
                // "shaker" keeps the scenario's continuous excitation.
                (AxisSetting::Excitation, AxisValue::Text(t)) if t == "hammer" => {
                    s.campaign.excitation = sim::Excitation::Hammer
                }
                (AxisSetting::Excitation, AxisValue::Text(_)) => {}
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

    /// The score keys of every trial: the time route's, the FRF route's,
    /// or both ([`ScoreKey::of_routes`]).
    pub fn score_keys(&self) -> Vec<ScoreKey> {
        let id = &self.scenario.identification;
        ScoreKey::of_routes(
            self.scenario.structure.dofs(),
            id.refine,
            id.route.time(),
            id.route.frf(),
        )
    }

    /// The keys of the trials of `shard` (all if `None`), in canonical
    /// order; only the shard's trials are generated.
    pub fn shard_keys(&self, shard: Option<Shard>) -> Vec<TrialKey> {
        let total = self
            .trial_count()
            .expect("trial count checked with the plan");
        let (first, step) = shard.map_or((0, 1), |s| (s.index - 1, s.count));
        (first..total)
            .step_by(step)
            .map(|p| self.key_at(p))
            .collect()
    }

    /// Trials in `shard` (all if `None`), without generating them.
    pub fn shard_len(&self, shard: Option<Shard>) -> usize {
        let total = self
            .trial_count()
            .expect("trial count checked with the plan");
        match shard {
            None => total,
            Some(s) => total.saturating_sub(s.index - 1).div_ceil(s.count),
        }
    }

    /// A generous estimate of the bytes `trials.csv` takes for `shard`:
    /// about 24 characters per score (shortest round-trip doubles) plus
    /// the fixed columns.
    pub fn output_bytes(&self, shard: Option<Shard>) -> u128 {
        let per_row = 24 * self.score_keys().len() as u128 + 120;
        per_row * self.shard_len(shard) as u128
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
        _ => "identification failed",
    }
    .to_string()
}

/// A short, stable category of a failure of the FRF route.
pub fn frf_failure_reason(e: &FrfRouteError) -> String {
    use ident::frf::FrfIdentError as E;
    match e {
        FrfRouteError::Estimate { .. } => "FRF estimation failed",
        FrfRouteError::Identify { error } => match error {
            E::InvalidParams { .. } => "invalid parameters",
            E::Frf(_) | E::TooFewLines { .. } | E::Weighting { .. } => "unusable FRFs",
            E::Numerical { .. } | E::Linalg { .. } => "pLSCF failed",
            E::LsfdRankDeficient { .. } => "LSFD failed",
            E::NoStableModes { .. } => "no stable modes",
            E::ModeCount { .. } | E::ModeNotFound { .. } => "too few modes",
            E::Mkr(m) => match m {
                ident::MkrError::NotPositiveDefinite { .. } => "MKR: not positive definite",
                ident::MkrError::InconsistentPolarity { .. } => "MKR: inconsistent polarity",
                _ => "MKR failed",
            },
            E::Rayleigh(_) => "Rayleigh fit failed",
            E::NonFiniteResult { .. } => "non-finite result",
            _ => "identification failed",
        },
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
        _ => "failed",
    };
    format!("refinement: {what}")
}

/// Runs the trials of `shard` (all if `None`) on `threads` threads;
/// `progress` is called once per finished trial (from any worker thread).
pub fn run(
    plan: &Plan,
    truth: &TrueModel,
    shard: Option<Shard>,
    threads: usize,
    progress: &(dyn Fn() + Sync),
) -> Result<Vec<TrialRow>, StudyError> {
    let axis_count = plan.axis_values().len();
    let simulators: Vec<Simulator> = (0..axis_count)
        .map(|a| {
            plan.scenario_at(a)
                .simulator(truth.model.clone())
                .map_err(|error| StudyError::Simulation {
                    context: format!("sweep axis value {}", plan.axis_label(a)),
                    error,
                })
        })
        .collect::<Result<_, _>>()?;
    let scenarios: Vec<Scenario> = (0..axis_count).map(|a| plan.scenario_at(a)).collect();
    let identifiers: Vec<ident::Identifier> = scenarios.iter().map(Scenario::identifier).collect();
    let refiners: Vec<Option<ident::refine::Refiner>> = scenarios
        .iter()
        .map(|s| s.identification.refine.then(|| s.refiner()))
        .collect();
    let frf_routes: Vec<FrfRoute> = scenarios.iter().map(Scenario::frf_route).collect();
    let route = plan.scenario.identification.route;
    let keys = plan.shard_keys(shard);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()?;
    let rows = pool.install(|| {
        keys.par_iter()
            .map(|&key| {
                let seed = plan.trial_seed(key);
                let noise = noise_at(&plan.scenario.campaign.noise, plan.noise_levels[key.noise]);
                let routes = Routes {
                    time: route.time().then_some(&identifiers[key.axis]),
                    refiner: refiners[key.axis].as_ref(),
                    frf: route.frf().then_some(&frf_routes[key.axis]),
                };
                let outcome = catch_unwind(AssertUnwindSafe(|| {
                    let trial = run_trial(&simulators[key.axis], routes, &noise, seed);
                    outcome(&trial, plan, truth)
                }))
                .unwrap_or_else(|panic| Outcome::Failed {
                    reason: "panic".into(),
                    message: panic
                        .downcast_ref::<String>()
                        .cloned()
                        .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                        .unwrap_or_default(),
                });
                progress();
                TrialRow { key, seed, outcome }
            })
            .collect::<Vec<_>>()
    });
    Ok(rows)
}

/// The outcome of a trial, its scores aligned with [`Plan::score_keys`].
///
/// One route: `Failed` when it failed, as always. Both routes: `Failed`
/// when both failed (the reason and message name both); otherwise `Ok`,
/// the failed route's scores NaN, [`ScoreKey::RouteFailed`] 1 for it, and
/// its reason (prefixed `time route: ` or `FRF route: `) in the note.
fn outcome(trial: &TrialResult, plan: &Plan, truth: &TrueModel) -> Outcome {
    let n = truth.dofs();
    let refine = plan.scenario.identification.refine;
    let refine_note = match &trial.refinement {
        Some(Err(e)) => Some((refine_failure_reason(e), e.to_string())),
        _ => None,
    };
    let time = trial.identification.as_ref().map(|r| match r {
        Ok(id) => Ok(score(id, trial.refinement.as_ref(), truth)),
        Err(e) => Err((failure_reason(e), e.to_string())),
    });
    let frf = trial.frf.as_ref().map(|r| match r {
        Ok(id) => Ok(score_frf(id, truth)),
        Err(e) => Err((frf_failure_reason(e), e.to_string())),
    });
    match (time, frf) {
        (Some(Ok(scores)), None) => Outcome::Ok {
            scores,
            note: refine_note,
        },
        (None, Some(Ok(scores))) => Outcome::Ok { scores, note: None },
        (Some(Err((reason, message))), None) | (None, Some(Err((reason, message)))) => {
            Outcome::Failed { reason, message }
        }
        (Some(time), Some(frf)) => {
            let flags = [time.is_err(), frf.is_err()];
            let prefixed = |route: Route, (reason, message): (String, String)| {
                let name = format!("{} route: ", route.label());
                (name.clone() + &reason, name + &message)
            };
            let mut notes = Vec::new();
            let mut scores = match time {
                Ok(scores) => {
                    notes.extend(refine_note);
                    scores
                }
                Err(e) => {
                    notes.push(prefixed(Route::Time, e));
                    missing(ScoreKey::of_routes(n, refine, true, false).len())
                }
            };
            match frf {
                Ok(s) => scores.extend(s),
                Err(e) => {
                    notes.push(prefixed(Route::Frf, e));
                    scores.extend(missing(ScoreKey::of_routes(n, false, false, true).len()));
                }
            }
            scores.extend(flags.map(|failed| if failed { 1.0 } else { 0.0 }));
            let joined = |pick: fn(&(String, String)) -> &String| {
                notes
                    .iter()
                    .map(pick)
                    .cloned()
                    .collect::<Vec<_>>()
                    .join("; ")
            };
            let (reason, message) = (joined(|n| &n.0), joined(|n| &n.1));
            if flags == [true, true] {
                Outcome::Failed { reason, message }
            } else {
                Outcome::Ok {
                    scores,
                    note: (!notes.is_empty()).then_some((reason, message)),
                }
            }
        }
        (None, None) => unreachable!("a plan runs at least one route"),
    }
}

const FIXED_COLUMNS: [&str; 7] = [
    "axis", "noise", "trial", "seed", "status", "reason", "message",
];

/// Writes `trials.csv`: one row per trial in canonical order; scores in
/// shortest round-trip form (empty for failed trials). The bytes are
/// those of [`format_trials`].
pub fn write_trials(
    path: &Path,
    plan: &Plan,
    keys: &[ScoreKey],
    rows: &[TrialRow],
) -> Result<(), StudyError> {
    let bytes = format_trials(path, plan, keys, rows)?;
    records::write_atomically(path, &bytes)?;
    Ok(())
}

/// The contents of `trials.csv` for `rows`, in memory (the Python binding
/// compares them byte for byte); `path` is named in messages only.
pub fn format_trials(
    path: &Path,
    plan: &Plan,
    keys: &[ScoreKey],
    rows: &[TrialRow],
) -> Result<Vec<u8>, StudyError> {
    let csv_error = |e: csv::Error| StudyError::bad_file(path, None, format!("cannot format: {e}"));
    let mut w = csv::Writer::from_writer(Vec::new());
    let header: Vec<String> = FIXED_COLUMNS
        .iter()
        .map(ToString::to_string)
        .chain(keys.iter().map(ToString::to_string))
        .collect();
    w.write_record(&header).map_err(csv_error)?;
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
                rec.extend(keys.iter().map(|_| String::new()));
            }
        }
        w.write_record(&rec).map_err(csv_error)?;
    }
    w.into_inner()
        .map_err(|e| StudyError::bad_file(path, None, format!("cannot format: {e}")))
}

/// Reads a `trials.csv` written for `plan`; checks header and keys.
pub fn read_trials(
    path: &Path,
    plan: &Plan,
    keys: &[ScoreKey],
) -> Result<Vec<TrialRow>, StudyError> {
    let bytes = std::fs::read(path).map_err(|e| StudyError::io(path, "read", e))?;
    parse_trials(&bytes, path, plan, keys)
}

/// Parses the contents of a `trials.csv` written for `plan` (see
/// [`read_trials`]); `path` is named in messages only.
pub fn parse_trials(
    bytes: &[u8],
    path: &Path,
    plan: &Plan,
    keys: &[ScoreKey],
) -> Result<Vec<TrialRow>, StudyError> {
    let mut r = csv::Reader::from_reader(bytes);
    let expected: Vec<String> = FIXED_COLUMNS
        .iter()
        .map(ToString::to_string)
        .chain(keys.iter().map(ToString::to_string))
        .collect();
    let header = r
        .headers()
        .map_err(|e| StudyError::bad_file(path, Some(1), format!("no header: {e}")))?
        .clone();
    if header.iter().collect::<Vec<_>>() != expected {
        return Err(StudyError::bad_file(
            path,
            Some(1),
            "the columns do not match this sweep's scores",
        ));
    }
    let labels: Vec<String> = (0..plan.axis_values().len())
        .map(|a| plan.axis_label(a))
        .collect();
    let mut rows = Vec::new();
    for (i, rec) in r.records().enumerate() {
        let line = i + 2;
        let rec = rec.map_err(|e| StudyError::bad_file(path, Some(line), e.to_string()))?;
        let field = |k: usize| rec.get(k).unwrap_or("");
        let bad = |what: &str| StudyError::bad_file(path, Some(line), what);
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
                scores: (0..keys.len())
                    .map(|k| {
                        field(FIXED_COLUMNS.len() + k)
                            .parse::<f64>()
                            .map_err(|_| bad("score is not a number"))
                    })
                    .collect::<Result<_, _>>()?,
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
    /// The axis value (none without an axis).
    pub axis_value: Option<AxisValue>,
    /// The noise level.
    pub noise: f64,
    /// Trials run.
    pub trials: usize,
    /// Trials whose identification failed.
    pub failures: usize,
    /// `failures / trials`.
    pub failure_rate: f64,
    /// Failures counted by reason.
    pub failure_reasons: BTreeMap<String, usize>,
    /// Trials whose identification succeeded with a note, by reason: the
    /// refinement failed (`refinement: ...`) or, with both routes, one
    /// route failed (`time route: ...`, `FRF route: ...`).
    pub refine_failures: BTreeMap<String, usize>,
    /// Statistics of every score over the successful trials.
    pub scores: BTreeMap<ScoreKey, Stats>,
    /// The Cramér–Rao bound at this level (none at zero noise, or if it
    /// could not be computed).
    pub bound: Option<Bound>,
    /// Per score with a bound: bound / RMS error over the successful trials
    /// (1 = efficient).
    pub efficiency: BTreeMap<ScoreKey, f64>,
    /// Monte Carlo standard error of each `efficiency`: the efficiency times
    /// the relative standard error of the RMS error
    /// ([`stats::rms_with_error`]; the bound itself is exact). Two sweeps'
    /// efficiencies agree within their Monte Carlo error when they differ by
    /// less than about twice the root sum of squares of these. Missing below
    /// two trials; summaries written before it was added read as empty.
    #[serde(default)]
    pub efficiency_se: BTreeMap<ScoreKey, f64>,
    /// Refined M, K, damping: mean standard error reported by a single
    /// refinement over the RMS error across trials (1 = honest error bars).
    pub standard_error_ratio: BTreeMap<String, f64>,
}

/// Contents of `summary.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    /// Version of frameid that wrote it.
    pub frameid_version: String,
    /// What was run.
    pub plan: Plan,
    /// The scores, in column order.
    pub score_names: Vec<ScoreKey>,
    /// One summary per (axis value, noise level).
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
                    // JSON has no NaN: a bound that is not a positive number
                    // everywhere would be written as null and the summary
                    // could not be read back.
                    .filter(Bound::is_usable)
                })
                .collect()
        })
        .collect()
}

/// Summarizes rows (all trials of the plan, canonical order).
pub fn summarize(plan: &Plan, truth: &TrueModel, keys: &[ScoreKey], rows: &[TrialRow]) -> Summary {
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
            let mut columns: Vec<Vec<f64>> = vec![Vec::new(); keys.len()];
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
            let column = |key: ScoreKey| keys.iter().position(|&k| k == key).map(|i| &columns[i]);
            let rms = |v: &[f64]| {
                let finite: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
                (!finite.is_empty()).then(|| {
                    (finite.iter().map(|x| x * x).sum::<f64>() / finite.len() as f64).sqrt()
                })
            };
            let bound = bounds[a][ni].clone();
            let efficiency = match &bound {
                Some(b) => keys
                    .iter()
                    .filter_map(|&k| {
                        let (bound, rms) = (b.for_score(k)?, rms(column(k)?)?);
                        // Infinite when the errors are all zero: left out
                        // (JSON would write null).
                        let efficiency = bound / rms;
                        efficiency.is_finite().then_some((k, efficiency))
                    })
                    .collect(),
                None => BTreeMap::new(),
            };
            let efficiency_se = efficiency
                .iter()
                .filter_map(|(&k, &eff)| {
                    let (rms, se) = stats::rms_with_error(column(k)?)?;
                    let se = eff * se / rms;
                    se.is_finite().then_some((k, se))
                })
                .collect();
            // Meaningless without noise (errors at round-off level).
            let standard_error_ratio = MatrixEstimate::REFINED
                .iter()
                .filter(|_| bound.is_some())
                .filter_map(|&m| {
                    let se = column(ScoreKey::StandardError(m))?;
                    let err = rms(column(ScoreKey::Matrix(m))?)?;
                    let mean_se = Stats::of(se).mean?;
                    let name = m.name().trim_end_matches("_refined").to_string();
                    let ratio = mean_se / err;
                    ratio.is_finite().then_some((name, ratio))
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
                scores: keys
                    .iter()
                    .copied()
                    .zip(columns.iter().map(|c| Stats::of(c)))
                    .collect(),
                bound,
                efficiency,
                efficiency_se,
                standard_error_ratio,
            });
        }
    }
    Summary {
        frameid_version: env!("CARGO_PKG_VERSION").into(),
        plan: plan.clone(),
        score_names: keys.to_vec(),
        levels,
    }
}

/// `sweep.json`: what a directory holds (the plan and which shard).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    /// Version of frameid that wrote it.
    pub frameid_version: String,
    /// The scenario file as given.
    pub scenario_path: String,
    /// What was run.
    pub plan: Plan,
    /// Which part (none for a whole sweep).
    pub shard: Option<Shard>,
}

/// Writes the files of a sweep into `dir` (a fresh directory being built,
/// see [`fsio::OutputDir`]): `trials.csv`, `summary.json` (complete runs
/// only: pass their summary) and `sweep.json`.
pub fn write_dir(
    dir: &Path,
    manifest: &Manifest,
    keys: &[ScoreKey],
    rows: &[TrialRow],
    summary: Option<&Summary>,
) -> Result<(), StudyError> {
    write_trials(&dir.join("trials.csv"), &manifest.plan, keys, rows)?;
    if let Some(summary) = summary {
        write_json(&dir.join("summary.json"), summary)?;
    }
    write_json(&dir.join("sweep.json"), manifest)
}

/// Reads `sweep.json` of a directory.
pub fn read_manifest(dir: &Path) -> Result<Manifest, StudyError> {
    let path = dir.join("sweep.json");
    if !path.exists() {
        return Err(StudyError::bad_file(
            &path,
            None,
            "missing: not a sweep directory",
        ));
    }
    read_json(&path, "a sweep manifest")
}

/// Joins shard directories into what one run gives (with the
/// representative campaign), written whole into `out`.
pub fn merge(dirs: &[&Path], out: &Path) -> Result<Merged, StudyError> {
    let merge_error = |problem: String| StudyError::Merge { problem };
    if dirs.is_empty() {
        return Err(merge_error("merge: no directories given".into()));
    }
    let manifests: Vec<Manifest> = dirs
        .iter()
        .map(|d| read_manifest(d))
        .collect::<Result<_, _>>()?;
    let first = &manifests[0];
    for (m, d) in manifests.iter().zip(dirs).skip(1) {
        if let Some(problem) = manifest_mismatch((d, m), (dirs[0], first)) {
            return Err(merge_error(problem));
        }
    }
    let truth = plan_truth(&first.plan)?;
    let keys = first.plan.score_keys();
    let parts = dirs
        .iter()
        .map(|d| {
            read_trials(&d.join("trials.csv"), &first.plan, &keys)
                .map(|rows| (d.display().to_string(), rows))
        })
        .collect::<Result<Vec<_>, _>>()?;
    let rows = join_rows(&first.plan, parts)?;
    let manifest = Manifest {
        shard: None,
        ..first.clone()
    };
    let summary = summarize(&manifest.plan, &truth, &keys, &rows);
    let dir = fsio::OutputDir::create(out, "sweep.json")?;
    write_dir(dir.path(), &manifest, &keys, &rows, Some(&summary))?;
    let warnings = write_representative(
        &manifest.plan.scenario,
        &truth,
        manifest.plan.seed,
        dir.path(),
    )?;
    dir.commit()?;
    Ok(Merged { summary, warnings })
}

/// Why directory `dir` (manifest `m`) cannot be merged with directory
/// `first_dir` (manifest `first`), as a message naming both: another
/// frameid version (its trials need not be the ones this version
/// computes), another plan (the first field that differs, its path in
/// `sweep.json` and both values) or another shard split. `None` if they can
/// be merged. The scenario path is not compared: the same scenario may sit
/// in different places on the machines that ran the shards. (Public for
/// the Python package's merge of shards held in memory, whose messages are
/// the command line's.)
pub fn manifest_mismatch(
    (dir, m): (&Path, &Manifest),
    (first_dir, first): (&Path, &Manifest),
) -> Option<String> {
    let (dir, first_dir) = (dir.display(), first_dir.display());
    if m.frameid_version != first.frameid_version {
        return Some(format!(
            "{dir}: written by frameid {}, {first_dir} by frameid {} (sweep.json frameid_version): shards of different versions need not hold the same trials; run every shard with one version",
            m.frameid_version, first.frameid_version
        ));
    }
    if m.plan != first.plan {
        let difference = match (
            serde_json::to_value(&m.plan),
            serde_json::to_value(&first.plan),
        ) {
            (Ok(a), Ok(b)) => first_difference(&a, &b, "plan"),
            _ => None,
        };
        return Some(match difference {
            Some((path, here, there)) => format!(
                "{dir}: a different sweep than {first_dir}: sweep.json {path} is {here} here, {there} there"
            ),
            // Equal as JSON but not as values: not seen for plans read from
            // JSON; refused all the same.
            None => format!(
                "{dir}: a different sweep than {first_dir} (scenario, noise levels, trials, seed or axis differ)"
            ),
        });
    }
    match (m.shard, first.shard) {
        (Some(s), Some(f)) if s.count != f.count => Some(format!(
            "{dir}: shard {}/{}, {first_dir} shard {}/{} (sweep.json shard): parts of different splits",
            s.index, s.count, f.index, f.count
        )),
        _ => None,
    }
}

/// The first place, in document order, where JSON values `a` and `b`
/// differ: its path below `path` (`plan.seed`, `plan.noise_levels`,
/// `plan.scenario.noise.kind`) and the two values as JSON text (shortened
/// to 120 characters). `None` if they are equal.
fn first_difference(
    a: &serde_json::Value,
    b: &serde_json::Value,
    path: &str,
) -> Option<(String, String, String)> {
    use serde_json::Value;
    match (a, b) {
        (Value::Object(x), Value::Object(y)) => {
            let mut keys: Vec<&String> = x.keys().chain(y.keys()).collect();
            keys.sort();
            keys.dedup();
            keys.into_iter().find_map(|k| {
                let child = format!("{path}.{k}");
                match (x.get(k), y.get(k)) {
                    (Some(u), Some(v)) => first_difference(u, v, &child),
                    (u, v) => Some((child, shown(u), shown(v))),
                }
            })
        }
        (Value::Array(x), Value::Array(y)) if x.len() == y.len() => x
            .iter()
            .zip(y)
            .enumerate()
            .find_map(|(i, (u, v))| first_difference(u, v, &format!("{path}[{i}]"))),
        _ if a == b => None,
        _ => Some((path.to_string(), shown(Some(a)), shown(Some(b)))),
    }
}

/// A JSON value as text for a message, at most 120 characters; `absent`
/// for a missing key.
fn shown(v: Option<&serde_json::Value>) -> String {
    let Some(v) = v else {
        return "absent".into();
    };
    let text = v.to_string();
    match text.char_indices().nth(120) {
        Some((cut, _)) => format!("{}...", &text[..cut]),
        None => text,
    }
}

/// Joins the rows of the parts of a sweep of `plan` (each named, for
/// messages, by its directory or shard) into every trial of the plan in
/// canonical order; refuses a trial given twice or missing. [`merge`]
/// uses it on directories, the Python binding on shards in memory.
pub fn join_rows(
    plan: &Plan,
    parts: Vec<(String, Vec<TrialRow>)>,
) -> Result<Vec<TrialRow>, StudyError> {
    let merge_error = |problem: String| StudyError::Merge { problem };
    let mut rows: BTreeMap<TrialKey, TrialRow> = BTreeMap::new();
    for (name, part) in parts {
        for r in part {
            let key = r.key;
            if rows.insert(key, r).is_some() {
                return Err(merge_error(format!(
                    "{name}: trial {} at noise {} appears in more than one directory",
                    key.trial, plan.noise_levels[key.noise]
                )));
            }
        }
    }
    if let Some(missing) = plan.keys().find(|k| !rows.contains_key(k)) {
        return Err(merge_error(format!(
            "merge: trial {} at noise {}{} is missing: are all shards given?",
            missing.trial,
            plan.noise_levels[missing.noise],
            match plan.axis_label(missing.axis).as_str() {
                "" => String::new(),
                l => format!(", axis value {l}"),
            }
        )));
    }
    Ok(rows.into_values().collect())
}

/// What [`merge`] did.
#[derive(Debug, Clone)]
pub struct Merged {
    /// The summary of all trials.
    pub summary: Summary,
    /// Things the user should know (e.g. no representative campaign).
    pub warnings: Vec<String>,
}

/// The true model of a plan's scenario.
pub fn plan_truth(plan: &Plan) -> Result<TrueModel, StudyError> {
    let context = || format!("scenario {}", plan.scenario.name);
    let model = plan
        .scenario
        .model()
        .map_err(|error| StudyError::Simulation {
            context: context(),
            error,
        })?;
    TrueModel::new(model).map_err(|error| StudyError::Simulation {
        context: context(),
        error,
    })
}

impl Plan {
    /// The plan of a scenario's `[sweep]` table with the given overrides
    /// (noise levels, trials, seed); checks the result.
    pub fn new(
        loaded: &crate::scenario::LoadedScenario,
        noise: Option<&[f64]>,
        trials: Option<usize>,
        seed: Option<u64>,
    ) -> Result<Plan, StudyError> {
        let mut scenario = loaded.scenario.clone();
        if let Some(n) = noise {
            scenario.sweep.noise = n.to_vec();
        }
        if let Some(t) = trials {
            scenario.sweep.trials = t;
        }
        if let Some(s) = seed {
            scenario.sweep.seed = s;
        }
        scenario.check_study_settings().map_err(|e| match e {
            sim::SimError::Invalid { field, problem } => {
                StudyError::Scenario(crate::scenario::ScenarioError::Invalid {
                    path: loaded.path.clone(),
                    field,
                    problem,
                })
            }
            error => StudyError::Simulation {
                context: loaded.path.display().to_string(),
                error,
            },
        })?;
        let plan = Plan {
            noise_levels: scenario.sweep.noise.clone(),
            trials: scenario.sweep.trials,
            seed: scenario.sweep.seed,
            axis: scenario.sweep.axis.clone(),
            scenario,
        };
        // The damping scores (xi_err, damping_*_err) and their bound are
        // relative to the truth's: an undamped mode has none to score
        // against (its ratio is round-off: 4e-15 on paper case 1 without
        // damping, and the bound's own modal analysis gave it negative).
        // 1e-9 is six orders above that round-off and far below any
        // structure's damping.
        let truth = plan_truth(&plan)?;
        if let Some((j, xi)) = truth
            .modal
            .damping_ratios
            .iter()
            .enumerate()
            .find(|&(_, &xi)| xi.is_nan() || xi <= 1e-9)
        {
            return Err(StudyError::Scenario(
                crate::scenario::ScenarioError::Invalid {
                    path: loaded.path.clone(),
                    field: "damping".into(),
                    problem: format!(
                        "mode {} of the structure is undamped (damping ratio {xi:.1e}): a sweep scores damping ratios and the damping matrix relative to the truth's; give the structure damping ([damping] or [[dashpots]])",
                        j + 1
                    ),
                },
            ));
        }
        if plan.trial_count().is_none() {
            return Err(StudyError::InvalidSetting {
                setting: "trials".into(),
                problem: format!(
                    "{} trials x {} noise levels x {} axis values overflow a count of trials",
                    plan.trials,
                    plan.noise_levels.len(),
                    plan.axis_values().len()
                ),
            });
        }
        Ok(plan)
    }
}

impl Plan {
    /// The same plan identified by `route` instead of the scenario's
    /// (`--route` on the command line); checks the result (the refinement
    /// needs the time route: a message names `identification.refine`).
    pub fn with_route(mut self, route: crate::scenario::RouteSetting) -> Result<Plan, StudyError> {
        self.scenario.identification.route = route;
        self.scenario.check_study_settings().map_err(|e| match e {
            sim::SimError::Invalid { field, problem } => StudyError::InvalidSetting {
                setting: format!("route {route} ({field})"),
                problem,
            },
            error => StudyError::Simulation {
                context: format!("route {route}"),
                error,
            },
        })?;
        Ok(self)
    }
}

/// What [`execute`] did.
#[derive(Debug, Clone)]
pub struct Execution {
    /// The summary (none for a shard).
    pub summary: Option<Summary>,
    /// Trials run.
    pub trials: usize,
    /// Things the user should know (e.g. no representative campaign).
    pub warnings: Vec<String>,
}

/// Runs a whole sweep (or one shard) and writes its directory: trials,
/// manifest, and for a whole sweep the summary and the representative
/// campaign. `scenario_path` is recorded in the manifest.
pub fn execute(
    scenario_path: &Path,
    plan: &Plan,
    out: &Path,
    shard: Option<Shard>,
    threads: usize,
    progress: &(dyn Fn() + Sync),
) -> Result<Execution, StudyError> {
    let truth = plan_truth(plan)?;
    let keys = plan.score_keys();
    // Checked before any trial runs: the directory can be replaced.
    let dir = fsio::OutputDir::create(out, "sweep.json")?;
    let rows = run(plan, &truth, shard, threads, progress)?;
    let manifest = Manifest {
        frameid_version: env!("CARGO_PKG_VERSION").into(),
        scenario_path: scenario_path.display().to_string(),
        plan: plan.clone(),
        shard,
    };
    if shard.is_some() {
        write_dir(dir.path(), &manifest, &keys, &rows, None)?;
        dir.commit()?;
        return Ok(Execution {
            summary: None,
            trials: rows.len(),
            warnings: Vec::new(),
        });
    }
    let summary = summarize(plan, &truth, &keys, &rows);
    write_dir(dir.path(), &manifest, &keys, &rows, Some(&summary))?;
    let warnings = write_representative(&plan.scenario, &truth, plan.seed, dir.path())?;
    dir.commit()?;
    Ok(Execution {
        summary: Some(summary),
        trials: rows.len(),
        warnings,
    })
}

/// Writes `representative.json` (the report's example campaign). If its
/// identification fails (the sweep counts such failures), the report goes
/// without it: a warning is returned, and no stale file is left.
pub fn write_representative(
    scenario: &Scenario,
    truth: &TrueModel,
    seed: u64,
    out: &Path,
) -> Result<Vec<String>, StudyError> {
    let path = out.join("representative.json");
    match crate::representative::representative(scenario, truth, seed) {
        Ok(rep) => write_json(&path, &rep).map(|()| Vec::new()),
        Err(e) => {
            if path.exists() {
                std::fs::remove_file(&path).map_err(|err| StudyError::io(&path, "remove", err))?;
            }
            Ok(vec![format!(
                "no representative campaign in the report: {e}"
            )])
        }
    }
}
