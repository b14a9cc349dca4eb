//! Identification of a campaign of records with everything around it: the
//! hit quality checks and which hits to use, the joint identification, its
//! error bars (jackknife over the hits) and the maximum-likelihood
//! refinement, with every message naming the record, channel or setting
//! concerned. This is what `frameid identify` runs on record files; its
//! outcome is rendered as text or JSON by the binary.

use ident::refine::{Refinement, Refiner, SecondOrder};
use ident::{Campaign, Identification, Identifier, Jackknife, ModelOrder, ObserverOrder};
use records::numfmt::sig;
use records::quality::{HitQuality, QualitySettings, assess_campaign};

use crate::scenario::ParametrizationSetting;

/// Which hits to identify after the quality checks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Screening {
    /// Keep every hit (failed checks are warnings); refuse hits without a
    /// pulse.
    #[default]
    Warn,
    /// Refuse the campaign if any hit fails a check (`--strict`).
    Strict,
    /// Identify without the hits that fail a check (`--drop-bad-hits`).
    DropBad,
}

/// What to run, checked before anything is identified.
#[derive(Debug, Clone, PartialEq)]
pub struct AnalysisSettings {
    /// The identifier (intersample assumption, orders, collocated pair).
    pub identifier: Identifier,
    /// Thresholds of the hit quality checks.
    pub quality: QualitySettings,
    /// What to do with hits that fail a check.
    pub screening: Screening,
    /// Error bars by the jackknife over the hits.
    pub uncertainty: bool,
    /// Maximum-likelihood refinement with this parametrization.
    pub refine: Option<ParametrizationSetting>,
}

impl Default for AnalysisSettings {
    /// What `frameid identify` does without options.
    fn default() -> Self {
        AnalysisSettings {
            identifier: Identifier::default(),
            quality: QualitySettings::default(),
            screening: Screening::Warn,
            uncertainty: true,
            refine: None,
        }
    }
}

/// The outcome of [`analyze`].
#[derive(Debug, Clone)]
pub struct Analysis {
    /// The hits identified (dropped ones left out), with their names.
    pub campaign: Campaign,
    /// The joint identification of those hits.
    pub identification: Identification,
    /// The collocated force/accelerometer pair used.
    pub collocated: ident::CollocatedPair,
    /// Quality of every hit given, dropped or not, in the order given.
    pub hit_quality: Vec<HitQuality>,
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

/// Checks every hit, screens them, identifies the hits kept jointly, and
/// adds error bars and the refinement as `settings` ask.
pub fn analyze(
    campaign: &Campaign,
    settings: &AnalysisSettings,
) -> Result<Analysis, AnalysisError> {
    let hit_quality = assess_campaign(campaign, &settings.quality);
    let keep = screen_hits(&hit_quality, settings.screening)?;
    let dropped: Vec<usize> = (0..campaign.len()).filter(|i| !keep.contains(i)).collect();
    let c = campaign.subset(&keep);
    check_orders(&c, &settings.identifier)?;
    let id = &settings.identifier;
    let result = id
        .identify(&c.records, c.dt_s)
        .map_err(|e| identification_error(e, &c, id))?;
    check_modes_against_outputs(&result, &c)?;
    let (uncertainty, uncertainty_skipped) = if settings.uncertainty {
        match ident::jackknife(id, &c, &result) {
            Ok(u) => (Some(u), None),
            Err(e) => (None, Some(e.to_string())),
        }
    } else {
        (None, Some("--no-uncertainty".to_string()))
    };
    // Warnings: the quality checks first (every hit, dropped or not), then
    // the identification's with hits named by file.
    let mut warnings = quality_warnings(&hit_quality);
    if !dropped.is_empty() {
        let reasons: Vec<String> = dropped
            .iter()
            .map(|&i| &hit_quality[i])
            .map(|q| {
                let checks: Vec<&str> = q.failed_checks().iter().map(|c| c.label()).collect();
                format!("{} ({})", q.file, checks.join(", "))
            })
            .collect();
        warnings.push(format!(
            "dropped {} of {} hits: {}",
            dropped.len(),
            hit_quality.len(),
            reasons.join("; ")
        ));
    }
    warnings.extend(result.warnings.iter().map(|w| ident_warning(w, &c)));
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
    let refinement = match settings.refine {
        Some(p) => Some(refine(p, &c, &result, id)?),
        None => None,
    };
    Ok(Analysis {
        campaign: c,
        identification: result,
        collocated: id.collocated,
        hit_quality,
        dropped,
        uncertainty,
        uncertainty_skipped,
        refinement,
        warnings,
    })
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

/// The records showing more structural modes than there are outputs means
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
