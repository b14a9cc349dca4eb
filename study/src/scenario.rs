//! Scenario files (TOML): the structure, its damping, the hammer campaign
//! and how it is identified and swept. The schema is documented in the
//! README; every error names the file and the field.
//!
//! Files and the scenarios compiled into the binary ([`BUILTIN`]) go
//! through one loader, [`LoadedScenario::from_text`], which checks
//! everything a run needs before anything is simulated.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
pub use sim::StructureSpec;
use sim::{CampaignSettings, DampingSpec, Dashpot, Model, SimError, Simulator};

/// A scenario as written in its file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    /// Short name used in reports; defaults to the file stem.
    #[serde(default)]
    pub name: String,
    /// Free text shown in reports; default empty.
    #[serde(default)]
    pub description: String,
    /// `[structure]`: the frame, as M and K matrices or from storey and floor
    /// geometry (lumped masses include the sensors).
    pub structure: StructureSpec,
    /// `[damping]`: how the damping matrix is built from M and K; default
    /// none.
    #[serde(default = "no_damping")]
    pub damping: DampingSpec,
    /// `[[dashpots]]`: extra viscous dashpots across storeys, added to the
    /// damping matrix (the damping is then not proportional).
    #[serde(default)]
    pub dashpots: Vec<Dashpot>,
    /// `[campaign]`: hits, hammer, sampling, acquisition chain, rig effects
    /// and noise of the simulated test.
    pub campaign: CampaignSettings,
    /// `[identification]`: how campaigns are identified.
    #[serde(default)]
    pub identification: IdentificationSettings,
    /// `[sweep]`: the Monte Carlo sweep over noise levels.
    #[serde(default)]
    pub sweep: SweepSettings,
}

/// How the campaign is identified (defaults follow the acquisition).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IdentificationSettings {
    /// `zoh` or `bandlimited`; default: `zoh` for held records, `bandlimited`
    /// for analyzer records.
    #[serde(default)]
    pub intersample: Option<ident::Intersample>,
    /// Model order (state dimension); default automatic.
    #[serde(default)]
    pub order: Option<usize>,
    /// OKID observer order; default automatic.
    #[serde(default)]
    pub observer_order: Option<usize>,
    /// Refine M, K and the damping matrix by maximum likelihood after MKR.
    #[serde(default)]
    pub refine: bool,
    /// Physical parameters of the refinement and of the Cramér–Rao bound.
    #[serde(default)]
    pub parametrization: ParametrizationSetting,
    /// Which route(s) identify every simulated campaign: `time` (default),
    /// `frf` or `both` (on the same campaigns, for a paired comparison).
    #[serde(default, skip_serializing_if = "RouteSetting::is_time")]
    pub route: RouteSetting,
    /// `[identification.frf]`: how the FRF route estimates its FRFs.
    #[serde(default, skip_serializing_if = "FrfSettings::is_default")]
    pub frf: FrfSettings,
}

/// Which identification route(s) a scenario runs, as written in files
/// (`route = "time" | "frf" | "both"`; [`std::str::FromStr`] and
/// [`std::fmt::Display`] use the same words).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum RouteSetting {
    /// The time records: OKID, ERA/DC, MKR (and the refinement, if set).
    #[default]
    Time,
    /// FRFs across the hits, then pLSCF, LSFD and MKR.
    Frf,
    /// Both, on the same simulated campaigns.
    Both,
}

impl RouteSetting {
    /// Every setting.
    pub const ALL: [RouteSetting; 3] = [RouteSetting::Time, RouteSetting::Frf, RouteSetting::Both];

    /// The word used in files.
    pub fn name(self) -> &'static str {
        match self {
            RouteSetting::Time => "time",
            RouteSetting::Frf => "frf",
            RouteSetting::Both => "both",
        }
    }

    /// Whether the time route runs.
    pub fn time(self) -> bool {
        self != RouteSetting::Frf
    }

    /// Whether the FRF route runs.
    pub fn frf(self) -> bool {
        self != RouteSetting::Time
    }

    fn is_time(&self) -> bool {
        *self == RouteSetting::Time
    }
}

impl std::fmt::Display for RouteSetting {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for RouteSetting {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        RouteSetting::ALL
            .into_iter()
            .find(|r| r.name() == s.trim())
            .ok_or_else(|| format!("expected `time`, `frf` or `both`, got `{s}`"))
    }
}

/// `[identification.frf]`: FRF estimation of the FRF route. The FRFs are
/// averaged across the campaign's hits (one average per hit, the whole
/// record one block), so the noise of `n` averages is that of `n` noisy
/// hits.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FrfSettings {
    /// `"H1"` (default: noise on the responses), `"H2"` or `"Hv"`.
    #[serde(default = "default_estimator")]
    pub estimator: ident::frf::estimate::Estimator,
    /// Lines kept, `[low, high]` in Hz, for the estimate and the
    /// identification; default 0 Hz to the analyzer's passband (analyzer
    /// records) or to Nyquist (held records).
    #[serde(default)]
    pub band_hz: Option<[f64; 2]>,
    /// Exponential window on every channel: the amplitude it leaves at the
    /// last sample, in `(0, 1]`; 1 applies no window. Default 1e-3. Its
    /// damping is taken out of the identified poles.
    #[serde(default = "default_end_amplitude")]
    pub exponential_end_amplitude: f64,
    /// Window on the force channel around each pulse
    /// (`{ before_peak_s, after_peak_s, taper_s }`); default none.
    #[serde(default)]
    pub force_window: Option<ident::frf::estimate::ForceWindow>,
}

fn default_estimator() -> ident::frf::estimate::Estimator {
    ident::frf::estimate::Estimator::H1
}

fn default_end_amplitude() -> f64 {
    // The leakage of a 0.5 % damped mode that has decayed to a few % at
    // the end of 32 s records: ident's FRF round trip measured M errors
    // ten times smaller with 1e-3 than with 1e-2.
    1e-3
}

impl Default for FrfSettings {
    fn default() -> Self {
        FrfSettings {
            estimator: default_estimator(),
            band_hz: None,
            exponential_end_amplitude: default_end_amplitude(),
            force_window: None,
        }
    }
}

impl FrfSettings {
    fn is_default(&self) -> bool {
        *self == FrfSettings::default()
    }
}

/// Physical parametrization of the refinement, as written in scenario files
/// and on the command line (`--parametrization`).
/// Written `full` or `shear-frame` ([`std::str::FromStr`] and
/// [`std::fmt::Display`] use the same words as serde).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ParametrizationSetting {
    /// Symmetric M, K and damping (every upper-triangle entry).
    #[default]
    Full,
    /// One mass per floor, one spring and one dashpot per storey, plus a
    /// dashpot from every floor above the first to the ground (so that
    /// Rayleigh damping is representable).
    ShearFrame,
}

impl ParametrizationSetting {
    /// Every setting.
    pub const ALL: [ParametrizationSetting; 2] = [
        ParametrizationSetting::Full,
        ParametrizationSetting::ShearFrame,
    ];

    /// The word used in files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            ParametrizationSetting::Full => "full",
            ParametrizationSetting::ShearFrame => "shear-frame",
        }
    }

    /// The refinement's parametrization for `dofs` floors.
    pub fn parametrization(self, dofs: usize) -> ident::refine::Parametrization {
        use ident::refine::{Dashpot, Node, Parametrization};
        match self {
            ParametrizationSetting::Full => Parametrization::Full,
            ParametrizationSetting::ShearFrame => Parametrization::ShearFrame {
                dashpots: (1..dofs)
                    .map(|i| Dashpot::between(Node::Ground, Node::Dof(i)))
                    .collect(),
            },
        }
    }
}

impl std::fmt::Display for ParametrizationSetting {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for ParametrizationSetting {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        ParametrizationSetting::ALL
            .into_iter()
            .find(|p| p.name() == s.trim())
            .ok_or_else(|| format!("expected `full` or `shear-frame`, got `{s}`"))
    }
}

/// A Monte Carlo sweep over noise levels (and optionally a second axis).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SweepSettings {
    /// Noise levels, fractions of each channel's RMS.
    #[serde(default = "default_noise_levels")]
    pub noise: Vec<f64>,
    /// Trials (simulated campaigns) per noise level and axis value.
    #[serde(default = "default_trials")]
    pub trials: usize,
    /// Base seed of every trial's ChaCha8 streams (see [`crate::sweep`] for
    /// how trial seeds derive from it); default 1.
    #[serde(default = "default_seed")]
    pub seed: u64,
    /// Optional second axis.
    #[serde(default)]
    pub axis: Option<SweepAxis>,
}

fn default_noise_levels() -> Vec<f64> {
    vec![0.0, 0.005, 0.01, 0.02, 0.05]
}
fn default_trials() -> usize {
    20
}
fn default_seed() -> u64 {
    1
}

impl Default for SweepSettings {
    fn default() -> Self {
        SweepSettings {
            noise: default_noise_levels(),
            trials: default_trials(),
            seed: default_seed(),
            axis: None,
        }
    }
}

/// A second sweep axis: one setting and the values it takes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SweepAxis {
    /// The setting varied.
    pub setting: AxisSetting,
    /// Its values, in the order swept (numbers for `hits` and
    /// `pulse_duration_s`, `"zoh"`/`"bandlimited"` for `intersample`,
    /// `"hammer"`/`"shaker"` for `excitation`).
    pub values: Vec<AxisValue>,
}

/// Settings a sweep can vary besides the noise level.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum AxisSetting {
    /// Hits per campaign.
    Hits,
    /// Hammer pulse duration, s.
    PulseDurationS,
    /// Intersample assumption of the identification (`zoh`, `bandlimited`).
    Intersample,
    /// What excites the campaign: `"hammer"` (`[campaign.hammer]`) or
    /// `"shaker"` (the continuous `[campaign.excitation]` of the scenario),
    /// on the same frame, to compare the two.
    Excitation,
}

/// A value of a sweep axis.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum AxisValue {
    /// A number (TOML integer or float): hits, or a pulse duration in s.
    Number(f64),
    /// A string: an intersample assumption.
    Text(String),
}

impl std::fmt::Display for AxisValue {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            AxisValue::Number(x) => write!(f, "{x}"),
            AxisValue::Text(t) => write!(f, "{t}"),
        }
    }
}

impl AxisSetting {
    /// The name used in files and reports.
    pub fn name(self) -> &'static str {
        match self {
            AxisSetting::Hits => "hits",
            AxisSetting::PulseDurationS => "pulse_duration_s",
            AxisSetting::Intersample => "intersample",
            AxisSetting::Excitation => "excitation",
        }
    }
}

fn no_damping() -> DampingSpec {
    DampingSpec::None
}

/// Why a scenario cannot be used.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ScenarioError {
    /// The file cannot be read.
    #[error("{}: cannot read scenario: {message}", path.display())]
    Io {
        /// The scenario file.
        path: PathBuf,
        /// The operating system's message.
        message: String,
    },
    /// Not valid TOML or not the schema (the message carries line and column).
    #[error("{}: {}", path.display(), message.trim_end())]
    Parse {
        /// The scenario file.
        path: PathBuf,
        /// The TOML parser's message, with line and column.
        message: String,
    },
    /// A field has an invalid value.
    #[error("{}: {field}: {problem}", path.display())]
    Invalid {
        /// The scenario file.
        path: PathBuf,
        /// The field, as a TOML path (`campaign.hammer.floor`).
        field: String,
        /// What is wrong with it.
        problem: String,
    },
    /// No scenario of that name is compiled in.
    #[error("no built-in scenario named '{name}'; built-in: {}", BUILTIN.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", "))]
    UnknownBuiltin {
        /// The name asked for.
        name: String,
    },
}

/// A scenario with the file it came from, checked and ready to simulate.
#[derive(Debug, Clone)]
pub struct LoadedScenario {
    /// The file it was read from (`scenarios/<name>` for a built-in one);
    /// used in messages.
    pub path: PathBuf,
    /// The scenario as written (its `name` filled from the file stem if
    /// empty).
    pub scenario: Scenario,
    /// The structural model built from it (M, K, damping), checked.
    pub model: Model,
}

impl Scenario {
    /// Parses TOML text; `path` is used in messages and for the default name.
    pub fn parse(text: &str, path: &Path) -> Result<Scenario, ScenarioError> {
        let mut s: Scenario = toml::from_str(text).map_err(|e| ScenarioError::Parse {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
        if s.name.is_empty() {
            s.name = path
                .file_stem()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
        }
        Ok(s)
    }

    /// Builds and checks the structural model (M, K, damping); the mass
    /// includes the sensor masses.
    pub fn model(&self) -> Result<Model, SimError> {
        let m = self.structure.matrices()?;
        let (mass, stiffness) = (m.mass, m.stiffness);
        let damping = sim::build_damping(&mass, &stiffness, &self.damping, &self.dashpots)?;
        Model::new(mass, stiffness, damping).map_err(|e| match e {
            SimError::NotPositiveDefinite { matrix, pivot } => SimError::Invalid {
                field: structure_field(matrix),
                problem: format!("not positive definite (Cholesky pivot {pivot} is not positive)"),
            },
            SimError::NotSymmetric {
                matrix,
                row,
                col,
                difference,
            } => SimError::Invalid {
                field: structure_field(matrix),
                problem: format!("not symmetric: entry ({row},{col}) differs from ({col},{row}) by {difference:.3e}"),
            },
            other => other,
        })
    }

    /// The simulator for this scenario's campaign.
    pub fn simulator(&self, model: Model) -> Result<Simulator, SimError> {
        Simulator::new(model, self.campaign.clone()).map_err(|e| prefix("campaign.", e))
    }

    /// The intersample assumption: as set, else from the acquisition.
    pub fn intersample(&self) -> ident::Intersample {
        match self.identification.intersample {
            Some(s) => s,
            None => match self.campaign.acquisition {
                sim::Acquisition::Held => ident::Intersample::Zoh,
                sim::Acquisition::Analyzer(_) => ident::Intersample::Bandlimited,
            },
        }
    }

    /// The identifier configured by the `[identification]` table, with the
    /// hit floor's accelerometer as the collocated output.
    pub fn identifier(&self) -> ident::Identifier {
        let mut id = ident::Identifier::default()
            .intersample(self.intersample())
            .collocated(self.campaign.hammer.floor - 1, 0);
        if let Some(n) = self.identification.order {
            id = id.order(ident::ModelOrder::Fixed(n));
        }
        if let Some(p) = self.identification.observer_order {
            id = id.observer_order(ident::ObserverOrder::Fixed(p));
        }
        id
    }

    /// The band of the FRF route, Hz: as set, else 0 Hz to the analyzer's
    /// passband (analyzer records) or to Nyquist (held records).
    pub fn frf_band_hz(&self) -> (f64, f64) {
        if let Some([low, high]) = self.identification.frf.band_hz {
            return (low, high);
        }
        let fs_hz = self.campaign.sampling.sample_rate_hz;
        let high = match &self.campaign.acquisition {
            sim::Acquisition::Held => fs_hz / 2.0,
            sim::Acquisition::Analyzer(a) => {
                a.design(fs_hz).map_or(fs_hz / 2.56, |d| d.passband_hz)
            }
        };
        (0.0, high)
    }

    /// The FRF route configured by `[identification.frf]`: H1 (or the
    /// estimator set) across the hits in the band, the windows set, then
    /// pLSCF, LSFD and MKR in the same band with the hit floor's
    /// accelerometer as the collocated output.
    pub fn frf_route(&self) -> crate::experiment::FrfRoute {
        use ident::frf::estimate::{Averaging, ExponentialWindow, FrfParams, HitAveraging};
        let f = &self.identification.frf;
        let (low, high) = self.frf_band_hz();
        let estimation = FrfParams::hits()
            .estimator(f.estimator)
            .averaging(Averaging::Hits(HitAveraging {
                block_len: None,
                force_window: f.force_window,
                exponential_window: (f.exponential_end_amplitude < 1.0)
                    .then_some(ExponentialWindow::EndAmplitude(f.exponential_end_amplitude)),
            }))
            .band_hz(low, high);
        let identifier = ident::frf::FrfIdentifier::default()
            .band_hz(low, high)
            .collocated(self.campaign.hammer.floor - 1, 0);
        crate::experiment::FrfRoute {
            estimation,
            identifier,
        }
    }

    /// The maximum-likelihood refiner (also used for the Cramér–Rao bound):
    /// the scenario's parametrization, the hit floor as input, noise levels
    /// estimated from the residuals.
    pub fn refiner(&self) -> ident::refine::Refiner {
        ident::refine::Refiner::default()
            .parametrization(
                self.identification
                    .parametrization
                    .parametrization(self.structure.dofs()),
            )
            .intersample(self.intersample())
            .input_dofs(vec![self.campaign.hammer.floor - 1])
    }

    /// The intersample behaviour of the records themselves (held records are
    /// ZOH, analyzer records band-limited), whatever the identification
    /// assumes: what the Cramér–Rao bound is computed for.
    pub fn acquisition_intersample(&self) -> ident::Intersample {
        match self.campaign.acquisition {
            sim::Acquisition::Held => ident::Intersample::Zoh,
            sim::Acquisition::Analyzer(_) => ident::Intersample::Bandlimited,
        }
    }

    /// Checks the `[identification]` and `[sweep]` tables.
    pub fn check_study_settings(&self) -> Result<(), SimError> {
        let bad = |field: &str, problem: String| SimError::Invalid {
            field: field.into(),
            problem,
        };
        if self.identification.order == Some(0) {
            return Err(bad("identification.order", "must be at least 2".into()));
        }
        if self.identification.observer_order == Some(0) {
            return Err(bad(
                "identification.observer_order",
                "must be at least 1".into(),
            ));
        }
        self.identifier()
            .check()
            .map_err(|e| bad("identification", e.to_string()))?;
        self.refiner()
            .check()
            .map_err(|e| bad("identification", e.to_string()))?;
        let id = &self.identification;
        if id.refine && !id.route.time() {
            return Err(bad(
                "identification.refine",
                "the refinement starts from the time route's estimate; set route = \"both\" (or \"time\"), or refine = false".into(),
            ));
        }
        let a = id.frf.exponential_end_amplitude;
        if !(a > 0.0 && a <= 1.0) {
            return Err(bad(
                "identification.frf.exponential_end_amplitude",
                format!("must be in (0, 1] (1: no window), got {a}"),
            ));
        }
        if let Some([low, high]) = id.frf.band_hz {
            let nyquist_hz = self.campaign.sampling.sample_rate_hz / 2.0;
            if !(low.is_finite()
                && high.is_finite()
                && low >= 0.0
                && high > low
                && high <= nyquist_hz)
            {
                return Err(bad(
                    "identification.frf.band_hz",
                    format!(
                        "must be [low, high] with 0 <= low < high <= {nyquist_hz} Hz (Nyquist), got [{low}, {high}]"
                    ),
                ));
            }
        }
        if let Some(w) = id.frf.force_window {
            for (name, v) in [
                ("before_peak_s", w.before_peak_s),
                ("after_peak_s", w.after_peak_s),
                ("taper_s", w.taper_s),
            ] {
                if !(v.is_finite() && v >= 0.0) {
                    return Err(bad(
                        &format!("identification.frf.force_window.{name}"),
                        format!("must be a finite number of seconds >= 0, got {v}"),
                    ));
                }
            }
        }
        if id.route.frf() {
            let route = self.frf_route();
            route
                .estimation
                .check()
                .map_err(|e| bad("identification.frf", e.to_string()))?;
            route
                .identifier
                .check()
                .map_err(|e| bad("identification.frf", e.to_string()))?;
        }
        let sw = &self.sweep;
        if sw.noise.is_empty() {
            return Err(bad("sweep.noise", "needs at least one noise level".into()));
        }
        for (i, &n) in sw.noise.iter().enumerate() {
            if !(n.is_finite() && n >= 0.0) {
                return Err(bad(
                    &format!("sweep.noise[{i}]"),
                    format!("must be a fraction >= 0, got {n}"),
                ));
            }
            if sw.noise[..i].contains(&n) {
                return Err(bad(
                    &format!("sweep.noise[{i}]"),
                    format!("noise level {n} appears twice"),
                ));
            }
        }
        if sw.trials == 0 {
            return Err(bad("sweep.trials", "must be at least 1".into()));
        }
        if let Some(axis) = &sw.axis {
            if axis.values.is_empty() {
                return Err(bad("sweep.axis.values", "needs at least one value".into()));
            }
            for (i, v) in axis.values.iter().enumerate() {
                let field = format!("sweep.axis.values[{i}]");
                match (axis.setting, v) {
                    (AxisSetting::Hits, AxisValue::Number(x)) if *x >= 1.0 && x.fract() == 0.0 => {}
                    (AxisSetting::Hits, _) => {
                        return Err(bad(
                            &field,
                            format!("hits must be a whole number >= 1, got {v}"),
                        ));
                    }
                    (AxisSetting::PulseDurationS, AxisValue::Number(x))
                        if x.is_finite() && *x > 0.0 => {}
                    (AxisSetting::PulseDurationS, _) => {
                        return Err(bad(
                            &field,
                            format!("a pulse duration must be a number of seconds > 0, got {v}"),
                        ));
                    }
                    (AxisSetting::Intersample, AxisValue::Text(t))
                        if ident::Intersample::ALL.iter().any(|i| i.name() == t) => {}
                    (AxisSetting::Intersample, _) => {
                        return Err(bad(
                            &field,
                            format!("intersample must be \"zoh\" or \"bandlimited\", got {v}"),
                        ));
                    }
                    (AxisSetting::Excitation, AxisValue::Text(t)) if t == "hammer" => {}
                    (AxisSetting::Excitation, AxisValue::Text(t)) if t == "shaker" => {
                        if self.campaign.excitation == sim::Excitation::Hammer {
                            return Err(bad(
                                &field,
                                "\"shaker\" needs a continuous [campaign.excitation] (random, burst-random or chirp) in the scenario".into(),
                            ));
                        }
                    }
                    (AxisSetting::Excitation, _) => {
                        return Err(bad(
                            &field,
                            format!("excitation must be \"hammer\" or \"shaker\", got {v}"),
                        ));
                    }
                }
                if axis.values[..i].contains(v) {
                    return Err(bad(&field, format!("value {v} appears twice")));
                }
            }
        }
        Ok(())
    }
}

fn structure_field(matrix: &str) -> String {
    match matrix {
        "damping" => "damping".into(),
        m => format!("structure.{m}"),
    }
}

fn prefix(p: &str, e: SimError) -> SimError {
    match e {
        SimError::Invalid { field, problem } => SimError::Invalid {
            field: format!("{p}{field}"),
            problem,
        },
        other => other,
    }
}

/// The scenarios compiled into the binary, as (file name, contents): the
/// default study's. The same files are in `scenarios/`.
pub const BUILTIN: [(&str, &str); 3] = [
    (
        "paper-case1.toml",
        include_str!("../../scenarios/paper-case1.toml"),
    ),
    (
        "paper-case2.toml",
        include_str!("../../scenarios/paper-case2.toml"),
    ),
    (
        "frame-added-mass.toml",
        include_str!("../../scenarios/frame-added-mass.toml"),
    ),
];

impl LoadedScenario {
    /// Reads, parses and checks a scenario file.
    pub fn load(path: &Path) -> Result<LoadedScenario, ScenarioError> {
        let text = std::fs::read_to_string(path).map_err(|e| ScenarioError::Io {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
        Self::from_text(&text, path)
    }

    /// A scenario of [`BUILTIN`] by file name (`paper-case1.toml`); its
    /// path in messages is `scenarios/<name>`.
    pub fn builtin(name: &str) -> Result<LoadedScenario, ScenarioError> {
        let (file, text) = BUILTIN
            .iter()
            .find(|(n, _)| *n == name)
            .ok_or_else(|| ScenarioError::UnknownBuiltin { name: name.into() })?;
        Self::from_text(text, &Path::new("scenarios").join(file))
    }

    /// Parses and checks scenario text: the model, the campaign (by building
    /// its simulator) and the identification and sweep settings. `path` is
    /// used in messages and for the default name.
    pub fn from_text(text: &str, path: &Path) -> Result<LoadedScenario, ScenarioError> {
        let scenario = Scenario::parse(text, path)?;
        let invalid = |e: SimError| match e {
            SimError::Invalid { field, problem } => ScenarioError::Invalid {
                path: path.to_path_buf(),
                field,
                problem,
            },
            other => ScenarioError::Invalid {
                path: path.to_path_buf(),
                field: "structure".into(),
                problem: other.to_string(),
            },
        };
        let model = scenario.model().map_err(invalid)?;
        // Build the simulator once to check the campaign settings.
        scenario.simulator(model.clone()).map_err(invalid)?;
        scenario.check_study_settings().map_err(invalid)?;
        Ok(LoadedScenario {
            path: path.to_path_buf(),
            scenario,
            model,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MINIMAL: &str = r#"
[structure]
kind = "matrices"
mass = [[1.0, 0.0], [0.0, 1.0]]
stiffness = [[200.0, -100.0], [-100.0, 100.0]]

[damping]
kind = "rayleigh"
alpha = 0.1
beta = 1e-4

[campaign]
hits = 2
[campaign.hammer]
floor = 1
duration_s = 0.003
peak_n = 10.0
"#;

    fn load_text(text: &str) -> Result<LoadedScenario, ScenarioError> {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("case.toml");
        std::fs::write(&path, text).unwrap();
        LoadedScenario::load(&path).map_err(|e| match e {
            // Report relative to the file name only, for stable messages.
            ScenarioError::Parse { message, .. } => ScenarioError::Parse {
                path: "case.toml".into(),
                message,
            },
            ScenarioError::Invalid { field, problem, .. } => ScenarioError::Invalid {
                path: "case.toml".into(),
                field,
                problem,
            },
            other => other,
        })
    }

    #[test]
    fn minimal_scenario_loads_with_defaults() {
        let s = load_text(MINIMAL).unwrap();
        assert_eq!(s.scenario.name, "case");
        assert_eq!(s.scenario.campaign.sampling.samples, 2048);
        assert_eq!(s.model.dofs(), 2);
    }

    #[test]
    fn errors_name_file_and_field() {
        let bad = MINIMAL.replace("floor = 1", "floor = 3");
        assert_eq!(
            load_text(&bad).unwrap_err().to_string(),
            "case.toml: campaign.hammer.floor: floor 3 does not exist; floors are numbered 1..=2"
        );
        let bad = MINIMAL.replace(
            "[[200.0, -100.0], [-100.0, 100.0]]",
            "[[200.0, -100.0], [-100.0]]",
        );
        assert_eq!(
            load_text(&bad).unwrap_err().to_string(),
            "case.toml: structure.stiffness[1]: has 1 entries, expected 2"
        );
        let bad = MINIMAL.replace(
            "[[200.0, -100.0], [-100.0, 100.0]]",
            "[[100.0, -200.0], [-200.0, 100.0]]",
        );
        assert_eq!(
            load_text(&bad).unwrap_err().to_string(),
            "case.toml: structure.stiffness: not positive definite (Cholesky pivot 1 is not positive)"
        );
        let bad = MINIMAL.replace("peak_n = 10.0", "peak_n = 10.0\npeak = 3");
        let msg = load_text(&bad).unwrap_err().to_string();
        assert!(
            msg.contains("line 18") && msg.contains("unknown field `peak`"),
            "{msg}"
        );
        let bad = MINIMAL.replace("alpha = 0.1", "alpha = -0.1");
        assert_eq!(
            load_text(&bad).unwrap_err().to_string(),
            "case.toml: damping.alpha: must be a finite number >= 0, got -0.1"
        );
    }

    #[test]
    fn route_keys_load_and_are_checked() {
        let s = load_text(MINIMAL).unwrap();
        assert_eq!(s.scenario.identification.route, RouteSetting::Time);
        assert_eq!(s.scenario.identification.frf, FrfSettings::default());
        // A time-route scenario serializes as it did before the keys
        // existed (the golden sweep files stay byte-identical).
        let json = serde_json::to_string(&s.scenario.identification).unwrap();
        assert!(!json.contains("route") && !json.contains("frf"), "{json}");

        let both = format!(
            "{MINIMAL}\n[identification]\nroute = \"both\"\n[identification.frf]\nestimator = \"Hv\"\nband_hz = [0.5, 20.0]\nexponential_end_amplitude = 1.0\nforce_window = {{ before_peak_s = 0.01, after_peak_s = 0.02, taper_s = 0.005 }}\n"
        );
        let s = load_text(&both).unwrap();
        let id = &s.scenario.identification;
        assert_eq!(id.route, RouteSetting::Both);
        assert_eq!(id.frf.estimator, ident::frf::estimate::Estimator::Hv);
        assert_eq!(s.scenario.frf_band_hz(), (0.5, 20.0));
        let route = s.scenario.frf_route();
        assert_eq!(route.estimation.band_hz, Some((0.5, 20.0)));
        // End amplitude 1: no exponential window.
        assert!(matches!(
            route.estimation.averaging,
            ident::frf::estimate::Averaging::Hits(h)
                if h.exponential_window.is_none() && h.force_window.is_some()
        ));
        // The plan round-trips through JSON with the keys.
        let json = serde_json::to_string(&s.scenario).unwrap();
        assert_eq!(serde_json::from_str::<Scenario>(&json).unwrap(), s.scenario);

        // Default band: 0 Hz to the analyzer's passband, fs / 2.56.
        let s = load_text(&MINIMAL.replace(
            "[campaign]",
            "[identification]\nroute = \"frf\"\n[campaign]",
        ))
        .unwrap();
        assert_eq!(
            s.scenario.frf_band_hz(),
            (0.0, s.scenario.campaign.sampling.sample_rate_hz / 2.56)
        );

        for (edit, message) in [
            (
                "route = \"frf\"\nrefine = true",
                "case.toml: identification.refine: the refinement starts from the time route's estimate; set route = \"both\" (or \"time\"), or refine = false",
            ),
            (
                "route = \"both\"\n[identification.frf]\nband_hz = [0.0, 40.0]",
                "case.toml: identification.frf.band_hz: must be [low, high] with 0 <= low < high <= 32 Hz (Nyquist), got [0, 40]",
            ),
            (
                "route = \"both\"\n[identification.frf]\nexponential_end_amplitude = 0.0",
                "case.toml: identification.frf.exponential_end_amplitude: must be in (0, 1] (1: no window), got 0",
            ),
            (
                "route = \"both\"\n[identification.frf]\nforce_window = { before_peak_s = -1.0, after_peak_s = 0.02, taper_s = 0.0 }",
                "case.toml: identification.frf.force_window.before_peak_s: must be a finite number of seconds >= 0, got -1",
            ),
        ] {
            let text = MINIMAL.replace(
                "[campaign]",
                &format!("[identification]\n{edit}\n[campaign]"),
            );
            assert_eq!(load_text(&text).unwrap_err().to_string(), message, "{edit}");
        }
        for (edit, needle) in [
            ("route = \"frequency\"", "unknown variant `frequency`"),
            (
                "[identification.frf]\nestimator = \"h1\"",
                "unknown variant `h1`",
            ),
            (
                "[identification.frf]\nwindow = 0.1",
                "unknown field `window`",
            ),
        ] {
            let text = MINIMAL.replace(
                "[campaign]",
                &format!("[identification]\n{edit}\n[campaign]"),
            );
            let msg = load_text(&text).unwrap_err().to_string();
            assert!(
                msg.contains(needle) && msg.contains("line"),
                "{edit}: {msg}"
            );
        }
    }
}
