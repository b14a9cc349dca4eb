//! FRFs of a campaign of records, screened as `frameid identify` screens
//! them: what `frameid frf` computes.
//!
//! The hits are checked first ([`analyze_located`] without error bars: the
//! quality of each hit, each hit against the others, and each hit against
//! the joint model). Where the campaign cannot be identified (one output
//! only, fewer outputs than modes...), the checks of the records alone
//! ([`screen_records`]) screen it instead, and a warning says the
//! model-based checks were skipped. Then the kept hits are averaged: one
//! block per hit for hammer records, Welch segments for continuous ones
//! (as detected per record, or as the user says).

use ident::Campaign;
use ident::frf::estimate::{
    Averaging, Estimator, ExponentialWindow, ForceWindow, FrfEstimate, FrfEstimateError, FrfParams,
    HitAveraging, WelchAveraging,
};
use records::consistency::Locate;
use records::quality::{Excitation, HitQuality};

use crate::analysis::{
    AnalysisError, AnalysisSettings, Screened, analyze_located, quality_warnings, screen_records,
};

/// How blocks are formed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum AveragingChoice {
    /// One block per hit for hammer records, Welch segments for continuous
    /// ones (as detected).
    #[default]
    Auto,
    /// One block per hit.
    Hits,
    /// Welch segments of this many samples (`None`: the longest power of
    /// two that still gives [`WELCH_MIN_AVERAGES`] segments over all the
    /// records with 50 % overlap, at least [`WELCH_MIN_LEN`] samples).
    Welch(Option<usize>),
}

/// Fewest Welch averages (over all records) the automatic segment length
/// keeps. Longer segments mean finer lines, and lightly damped modes need
/// them: a Hann window's leakage inflates the damping of a mode whose
/// half-power bandwidth is not several lines wide (measured on paper case
/// 1, six 32 s shaker runs: a 2.7 Hz mode of 0.54 % damping comes out at
/// 1.9 % with 4 s segments, 0.67 % with 16 s). 16 averages keep the
/// random error of H1 and of the coherence near a quarter of a single
/// estimate's.
pub const WELCH_MIN_AVERAGES: usize = 16;

/// Shortest automatic Welch segment, samples.
pub const WELCH_MIN_LEN: usize = 256;

/// What `frameid frf` runs.
#[derive(Debug, Clone, PartialEq)]
pub struct FrfSettings {
    /// The estimator written (H1, H2 or Hv).
    pub estimator: Estimator,
    /// How blocks are formed.
    pub averaging: AveragingChoice,
    /// Force window of hammer records.
    pub force_window: Option<ForceWindow>,
    /// Exponential window of hammer records.
    pub exponential_window: Option<ExponentialWindow>,
    /// Lines kept, Hz.
    pub band_hz: Option<(f64, f64)>,
    /// The screening of the hits (quality, consistency, strictness; the
    /// identifier of the model-based checks).
    pub analysis: AnalysisSettings,
}

impl Default for FrfSettings {
    fn default() -> Self {
        FrfSettings {
            estimator: Estimator::H1,
            averaging: AveragingChoice::Auto,
            force_window: None,
            exponential_window: None,
            band_hz: None,
            analysis: AnalysisSettings {
                uncertainty: false,
                ..AnalysisSettings::default()
            },
        }
    }
}

/// FRFs of the hits kept.
#[derive(Debug, Clone)]
pub struct FrfOutcome {
    /// The estimate: outputs and references named as in the campaign.
    pub estimate: FrfEstimate,
    /// Hits averaged.
    pub campaign: Campaign,
    /// Positions (in the campaign given) of the hits left out.
    pub dropped: Vec<usize>,
    /// The excitation the averaging was chosen for.
    pub excitation: Excitation,
    /// Quality of every hit given.
    pub hit_quality: Vec<HitQuality>,
    /// Whether the hits were also checked against the joint model.
    pub model_checks: bool,
    /// Every warning, naming files and channels.
    pub warnings: Vec<String>,
}

/// Why no FRFs were estimated.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum FrfError {
    /// The screening refused the campaign.
    #[error(transparent)]
    Screening(#[from] AnalysisError),
    /// The estimation failed.
    #[error("FRF estimation: {0}")]
    Estimate(#[from] FrfEstimateError),
}

/// Screens `campaign` and estimates its FRFs (see the module docs).
pub fn estimate_frfs(
    campaign: &Campaign,
    locate: &dyn Locate,
    settings: &FrfSettings,
) -> Result<FrfOutcome, FrfError> {
    let analysis = AnalysisSettings {
        uncertainty: false,
        refine: None,
        ..settings.analysis.clone()
    };
    let (kept, dropped, hit_quality, mut warnings, model_checks) = match analyze_located(
        campaign, locate, &analysis,
    ) {
        // The FRFs of the records as read (the identification may have
        // decimated them or cut their start).
        Ok(a) => {
            let keep: Vec<usize> = (0..campaign.len())
                .filter(|i| !a.dropped.contains(i))
                .collect();
            (
                records::quality::remove_drifts(campaign, &a.hit_quality).subset(&keep),
                a.dropped,
                a.hit_quality,
                a.warnings,
                true,
            )
        }
        Err(
            e @ (AnalysisError::Identification { .. }
            | AnalysisError::TooFewOutputs { .. }
            | AnalysisError::OrderTooSmall { .. }
            | AnalysisError::FewerOutputsThanModes { .. }),
        ) => {
            let Screened {
                hit_quality,
                consistency,
                keep,
            } = screen_records(campaign, locate, &analysis)?;
            let mut warnings = quality_warnings(&hit_quality);
            warnings.extend(consistency.flags.iter().map(ToString::to_string));
            let dropped: Vec<usize> = (0..campaign.len()).filter(|i| !keep.contains(i)).collect();
            if !dropped.is_empty() {
                warnings.push(format!(
                    "dropped {} of {} hits: {} (--strict refuses the campaign instead)",
                    dropped.len(),
                    campaign.len(),
                    dropped
                        .iter()
                        .map(|&i| campaign.label(i))
                        .collect::<Vec<_>>()
                        .join(", ")
                ));
            }
            warnings.push(format!(
                    "the hits were not checked against a joint model (the campaign could not be identified: {}); only the checks of the records alone ran",
                    e.to_string().lines().next().unwrap_or_default()
                ));
            (
                records::quality::remove_drifts(campaign, &hit_quality).subset(&keep),
                dropped,
                hit_quality,
                warnings,
                false,
            )
        }
        Err(e) => return Err(e.into()),
    };
    let continuous = hit_quality
        .iter()
        .enumerate()
        .filter(|(i, _)| !dropped.contains(i))
        .any(|(_, q)| q.excitation == Excitation::Continuous);
    // Runs may differ in length: Welch segments must fit the shortest, and
    // hits of different lengths are zero-padded to the longest (one grid of
    // lines for all). Equal lengths are averaged as they are.
    let lengths: Vec<usize> = kept.records.iter().map(|r| r.outputs.ncols()).collect();
    let samples = lengths.iter().copied().min().unwrap_or(0);
    let longest = lengths.iter().copied().max().unwrap_or(0);
    let pad_to = (samples != longest).then_some(longest);
    let shortest = samples;
    let welch = |len: Option<usize>| {
        let len = len.unwrap_or_else(|| {
            let averages = |p: usize| -> usize {
                lengths
                    .iter()
                    .map(|&n| WelchAveraging::new(p).segments(n))
                    .sum()
            };
            // The longest power of two within the shortest record that keeps
            // the averages; the shortest allowed if none does.
            let mut p = WELCH_MIN_LEN.min(shortest.max(1));
            while p * 2 <= shortest && averages(p * 2) >= WELCH_MIN_AVERAGES {
                p *= 2;
            }
            p
        });
        Averaging::Welch(WelchAveraging::new(len))
    };
    let hits = Averaging::Hits(HitAveraging {
        block_len: pad_to,
        force_window: settings.force_window,
        exponential_window: settings.exponential_window,
    });
    let (averaging, excitation) = match settings.averaging {
        AveragingChoice::Hits => (hits, Excitation::Hammer),
        AveragingChoice::Welch(len) => (welch(len), Excitation::Continuous),
        AveragingChoice::Auto if continuous => (welch(None), Excitation::Continuous),
        AveragingChoice::Auto => (hits, Excitation::Hammer),
    };
    if matches!(averaging, Averaging::Welch(_))
        && (settings.force_window.is_some() || settings.exponential_window.is_some())
    {
        warnings.push(
            "the force and exponential windows apply to hammer records; Welch segments of continuous records use a Hann window instead"
                .into(),
        );
    }
    let mut params = FrfParams::hits()
        .estimator(settings.estimator)
        .averaging(averaging);
    if let Some((lo, hi)) = settings.band_hz {
        params = params.band_hz(lo, hi);
    }
    let mut estimate = params.estimate(&kept.records, kept.dt_s)?;
    estimate.frf.outputs = kept.outputs.clone();
    estimate.frf.references = kept.inputs.clone();
    Ok(FrfOutcome {
        estimate,
        campaign: kept,
        dropped,
        excitation,
        hit_quality,
        model_checks,
        warnings,
    })
}

/// What `frameid frf` did (`frf.json`, and `--json` on standard output).
#[derive(Debug, Clone, serde::Serialize)]
pub struct FrfSummary {
    /// The record files given.
    pub files: Vec<String>,
    /// Hits (records) averaged.
    pub hits_used: usize,
    /// Files left out (quality or consistency), with the warnings saying why.
    pub dropped: Vec<String>,
    /// The excitation the averaging was chosen for (`hammer`, `continuous`).
    pub excitation: String,
    /// H1, H2 or Hv.
    pub estimator: String,
    /// Averages behind each line.
    pub averages: usize,
    /// FFT length, samples.
    pub block_len: usize,
    /// Line spacing, Hz.
    pub resolution_hz: f64,
    /// Lines written.
    pub lines: usize,
    /// First and last line, Hz.
    pub band_hz: [f64; 2],
    /// The windows and blocks used.
    pub windows: ident::frf::estimate::AppliedWindows,
    /// Time constant of the exponential window, s: its damping
    /// (`1 / (tau omega)` of critical at `omega`) is in the FRFs and is
    /// removed by `frameid identify`.
    pub exponential_tau_s: Option<f64>,
    /// Whether the hits were checked against a joint model as well as
    /// against each other.
    pub model_checks: bool,
    /// Responses (outputs) and references (forces), in file order.
    pub outputs: Vec<String>,
    /// The references.
    pub references: Vec<String>,
    /// Lowest coherence of any pair over the lines, and its median.
    pub coherence_min: f64,
    /// Median coherence over the lines and pairs.
    pub coherence_median: f64,
    /// The files written, in the output directory.
    pub written: Vec<String>,
    /// Every warning, naming files and channels.
    pub warnings: Vec<String>,
}

impl FrfSummary {
    /// The summary of an estimate written as `written` (file names in the
    /// output directory).
    pub fn new(o: &FrfOutcome, files: &[std::path::PathBuf], written: Vec<String>) -> Self {
        let frf = &o.estimate.frf;
        let mut gamma: Vec<f64> = frf
            .coherence
            .iter()
            .flatten()
            .flat_map(|g| g.iter().copied())
            .filter(|g| g.is_finite())
            .collect();
        gamma.sort_by(f64::total_cmp);
        let n = frf.frequency_hz.len();
        FrfSummary {
            files: files.iter().map(|f| f.display().to_string()).collect(),
            hits_used: o.campaign.records.len(),
            dropped: o
                .dropped
                .iter()
                .map(|&i| {
                    files
                        .get(i)
                        .map_or(format!("#{i}"), |f| f.display().to_string())
                })
                .collect(),
            excitation: o.excitation.label().to_string(),
            estimator: o.estimate.estimator.to_string(),
            averages: frf.averages.unwrap_or(0),
            block_len: o.estimate.windows.block_len,
            resolution_hz: 1.0 / (o.estimate.windows.block_len as f64 * o.campaign.dt_s),
            lines: n,
            band_hz: [
                frf.frequency_hz.first().copied().unwrap_or(f64::NAN),
                frf.frequency_hz.last().copied().unwrap_or(f64::NAN),
            ],
            windows: o.estimate.windows.clone(),
            exponential_tau_s: o.estimate.windows.exponential_tau_s,
            model_checks: o.model_checks,
            outputs: frf.outputs.clone(),
            references: frf.references.clone(),
            coherence_min: gamma.first().copied().unwrap_or(f64::NAN),
            coherence_median: gamma.get(gamma.len() / 2).copied().unwrap_or(f64::NAN),
            written,
            warnings: o.warnings.clone(),
        }
    }
}
