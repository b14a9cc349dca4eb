//! Identification of a campaign of records with everything around it: the
//! hit quality checks and which hits to use, the joint identification, its
//! error bars (jackknife over the hits) and the maximum-likelihood
//! refinement, with every message naming the record, channel or setting
//! concerned. This is what `frameid identify` runs on record files; its
//! outcome is rendered as text or JSON by the binary.

use ident::refine::{Refinement, Refiner, SecondOrder};
use ident::{Campaign, Identification, Identifier, Jackknife, ModelOrder, ObserverOrder};
use nalgebra::DMatrix;
use rayon::prelude::*;
use records::consistency::{
    ByPosition, Consistency, ConsistencyFlag, ConsistencySettings, Inconsistency, Locate,
    check_consistency,
};
use records::numfmt::sig;
use records::quality::{Check, Excitation, HitQuality, QualitySettings, assess_campaign};
use std::borrow::Cow;

use crate::decimate::{Decimation, DecimationSetting};
use crate::scenario::ParametrizationSetting;

/// What the identification assumes about the state at the start of every
/// record (`--initial-state`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum InitialStateSetting {
    /// At rest, unless the records say otherwise (see
    /// [`InitialStateReport`]): continuous records whose outputs move before
    /// the force starts, or whose misfit to a model identified from rest
    /// stands out at their start.
    #[default]
    Auto,
    /// At rest (every sample an equation, zeros before the record).
    AtRest,
    /// Unknown: OKID forms no equations for the first samples of every
    /// record (see `ident::InitialState::Unknown`).
    Unknown,
}

impl std::str::FromStr for InitialStateSetting {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.trim() {
            "auto" => Ok(Self::Auto),
            "at-rest" => Ok(Self::AtRest),
            "unknown" => Ok(Self::Unknown),
            _ => Err(format!("expected auto, at-rest or unknown, got '{s}'")),
        }
    }
}

/// A continuous record's misfit to the model identified from rest counts
/// as a start away from rest when its RMS over the first eighth of the
/// record exceeds this many times its RMS over the last eighth: 2. From
/// rest, the misfit is noise and model error, as large at the start as at
/// the end (measured 0.90-1.10 on six simulated random-shaker records of
/// paper case 1 at 1 % noise); a record that starts vibrating carries the
/// free decay of its initial state at the start (measured 3.4-10.7 on six
/// such records in steady state at their first sample: the decay's size
/// depends on the state the record happens to start in). One record so
/// judged is enough: the whole campaign is then identified with an
/// unknown initial state, which costs the records at rest only the first
/// observer-order samples' equations.
pub const START_MISFIT_FACTOR: f64 = 2.0;

/// How one continuous record was judged.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct RecordRest {
    /// The record's label (its file).
    pub file: String,
    /// Outputs' RMS before the force starts over their RMS over the record
    /// (null when the force is on from the first sample).
    pub pre_excitation_ratio: Option<f64>,
    /// Misfit to the model identified from rest: RMS over the first eighth
    /// of the record over RMS over the last eighth (largest over the
    /// outputs; null when not computed).
    pub start_misfit_ratio: Option<f64>,
    /// Whether the record is judged to start at rest.
    pub at_rest: bool,
}

/// What the identification assumed about the initial state, and why.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct InitialStateReport {
    /// `at-rest` or `unknown`.
    pub assumed: ident::InitialState,
    /// `auto` (judged from the records) or `given` (`--initial-state`).
    pub chosen: &'static str,
    /// Equations OKID did not form at the start of every record.
    pub skipped_equations: usize,
    /// Samples cut at the start of every record (the decimation filter's
    /// settling, which mixes in the zeros it assumes before the record).
    pub cut_samples: usize,
    /// The continuous records judged (hammer records start at rest).
    pub records: Vec<RecordRest>,
    /// What was done, in words.
    pub reason: String,
}

/// Which hits to identify after the quality and consistency checks.
///
/// Whatever the screening, a hit that is inconsistent with the others
/// ([`records::consistency`]) is never used silently: it is dropped with a
/// warning, or the campaign is refused under [`Screening::Strict`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Screening {
    /// Keep every hit that fails a quality check of its own (the failures
    /// are warnings); refuse hits without a pulse; drop inconsistent hits
    /// with a warning.
    #[default]
    Warn,
    /// Refuse the campaign if any hit fails a check or is inconsistent
    /// (`--strict`).
    Strict,
    /// Identify without the hits that fail a check or are inconsistent
    /// (`--drop-bad-hits`).
    DropBad,
}

/// What to run, checked before anything is identified.
#[derive(Debug, Clone, PartialEq)]
pub struct AnalysisSettings {
    /// The identifier (intersample assumption, orders, collocated pair).
    pub identifier: Identifier,
    /// Thresholds of the hit quality checks.
    pub quality: QualitySettings,
    /// Thresholds of the checks of every hit against the others.
    pub consistency: ConsistencySettings,
    /// What to do with hits that fail a check.
    pub screening: Screening,
    /// Error bars by the jackknife over the hits.
    pub uncertainty: bool,
    /// Maximum-likelihood refinement with this parametrization.
    pub refine: Option<ParametrizationSetting>,
    /// Decimation of records sampled far above the modes' band.
    pub decimation: DecimationSetting,
    /// What is assumed about the state at the start of every record.
    pub initial_state: InitialStateSetting,
}

impl Default for AnalysisSettings {
    /// What `frameid identify` does without options.
    fn default() -> Self {
        AnalysisSettings {
            identifier: Identifier::default(),
            quality: QualitySettings::default(),
            consistency: ConsistencySettings::default(),
            screening: Screening::Warn,
            uncertainty: true,
            refine: None,
            decimation: DecimationSetting::Auto,
            initial_state: InitialStateSetting::Auto,
        }
    }
}

/// The outcome of [`analyze`].
#[derive(Debug, Clone)]
pub struct Analysis {
    /// The hits identified (dropped ones left out), with their names, as
    /// identified: decimated, and cut at the start, if they were.
    pub campaign: Campaign,
    /// The decimation (factor 1 when the records were identified at their
    /// own rate).
    pub decimation: Decimation,
    /// The initial state assumed, when anything was judged or given (null
    /// for hammer records with `--initial-state auto`).
    pub initial_state: Option<InitialStateReport>,
    /// The joint identification of those hits.
    pub identification: Identification,
    /// The collocated force/accelerometer pair used.
    pub collocated: ident::CollocatedPair,
    /// Quality of every hit given, dropped or not, in the order given.
    pub hit_quality: Vec<HitQuality>,
    /// Every hit checked against the others: the flags (records by their
    /// position in the campaign given, residual flags included) and notes.
    pub consistency: Consistency,
    /// Positions (in the campaign given) of the hits left out.
    pub dropped: Vec<usize>,
    /// Error bars, if computed.
    pub uncertainty: Option<Jackknife>,
    /// Why there are no error bars, if there are none.
    pub uncertainty_skipped: Option<String>,
    /// The refinement, if asked for.
    pub refinement: Option<Refinement>,
    /// Every warning, naming the file: the quality checks (every hit), the
    /// hits dropped, the identification's and the failed resamples.
    pub warnings: Vec<String>,
}

/// Why a campaign was not identified.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum AnalysisError {
    /// A threshold of the checks is out of range.
    #[error("{message}")]
    Settings {
        /// The field and what is wrong.
        message: String,
    },
    /// Hits without a usable pulse (fatal quality checks).
    #[error(
        "{}\n(remove the record, or pass --drop-bad-hits to identify without it)",
        lines.join("\n")
    )]
    NoHit {
        /// One line per failed check, naming the file.
        lines: Vec<String>,
    },
    /// `--strict` and some hits fail a check.
    #[error(
        "--strict: {failing} of {hits} hits fail the quality checks:\n{}",
        lines.join("\n")
    )]
    Strict {
        /// Hits failing.
        failing: usize,
        /// Hits given.
        hits: usize,
        /// The failed checks, per hit.
        lines: Vec<String>,
    },
    /// `--strict` and some hits are inconsistent with the others.
    #[error(
        "--strict: {failing} of {hits} hits are inconsistent with the others:\n{}",
        lines.join("\n")
    )]
    StrictInconsistent {
        /// Hits flagged.
        failing: usize,
        /// Hits given.
        hits: usize,
        /// The flags, one per line, naming file and channel.
        lines: Vec<String>,
    },
    /// Every hit is inconsistent (or fails a check under
    /// `--drop-bad-hits`): none remains.
    #[error(
        "all {hits} hits are inconsistent with the others or fail the checks, none remain to identify:\n{}",
        lines.join("\n")
    )]
    NoneConsistent {
        /// Hits given.
        hits: usize,
        /// The flags, one per line.
        lines: Vec<String>,
    },
    /// `--drop-bad-hits` and every hit fails a check.
    #[error(
        "--drop-bad-hits: all {hits} hits fail the quality checks, none remain to identify:\n{}",
        lines.join("\n")
    )]
    AllDropped {
        /// Hits given.
        hits: usize,
        /// The failed checks, per hit.
        lines: Vec<String>,
    },
    /// Fewer than two outputs selected.
    #[error(
        "only {} output selected ({}): MKR needs an accelerometer on every floor (one output per degree of freedom) and the Rayleigh fit needs at least 2 modes; select every floor's accelerometer with --outputs",
        outputs.len(),
        outputs.join(", ")
    )]
    TooFewOutputs {
        /// The outputs selected.
        outputs: Vec<String>,
    },
    /// A fixed model order too small for the outputs.
    #[error(
        "--order {order}: a realization of order {order} has at most {} mode(s), but {} outputs (one per degree of freedom: {}) need {}; use --order {} or more, or leave it out",
        order / 2,
        outputs.len(),
        outputs.join(", "),
        outputs.len(),
        2 * outputs.len()
    )]
    OrderTooSmall {
        /// The order asked for.
        order: usize,
        /// The outputs selected.
        outputs: Vec<String>,
    },
    /// The records show more structural modes than outputs.
    #[error(
        "{records}: the records show {} structural modes ({} Hz) but only {} outputs are selected ({}): fewer outputs than degrees of freedom. MKR needs an accelerometer on every floor; select them all with --outputs (if a mode is spurious, set the model order with --order)",
        modes_hz.len(),
        modes_hz.iter().map(|f| sig(*f, 4)).collect::<Vec<_>>().join(", "),
        outputs.len(),
        outputs.join(", ")
    )]
    FewerOutputsThanModes {
        /// The records, as a phrase.
        records: String,
        /// Every structural mode found, Hz, ascending.
        modes_hz: Vec<f64>,
        /// The outputs selected.
        outputs: Vec<String>,
    },
    /// The identification failed; the message names files, channels and
    /// settings, `error` is the identifier's own.
    #[error("{message}")]
    Identification {
        /// What failed, in the user's terms.
        message: String,
        /// The identifier's error.
        error: ident::Error,
    },
    /// The refinement needs exactly one force input.
    #[error(
        "--refine: supports one force input, got {} ({})",
        inputs.len(),
        inputs.join(", ")
    )]
    RefineInputs {
        /// The inputs selected.
        inputs: Vec<String>,
    },
    /// The refinement failed.
    #[error("--refine: {error}")]
    Refinement {
        /// The refinement's error.
        error: ident::RefineError,
    },
}

/// The checks of the records alone, before any identification: every hit's
/// quality and every hit against the others (dead, copied or spiked
/// channels, duplicates, level and spectrum). Hits are dropped or the
/// campaign refused as `settings.screening` says.
#[derive(Debug, Clone)]
pub struct Screened {
    /// Quality of every hit given, in the order given.
    pub hit_quality: Vec<HitQuality>,
    /// Every hit checked against the others.
    pub consistency: Consistency,
    /// Positions of the hits kept.
    pub keep: Vec<usize>,
}

/// Runs the checks of the records alone (see [`Screened`]); the model-based
/// checks of [`analyze_located`] come after it.
pub fn screen_records(
    campaign: &Campaign,
    locate: &dyn Locate,
    settings: &AnalysisSettings,
) -> Result<Screened, AnalysisError> {
    settings
        .consistency
        .check()
        .map_err(|message| AnalysisError::Settings { message })?;
    // Held records have no filter precursor: they may start at the hit.
    let quality = match settings.identifier.intersample {
        ident::Intersample::Zoh => QualitySettings {
            min_samples_before_hit: 0,
            ..settings.quality.clone()
        },
        ident::Intersample::Bandlimited => settings.quality.clone(),
    };
    let hit_quality = assess_campaign(campaign, &quality);
    let consistency = check_consistency(campaign, locate, &settings.consistency);
    let inconsistent = consistency.flagged_records();
    let flag_lines = |flags: &[ConsistencyFlag]| -> Vec<String> {
        flags.iter().map(|f| format!("  {f}")).collect()
    };
    if settings.screening == Screening::Strict && !inconsistent.is_empty() {
        return Err(AnalysisError::StrictInconsistent {
            failing: inconsistent.len(),
            hits: campaign.len(),
            lines: flag_lines(&consistency.flags),
        });
    }
    // The quality screening sees the consistent hits only.
    let consistent: Vec<usize> = (0..campaign.len())
        .filter(|i| !inconsistent.contains(i))
        .collect();
    if consistent.is_empty() {
        return Err(AnalysisError::NoneConsistent {
            hits: campaign.len(),
            lines: flag_lines(&consistency.flags),
        });
    }
    let quality_of: Vec<HitQuality> = consistent.iter().map(|&i| hit_quality[i].clone()).collect();
    let keep: Vec<usize> = screen_hits(&quality_of, settings.screening)?
        .into_iter()
        .map(|i| consistent[i])
        .collect();
    Ok(Screened {
        hit_quality,
        consistency,
        keep,
    })
}

/// Checks every hit, screens them, identifies the hits kept jointly, and
/// adds error bars and the refinement as `settings` ask. Samples are named
/// by position in messages; [`analyze_located`] names their file lines.
pub fn analyze(
    campaign: &Campaign,
    settings: &AnalysisSettings,
) -> Result<Analysis, AnalysisError> {
    analyze_located(campaign, &ByPosition, settings)
}

/// [`analyze`], with `locate` naming the place of a sample in its file
/// (a line of a CSV or UFF file) in the messages of the consistency checks.
///
/// The stages, in order: the quality checks of every hit on its own; the
/// checks of every hit against the others (inconsistent hits are dropped
/// with a warning, or refused under `--strict`); the quality screening of
/// the remaining hits; the joint identification; the residual of every hit
/// against the joint model (hits whose residual stands out are dropped, and
/// the rest identified again); error bars; refinement.
pub fn analyze_located(
    campaign: &Campaign,
    locate: &dyn Locate,
    settings: &AnalysisSettings,
) -> Result<Analysis, AnalysisError> {
    let Screened {
        hit_quality,
        mut consistency,
        mut keep,
    } = screen_records(campaign, locate, settings)?;
    // Drifting baselines found by the quality checks are removed (and said
    // in the warnings, from the flags) before anything is identified.
    let detrended = records::quality::remove_drifts(campaign, &hit_quality);
    let campaign: &Campaign = &detrended;
    let flag_lines = |flags: &[ConsistencyFlag]| -> Vec<String> {
        flags.iter().map(|f| format!("  {f}")).collect()
    };
    // The records as read are checked above; the identification and the
    // checks against a model see them decimated and, when not at rest, cut
    // at the start (sample positions mapped back for the messages).
    let continuous = keep
        .iter()
        .any(|&i| hit_quality[i].excitation == Excitation::Continuous);
    let (decimated, decimation) =
        decimate_campaign(campaign, &subset(campaign, &keep), continuous, settings);
    let mut identifier = settings.identifier.clone();
    let (initial_state, cut) = initial_state(
        &decimated,
        &keep,
        &hit_quality,
        &identifier,
        decimation.settling_samples,
        settings.initial_state,
        settings.quality.max_initial_motion,
    );
    if let Some(report) = &initial_state {
        identifier = identifier.initial_state(report.assumed);
    }
    let work = if cut > 0 {
        Cow::Owned(cut_start(&decimated, cut))
    } else {
        decimated
    };
    let mapped = Resampled {
        inner: locate,
        factor: decimation.factor,
        offset: cut,
    };
    let locate: &dyn Locate = &mapped;
    let campaign: &Campaign = &work;
    let id = &identifier;
    // The kept hits' records are validated and their OKID moments accumulated once, for
    // the joint identification, the consistency check's core and the jackknife's
    // resamples. When hits are dropped (the joint identification fails with one, or the
    // residual check below finds some), the others form `replaced` and are identified
    // from scratch, the moments prepared then set aside.
    let joint_campaign = campaign.subset(&keep);
    check_orders(&joint_campaign, id)?;
    let prepared = id
        .prepare(&joint_campaign.records, joint_campaign.dt_s)
        .ok();
    let joint = match &prepared {
        Some(p) => p.identify(),
        None => id.identify(&joint_campaign.records, joint_campaign.dt_s),
    };
    let mut replaced: Option<Campaign> = None;
    let mut result = match joint {
        Ok(r) => r,
        Err(e) => {
            // A hit that breaks the joint identification on its own is
            // inconsistent with the others: find it, or refuse naming none.
            let Some((bad, r)) = without_breaking_hit(campaign, &keep, id, &settings.consistency)
            else {
                return Err(identification_error(e, &joint_campaign, id));
            };
            let flag = ConsistencyFlag {
                record: bad,
                file: campaign.label(bad),
                channel: None,
                kind: Inconsistency::BreaksIdentification,
                message: format!(
                    "the joint identification fails with this hit ({}) and succeeds without it",
                    identification_error(e, &joint_campaign, id)
                ),
            };
            if settings.screening == Screening::Strict {
                return Err(AnalysisError::StrictInconsistent {
                    failing: 1,
                    hits: campaign.len(),
                    lines: flag_lines(std::slice::from_ref(&flag)),
                });
            }
            consistency.flags.push(flag);
            consistency.flags.sort_by_key(|f| f.record);
            keep.retain(|&i| i != bad);
            replaced = Some(campaign.subset(&keep));
            r
        }
    };
    // The moments prepared are those of the campaign identified.
    let prepared = prepared.filter(|_| replaced.is_none());
    // Every kept hit against the model of the hits that agree best with the
    // joint model (the better half): a hit whose outputs do not follow it
    // is dropped (if such hits are a minority) and the rest identified
    // again, once.
    //
    // The error bars of the joint result are computed alongside (both use
    // every thread): they are kept unless hits are dropped here, which is
    // rare, and then computed again for the hits kept.
    let jackknife_of =
        |c: &Campaign, result: &Identification, prepared: Option<&ident::PreparedRecords>| {
            settings.uncertainty.then(|| {
                match prepared {
                    Some(p) => ident::jackknife_prepared(p, c, result),
                    None => ident::jackknife(id, c, result),
                }
                .map_err(|e| e.to_string())
            })
        };
    let mut residual_notes = Vec::new();
    let mut error_bars = None;
    let c = replaced.as_ref().unwrap_or(&joint_campaign);
    if keep.len() >= settings.consistency.min_hits {
        let core = CoreIdentifier {
            identifier: id,
            prepared: prepared.as_ref(),
        };
        let (flags, bars) = rayon::join(
            || residual_flags(c, &keep, &result, &core, locate, &settings.consistency),
            || jackknife_of(c, &result, prepared.as_ref()),
        );
        error_bars = Some(bars);
        let odd: Vec<usize> = {
            let mut v: Vec<usize> = flags.iter().map(|f| f.record).collect();
            v.dedup();
            v
        };
        if !odd.is_empty() {
            if settings.screening == Screening::Strict {
                return Err(AnalysisError::StrictInconsistent {
                    failing: odd.len(),
                    hits: campaign.len(),
                    lines: flag_lines(&flags),
                });
            }
            if 2 * odd.len() < keep.len() {
                keep.retain(|i| !odd.contains(i));
                consistency.flags.extend(flags);
                consistency.flags.sort_by_key(|f| f.record);
                let kept = campaign.subset(&keep);
                result = id
                    .identify(&kept.records, kept.dt_s)
                    .map_err(|e| identification_error(e, &kept, id))?;
                replaced = Some(kept);
                error_bars = None;
            } else {
                residual_notes.push(format!(
                    "the residuals of {} of {} hits stand out against the model of the others; as they are not a minority no hit is dropped (is the campaign a mix of set-ups?): {}",
                    odd.len(),
                    keep.len(),
                    flags.iter().map(ToString::to_string).collect::<Vec<_>>().join("; ")
                ));
            }
        }
    }
    consistency.notes.extend(residual_notes);
    let dropped: Vec<usize> = (0..campaign.len()).filter(|i| !keep.contains(i)).collect();
    let prepared = prepared.filter(|_| replaced.is_none());
    let c = replaced.as_ref().unwrap_or(&joint_campaign);
    if settings.screening == Screening::Strict {
        check_modes_against_outputs(&result, c)?;
    }
    let (uncertainty, uncertainty_skipped) =
        match error_bars.unwrap_or_else(|| jackknife_of(c, &result, prepared.as_ref())) {
            Some(Ok(u)) => (Some(u), None),
            Some(Err(e)) => (None, Some(e)),
            None => (None, Some("--no-uncertainty".to_string())),
        };
    // Warnings: the quality checks first (every hit, dropped or not), the
    // consistency flags and notes, the hits dropped, then the
    // identification's with hits named by file.
    let mut warnings = quality_warnings(&hit_quality);
    if decimation.factor > 1 {
        warnings.push(format!(
            "decimated by {} ({} Hz to {} Hz) before identification: {}",
            decimation.factor,
            sig(decimation.original_rate_hz, 4),
            sig(decimation.rate_hz, 4),
            decimation.reason
        ));
    }
    if let Some(report) = &initial_state
        && report.assumed == ident::InitialState::Unknown
    {
        warnings.push(format!("initial state: {}", report.reason));
    }
    warnings.extend(consistency.flags.iter().map(ToString::to_string));
    warnings.extend(
        consistency
            .notes
            .iter()
            .map(|n| format!("consistency: {n}")),
    );
    if !dropped.is_empty() {
        let reasons: Vec<String> = dropped
            .iter()
            .map(|&i| {
                let mut why: Vec<String> = consistency
                    .flags
                    .iter()
                    .filter(|f| f.record == i)
                    .map(|f| match &f.channel {
                        Some(ch) => format!("{ch}: {}", f.kind),
                        None => f.kind.to_string(),
                    })
                    .collect();
                why.extend(
                    hit_quality[i]
                        .failed_checks()
                        .iter()
                        .map(|c| c.label().to_string()),
                );
                why.dedup();
                format!("{} ({})", hit_quality[i].file, why.join(", "))
            })
            .collect();
        warnings.push(format!(
            "dropped {} of {} hits: {} (--strict refuses the campaign instead)",
            dropped.len(),
            hit_quality.len(),
            reasons.join("; ")
        ));
    }
    warnings.extend(
        result
            .warnings
            .iter()
            .filter(|w| !matches!(w, ident::Warning::ExtraStructuralModes { .. }))
            .map(|w| ident_warning(w, c)),
    );
    let outside = result.out_of_model_modes();
    if !outside.is_empty() {
        let describe = |j: &usize| {
            let md = &result.modes[*j];
            format!(
                "{} Hz (damping {} %)",
                sig(md.frequency_hz, 4),
                sig(100.0 * md.damping_ratio, 2)
            )
        };
        warnings.push(format!(
            "{} structural mode(s) outside the {}-DOF model (a mode the shear model lacks, or a floor without an accelerometer): {}; M, K and R use {} Hz, chosen as {}. Name the model's modes with --modes or --band if the choice is wrong; if a floor has no accelerometer selected, the model is wrong: select every floor's with --outputs (--strict refuses instead)",
            outside.len(),
            c.outputs.len(),
            outside.iter().map(describe).collect::<Vec<_>>().join(", "),
            result
                .frequencies_hz
                .iter()
                .map(|f| sig(*f, 4))
                .collect::<Vec<_>>()
                .join(", "),
            result.mode_selection.describe()
        ));
    }
    if let Some(u) = &uncertainty {
        for f in &u.failed {
            warnings.push(format!(
                "uncertainty: without {} the identification fails ({}); that resample is left out",
                f.left_out, f.error
            ));
        }
    } else if let Some(reason) = &uncertainty_skipped
        && settings.uncertainty
        && c.len() >= ident::jackknife::MIN_HITS
    {
        warnings.push(format!("no error bars: {reason}"));
    }
    drop(prepared);
    let c = replaced.unwrap_or(joint_campaign);
    let refinement = match settings.refine {
        Some(p) => Some(refine(p, &c, &result, id)?),
        None => None,
    };
    if let Some(r) = &refinement {
        warnings.extend(refinement_warnings(
            r.stop,
            (r.noise_updates, r.noise_change),
            &r.uncertainty.modes,
            r.mass.nrows(),
        ));
    }
    Ok(Analysis {
        campaign: c,
        decimation,
        initial_state,
        identification: result,
        collocated: id.collocated,
        hit_quality,
        consistency,
        dropped,
        uncertainty,
        uncertainty_skipped,
        refinement,
        warnings,
    })
}

/// When the joint identification of the hits `keep` of `campaign` fails:
/// the one hit without which it succeeds, with that identification. When
/// several hits can be left out with success, the one whose own residual
/// against the model of the others is `residual_factor` times every other
/// candidate's (and above `residual_floor`) is to blame. `None` with fewer
/// than `min_hits` hits, or when no single hit is to blame.
fn without_breaking_hit(
    campaign: &Campaign,
    keep: &[usize],
    id: &Identifier,
    settings: &ConsistencySettings,
) -> Option<(usize, Identification)> {
    if keep.len() < settings.min_hits {
        return None;
    }
    let sub = campaign.subset(keep);
    let results = ident::leave_one_out(id, &sub, None);
    let mut ok: Vec<(usize, Identification)> = results
        .into_iter()
        .enumerate()
        .filter_map(|(k, r)| Some((k, r.ok()?)))
        .collect();
    if ok.len() <= 1 {
        return ok.pop().map(|(k, r)| (keep[k], r));
    }
    // Residual share of each candidate hit against the model without it.
    let scores: Vec<f64> = ok
        .iter()
        .map(|(k, model)| {
            let rec = &sub.records[*k];
            let sign = if model.polarity_flipped { -1.0 } else { 1.0 };
            let p = model.realization.simulate(&rec.inputs);
            let (mut d, mut e) = (0.0, 0.0);
            for (y, q) in rec.outputs.iter().zip(p.iter()) {
                d += (y - sign * q) * (y - sign * q);
                e += q * q;
            }
            if e > 0.0 { d / e } else { f64::INFINITY }
        })
        .collect();
    let (best, &top) = scores
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.total_cmp(b.1))?;
    let blamed = top > settings.residual_floor
        && scores
            .iter()
            .enumerate()
            .all(|(i, &s)| i == best || top > settings.residual_factor * s);
    blamed.then(|| {
        let (k, r) = ok.swap_remove(best);
        (keep[k], r)
    })
}

/// How one output of one hit misfits a model's response to the hit's
/// inputs (`y_model`, with the realization's polarity undone).
#[derive(Debug, Clone, Copy)]
struct Misfit {
    /// Energy of `y - y_model` over that of `y_model`.
    share: f64,
    /// Least-squares factor from `y_model` to `y`.
    gain: f64,
    /// Sample of the largest residual, and its size in robust deviations
    /// of the residual (1.4826 x its median absolute deviation).
    glitch: (usize, f64),
    /// That largest departure over the channel's peak `|y|` in the hit.
    glitch_of_peak: f64,
}

/// The misfit of every output (inner) of every hit of `c` (outer) to
/// `model`; without `glitches`, only the shares and gains (the glitch
/// fields zero: their medians are most of the cost).
fn misfits(c: &Campaign, model: &Identification, glitches: bool) -> Vec<Vec<Misfit>> {
    let median = records::consistency::median;
    let sign = if model.polarity_flipped { -1.0 } else { 1.0 };
    // Hits in parallel, each its own numbers.
    c.records
        .par_iter()
        .map(|r| {
            let p = model.realization.simulate(&r.inputs);
            (0..c.outputs.len())
                .map(|j| {
                    let residual = output_residual(r, &p, sign, j);
                    let (mut d, mut e, mut x) = (0.0, 0.0, 0.0);
                    for ((y, q), r) in r.outputs.row(j).iter().zip(p.row(j).iter()).zip(&residual) {
                        let q = sign * q;
                        d += r * r;
                        e += q * q;
                        x += y * q;
                    }
                    let (share, gain) = if e > 0.0 {
                        (d / e, x / e)
                    } else {
                        (f64::INFINITY, 0.0)
                    };
                    if !glitches {
                        return Misfit {
                            share,
                            gain,
                            glitch: (0, 0.0),
                            glitch_of_peak: 0.0,
                        };
                    }
                    let mid = median(&residual);
                    let dev: Vec<f64> = residual.iter().map(|v| (v - mid).abs()).collect();
                    let scale = 1.4826 * median(&dev);
                    let (at, top) = dev
                        .iter()
                        .enumerate()
                        .fold((0, 0.0), |a, (i, &d)| if d > a.1 { (i, d) } else { a });
                    let peak = r
                        .outputs
                        .row(j)
                        .iter()
                        .fold(0.0, |a: f64, y| a.max(y.abs()));
                    Misfit {
                        share,
                        gain,
                        glitch: (at, if scale > 0.0 { top / scale } else { 0.0 }),
                        glitch_of_peak: if peak > 0.0 { top / peak } else { 0.0 },
                    }
                })
                .collect()
        })
        .collect()
}

/// How the core of a campaign is identified: on its own (its own model and
/// observer orders: at the joint's, which a bad hit can inflate, the core's
/// model follows that hit too), from the moments of the campaign's records
/// when they are `prepared`.
struct CoreIdentifier<'a, 'r> {
    identifier: &'a Identifier,
    prepared: Option<&'a ident::PreparedRecords<'r>>,
}

impl CoreIdentifier<'_, '_> {
    /// The hits `core` (increasing indices) of `c` identified on their own.
    fn identify(&self, c: &Campaign, core: &[usize]) -> Result<Identification, ident::Error> {
        match self.prepared {
            Some(p) => p.identify_subset(core),
            None => {
                let sub = c.subset(core);
                self.identifier.identify(&sub.records, sub.dt_s)
            }
        }
    }
}

/// Every hit of `c` (hit `i` of `c` is record `index[i]` of the campaign
/// given) against the model of its core: the better half of the hits by
/// their residual against the joint model `joint`, identified again on
/// their own (so that one bad hit, which pulls the joint model towards
/// itself, does not hide behind it). A hit is flagged when, for an output,
///
/// - its gain differs from the median gain over the hits by more than
///   `transfer_floor` and `transfer_sigmas` robust deviations (a
///   [`Inconsistency::Transfer`] flag), or
/// - its residual share exceeds `residual_factor` times the median over the
///   hits and `residual_floor` ([`Inconsistency::Residual`]).
fn residual_flags(
    c: &Campaign,
    index: &[usize],
    joint: &Identification,
    core_identifier: &CoreIdentifier,
    locate: &dyn Locate,
    settings: &ConsistencySettings,
) -> Vec<ConsistencyFlag> {
    let m = c.outputs.len();
    let n = c.len();
    // The joint model's shares order the hits; its glitches are not judged.
    let against_joint = misfits(c, joint, false);
    let worst = |s: &Vec<Misfit>| s.iter().map(|v| v.share).fold(0.0, f64::max);
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| worst(&against_joint[a]).total_cmp(&worst(&against_joint[b])));
    let mut core: Vec<usize> = order[..n.div_ceil(2).max(2)].to_vec();
    core.sort_unstable();
    let core_model = core_identifier.identify(c, &core);
    // Glitches are judged against the core model only.
    let (shares, glitch_check) = match &core_model {
        Ok(model) => (misfits(c, model, true), true),
        Err(_) => (against_joint, false),
    };
    let median = records::consistency::median;
    // Medians and spreads over every hit (robust to a minority of odd ones);
    // the core only provides the uncontaminated model.
    let column =
        |j: usize, g: fn(&Misfit) -> f64| -> Vec<f64> { shares.iter().map(|s| g(&s[j])).collect() };
    let medians: Vec<f64> = (0..m).map(|j| median(&column(j, |s| s.share))).collect();
    // Gains: median and robust spread (1.4826 MAD) over the core, per output.
    let gains: Vec<(f64, f64)> = (0..m)
        .map(|j| {
            let g = column(j, |s| s.gain);
            let med = median(&g);
            let dev: Vec<f64> = g.iter().map(|x| (x - med).abs()).collect();
            (med, 1.4826 * median(&dev))
        })
        .collect();
    let judged = n;
    let glitch_medians: Vec<f64> = (0..m).map(|j| median(&column(j, |s| s.glitch.1))).collect();
    let mut flags = Vec::new();
    for (k, share) in shares.iter().enumerate() {
        if glitch_check
            && let Some(j) = (0..m).find(|&j| {
                share[j].glitch.1 > settings.glitch_sigmas
                    && share[j].glitch.1 > settings.glitch_factor * glitch_medians[j]
                    && share[j].glitch_of_peak > settings.glitch_floor
            })
        {
            let (at, z) = share[j].glitch;
            flags.push(ConsistencyFlag {
                record: index[k],
                file: c.label(k),
                channel: Some(c.outputs[j].clone()),
                kind: Inconsistency::Spike,
                message: format!(
                    "{} departs from the model of the hits that agree best by {} robust deviations of the channel's misfit, {}x the median largest departure over the {n} hits (limits {} and {}x): a single-sample glitch",
                    locate.sample(index[k], &c.outputs[j], at),
                    sig(z, 3),
                    sig(z / glitch_medians[j].max(f64::MIN_POSITIVE), 3),
                    sig(settings.glitch_sigmas, 3),
                    sig(settings.glitch_factor, 3)
                ),
            });
            continue;
        }
        for j in 0..m {
            let (r, g, med) = (share[j].share, share[j].gain, medians[j]);
            let (g_med, g_sd) = gains[j];
            let off = (g - g_med).abs();
            if g_med > 0.0
                && off > settings.transfer_floor * g_med
                && off > settings.transfer_sigmas * g_sd
            {
                flags.push(ConsistencyFlag {
                    record: index[k],
                    file: c.label(k),
                    channel: Some(c.outputs[j].clone()),
                    kind: Inconsistency::Transfer,
                    message: format!(
                        "its gain from {} is {} times the median gain over the {judged} hits against the model of the hits that agree best ({} robust deviations; limits {} % and {}): a calibration, sign or set-up change in this hit",
                        c.inputs.join(", "),
                        sig(g / g_med, 4),
                        sig(off / g_sd.max(f64::MIN_POSITIVE), 3),
                        sig(100.0 * settings.transfer_floor, 3),
                        sig(settings.transfer_sigmas, 3)
                    ),
                });
                break;
            }
            if r > settings.residual_factor * med && r > settings.residual_floor {
                flags.push(ConsistencyFlag {
                    record: index[k],
                    file: c.label(k),
                    channel: Some(c.outputs[j].clone()),
                    kind: Inconsistency::Residual,
                    message: format!(
                        "does not follow the model of the other hits: residual {} % of the predicted response energy, {}x the median {} % over the {judged} hits against the model of the hits that agree best (limits {}x and {} %): its transfer from {} differs (gain, sign, delay, sensor moved or swapped, a changed set-up?)",
                        sig(100.0 * r, 3),
                        sig(r / med.max(f64::MIN_POSITIVE), 3),
                        sig(100.0 * med, 3),
                        sig(settings.residual_factor, 3),
                        sig(100.0 * settings.residual_floor, 3),
                        c.inputs.join(", ")
                    ),
                });
                break;
            }
        }
    }
    flags
}

/// What a refinement's result says that its numbers alone do not: an
/// optimizer that stopped without converging (the estimates are not the
/// maximum-likelihood ones), fewer oscillatory modes than floors (an
/// overdamped pair of poles: from a poor start, a local minimum) and a
/// negative damping ratio (a pole in the right half-plane, an unstable model
/// no passive structure has: that mode's damping is not determined to its
/// sign). Also a noise alternation that stopped at its update limit while
/// the levels still moved (`noise`: updates done and the last relative
/// change): the weights, and so the estimate and its standard errors, are not
/// those of its fixed point. The FRF route's refinement warns of the last
/// three alike.
fn refinement_warnings(
    stop: ident::refine::StopReason,
    (noise_updates, noise_change): (usize, f64),
    modes: &[ident::refine::ModalEstimate],
    floors: usize,
) -> Vec<String> {
    let mut out = Vec::new();
    if !stop.converged() {
        out.push(format!(
            "--refine: the optimizer stopped without converging ({stop:?}): the refined M, K and damping are not the maximum-likelihood estimates"
        ));
    }
    if noise_change >= ident::refine::NOISE_CHANGE_TOLERANCE {
        out.push(format!(
            "--refine: the noise levels still changed by {} (relative) at the last of {noise_updates} re-estimations (settled below {}): the weights, and so the refined values and their standard errors, are not yet those of the noise fit's fixed point",
            records::numfmt::sig(noise_change, 2),
            ident::refine::NOISE_CHANGE_TOLERANCE
        ));
    }
    if modes.len() < floors {
        out.push(format!(
            "--refine: the refined model has {} oscillatory modes for {floors} floors (an overdamped pair of poles): a local minimum from a poor start",
            modes.len()
        ));
    }
    for (j, m) in modes.iter().enumerate() {
        if m.damping_ratio < 0.0 {
            out.push(format!(
                "--refine: refined mode {} ({} Hz) has a negative damping ratio {} (standard error {}): an unstable model, no use for simulation; the data do not determine that mode's damping to its sign",
                j + 1,
                records::numfmt::sig(m.frequency_hz, 4),
                records::numfmt::sig(m.damping_ratio, 3),
                records::numfmt::sig(m.damping_ratio_std, 2)
            ));
        }
    }
    out
}

/// Maximum-likelihood M, K and damping from all hits, started from MKR's M
/// and K with the Rayleigh damping.
fn refine(
    parametrization: ParametrizationSetting,
    c: &Campaign,
    result: &Identification,
    id: &Identifier,
) -> Result<Refinement, AnalysisError> {
    if c.inputs.len() != 1 {
        return Err(AnalysisError::RefineInputs {
            inputs: c.inputs.clone(),
        });
    }
    Refiner::default()
        .parametrization(parametrization.parametrization(c.outputs.len()))
        .intersample(id.intersample)
        .input_dofs(vec![id.collocated.output])
        .refine(
            &c.records,
            c.dt_s,
            &SecondOrder::from_identification(result),
        )
        .map_err(|error| AnalysisError::Refinement { error })
}

/// The hits `keep` of `campaign`: the campaign itself when that is all of
/// them (a long record is not copied).
fn subset<'a>(campaign: &'a Campaign, keep: &[usize]) -> Cow<'a, Campaign> {
    if keep.iter().copied().eq(0..campaign.len()) {
        Cow::Borrowed(campaign)
    } else {
        Cow::Owned(campaign.subset(keep))
    }
}

/// `campaign` decimated as `settings.decimation` says, the factor chosen
/// from `kept` (the hits kept, as read); `campaign` itself (not a copy)
/// when the factor is 1.
fn decimate_campaign<'a>(
    campaign: &'a Campaign,
    kept: &Campaign,
    continuous: bool,
    settings: &AnalysisSettings,
) -> (Cow<'a, Campaign>, Decimation) {
    let (factor, peaks_hz, reason) = crate::decimate::choose(
        kept,
        continuous,
        settings.decimation,
        &settings.identifier.modes,
    );
    let (out, filter, half) = if factor > 1 {
        let (out, filter, half) = crate::decimate::decimate(campaign, factor);
        (Cow::Owned(out), filter, half)
    } else {
        (Cow::Borrowed(campaign), None, 0)
    };
    let n = |c: &Campaign| c.records.first().map_or(0, ident::Record::len);
    let dropped_end_samples = if factor > 1 {
        n(campaign).saturating_sub((n(&out).saturating_sub(1)) * factor + 1)
    } else {
        0
    };
    let decimation = Decimation {
        factor,
        original_rate_hz: 1.0 / campaign.dt_s,
        rate_hz: 1.0 / out.dt_s,
        chosen: if settings.decimation == DecimationSetting::Auto {
            "auto"
        } else {
            "given"
        },
        highest_mode_hz: peaks_hz.last().copied(),
        peaks_hz,
        filter,
        dropped_end_samples,
        settling_samples: if factor > 1 { half.div_ceil(factor) } else { 0 },
        reason,
    };
    (out, decimation)
}

/// Output `j` of record `r` less the model's prediction `p` (outputs x samples) with
/// the input polarity `sign`.
fn output_residual(r: &ident::Record, p: &DMatrix<f64>, sign: f64, j: usize) -> Vec<f64> {
    r.outputs
        .row(j)
        .iter()
        .zip(p.row(j).iter())
        .map(|(y, q)| y - sign * q)
        .collect()
}

/// Every record of `c` without its first `cut` samples.
fn cut_start(c: &Campaign, cut: usize) -> Campaign {
    let records = c
        .records
        .iter()
        .map(|r| {
            let keep = r.len().saturating_sub(cut);
            let from = r.len() - keep;
            ident::Record::new(
                r.inputs.columns(from, keep).into_owned(),
                r.outputs.columns(from, keep).into_owned(),
            )
        })
        .collect();
    Campaign::named(
        records,
        c.dt_s,
        c.inputs.clone(),
        c.outputs.clone(),
        c.labels.clone(),
    )
}

/// Sample positions of a decimated campaign, cut at the start, named by
/// the place of the sample they were computed at in the records as read.
struct Resampled<'a> {
    inner: &'a dyn Locate,
    factor: usize,
    offset: usize,
}

impl Locate for Resampled<'_> {
    fn sample(&self, record: usize, channel: &str, sample: usize) -> String {
        self.inner
            .sample(record, channel, (sample + self.offset) * self.factor)
    }
}

/// RMS of `x`.
fn rms(x: &[f64]) -> f64 {
    if x.is_empty() {
        0.0
    } else {
        (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt()
    }
}

/// For each record of `c`: its misfit to `model` (simulated from rest)
/// over the first eighth of the record over that over the last eighth,
/// largest over the outputs.
fn start_misfit_ratios(c: &Campaign, model: &Identification) -> Vec<Option<f64>> {
    let sign = if model.polarity_flipped { -1.0 } else { 1.0 };
    c.records
        .iter()
        .map(|r| {
            let n = r.len();
            let w = n / 8;
            if w < 8 {
                return None;
            }
            let p = model.realization.simulate(&r.inputs);
            (0..r.outputs.nrows())
                .filter_map(|j| {
                    let e = output_residual(r, &p, sign, j);
                    let end = rms(&e[n - w..]);
                    (end > 0.0).then(|| rms(&e[..w]) / end)
                })
                .max_by(f64::total_cmp)
        })
        .collect()
}

/// What to assume about the initial state of the hits `keep` of `c`, and
/// how many samples to cut at the start of every record (`settling`, the
/// decimation filter's, when not at rest). `None` when nothing was judged:
/// hammer records under `auto` (their pre-trigger is checked by the SNR
/// check).
fn initial_state(
    c: &Campaign,
    keep: &[usize],
    hit_quality: &[HitQuality],
    id: &Identifier,
    settling: usize,
    setting: InitialStateSetting,
    max_initial_motion: f64,
) -> (Option<InitialStateReport>, usize) {
    use ident::InitialState;
    let continuous: Vec<usize> = keep
        .iter()
        .copied()
        .filter(|&i| hit_quality[i].excitation == Excitation::Continuous)
        .collect();
    let pre = |i: usize| hit_quality[i].initial_motion.as_ref().and_then(|m| m.ratio);
    let moving = |i: usize| {
        hit_quality[i]
            .flags
            .iter()
            .any(|f| f.check == Check::NotAtRest)
    };
    let unknown_report = |chosen, records: Vec<RecordRest>, reason: String| {
        let skipped = id
            .clone()
            .initial_state(InitialState::Unknown)
            .check()
            .map_or(0, |v| v.okid.skipped_equations());
        (
            Some(InitialStateReport {
                assumed: InitialState::Unknown,
                chosen,
                skipped_equations: skipped,
                cut_samples: settling,
                records,
                reason,
            }),
            settling,
        )
    };
    let cut_note = if settling > 0 {
        format!(
            " and cut the first {settling} samples of every record (where the decimation filter assumed rest before the record)"
        )
    } else {
        String::new()
    };
    match setting {
        InitialStateSetting::AtRest => (
            Some(InitialStateReport {
                assumed: InitialState::AtRest,
                chosen: "given",
                skipped_equations: 0,
                cut_samples: 0,
                records: Vec::new(),
                reason: "--initial-state at-rest".into(),
            }),
            0,
        ),
        InitialStateSetting::Unknown => unknown_report(
            "given",
            Vec::new(),
            format!(
                "--initial-state unknown: OKID formed no equations for the first samples of every record{cut_note}"
            ),
        ),
        InitialStateSetting::Auto if continuous.is_empty() => (None, 0),
        InitialStateSetting::Auto => {
            // The records alone first (outputs moving before the force
            // starts), then the misfit of a model identified from rest.
            let mut records: Vec<RecordRest> = continuous
                .iter()
                .map(|&i| RecordRest {
                    file: hit_quality[i].file.clone(),
                    pre_excitation_ratio: pre(i),
                    start_misfit_ratio: None,
                    at_rest: !moving(i),
                })
                .collect();
            let kept = c.subset(keep);
            if let Ok(model) = id.identify(&kept.records, kept.dt_s) {
                let ratios = start_misfit_ratios(&kept, &model);
                for (rest, &i) in records.iter_mut().zip(&continuous) {
                    let k = keep.iter().position(|&j| j == i).expect("a kept hit");
                    rest.start_misfit_ratio = ratios[k];
                    if ratios[k].is_some_and(|r| r > START_MISFIT_FACTOR) {
                        rest.at_rest = false;
                    }
                }
            }
            let moving: Vec<String> = records
                .iter()
                .zip(&continuous)
                .filter(|(r, _)| !r.at_rest)
                .map(|(r, &i)| {
                    let mut why = Vec::new();
                    if moving(i)
                        && let Some(p) = r.pre_excitation_ratio
                    {
                        why.push(format!("motion before the force {}", sig(p, 3)));
                    }
                    if let Some(m) = r.start_misfit_ratio
                        && m > START_MISFIT_FACTOR
                    {
                        why.push(format!("start misfit {}x", sig(m, 3)));
                    }
                    format!("{} ({})", r.file, why.join(", "))
                })
                .collect();
            if moving.is_empty() {
                (
                    Some(InitialStateReport {
                        assumed: InitialState::AtRest,
                        chosen: "auto",
                        skipped_equations: 0,
                        cut_samples: 0,
                        records,
                        reason: format!(
                            "the {} continuous record(s) start at rest",
                            continuous.len()
                        ),
                    }),
                    0,
                )
            } else {
                let n = moving.len();
                unknown_report(
                    "auto",
                    records,
                    format!(
                        "{n} of {} continuous record(s) do not start at rest: {} (motion before the force: outputs' RMS before the force starts over their RMS, limit {}; start misfit: misfit to a model identified from rest over the first eighth of the record over that over the last, limit {START_MISFIT_FACTOR}); identified with an unknown initial state: OKID formed no equations for the first samples of every record (the observer forgets the initial state within its order){cut_note}",
                        continuous.len(),
                        moving.join(", "),
                        sig(max_initial_motion, 3)
                    ),
                )
            }
        }
    }
}

/// One warning line per failed check (and note), naming the file.
pub fn quality_warnings(hits: &[HitQuality]) -> Vec<String> {
    hits.iter()
        .flat_map(|q| q.flags.iter().map(move |f| format!("{}: {f}", q.file)))
        .collect()
}

/// The hits to identify (indices). Refuses hits without a pulse (unless
/// they are dropped), and when strict any hit that fails a check; when
/// dropping keeps only the hits that pass.
fn screen_hits(hits: &[HitQuality], screening: Screening) -> Result<Vec<usize>, AnalysisError> {
    let describe = |q: &HitQuality| -> String {
        q.flags
            .iter()
            .filter(|f| f.check.fails_hit())
            .map(|f| format!("  {}: {f}", q.file))
            .collect::<Vec<_>>()
            .join("\n")
    };
    let fatal: Vec<&HitQuality> = hits.iter().filter(|q| q.fatal()).collect();
    if !fatal.is_empty() && screening != Screening::DropBad {
        let lines: Vec<String> = fatal
            .iter()
            .flat_map(|q| {
                q.flags
                    .iter()
                    .filter(|f| f.check.is_fatal())
                    .map(|f| format!("{}: {f}", q.file))
            })
            .collect();
        return Err(AnalysisError::NoHit { lines });
    }
    let failing: Vec<&HitQuality> = hits.iter().filter(|q| !q.passed()).collect();
    if screening == Screening::Strict && !failing.is_empty() {
        return Err(AnalysisError::Strict {
            failing: failing.len(),
            hits: hits.len(),
            lines: failing.iter().map(|q| describe(q)).collect(),
        });
    }
    if screening == Screening::DropBad {
        let keep: Vec<usize> = (0..hits.len()).filter(|&i| hits[i].passed()).collect();
        if keep.is_empty() {
            return Err(AnalysisError::AllDropped {
                hits: hits.len(),
                lines: failing.iter().map(|q| describe(q)).collect(),
            });
        }
        return Ok(keep);
    }
    Ok((0..hits.len()).collect())
}

/// Refuses output selections and orders that cannot give one mode per
/// output before running the identification.
fn check_orders(c: &Campaign, id: &Identifier) -> Result<(), AnalysisError> {
    let m = c.outputs.len();
    if m < 2 {
        return Err(AnalysisError::TooFewOutputs {
            outputs: c.outputs.clone(),
        });
    }
    if let ModelOrder::Fixed(n) = id.order
        && n < 2 * m
    {
        return Err(AnalysisError::OrderTooSmall {
            order: n,
            outputs: c.outputs.clone(),
        });
    }
    Ok(())
}

/// Under `--strict`: the records showing more structural modes than there
/// are outputs means
/// fewer outputs than degrees of freedom: MKR would build a model with the
/// wrong number of floors.
fn check_modes_against_outputs(r: &Identification, c: &Campaign) -> Result<(), AnalysisError> {
    for w in &r.warnings {
        if let ident::Warning::ExtraStructuralModes {
            kept_hz,
            dropped_hz,
        } = w
        {
            let mut all: Vec<f64> = kept_hz.iter().chain(dropped_hz).copied().collect();
            all.sort_by(f64::total_cmp);
            return Err(AnalysisError::FewerOutputsThanModes {
                records: c.describe(),
                modes_hz: all,
                outputs: c.outputs.clone(),
            });
        }
    }
    Ok(())
}

/// An identification error with the files, channels and settings named.
fn identification_error(e: ident::Error, c: &Campaign, id: &Identifier) -> AnalysisError {
    use ident::{Channel, DataError, EraError, MkrError, OkidError};
    let file = |i: usize| c.label(i);
    let channel = |ch: Channel| match ch {
        Channel::Input(i) => format!("input '{}'", c.inputs[i]),
        Channel::Output(i) => format!("output '{}'", c.outputs[i]),
    };
    let fixed_order = match id.order {
        ModelOrder::Fixed(n) => Some(n),
        ModelOrder::Auto { .. } => None,
    };
    let orders = || {
        let mut v = Vec::new();
        if let Some(n) = fixed_order {
            v.push(format!("--order {n}"));
        }
        if let ObserverOrder::Fixed(p) = id.observer_order {
            v.push(format!("--observer-order {p}"));
        }
        if v.is_empty() {
            "the automatic orders".to_string()
        } else {
            v.join(" and ")
        }
    };
    let message = match &e {
        ident::Error::Data(DataError::TooShort {
            record,
            samples,
            required,
            reason,
        }) => format!(
            "{}: too short for {}: {samples} samples, {required} are needed ({reason}); record longer or lower the orders",
            file(*record),
            orders()
        ),
        ident::Error::Okid(OkidError::Underdetermined {
            equations,
            unknowns,
        }) => format!(
            "{}: too short for {}: {} hit(s) of {} samples give OKID {equations} equations for {unknowns} unknowns; record longer or lower --observer-order",
            c.describe(),
            orders(),
            c.len(),
            c.records.first().map_or(0, ident::Record::len)
        ),
        ident::Error::Data(DataError::NoExcitation { record }) => format!(
            "{}: no hit: every sample of the force is zero",
            file(*record)
        ),
        ident::Error::Data(DataError::DeadChannel { channel: ch }) => format!(
            "{}: {} is zero in every record (a dead or disconnected sensor)",
            c.describe(),
            channel(*ch)
        ),
        ident::Error::Data(DataError::NonFinite {
            record,
            channel: ch,
            sample,
            value,
        }) => format!(
            "{}: {}, sample {sample} is not finite ({value})",
            file(*record),
            channel(*ch)
        ),
        ident::Error::Era(EraError::OrderTooLarge { order, max }) if fixed_order.is_some() => {
            format!(
                "--order {order}: larger than the largest order {max} that {} supports; lower it (or leave it out)",
                c.describe()
            )
        }
        ident::Error::Era(EraError::RankDeficient { order, rank }) if fixed_order.is_some() => {
            format!(
                "--order {order}: the Hankel matrix of {} has rank {rank} only, the records do not support that order; use --order {} or less (or leave it out)",
                c.describe(),
                rank - rank % 2
            )
        }
        ident::Error::Mkr(MkrError::InconsistentPolarity { imaginary_parts }) => {
            let parts: Vec<String> = imaginary_parts.iter().map(|v| format!("{v:.3e}")).collect();
            format!(
                "{}: input '{}' is not collocated with output '{}': the driving-point residues of the modes have mixed signs ({}), which a force and an accelerometer at the same floor cannot give. Name the accelerometer at the hit floor with --collocated OUT:IN (outputs: {})",
                c.describe(),
                c.inputs[id.collocated.input],
                c.outputs[id.collocated.output],
                parts.join(", "),
                c.outputs.join(", ")
            )
        }
        other => format!("identification of {} failed: {other}", c.describe()),
    };
    AnalysisError::Identification { message, error: e }
}

/// An identification warning with record indices replaced by labels.
fn ident_warning(w: &ident::Warning, c: &Campaign) -> String {
    match w {
        ident::Warning::ShortPretrigger {
            record,
            peak_sample,
            recommended,
        } => format!(
            "{}: the hit is at sample {peak_sample}, less than {recommended} samples after the record start; the band-limited precursor before the record is neglected",
            c.label(*record)
        ),
        other => other.to_string(),
    }
}

/// The identifier of a campaign's settings: the intersample assumption, the
/// collocated pair (output, input) and the orders (`None`: automatic).
pub fn identifier(
    intersample: ident::Intersample,
    collocated: (usize, usize),
    order: Option<usize>,
    observer_order: Option<usize>,
) -> Identifier {
    let mut id = Identifier::default()
        .intersample(intersample)
        .collocated(collocated.0, collocated.1);
    if let Some(n) = order {
        id = id.order(ModelOrder::Fixed(n));
    }
    if let Some(p) = observer_order {
        id = id.observer_order(ObserverOrder::Fixed(p));
    }
    id
}

/// The mass matrix with known sensor masses taken off its diagonal: an
/// accelerometer of mass `s_i` on floor `i` adds `s_i` to that floor's
/// lumped mass, so the structure's own is `M - diag(s)` (K and the damping
/// are the structure's either way). `sensor_mass_kg` holds one mass per
/// DOF, or one for every DOF. Refuses a count that fits neither, a mass
/// that is negative or not finite, and a result whose diagonal is not
/// positive (a sensor heavier than its floor is not a sensor of it).
pub fn subtract_sensor_masses(
    mass: &DMatrix<f64>,
    sensor_mass_kg: &[f64],
) -> Result<DMatrix<f64>, String> {
    let n = mass.nrows();
    let per_dof: Vec<f64> = match sensor_mass_kg.len() {
        1 => vec![sensor_mass_kg[0]; n],
        k if k == n => sensor_mass_kg.to_vec(),
        k => {
            return Err(format!(
                "{k} sensor masses for {n} floors: give one per floor (DOF order) or one for all"
            ));
        }
    };
    let mut out = mass.clone();
    for (i, &s) in per_dof.iter().enumerate() {
        if !(s.is_finite() && s >= 0.0) {
            return Err(format!(
                "sensor mass {} (floor {}) must be a mass in kg, finite and not negative, got {s}",
                i + 1,
                i + 1
            ));
        }
        out[(i, i)] -= s;
        if out[(i, i)] <= 0.0 {
            return Err(format!(
                "sensor mass {s} kg on floor {} is not below the identified floor mass M{}{} = {} kg",
                i + 1,
                i + 1,
                i + 1,
                sig(mass[(i, i)], 5)
            ));
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use ident::refine::{ModalEstimate, StopReason};
    use nalgebra::DVector;

    fn mode(frequency_hz: f64, damping_ratio: f64) -> ModalEstimate {
        ModalEstimate {
            frequency_hz,
            frequency_std_hz: 1e-3,
            damping_ratio,
            damping_ratio_std: 3e-4,
            pole: ident::linalg::C64::new(0.0, 1.0),
            shape: DVector::zeros(2),
            shape_std_re: DVector::zeros(2),
            shape_std_im: DVector::zeros(2),
        }
    }

    #[test]
    fn a_refinement_that_is_no_maximum_likelihood_estimate_is_named() {
        // Converged, two stable modes for two floors: nothing to say.
        let good = [mode(2.7, 5e-3), mode(9.2, 2e-3)];
        assert!(refinement_warnings(StopReason::Cost, (2, 0.05), &good, 2).is_empty());
        // Not converged, one mode for two floors, that mode unstable: three warnings.
        let w = refinement_warnings(StopReason::MaxIterations, (2, 0.05), &[mode(2.7, -2e-4)], 2);
        assert_eq!(w.len(), 3, "{w:?}");
        assert!(
            w[0].contains("stopped without converging (MaxIterations)"),
            "{}",
            w[0]
        );
        assert!(
            w[1].contains("1 oscillatory modes for 2 floors"),
            "{}",
            w[1]
        );
        assert!(
            w[2].contains("refined mode 1 (2.700 Hz) has a negative damping ratio -2.00e-4"),
            "{}",
            w[2]
        );
        // Noise levels still moving by 30 % at the last of four updates: named; by exactly
        // the tolerance too (it settles below it).
        for change in [0.3, ident::refine::NOISE_CHANGE_TOLERANCE] {
            let w = refinement_warnings(StopReason::Cost, (4, change), &good, 2);
            assert_eq!(w.len(), 1, "{w:?}");
            assert!(
                w[0].contains("at the last of 4 re-estimations (settled below 0.1)"),
                "{}",
                w[0]
            );
        }
    }
}
