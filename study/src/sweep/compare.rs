//! Two sweeps' medians and efficiencies compared within their Monte Carlo
//! errors: the check that a change of the identifier (a faster algorithm,
//! another stop rule) left its accuracy as it was.

use std::path::Path;

use serde::Serialize;

use super::{LevelSummary, Summary};
use crate::error::StudyError;
use crate::fsutil::read_json;
use crate::score::ScoreKey;

/// Default `|difference| / combined standard error` above which a median or
/// efficiency is reported as changed. A sweep has hundreds of such
/// comparisons (about 60 scores x levels); for independent sweeps a
/// threshold of 3 flags one of them by chance in about 370 (two-sided
/// normal), so a clean comparison of 300 expects 0.8 chance flags, 4 one in
/// 16,000 (0.02 expected). Sweeps of the same seed share their campaigns,
/// so their differences are far below the independent errors used here.
pub const DEFAULT_THRESHOLD: f64 = 4.0;

/// What is compared at a cell.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum Statistic {
    /// The median of a score.
    Median,
    /// The efficiency (Cramér–Rao bound over RMS error) of a score.
    Efficiency,
}

/// One median or efficiency of both sweeps.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Difference {
    /// Noise level of the cell.
    pub noise: f64,
    /// The second axis's value of the cell, as text (empty without an axis).
    pub axis_value: String,
    /// The score.
    pub score: String,
    /// Median or efficiency.
    pub statistic: Statistic,
    /// The first sweep's value.
    pub first: f64,
    /// The second sweep's value.
    pub second: f64,
    /// `sqrt(se_1^2 + se_2^2)`.
    pub standard_error: f64,
    /// `|second - first| / standard_error`; infinite (`null` in JSON) for
    /// values without a Monte Carlo error that differ.
    pub z: f64,
}

/// The comparison of two sweeps.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Comparison {
    /// Cells (axis value, noise level) present in both.
    pub cells: usize,
    /// Medians and efficiencies compared (both finite, with errors).
    pub compared: usize,
    /// Present in both but not comparable: a missing Monte Carlo error (fewer
    /// than 8 trials, a single one) or a zero one (noise-free trials); such
    /// values are only reported as changed when they differ.
    pub without_error: usize,
    /// The comparison with the largest `z`.
    pub largest: Option<Difference>,
    /// Every comparison above the threshold, largest first.
    pub changed: Vec<Difference>,
    /// The threshold used.
    pub threshold: f64,
    /// Scores left out by name (as given).
    pub ignored: Vec<String>,
}

impl Comparison {
    /// Whether every median and efficiency agrees within the threshold.
    pub fn agrees(&self) -> bool {
        self.changed.is_empty()
    }
}

/// Reads `summary.json` of a sweep directory (complete or merged).
pub fn read_summary(dir: &Path) -> Result<Summary, StudyError> {
    let path = dir.join("summary.json");
    if !path.exists() {
        return Err(StudyError::bad_file(
            &path,
            None,
            "missing: not a complete sweep directory (merge shards with `frameid merge` first)",
        ));
    }
    read_json(&path, "a sweep summary")
}

fn axis_text(l: &LevelSummary) -> String {
    l.axis_value
        .as_ref()
        .map(|v| serde_json::to_string(v).unwrap_or_default())
        .unwrap_or_default()
}

/// [`compare`] of the summaries of two sweep directories; errors name the
/// directories.
pub fn compare_dirs(
    first: &Path,
    second: &Path,
    threshold: f64,
    ignore: &[String],
) -> Result<Comparison, StudyError> {
    let (a, b) = (read_summary(first)?, read_summary(second)?);
    compare(&a, &b, threshold, ignore).map_err(|problem| StudyError::Merge {
        problem: format!(
            "cannot compare {} with {}: {problem}",
            first.display(),
            second.display()
        ),
    })
}

/// Compares every median and efficiency the two summaries share, cell by
/// cell (same axis value and noise level), except the scores named in
/// `ignore` (bookkeeping such as `refine_iterations`, which a faster
/// optimizer is meant to change). Refuses summaries of different scenarios
/// (by name) or without a common cell, a threshold that is not a positive
/// number and an ignored name that is no score of either, saying which.
pub fn compare(
    first: &Summary,
    second: &Summary,
    threshold: f64,
    ignore: &[String],
) -> Result<Comparison, String> {
    if !(threshold.is_finite() && threshold > 0.0) {
        return Err(format!("threshold {threshold}: must be a positive number"));
    }
    let (na, nb) = (&first.plan.scenario.name, &second.plan.scenario.name);
    if na != nb {
        return Err(format!(
            "they are sweeps of different scenarios ('{na}' and '{nb}')"
        ));
    }
    for name in ignore {
        let known = |s: &Summary| s.score_names.iter().any(|k| k.to_string() == *name);
        if !(known(first) || known(second)) {
            return Err(format!("--ignore {name}: no score of that name"));
        }
    }
    let mut out = Comparison {
        cells: 0,
        compared: 0,
        without_error: 0,
        largest: None,
        changed: Vec::new(),
        threshold,
        ignored: ignore.to_vec(),
    };
    let mut all = Vec::new();
    for la in &first.levels {
        let Some(lb) = second
            .levels
            .iter()
            .find(|lb| lb.axis_value == la.axis_value && lb.noise.to_bits() == la.noise.to_bits())
        else {
            continue;
        };
        out.cells += 1;
        let mut consider = |key: &ScoreKey,
                            statistic,
                            a: Option<(f64, Option<f64>)>,
                            b: Option<(f64, Option<f64>)>| {
            let (Some((va, sa)), Some((vb, sb))) = (a, b) else {
                return;
            };
            if !(va.is_finite() && vb.is_finite()) || ignore.contains(&key.to_string()) {
                return;
            }
            let se = match (sa, sb) {
                (Some(sa), Some(sb)) if sa.is_finite() && sb.is_finite() => sa.hypot(sb),
                _ => 0.0,
            };
            let z = if se > 0.0 {
                out.compared += 1;
                (vb - va).abs() / se
            } else {
                out.without_error += 1;
                if va == vb { 0.0 } else { f64::INFINITY }
            };
            all.push(Difference {
                noise: la.noise,
                axis_value: axis_text(la),
                score: key.to_string(),
                statistic,
                first: va,
                second: vb,
                standard_error: se,
                z,
            });
        };
        for (key, sa) in &la.scores {
            let sb = lb.scores.get(key);
            consider(
                key,
                Statistic::Median,
                sa.median.map(|m| (m, sa.median_se)),
                sb.and_then(|s| s.median.map(|m| (m, s.median_se))),
            );
        }
        for (key, &ea) in &la.efficiency {
            consider(
                key,
                Statistic::Efficiency,
                Some((ea, la.efficiency_se.get(key).copied())),
                lb.efficiency
                    .get(key)
                    .map(|&eb| (eb, lb.efficiency_se.get(key).copied())),
            );
        }
    }
    if out.cells == 0 {
        return Err("they share no (axis value, noise level) cell".into());
    }
    all.sort_by(|a, b| b.z.total_cmp(&a.z));
    out.largest = all.first().cloned();
    out.changed = all.into_iter().filter(|d| d.z > threshold).collect();
    Ok(out)
}
