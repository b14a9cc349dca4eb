//! Scores of one trial against the truth, and their typed keys.
//!
//! A [`ScoreKey`] names one score column of `trials.csv` and one entry of
//! `summary.json`. Its text form ([`std::fmt::Display`], parsed back by
//! [`std::str::FromStr`]) is defined here and nowhere else:
//!
//! | key | text | value |
//! |---|---|---|
//! | `Frequency { mode: j, .. }` | `f{j}_err`, `f{j}_refined_err` | \|relative error\| of natural frequency j (ascending) |
//! | `DampingRatio` | `xi{j}_err`, `xi{j}_refined_err` | \|relative error\| of damping ratio j |
//! | `MacDefect` | `mac{j}_defect`, `mac{j}_refined_defect` | 1 - MAC of mode shape j against the truth |
//! | `Matrix(m)` | `mass_err`, `damping_refined_err`, ... | relative Frobenius error |
//! | `Entry { matrix, row, col }` | `mass_12_err` (`mass_1_12_err` from 10 DOFs on) | `(est_ij - true_ij) / sqrt(true_ii true_jj)`, `i <= j`, 1-based |
//! | `StandardError(m)` | `mass_refined_se` | reported standard errors as `sqrt(sum of entry variances) / \|\|true\|\|` |
//! | `Consistency` | `consistency` | MKR's `\|\|W W^T\|\| / \|\|W L W^T\|\|` |
//! | `ModelOrder`, `Warnings` | `model_order`, `warnings` | what the identifier did |
//! | `RefineFailed`, `RefineIterations` | `refine_failed`, `refine_iterations` | 0/1 and the refinement's iterations |
//! | `Frf(s)` | `frf_` + the text of [`FrfScore::time_key`]: `frf_f1_err`, `frf_mass_err`, `frf_damping_mkr_12_err`, `frf_consistency`, ... | the same measure on the FRF route ([`Route::Frf`]); `frf_model_order` is the pLSCF order |
//! | `RouteFailed(route)` | `time_failed`, `frf_failed` | 0/1: that route's identification failed (only in sweeps that run both routes) |
//!
//! The keys without a route name (`f1_err`, `mass_err`, ...) are the time
//! route's ([`Route::Time`]): sweeps of the time route alone keep the
//! columns they always had. Modes are numbered from 1 in ascending
//! frequency.

use std::cmp::Ordering;
use std::fmt;
use std::str::FromStr;

use ident::frf::FrfIdentification;
use ident::refine::Refinement;
use ident::{Identification, RefineError};
use nalgebra::DMatrix;
use num_complex::Complex64;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use crate::experiment::TrueModel;

/// A matrix estimate that is scored.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum MatrixEstimate {
    /// Mass from MKR.
    Mass,
    /// Stiffness from MKR.
    Stiffness,
    /// Damping from MKR (eq. 30).
    DampingMkr,
    /// Rayleigh damping `alpha M + beta K`.
    DampingRayleigh,
    /// Mass refined by maximum likelihood.
    MassRefined,
    /// Stiffness refined by maximum likelihood.
    StiffnessRefined,
    /// Damping refined by maximum likelihood.
    DampingRefined,
}

impl MatrixEstimate {
    /// The identifier's matrices, in column order.
    pub const IDENTIFIED: [MatrixEstimate; 4] = [
        MatrixEstimate::Mass,
        MatrixEstimate::Stiffness,
        MatrixEstimate::DampingMkr,
        MatrixEstimate::DampingRayleigh,
    ];
    /// The refinement's matrices, in column order.
    pub const REFINED: [MatrixEstimate; 3] = [
        MatrixEstimate::MassRefined,
        MatrixEstimate::StiffnessRefined,
        MatrixEstimate::DampingRefined,
    ];

    /// Prefix of the score texts.
    pub fn name(self) -> &'static str {
        match self {
            MatrixEstimate::Mass => "mass",
            MatrixEstimate::Stiffness => "stiffness",
            MatrixEstimate::DampingMkr => "damping_mkr",
            MatrixEstimate::DampingRayleigh => "damping_rayleigh",
            MatrixEstimate::MassRefined => "mass_refined",
            MatrixEstimate::StiffnessRefined => "stiffness_refined",
            MatrixEstimate::DampingRefined => "damping_refined",
        }
    }

    /// Whether this is an estimate of the refinement.
    pub fn is_refined(self) -> bool {
        Self::REFINED.contains(&self)
    }

    /// The physical matrix estimated.
    pub fn quantity(self) -> Quantity {
        match self {
            MatrixEstimate::Mass | MatrixEstimate::MassRefined => Quantity::Mass,
            MatrixEstimate::Stiffness | MatrixEstimate::StiffnessRefined => Quantity::Stiffness,
            _ => Quantity::Damping,
        }
    }

    fn all() -> impl Iterator<Item = MatrixEstimate> {
        Self::IDENTIFIED.into_iter().chain(Self::REFINED)
    }
}

/// The physical matrix a [`MatrixEstimate`] estimates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Quantity {
    /// Mass matrix.
    Mass,
    /// Stiffness matrix.
    Stiffness,
    /// Damping matrix.
    Damping,
}

/// The identification route an estimate comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Route {
    /// The time records: OKID, ERA/DC, MKR ([`ident::Identifier`]).
    Time,
    /// FRFs estimated across the hits ([`ident::frf::estimate`]), then
    /// pLSCF, LSFD and MKR ([`ident::frf::FrfIdentifier`]).
    Frf,
}

impl Route {
    /// Both routes, time first (the column order of the scores).
    pub const ALL: [Route; 2] = [Route::Time, Route::Frf];

    /// The word used in score texts and reports (`time`, `frf`).
    pub fn name(self) -> &'static str {
        match self {
            Route::Time => "time",
            Route::Frf => "frf",
        }
    }

    /// The name shown in reports ("time", "FRF").
    pub fn label(self) -> &'static str {
        match self {
            Route::Time => "time",
            Route::Frf => "FRF",
        }
    }
}

impl fmt::Display for Route {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// An identification score of the FRF route: the same measures as the time
/// route's ERA/DC and MKR scores (never the refinement's), against the same
/// truth. Its text is `frf_` followed by the text of [`FrfScore::time_key`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum FrfScore {
    /// |relative error| of natural frequency `mode` (1-based).
    Frequency {
        /// Mode, 1-based, ascending frequency.
        mode: usize,
    },
    /// |relative error| of damping ratio `mode` (1-based).
    DampingRatio {
        /// Mode, 1-based.
        mode: usize,
    },
    /// 1 - MAC of mode shape `mode` against the truth.
    MacDefect {
        /// Mode, 1-based.
        mode: usize,
    },
    /// Relative Frobenius error of a matrix (one of
    /// [`MatrixEstimate::IDENTIFIED`]).
    Matrix(MatrixEstimate),
    /// Diagonal-scaled signed error of entry (`row`, `col`), 1-based,
    /// `row <= col`, of one of [`MatrixEstimate::IDENTIFIED`].
    Entry {
        /// The matrix.
        matrix: MatrixEstimate,
        /// Row, 1-based.
        row: usize,
        /// Column, 1-based.
        col: usize,
    },
    /// MKR's second-order consistency.
    Consistency,
    /// The pLSCF model order used.
    ModelOrder,
    /// Number of identification warnings.
    Warnings,
}

impl FrfScore {
    /// The time route's key of the same measure.
    pub fn time_key(self) -> ScoreKey {
        match self {
            FrfScore::Frequency { mode } => ScoreKey::Frequency {
                mode,
                refined: false,
            },
            FrfScore::DampingRatio { mode } => ScoreKey::DampingRatio {
                mode,
                refined: false,
            },
            FrfScore::MacDefect { mode } => ScoreKey::MacDefect {
                mode,
                refined: false,
            },
            FrfScore::Matrix(m) => ScoreKey::Matrix(m),
            FrfScore::Entry { matrix, row, col } => ScoreKey::Entry { matrix, row, col },
            FrfScore::Consistency => ScoreKey::Consistency,
            FrfScore::ModelOrder => ScoreKey::ModelOrder,
            FrfScore::Warnings => ScoreKey::Warnings,
        }
    }

    /// The FRF route's score of the measure of a time-route key; `None`
    /// for the refinement's keys and the route-level ones, which have no
    /// FRF counterpart.
    pub fn of_time_key(key: ScoreKey) -> Option<FrfScore> {
        Some(match key {
            ScoreKey::Frequency {
                mode,
                refined: false,
            } => FrfScore::Frequency { mode },
            ScoreKey::DampingRatio {
                mode,
                refined: false,
            } => FrfScore::DampingRatio { mode },
            ScoreKey::MacDefect {
                mode,
                refined: false,
            } => FrfScore::MacDefect { mode },
            ScoreKey::Matrix(m) if !m.is_refined() => FrfScore::Matrix(m),
            ScoreKey::Entry { matrix, row, col } if !matrix.is_refined() => {
                FrfScore::Entry { matrix, row, col }
            }
            ScoreKey::Consistency => FrfScore::Consistency,
            ScoreKey::ModelOrder => FrfScore::ModelOrder,
            ScoreKey::Warnings => FrfScore::Warnings,
            _ => return None,
        })
    }
}

/// One score column (see the module docs for the text forms).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ScoreKey {
    /// |relative error| of natural frequency `mode` (1-based).
    Frequency {
        /// Mode, 1-based, ascending frequency.
        mode: usize,
        /// Of the refinement rather than ERA/DC.
        refined: bool,
    },
    /// |relative error| of damping ratio `mode`.
    DampingRatio {
        /// Mode, 1-based.
        mode: usize,
        /// Of the refinement rather than ERA/DC.
        refined: bool,
    },
    /// 1 - MAC of mode shape `mode` against the truth.
    MacDefect {
        /// Mode, 1-based.
        mode: usize,
        /// Of the refinement rather than ERA/DC.
        refined: bool,
    },
    /// Relative Frobenius error of a matrix.
    Matrix(MatrixEstimate),
    /// Diagonal-scaled signed error of entry (`row`, `col`), 1-based, `row <= col`.
    Entry {
        /// The matrix.
        matrix: MatrixEstimate,
        /// Row, 1-based.
        row: usize,
        /// Column, 1-based.
        col: usize,
    },
    /// The refinement's reported standard errors of a matrix, relative.
    StandardError(MatrixEstimate),
    /// MKR's second-order consistency.
    Consistency,
    /// Model order chosen.
    ModelOrder,
    /// Number of identification warnings.
    Warnings,
    /// 1 if the refinement failed, else 0.
    RefineFailed,
    /// Iterations of the refinement.
    RefineIterations,
    /// A score of the FRF route.
    Frf(FrfScore),
    /// 1 if the route's identification failed, else 0 (sweeps that run
    /// both routes).
    RouteFailed(Route),
}

impl ScoreKey {
    /// Every score of a trial for `dofs` floors, in column order (with the
    /// refinement's scores if `refine`).
    pub fn all(dofs: usize, refine: bool) -> Vec<ScoreKey> {
        let mut keys = Vec::new();
        let modal = |keys: &mut Vec<ScoreKey>, refined: bool| {
            keys.extend((1..=dofs).map(|mode| ScoreKey::Frequency { mode, refined }));
            keys.extend((1..=dofs).map(|mode| ScoreKey::DampingRatio { mode, refined }));
            keys.extend((1..=dofs).map(|mode| ScoreKey::MacDefect { mode, refined }));
        };
        let entries = |keys: &mut Vec<ScoreKey>, matrices: &[MatrixEstimate]| {
            for &matrix in matrices {
                for row in 1..=dofs {
                    for col in row..=dofs {
                        keys.push(ScoreKey::Entry { matrix, row, col });
                    }
                }
            }
        };
        modal(&mut keys, false);
        keys.extend(MatrixEstimate::IDENTIFIED.map(ScoreKey::Matrix));
        entries(&mut keys, &MatrixEstimate::IDENTIFIED);
        keys.extend([
            ScoreKey::Consistency,
            ScoreKey::ModelOrder,
            ScoreKey::Warnings,
        ]);
        if refine {
            modal(&mut keys, true);
            keys.extend(MatrixEstimate::REFINED.map(ScoreKey::Matrix));
            entries(&mut keys, &MatrixEstimate::REFINED);
            keys.extend(MatrixEstimate::REFINED.map(ScoreKey::StandardError));
            keys.extend([ScoreKey::RefineFailed, ScoreKey::RefineIterations]);
        }
        keys
    }

    /// Every score of a trial that runs the routes `time` and `frf` for
    /// `dofs` floors, in column order: the time route's scores as
    /// [`ScoreKey::all`] gives them (with the refinement's if `refine`),
    /// then the FRF route's in the same order, then with both routes
    /// [`ScoreKey::RouteFailed`] of each.
    pub fn of_routes(dofs: usize, refine: bool, time: bool, frf: bool) -> Vec<ScoreKey> {
        let mut keys = Vec::new();
        if time {
            keys = ScoreKey::all(dofs, refine);
        }
        if frf {
            keys.extend(
                ScoreKey::all(dofs, false)
                    .into_iter()
                    .filter_map(FrfScore::of_time_key)
                    .map(ScoreKey::Frf),
            );
        }
        if time && frf {
            keys.extend(Route::ALL.map(ScoreKey::RouteFailed));
        }
        keys
    }

    /// The route whose identification the score measures (the refinement
    /// starts from the time route's).
    pub fn route(self) -> Route {
        match self {
            ScoreKey::Frf(_) | ScoreKey::RouteFailed(Route::Frf) => Route::Frf,
            _ => Route::Time,
        }
    }

    /// Whether the score belongs to the refinement.
    pub fn is_refined(self) -> bool {
        match self {
            ScoreKey::Frequency { refined, .. }
            | ScoreKey::DampingRatio { refined, .. }
            | ScoreKey::MacDefect { refined, .. } => refined,
            ScoreKey::Matrix(m)
            | ScoreKey::StandardError(m)
            | ScoreKey::Entry { matrix: m, .. } => m.is_refined(),
            ScoreKey::RefineFailed | ScoreKey::RefineIterations => true,
            ScoreKey::Consistency
            | ScoreKey::ModelOrder
            | ScoreKey::Warnings
            | ScoreKey::Frf(_)
            | ScoreKey::RouteFailed(_) => false,
        }
    }
}

impl fmt::Display for ScoreKey {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let refined = |r: bool| if r { "_refined" } else { "" };
        match *self {
            ScoreKey::Frequency { mode, refined: r } => write!(f, "f{mode}{}_err", refined(r)),
            ScoreKey::DampingRatio { mode, refined: r } => {
                write!(f, "xi{mode}{}_err", refined(r))
            }
            ScoreKey::MacDefect { mode, refined: r } => {
                write!(f, "mac{mode}{}_defect", refined(r))
            }
            ScoreKey::Matrix(m) => write!(f, "{}_err", m.name()),
            ScoreKey::Entry { matrix, row, col } if row < 10 && col < 10 => {
                write!(f, "{}_{row}{col}_err", matrix.name())
            }
            ScoreKey::Entry { matrix, row, col } => {
                write!(f, "{}_{row}_{col}_err", matrix.name())
            }
            ScoreKey::StandardError(m) => write!(f, "{}_se", m.name()),
            ScoreKey::Consistency => f.write_str("consistency"),
            ScoreKey::ModelOrder => f.write_str("model_order"),
            ScoreKey::Warnings => f.write_str("warnings"),
            ScoreKey::RefineFailed => f.write_str("refine_failed"),
            ScoreKey::RefineIterations => f.write_str("refine_iterations"),
            ScoreKey::Frf(s) => write!(f, "{FRF_PREFIX}{}", s.time_key()),
            ScoreKey::RouteFailed(route) => write!(f, "{route}_failed"),
        }
    }
}

/// What the texts of the FRF route's scores start with.
const FRF_PREFIX: &str = "frf_";

/// A text that is not a score key.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("'{text}' is not a score name")]
pub struct UnknownScore {
    /// The text.
    pub text: String,
}

impl FromStr for ScoreKey {
    type Err = UnknownScore;

    fn from_str(s: &str) -> Result<Self, UnknownScore> {
        let unknown = || UnknownScore { text: s.into() };
        let fixed = [
            ScoreKey::Consistency,
            ScoreKey::ModelOrder,
            ScoreKey::Warnings,
            ScoreKey::RefineFailed,
            ScoreKey::RefineIterations,
            ScoreKey::RouteFailed(Route::Time),
            ScoreKey::RouteFailed(Route::Frf),
        ];
        if let Some(k) = fixed.into_iter().find(|k| k.to_string() == s) {
            return Ok(k);
        }
        if let Some(rest) = s.strip_prefix(FRF_PREFIX) {
            return rest
                .parse::<ScoreKey>()
                .ok()
                .and_then(FrfScore::of_time_key)
                .map(ScoreKey::Frf)
                .ok_or_else(unknown);
        }
        let mode = |s: &str, prefix: &str, suffix: &str| -> Option<(usize, bool)> {
            let rest = s.strip_prefix(prefix)?.strip_suffix(suffix)?;
            let (digits, refined) = match rest.strip_suffix("_refined") {
                Some(d) => (d, true),
                None => (rest, false),
            };
            let j = positive(digits)?;
            Some((j, refined))
        };
        if let Some((mode, refined)) = mode(s, "f", "_err") {
            return Ok(ScoreKey::Frequency { mode, refined });
        }
        if let Some((mode, refined)) = mode(s, "xi", "_err") {
            return Ok(ScoreKey::DampingRatio { mode, refined });
        }
        if let Some((mode, refined)) = mode(s, "mac", "_defect") {
            return Ok(ScoreKey::MacDefect { mode, refined });
        }
        // Longest prefix first: `damping_refined` before `damping`... none
        // is a prefix of another followed by `_`, but try them all.
        for m in MatrixEstimate::all() {
            let Some(rest) = s.strip_prefix(m.name()) else {
                continue;
            };
            match rest {
                "_err" => return Ok(ScoreKey::Matrix(m)),
                "_se" if m.is_refined() => return Ok(ScoreKey::StandardError(m)),
                _ => {}
            }
            let Some(indices) = rest.strip_prefix('_').and_then(|r| r.strip_suffix("_err")) else {
                continue;
            };
            let (row, col) = match indices.split_once('_') {
                Some((r, c)) => (positive(r), positive(c)),
                None if indices.len() == 2 => (positive(&indices[..1]), positive(&indices[1..])),
                None => (None, None),
            };
            if let (Some(row), Some(col)) = (row, col)
                && row <= col
            {
                return Ok(ScoreKey::Entry {
                    matrix: m,
                    row,
                    col,
                });
            }
        }
        Err(unknown())
    }
}

/// A 1-based index written in decimal without sign or leading zeros.
fn positive(text: &str) -> Option<usize> {
    if text.is_empty() || text.starts_with('0') || !text.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    text.parse().ok()
}

/// Score keys order as their text, so that maps keyed by them serialize in
/// the order of their names.
impl Ord for ScoreKey {
    fn cmp(&self, other: &Self) -> Ordering {
        self.to_string().cmp(&other.to_string())
    }
}

impl PartialOrd for ScoreKey {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl Serialize for ScoreKey {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

impl<'de> Deserialize<'de> for ScoreKey {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let text = String::deserialize(d)?;
        text.parse().map_err(serde::de::Error::custom)
    }
}

/// Relative Frobenius distance `||a - b|| / ||b||`.
pub fn rel_fro(a: &DMatrix<f64>, b: &DMatrix<f64>) -> f64 {
    (a - b).norm() / b.norm()
}

/// Modal assurance criterion of two complex shapes.
pub fn mac(a: &[Complex64], b: &[Complex64]) -> f64 {
    let dot: Complex64 = a.iter().zip(b).map(|(x, y)| x.conj() * y).sum();
    let na: f64 = a.iter().map(|x| x.norm_sqr()).sum();
    let nb: f64 = b.iter().map(|x| x.norm_sqr()).sum();
    dot.norm_sqr() / (na * nb)
}

/// Scores of one identification (and its refinement, if one was run)
/// against the truth, aligned with [`ScoreKey::all`].
pub fn score(
    id: &Identification,
    refined: Option<&Result<Refinement, RefineError>>,
    truth: &TrueModel,
) -> Vec<f64> {
    let mut v = score_identification(id.into(), truth);
    match refined {
        None => {}
        Some(Ok(r)) => v.extend(score_refinement(r, truth)),
        Some(Err(_)) => {
            // Every refined score NaN, then `refine_failed` = 1 and no
            // iteration count (the last two columns).
            let n = truth.dofs();
            let refined = ScoreKey::all(n, true).len() - ScoreKey::all(n, false).len();
            v.extend(std::iter::repeat_n(f64::NAN, refined - 2));
            v.extend([1.0, f64::NAN]);
        }
    }
    v
}

/// Signed entry errors `(est_ij - true_ij) / sqrt(true_ii true_jj)`, i <= j.
fn entry_errors(est: &DMatrix<f64>, truth: &DMatrix<f64>) -> impl Iterator<Item = f64> {
    let n = truth.nrows();
    (0..n).flat_map(move |i| {
        (i..n).map(move |j| {
            (est[(i, j)] - truth[(i, j)]) / (truth[(i, i)] * truth[(j, j)]).abs().sqrt()
        })
    })
}

fn score_refinement(r: &Refinement, truth: &TrueModel) -> Vec<f64> {
    let n = truth.dofs();
    let t = &truth.modal;
    let modes = &r.uncertainty.modes;
    let mut v = Vec::new();
    for j in 0..n {
        v.push(modes.get(j).map_or(f64::NAN, |m| {
            (m.frequency_hz / t.frequencies_hz[j] - 1.0).abs()
        }));
    }
    for j in 0..n {
        v.push(modes.get(j).map_or(f64::NAN, |m| {
            (m.damping_ratio / t.damping_ratios[j] - 1.0).abs()
        }));
    }
    for j in 0..n {
        v.push(modes.get(j).map_or(f64::NAN, |m| {
            let shape: Vec<Complex64> = m.shape.iter().copied().collect();
            1.0 - mac(&shape, &t.mode_shapes[j])
        }));
    }
    let estimates = [&r.mass, &r.stiffness, &r.damping];
    let references = [
        &truth.model.mass,
        &truth.model.stiffness,
        &truth.model.damping,
    ];
    for (e, t) in estimates.iter().zip(references) {
        v.push(rel_fro(e, t));
    }
    for (e, t) in estimates.iter().zip(references) {
        v.extend(entry_errors(e, t));
    }
    let u = &r.uncertainty;
    for (std, t) in [&u.mass_std, &u.stiffness_std, &u.damping_std]
        .iter()
        .zip(references)
    {
        v.push(std.norm() / t.norm());
    }
    v.push(0.0);
    v.push(r.iterations as f64);
    v
}

/// What the scores of an identification read, from either route.
struct Estimates<'a> {
    frequencies_hz: &'a [f64],
    damping_ratios: &'a [f64],
    mode_shapes: &'a DMatrix<Complex64>,
    mass: &'a DMatrix<f64>,
    stiffness: &'a DMatrix<f64>,
    damping_mkr: &'a DMatrix<f64>,
    damping_rayleigh: &'a DMatrix<f64>,
    consistency: f64,
    model_order: usize,
    warnings: usize,
}

impl<'a> From<&'a Identification> for Estimates<'a> {
    fn from(id: &'a Identification) -> Self {
        Estimates {
            frequencies_hz: &id.frequencies_hz,
            damping_ratios: &id.damping_ratios,
            mode_shapes: &id.mode_shapes,
            mass: &id.mass,
            stiffness: &id.stiffness,
            damping_mkr: &id.damping_mkr,
            damping_rayleigh: &id.damping_rayleigh,
            consistency: id.consistency,
            model_order: id.model_order,
            warnings: id.warnings.len(),
        }
    }
}

impl<'a> From<&'a FrfIdentification> for Estimates<'a> {
    fn from(id: &'a FrfIdentification) -> Self {
        Estimates {
            frequencies_hz: &id.frequencies_hz,
            damping_ratios: &id.damping_ratios,
            mode_shapes: &id.mode_shapes,
            mass: &id.mass,
            stiffness: &id.stiffness,
            damping_mkr: &id.damping_mkr,
            damping_rayleigh: &id.damping_rayleigh,
            consistency: id.consistency,
            model_order: id.order,
            warnings: id.warnings.len(),
        }
    }
}

/// Scores of an identification of the FRF route against the truth,
/// aligned with its [`ScoreKey::Frf`] keys of [`ScoreKey::of_routes`]
/// (the measures of the time route's identification scores, in their
/// order).
pub fn score_frf(id: &FrfIdentification, truth: &TrueModel) -> Vec<f64> {
    score_identification(id.into(), truth)
}

/// NaN for every score of a route that was not identified: `count`
/// values.
pub fn missing(count: usize) -> Vec<f64> {
    vec![f64::NAN; count]
}

fn score_identification(id: Estimates<'_>, truth: &TrueModel) -> Vec<f64> {
    let n = truth.dofs();
    assert_eq!(
        id.frequencies_hz.len(),
        n,
        "the identifier returns one mode per DOF"
    );
    let t = &truth.modal;
    let mut v = Vec::with_capacity(ScoreKey::all(n, false).len());
    for j in 0..n {
        v.push((id.frequencies_hz[j] / t.frequencies_hz[j] - 1.0).abs());
    }
    for j in 0..n {
        v.push((id.damping_ratios[j] / t.damping_ratios[j] - 1.0).abs());
    }
    for j in 0..n {
        let shape: Vec<Complex64> = id.mode_shapes.column(j).iter().copied().collect();
        v.push(1.0 - mac(&shape, &t.mode_shapes[j]));
    }
    let estimates = [id.mass, id.stiffness, id.damping_mkr, id.damping_rayleigh];
    let references = [
        &truth.model.mass,
        &truth.model.stiffness,
        &truth.model.damping,
        &truth.model.damping,
    ];
    for (e, r) in estimates.iter().zip(references) {
        v.push(rel_fro(e, r));
    }
    for (e, r) in estimates.iter().zip(references) {
        v.extend(entry_errors(e, r));
    }
    v.push(id.consistency);
    v.push(id.model_order as f64);
    v.push(id.warnings as f64);
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mac_of_collinear_shapes_is_one() {
        let a = vec![Complex64::new(1.0, 0.0), Complex64::new(-0.5, 0.1)];
        let b: Vec<Complex64> = a.iter().map(|x| x * Complex64::new(0.3, -2.0)).collect();
        assert!((mac(&a, &b) - 1.0).abs() < 1e-15);
        let c = vec![Complex64::new(0.5, 0.0), Complex64::new(1.0, 0.0)];
        let d = vec![Complex64::new(-1.0, 0.0), Complex64::new(0.5, 0.0)];
        assert!(mac(&c, &d) < 1e-15);
    }

    #[test]
    fn key_counts() {
        assert_eq!(ScoreKey::all(2, false).len(), 3 * 2 + 4 + 4 * 3 + 3);
        assert_eq!(ScoreKey::all(3, false).len(), 3 * 3 + 4 + 4 * 6 + 3);
        // Refined: 3 per mode, 3 Frobenius, 3 x entries, 3 SEs, 2 counters.
        assert_eq!(
            ScoreKey::all(2, true).len() - ScoreKey::all(2, false).len(),
            3 * 2 + 3 + 3 * 3 + 3 + 2
        );
    }

    #[test]
    fn every_key_parses_back_from_its_text() {
        for dofs in [1, 2, 3, 12] {
            let keys = ScoreKey::of_routes(dofs, true, true, true);
            let mut texts: Vec<String> = keys.iter().map(ToString::to_string).collect();
            for (k, t) in keys.iter().zip(&texts) {
                assert_eq!(t.parse::<ScoreKey>().unwrap(), *k, "{t}");
            }
            texts.sort();
            texts.dedup();
            assert_eq!(texts.len(), keys.len(), "texts are unique at {dofs} DOFs");
        }
    }

    #[test]
    fn route_keys() {
        // The time route alone: the columns sweeps always had.
        assert_eq!(
            ScoreKey::of_routes(2, true, true, false),
            ScoreKey::all(2, true)
        );
        // The FRF route: the identification scores, prefixed, same order.
        let frf = ScoreKey::of_routes(2, true, false, true);
        let time = ScoreKey::all(2, false);
        assert_eq!(frf.len(), time.len());
        for (f, t) in frf.iter().zip(&time) {
            assert_eq!(f.to_string(), format!("frf_{t}"));
            assert_eq!(f.route(), Route::Frf);
            assert!(!f.is_refined());
        }
        let both = ScoreKey::of_routes(2, false, true, true);
        assert_eq!(both.len(), 2 * time.len() + 2);
        assert_eq!(
            both[both.len() - 2..]
                .iter()
                .map(ToString::to_string)
                .collect::<Vec<_>>(),
            ["time_failed", "frf_failed"]
        );
        assert_eq!(
            "frf_damping_mkr_12_err".parse::<ScoreKey>().unwrap(),
            ScoreKey::Frf(FrfScore::Entry {
                matrix: MatrixEstimate::DampingMkr,
                row: 1,
                col: 2
            })
        );
        assert_eq!(
            "frf_f2_err".parse::<ScoreKey>().unwrap(),
            ScoreKey::Frf(FrfScore::Frequency { mode: 2 })
        );
    }

    #[test]
    fn texts_are_the_file_columns() {
        let texts: Vec<String> = ScoreKey::all(2, true)
            .iter()
            .map(ToString::to_string)
            .collect();
        for t in [
            "f1_err",
            "xi2_err",
            "mac1_defect",
            "mass_err",
            "damping_rayleigh_12_err",
            "consistency",
            "f2_refined_err",
            "mac2_refined_defect",
            "damping_refined_22_err",
            "stiffness_refined_se",
            "refine_iterations",
        ] {
            assert!(texts.iter().any(|x| x == t), "{t}");
        }
        assert_eq!(
            ScoreKey::Entry {
                matrix: MatrixEstimate::Mass,
                row: 3,
                col: 11
            }
            .to_string(),
            "mass_3_11_err"
        );
        for bad in [
            "f0_err",
            "f01_err",
            "mass_21_err",
            "mass_se",
            "x",
            "mass_1_err",
            "frf_mass_refined_err",
            "frf_refine_failed",
            "frf_frf_mass_err",
            "frf_time_failed",
            "route_failed",
        ] {
            assert!(bad.parse::<ScoreKey>().is_err(), "{bad}");
        }
    }
}
