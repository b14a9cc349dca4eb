//! `frameid frf`: records to FRFs with coherence, written as UFF58 and CSV
//! with a summary of what was done (`frf.json`).

use std::io::Write;

use anyhow::{Context, Result, bail};
use ident::frf::estimate::{Estimator, ExponentialWindow, ForceWindow};
use records::consistency::ByLine;
use records::frf::{FrfFile, FrfFormat, write_frf};
use study::analysis::{AnalysisSettings, Screening};
use study::frfs::{AveragingChoice, FrfSettings, estimate_frfs};

use crate::cli::{AveragingArg, EstimatorArg, FrfArgs, FrfFormatArg};
use crate::commands::identify::{load_campaign, parse_band, parse_collocated};

/// The file name and layout of each `--format`.
fn layout(f: FrfFormatArg) -> (&'static str, FrfFormat) {
    match f {
        FrfFormatArg::Uff => ("frf.uff", FrfFormat::Uff58Ascii),
        FrfFormatArg::UffBinary => ("frf.uffb", FrfFormat::Uff58Binary),
        FrfFormatArg::Csv => ("frf.csv", FrfFormat::Csv),
    }
}

/// Checks the numeric flags before any file is read.
fn settings(args: &FrfArgs) -> Result<FrfSettings> {
    if args.segment == Some(0) {
        bail!("--segment: must be at least 1 sample");
    }
    if let Some(s) = args.force_window
        && !(s.is_finite() && s > 0.0)
    {
        bail!("--force-window: must be a positive time in seconds, got {s}");
    }
    if let Some(a) = args.exponential_window
        && !(a > 0.0 && a < 1.0)
    {
        bail!(
            "--exponential-window: the amplitude left at the end of the record must be between 0 and 1 (e.g. 0.01), got {a}"
        );
    }
    if args.format.is_empty() {
        bail!("--format: give at least one of uff, uff-binary, csv");
    }
    Ok(FrfSettings {
        estimator: match args.estimator {
            EstimatorArg::H1 => Estimator::H1,
            EstimatorArg::H2 => Estimator::H2,
            EstimatorArg::Hv => Estimator::Hv,
        },
        averaging: match args.averaging {
            AveragingArg::Auto if args.segment.is_some() => AveragingChoice::Welch(args.segment),
            AveragingArg::Auto => AveragingChoice::Auto,
            AveragingArg::Hits => AveragingChoice::Hits,
            AveragingArg::Welch => AveragingChoice::Welch(args.segment),
        },
        force_window: args.force_window.map(|s| ForceWindow {
            before_peak_s: s,
            after_peak_s: s,
            taper_s: s,
        }),
        exponential_window: args.exponential_window.map(ExponentialWindow::EndAmplitude),
        band_hz: args
            .band
            .as_deref()
            .map(|b| parse_band("--band", b))
            .transpose()?,
        analysis: AnalysisSettings {
            screening: if args.strict {
                Screening::Strict
            } else {
                Screening::Warn
            },
            quality: records::quality::QualitySettings {
                excitation: args.excitation,
                ..Default::default()
            },
            uncertainty: false,
            ..AnalysisSettings::default()
        },
    })
}

/// Runs the command, saying on `out` what was written.
pub fn run(args: &FrfArgs, out: &mut dyn Write) -> Result<()> {
    let mut settings = settings(args)?;
    let (files, campaign) = load_campaign(&args.select, &args.files)?;
    let collocated = match &args.collocated {
        Some(text) => parse_collocated(text, &campaign.outputs, &campaign.inputs)?,
        None => (0, 0),
    };
    settings.analysis.identifier = settings
        .analysis
        .identifier
        .clone()
        .collocated(collocated.0, collocated.1);
    let outcome = estimate_frfs(&campaign, &ByLine(&files), &settings)?;

    let (responses, references) =
        study::export::record_points(&files, &outcome.campaign, collocated);
    let dir = fsio::OutputDir::create(&args.out, "frf.json")?;
    let mut written = Vec::new();
    for &f in &args.format {
        let (name, format) = layout(f);
        let path = dir.path().join(name);
        let mut file = FrfFile::from_frf(&path, &outcome.estimate.frf, &responses, &references);
        for pair in &mut file.pairs {
            pair.exponential_tau_s = outcome.estimate.windows.exponential_tau_s;
        }
        write_frf(&path, &file, format)?;
        written.push(name.to_string());
    }
    let summary = study::frfs::FrfSummary::new(&outcome, &args.files, written);
    study::write_json(&dir.path().join("frf.json"), &summary)?;
    let target = dir
        .commit()
        .with_context(|| format!("--out {}", args.out.display()))?;
    let text = if args.json {
        let mut t = serde_json::to_string_pretty(&summary)?;
        t.push('\n');
        t
    } else {
        crate::output::frf_summary_text(&summary, &target)
    };
    out.write_all(text.as_bytes())?;
    Ok(())
}
