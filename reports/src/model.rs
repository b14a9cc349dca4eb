//! The input of a report: what a frameid study found, already reduced to
//! numbers and pre-formatted set-up rows.
//!
//! Conventions: SI units unless a field says otherwise; noise levels are
//! fractions (0.01 = 1 % of the channel RMS), shown in % by the renderer;
//! complex numbers are `[re, im]`; floors are numbered from 1 (floor 1 is the
//! lowest). `NaN` marks a value that does not exist (e.g. a median at a noise
//! level where no trial succeeded).
//!
//! Every `f64` field also accepts `null` when deserialized and reads it as
//! `NaN`: `serde_json` writes non-finite numbers as `null`, so a report with
//! `NaN` medians survives a JSON round trip (infinities come back as `NaN`).

use serde::{Deserialize, Serialize};

/// A whole report: one HTML file, one or more studies.
#[derive(Serialize, Deserialize, Debug, Clone)]
pub struct Report {
    /// Title of the document (`<title>` and heading); "frameid report" when
    /// blank.
    pub title: String,
    /// Version of frameid that ran the studies, shown in the header and in
    /// every set-up table.
    pub frameid_version: String,
    /// The command line that produced the report, shown verbatim.
    pub command: String,
    /// The studies, in the order they are shown.
    pub studies: Vec<Study>,
}

/// One study: a structure, a campaign design and a Monte Carlo sweep over
/// noise levels.
#[derive(Serialize, Deserialize, Debug, Clone)]
pub struct Study {
    /// Name of the study (its heading and `data-study`).
    pub name: String,
    /// A sentence or two on what the study shows; may be empty.
    pub description: String,
    /// Seed of the random numbers of the study, shown in the set-up table so
    /// that the study can be repeated.
    pub seed: u64,
    /// Pre-formatted label/value rows: geometry, masses, stiffnesses,
    /// damping, hits, noise levels, sampling, intersample assumption...
    pub setup: Vec<SetupRow>,
    /// One campaign shown in detail; `None` when the study has none (the
    /// report says so).
    pub representative: Option<Representative>,
    /// The accuracy against noise from the Monte Carlo sweep.
    pub accuracy: Accuracy,
}

/// One row of the set-up table, already formatted by the caller.
#[derive(Serialize, Deserialize, Debug, Clone)]
pub struct SetupRow {
    /// What the row is about, e.g. "Sampling".
    pub label: String,
    /// Its value, with units, shown as given.
    pub value: String,
}

/// One campaign at a stated noise level, identified.
#[derive(Serialize, Deserialize, Debug, Clone)]
pub struct Representative {
    /// Noise level of this campaign, as a fraction of the channel RMS.
    #[serde(deserialize_with = "nullable::f64")]
    pub noise_fraction: f64,
    /// Sampling interval in s.
    #[serde(deserialize_with = "nullable::f64")]
    pub dt_s: f64,
    /// Floor hit by the hammer (1-based).
    pub hit_floor: usize,
    /// Hammer force of hit 1, N.
    #[serde(deserialize_with = "nullable::vec")]
    pub force: Vec<f64>,
    /// Accelerations of hit 1, one record per floor, m/s^2.
    #[serde(deserialize_with = "nullable::vec_vec")]
    pub accelerations: Vec<Vec<f64>>,
    /// Singular values of the (data-correlation) Hankel matrix, descending.
    #[serde(deserialize_with = "nullable::vec")]
    pub hankel_singular_values: Vec<f64>,
    /// The chosen state dimension.
    pub order: usize,
    /// The identified modes.
    pub modes: Vec<ModeShape>,
    /// The poles of the stabilization diagram, of every order tried.
    pub stabilization: Vec<StabilizationPoint>,
    /// One per output (floor).
    pub frf: Vec<Frf>,
    /// f, xi, M, K, MKR damping, Rayleigh damping.
    pub tables: Vec<ComparisonTable>,
    /// Warnings about this campaign's identification, shown above its
    /// figures.
    pub warnings: Vec<String>,
    /// Added field. Quality of every hit of the campaign, checked before
    /// identification.
    #[serde(default)]
    pub hit_quality: Vec<HitQualityRow>,
}

/// Added type. Quality metrics of one hit.
#[derive(Serialize, Deserialize, Debug, Clone)]
pub struct HitQualityRow {
    /// 1-based hit number.
    pub hit: usize,
    /// Peak force, N.
    #[serde(deserialize_with = "nullable::f64")]
    pub peak_force_n: f64,
    /// Equivalent pulse duration, s.
    #[serde(deserialize_with = "nullable::f64")]
    pub pulse_duration_s: f64,
    /// Lowest signal-to-noise ratio over the channels, dB.
    #[serde(deserialize_with = "nullable::f64")]
    pub min_snr_db: f64,
    /// Largest ratio of the RMS at the end of a record to its peak.
    #[serde(deserialize_with = "nullable::f64")]
    pub tail_ratio: f64,
    /// Failed checks, as text; empty when the hit passed.
    pub flags: Vec<String>,
}

/// An identified mode; shapes are complex `[re, im]` per DOF, scaled so the
/// largest component is 1 + 0i.
#[derive(Serialize, Deserialize, Debug, Clone)]
pub struct ModeShape {
    /// Identified natural frequency, Hz.
    #[serde(deserialize_with = "nullable::f64")]
    pub frequency_hz: f64,
    /// Identified damping ratio, a fraction of critical damping.
    #[serde(deserialize_with = "nullable::f64")]
    pub damping_ratio: f64,
    /// Identified shape, one component per floor.
    #[serde(deserialize_with = "nullable::complex_vec")]
    pub shape: Vec<[f64; 2]>,
    /// Shape of the same mode of the true model, scaled alike, when known.
    #[serde(default, deserialize_with = "nullable::opt_complex_vec")]
    pub truth: Option<Vec<[f64; 2]>>,
}

/// One pole of the stabilization diagram.
#[derive(Serialize, Deserialize, Debug, Clone)]
pub struct StabilizationPoint {
    /// Model order (state dimension) whose model has this pole.
    pub order: usize,
    /// Natural frequency of the pole, Hz.
    #[serde(deserialize_with = "nullable::f64")]
    pub frequency_hz: f64,
    /// Damping ratio of the pole, a fraction of critical damping.
    #[serde(deserialize_with = "nullable::f64")]
    pub damping_ratio: f64,
    /// How the pole compares with those of the next lower order.
    pub status: Stability,
}

/// How a pole compares with the poles of the next lower order.
#[derive(Serialize, Deserialize, Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Stability {
    /// Not matched at the lower order.
    New,
    /// Stable in frequency only.
    Frequency,
    /// Stable in frequency and damping ratio.
    Damping,
    /// Stable in frequency, damping ratio and mode shape.
    Stable,
}

/// Frequency response of one output to the hammer input.
#[derive(Serialize, Deserialize, Debug, Clone)]
pub struct Frf {
    /// Name of the output, e.g. "floor 1".
    pub output: String,
    /// Frequency lines, Hz; the complex vectors have one value per line.
    #[serde(deserialize_with = "nullable::vec")]
    pub frequency_hz: Vec<f64>,
    /// Estimated from the records, `[re, im]` in (m/s^2)/N.
    #[serde(deserialize_with = "nullable::complex_vec")]
    pub measured: Vec<[f64; 2]>,
    /// Of the identified model, same units.
    #[serde(deserialize_with = "nullable::complex_vec")]
    pub identified: Vec<[f64; 2]>,
    /// Of the true model, same units, when known.
    #[serde(default, deserialize_with = "nullable::opt_complex_vec")]
    pub truth: Option<Vec<[f64; 2]>>,
    /// Added field. Name of the reference (force) when it is not the hammer
    /// of the study, e.g. "force" or "shaker 2"; shown in the chart title.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reference: Option<String>,
    /// Added field. Ordinary coherence of the estimate per line, in [0, 1],
    /// when known; drawn as a chart of its own.
    #[serde(
        default,
        deserialize_with = "nullable::opt_vec",
        skip_serializing_if = "Option::is_none"
    )]
    pub coherence: Option<Vec<f64>>,
}

/// A campaign identified without a known truth (rig records or FRFs
/// exported by an analyzer): what `frameid identify --report` writes.
///
/// Rendered by [`crate::render_campaign`] as one self-contained page: the
/// source and preprocessing, warnings, hit quality, the stabilization
/// diagram, the modes (those of the model and those out of it), the
/// identified matrices with their error bars, and the measured FRFs against
/// the identified model with their coherence.
#[derive(Serialize, Deserialize, Debug, Clone)]
pub struct CampaignReport {
    /// Title of the document; "frameid identification" when blank.
    pub title: String,
    /// Version of frameid.
    pub frameid_version: String,
    /// The command line, shown verbatim.
    pub command: String,
    /// Pre-formatted rows on the data and what was done to it: files,
    /// hits, sampling, detected excitation, decimation, windows, route.
    pub source: Vec<SetupRow>,
    /// Every warning of the identification, naming files and channels.
    pub warnings: Vec<String>,
    /// Quality of every hit (time records only).
    #[serde(default)]
    pub hit_quality: Vec<HitQualityRow>,
    /// The chosen model order of the stabilization diagram.
    pub order: usize,
    /// Poles of the stabilization diagram, every order tried; may be empty.
    pub stabilization: Vec<StabilizationPoint>,
    /// The modes that form the M, K, damping model, ascending frequency.
    pub modes: Vec<ModeShape>,
    /// Structural modes identified but left out of the model (torsion,
    /// out-of-plane, local modes).
    pub out_of_model: Vec<ModeShape>,
    /// Measured FRFs against the identified model, one per
    /// response/reference pair.
    pub frf: Vec<Frf>,
    /// Identified values with their standard errors: modal parameters and
    /// matrices.
    pub tables: Vec<ValueTable>,
}

/// Identified values without a truth to compare with.
#[derive(Serialize, Deserialize, Debug, Clone)]
pub struct ValueTable {
    /// Caption, e.g. "Mass matrix M".
    pub title: String,
    /// Unit of the values; may be empty.
    pub unit: String,
    /// One row per value.
    pub rows: Vec<ValueRow>,
}

/// One identified value.
#[derive(Serialize, Deserialize, Debug, Clone)]
pub struct ValueRow {
    /// What the value is, e.g. "M12".
    pub label: String,
    /// The value.
    #[serde(deserialize_with = "nullable::f64")]
    pub value: f64,
    /// Its standard error, when known.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub std: Option<f64>,
}

/// Identified values against the truth; the renderer computes relative
/// errors.
#[derive(Serialize, Deserialize, Debug, Clone)]
pub struct ComparisonTable {
    /// Caption, e.g. "Mass matrix M".
    pub title: String,
    /// Unit of the values, shown in the caption as `[unit]`; may be empty.
    pub unit: String,
    /// One row per compared value.
    pub rows: Vec<ComparisonRow>,
}

/// One identified value against its true value.
#[derive(Serialize, Deserialize, Debug, Clone)]
pub struct ComparisonRow {
    /// What the value is, e.g. "M12".
    pub label: String,
    /// The true value.
    #[serde(deserialize_with = "nullable::f64")]
    pub truth: f64,
    /// The identified value, same unit.
    #[serde(deserialize_with = "nullable::f64")]
    pub identified: f64,
    /// Added field. Standard deviation of the identified value (e.g. across
    /// hits), shown as `± std` when present.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub std: Option<f64>,
}

/// The Monte Carlo sweep.
#[derive(Serialize, Deserialize, Debug, Clone)]
pub struct Accuracy {
    /// Name of the optional second axis (e.g. "added mass"); one panel per
    /// value.
    pub axis_name: Option<String>,
    /// One panel per value of the second axis; one panel without it.
    pub panels: Vec<Panel>,
    /// Efficiency of the estimators where a Cramér–Rao bound is known; may
    /// be empty.
    pub efficiency: Vec<EfficiencyRow>,
    /// Added field. The time and FRF identification routes side by side, on
    /// the same simulated campaigns (every panel, every noise level); empty
    /// when the study ran one route.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub routes: Vec<RouteRow>,
}

/// One matrix at one noise level as the time route and the FRF route
/// recovered it from the same simulated campaigns.
#[derive(Serialize, Deserialize, Debug, Clone)]
pub struct RouteRow {
    /// The noise level, a fraction of the channel RMS.
    #[serde(deserialize_with = "nullable::f64")]
    pub noise_level: f64,
    /// What is estimated, e.g. "mass matrix".
    pub quantity: String,
    /// The time route (OKID, ERA/DC, MKR).
    pub time: RouteErrors,
    /// The FRF route (FRFs, pLSCF, LSFD, MKR).
    pub frf: RouteErrors,
}

/// The relative Frobenius errors of one route's estimate of a matrix over
/// the trials in which that route identified.
#[derive(Serialize, Deserialize, Debug, Clone)]
pub struct RouteErrors {
    /// Trials in which the route identified (the statistics are over them).
    pub trials: usize,
    /// Median relative error.
    #[serde(deserialize_with = "nullable::f64")]
    pub median: f64,
    /// Root mean square of the relative errors.
    #[serde(deserialize_with = "nullable::f64")]
    pub rms: f64,
    /// Cramér–Rao bound over `rms` (1 = efficient); NaN without a bound.
    #[serde(deserialize_with = "nullable::f64")]
    pub efficiency: f64,
    /// Added field. Monte Carlo standard error of `median`, shown as
    /// `± se` when present.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub median_se: Option<f64>,
    /// Added field. Monte Carlo standard error of `efficiency`, shown as
    /// `± se` when present.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub efficiency_se: Option<f64>,
}

/// The sweep over noise levels at one value of the second axis (the only
/// panel if there is none). Every per-level vector has one entry per noise
/// level, or none when it was not computed.
#[derive(Serialize, Deserialize, Debug, Clone)]
pub struct Panel {
    /// The value of the second axis, formatted with its unit; `None`
    /// without a second axis.
    pub axis_value: Option<String>,
    /// Fractions of the channel RMS.
    #[serde(deserialize_with = "nullable::vec")]
    pub noise_levels: Vec<f64>,
    /// Number of Monte Carlo trials per noise level.
    pub trials: Vec<usize>,
    /// Fraction of failed trials, 0..1.
    #[serde(deserialize_with = "nullable::vec")]
    pub failure_rate: Vec<f64>,
    /// Failed trials by reason and noise level.
    pub failure_reasons: Vec<FailureCount>,
    /// The accuracy measures, each charted over the noise levels.
    pub quantities: Vec<Quantity>,
}

/// How many trials at one noise level failed for one reason.
#[derive(Serialize, Deserialize, Debug, Clone)]
pub struct FailureCount {
    /// The noise level, one of the panel's `noise_levels`.
    #[serde(deserialize_with = "nullable::f64")]
    pub noise_level: f64,
    /// Why the trials failed, as text; counts with the same reason share a
    /// table row.
    pub reason: String,
    /// Number of trials that failed so.
    pub count: usize,
}

/// One accuracy measure over the noise levels of a panel.
#[derive(Serialize, Deserialize, Debug, Clone)]
pub struct Quantity {
    /// Stable key, e.g. `damping_mkr_err`; the same quantity has the same key
    /// in every panel.
    pub key: String,
    /// Name shown in chart titles and on the y axis, e.g. "f₁ relative
    /// error".
    pub label: String,
    /// Unit of the values, shown on the y axis; empty for relative errors
    /// and other plain numbers.
    pub unit: String,
    /// Heading the quantity is shown under, e.g. "frequency", "damping ratio", "mode shape", "matrices",
    /// "damping matrices".
    pub group: String,
    /// Per noise level; NaN where no trial succeeded.
    #[serde(deserialize_with = "nullable::vec")]
    pub median: Vec<f64>,
    /// 5th percentile over the successful trials, per noise level.
    #[serde(deserialize_with = "nullable::vec")]
    pub p5: Vec<f64>,
    /// 95th percentile over the successful trials, per noise level.
    #[serde(deserialize_with = "nullable::vec")]
    pub p95: Vec<f64>,
    /// Cramér–Rao bound (standard deviation) where known.
    #[serde(default, deserialize_with = "nullable::opt_vec")]
    pub bound: Option<Vec<f64>>,
    /// Added field. Y axis scale of this quantity's charts; `None` chooses:
    /// logarithmic when every value is >= 0 and the positive ones span at
    /// least a decade (typical of relative errors), linear otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scale: Option<Scale>,
}

/// Axis scale.
#[derive(Serialize, Deserialize, Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scale {
    /// Linear axis.
    Linear,
    /// Logarithmic axis (base 10); values <= 0 are drawn at its bottom.
    Log,
}

/// Statistical efficiency of an estimator at one noise level: the
/// Cramér–Rao bound (standard deviation) over the estimator's RMS error,
/// 1 = efficient.
#[derive(Serialize, Deserialize, Debug, Clone)]
pub struct EfficiencyRow {
    /// The noise level, a fraction of the channel RMS.
    #[serde(deserialize_with = "nullable::f64")]
    pub noise_level: f64,
    /// The estimator, e.g. "ERA/DC" or "refined (ML)".
    pub estimator: String,
    /// What it estimates, e.g. "natural frequency 1".
    pub quantity: String,
    /// Bound over RMS error.
    #[serde(deserialize_with = "nullable::f64")]
    pub efficiency: f64,
    /// Added field. Monte Carlo standard error of `efficiency` (from the
    /// spread of the squared errors over the trials), shown as `± se` when
    /// present.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub se: Option<f64>,
}

/// Deserializers that read `null` as `NaN`.
mod nullable {
    use serde::{Deserialize, Deserializer};

    fn nan(v: Option<f64>) -> f64 {
        v.unwrap_or(f64::NAN)
    }

    fn pair(v: [Option<f64>; 2]) -> [f64; 2] {
        [nan(v[0]), nan(v[1])]
    }

    pub fn f64<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
        Option::<f64>::deserialize(d).map(nan)
    }

    pub fn vec<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<f64>, D::Error> {
        Vec::<Option<f64>>::deserialize(d).map(|v| v.into_iter().map(nan).collect())
    }

    pub fn opt_vec<'de, D: Deserializer<'de>>(d: D) -> Result<Option<Vec<f64>>, D::Error> {
        Option::<Vec<Option<f64>>>::deserialize(d)
            .map(|o| o.map(|v| v.into_iter().map(nan).collect()))
    }

    pub fn vec_vec<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<Vec<f64>>, D::Error> {
        Vec::<Vec<Option<f64>>>::deserialize(d).map(|vv| {
            vv.into_iter()
                .map(|v| v.into_iter().map(nan).collect())
                .collect()
        })
    }

    pub fn complex_vec<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<[f64; 2]>, D::Error> {
        Vec::<[Option<f64>; 2]>::deserialize(d).map(|v| v.into_iter().map(pair).collect())
    }

    pub fn opt_complex_vec<'de, D: Deserializer<'de>>(
        d: D,
    ) -> Result<Option<Vec<[f64; 2]>>, D::Error> {
        Option::<Vec<[Option<f64>; 2]>>::deserialize(d)
            .map(|o| o.map(|v| v.into_iter().map(pair).collect()))
    }
}
