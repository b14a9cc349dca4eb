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
    pub title: String,
    pub frameid_version: String,
    /// The command line that produced the report, shown verbatim.
    pub command: String,
    pub studies: Vec<Study>,
}

/// One study: a structure, a campaign design and a Monte Carlo sweep over
/// noise levels.
#[derive(Serialize, Deserialize, Debug, Clone)]
pub struct Study {
    pub name: String,
    pub description: String,
    pub seed: u64,
    /// Pre-formatted label/value rows: geometry, masses, stiffnesses,
    /// damping, hits, noise levels, sampling, intersample assumption...
    pub setup: Vec<SetupRow>,
    pub representative: Option<Representative>,
    pub accuracy: Accuracy,
}

/// One row of the set-up table, already formatted by the caller.
#[derive(Serialize, Deserialize, Debug, Clone)]
pub struct SetupRow {
    pub label: String,
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
    pub modes: Vec<ModeShape>,
    pub stabilization: Vec<StabilizationPoint>,
    /// One per output (floor).
    pub frf: Vec<Frf>,
    /// f, xi, M, K, MKR damping, Rayleigh damping.
    pub tables: Vec<ComparisonTable>,
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
    #[serde(deserialize_with = "nullable::f64")]
    pub frequency_hz: f64,
    #[serde(deserialize_with = "nullable::f64")]
    pub damping_ratio: f64,
    #[serde(deserialize_with = "nullable::complex_vec")]
    pub shape: Vec<[f64; 2]>,
    #[serde(default, deserialize_with = "nullable::opt_complex_vec")]
    pub truth: Option<Vec<[f64; 2]>>,
}

/// One pole of the stabilization diagram.
#[derive(Serialize, Deserialize, Debug, Clone)]
pub struct StabilizationPoint {
    pub order: usize,
    #[serde(deserialize_with = "nullable::f64")]
    pub frequency_hz: f64,
    #[serde(deserialize_with = "nullable::f64")]
    pub damping_ratio: f64,
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
    #[serde(deserialize_with = "nullable::vec")]
    pub frequency_hz: Vec<f64>,
    /// Estimated from the records, `[re, im]` in (m/s^2)/N.
    #[serde(deserialize_with = "nullable::complex_vec")]
    pub measured: Vec<[f64; 2]>,
    /// Of the identified model.
    #[serde(deserialize_with = "nullable::complex_vec")]
    pub identified: Vec<[f64; 2]>,
    #[serde(default, deserialize_with = "nullable::opt_complex_vec")]
    pub truth: Option<Vec<[f64; 2]>>,
}

/// Identified values against the truth; the renderer computes relative
/// errors.
#[derive(Serialize, Deserialize, Debug, Clone)]
pub struct ComparisonTable {
    pub title: String,
    pub unit: String,
    pub rows: Vec<ComparisonRow>,
}

#[derive(Serialize, Deserialize, Debug, Clone)]
pub struct ComparisonRow {
    pub label: String,
    #[serde(deserialize_with = "nullable::f64")]
    pub truth: f64,
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
    pub panels: Vec<Panel>,
    pub efficiency: Vec<EfficiencyRow>,
}

/// The sweep over noise levels at one value of the second axis (the only
/// panel if there is none). Every per-level vector has one entry per noise
/// level.
#[derive(Serialize, Deserialize, Debug, Clone)]
pub struct Panel {
    pub axis_value: Option<String>,
    /// Fractions of the channel RMS.
    #[serde(deserialize_with = "nullable::vec")]
    pub noise_levels: Vec<f64>,
    pub trials: Vec<usize>,
    /// Fraction of failed trials, 0..1.
    #[serde(deserialize_with = "nullable::vec")]
    pub failure_rate: Vec<f64>,
    pub failure_reasons: Vec<FailureCount>,
    pub quantities: Vec<Quantity>,
}

#[derive(Serialize, Deserialize, Debug, Clone)]
pub struct FailureCount {
    #[serde(deserialize_with = "nullable::f64")]
    pub noise_level: f64,
    pub reason: String,
    pub count: usize,
}

/// One accuracy measure over the noise levels of a panel.
#[derive(Serialize, Deserialize, Debug, Clone)]
pub struct Quantity {
    /// Stable key, e.g. `damping_mkr_err`; the same quantity has the same key
    /// in every panel.
    pub key: String,
    pub label: String,
    pub unit: String,
    /// e.g. "frequency", "damping ratio", "mode shape", "matrices",
    /// "damping matrices".
    pub group: String,
    /// Per noise level; NaN where no trial succeeded.
    #[serde(deserialize_with = "nullable::vec")]
    pub median: Vec<f64>,
    #[serde(deserialize_with = "nullable::vec")]
    pub p5: Vec<f64>,
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
    Linear,
    Log,
}

/// Statistical efficiency of an estimator at one noise level: the
/// Cramér–Rao bound (standard deviation) over the estimator's RMS error,
/// 1 = efficient.
#[derive(Serialize, Deserialize, Debug, Clone)]
pub struct EfficiencyRow {
    #[serde(deserialize_with = "nullable::f64")]
    pub noise_level: f64,
    pub estimator: String,
    pub quantity: String,
    #[serde(deserialize_with = "nullable::f64")]
    pub efficiency: f64,
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
