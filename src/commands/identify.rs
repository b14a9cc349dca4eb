//! `frameid identify`: records (or a published realization) to modal
//! parameters and M, K, R, as readable tables or JSON.

use std::io::Write;

use anyhow::{Context, Result, anyhow, bail};
use records::consistency::ByLine;
use records::{ChannelSpec, ReadOptions, RecordFile};
use study::analysis::{AnalysisSettings, Screening, analyze_located, identifier};

use crate::cli::IdentifyArgs;
use crate::output::{Collocated, IdentifyReport, Source};

/// Parses a comma-separated list of channel selectors given to `flag`.
fn parse_specs(flag: &str, list: &str) -> Result<Vec<ChannelSpec>> {
    list.split(',')
        .map(|s| s.parse::<ChannelSpec>().with_context(|| flag.to_string()))
        .collect()
}

/// Parses `OUT:IN` with zero-based indices or channel names.
fn parse_collocated(text: &str, outputs: &[String], inputs: &[String]) -> Result<(usize, usize)> {
    let (o, i) = text.split_once(':').ok_or_else(|| {
        anyhow!("--collocated: expected OUT:IN (e.g. 0:0 or acc1:force), got '{text}'")
    })?;
    let find = |what: &str, token: &str, names: &[String]| -> Result<usize> {
        let token = token.trim();
        if let Ok(k) = token.parse::<usize>() {
            if k < names.len() {
                return Ok(k);
            }
            bail!(
                "--collocated: {what} index {k} is out of range; there are {} {what}s (zero-based)",
                names.len()
            );
        }
        names
            .iter()
            .position(|n| n.eq_ignore_ascii_case(token))
            .ok_or_else(|| {
                anyhow!(
                    "--collocated: no {what} named '{token}'; {what}s: {}",
                    names.join(", ")
                )
            })
    };
    Ok((find("output", o, outputs)?, find("input", i, inputs)?))
}

/// `--modes F1,F2,...` or `--band LOW:HIGH` (Hz) as a mode selection.
fn mode_selection(args: &IdentifyArgs) -> Result<ident::ModeSelection> {
    let number = |flag: &str, t: &str| -> Result<f64> {
        let v: f64 = t
            .trim()
            .parse()
            .map_err(|_| anyhow!("{flag}: '{}' is not a number (Hz)", t.trim()))?;
        if !(v.is_finite() && v >= 0.0) {
            bail!("{flag}: {v} is not a frequency in Hz (finite, not negative)");
        }
        Ok(v)
    };
    if let Some(list) = &args.modes {
        let frequencies_hz = list
            .split(',')
            .map(|t| number("--modes", t))
            .collect::<Result<Vec<f64>>>()?;
        if let Some(f) = frequencies_hz.iter().find(|f| **f == 0.0) {
            bail!("--modes: {f} Hz is not a natural frequency");
        }
        return Ok(ident::ModeSelection::Near { frequencies_hz });
    }
    if let Some(band) = &args.band {
        let (lo, hi) = band
            .split_once(':')
            .ok_or_else(|| anyhow!("--band: expected LOW:HIGH in Hz (e.g. 1:12), got '{band}'"))?;
        let (low_hz, high_hz) = (number("--band", lo)?, number("--band", hi)?);
        if low_hz >= high_hz {
            bail!("--band: the low edge {low_hz} Hz must be below the high edge {high_hz} Hz");
        }
        return Ok(ident::ModeSelection::Band { low_hz, high_hz });
    }
    Ok(ident::ModeSelection::Auto)
}

/// Checks the numeric flags before any file is read, so that an error
/// names the flag.
fn check_flags(args: &IdentifyArgs) -> Result<()> {
    if let Some(fs) = args.fs
        && !(fs.is_finite() && fs > 0.0)
    {
        bail!("--fs: must be a positive sampling rate in Hz, got {fs}");
    }
    if args.observer_order == Some(0) {
        bail!("--observer-order: must be at least 1");
    }
    Ok(())
}

/// Runs the command, writing the result to `out`.
pub fn run(args: &IdentifyArgs, out: &mut dyn Write) -> Result<()> {
    check_flags(args)?;
    let modes = mode_selection(args)?;
    let report = match &args.realization {
        Some(path) => {
            let (realization, names) = records::realization::read_realization(path)?;
            let collocated = match &args.collocated {
                Some(c) => parse_collocated(c, &names.0, &names.1)?,
                None => (0, 0),
            };
            let result = identifier(
                args.intersample,
                collocated,
                args.order,
                args.observer_order,
            )
            .mode_selection(modes)
            .from_state_space(&realization)
            .with_context(|| path.display().to_string())?;
            let source = Source {
                files: vec![path.display().to_string()],
                realization: true,
                dt_s: realization.dt_s,
                hits: 0,
                samples: 0,
                inputs: names.1,
                outputs: names.0,
                collocated: Collocated {
                    output: collocated.0,
                    input: collocated.1,
                },
            };
            IdentifyReport::new(&result, source)
        }
        None => identify_records(args, modes)?,
    };
    let text = if args.json {
        let mut text = serde_json::to_string_pretty(&report)?;
        text.push('\n');
        text
    } else {
        report.human()
    };
    out.write_all(text.as_bytes())?;
    Ok(())
}

/// Reads the record files, selects the channels and runs the analysis.
fn identify_records(args: &IdentifyArgs, modes: ident::ModeSelection) -> Result<IdentifyReport> {
    if args.files.is_empty() {
        bail!("no record files given");
    }
    let opts = ReadOptions { fs_hz: args.fs };
    let files: Vec<RecordFile> = args
        .files
        .iter()
        .map(|f| records::read_record(f, &opts))
        .collect::<Result<_, _>>()?;
    let inputs = parse_specs("--input", &args.input)?;
    let outputs = args
        .outputs
        .as_deref()
        .map(|list| parse_specs("--outputs", list))
        .transpose()?;
    let campaign = records::select(&files, &inputs, outputs.as_deref())?;
    let collocated = match &args.collocated {
        Some(text) => parse_collocated(text, &campaign.outputs, &campaign.inputs)?,
        None => (0, 0),
    };
    let settings = AnalysisSettings {
        identifier: identifier(
            args.intersample,
            collocated,
            args.order,
            args.observer_order,
        )
        .mode_selection(modes),
        screening: if args.strict {
            Screening::Strict
        } else if args.drop_bad_hits {
            Screening::DropBad
        } else {
            Screening::Warn
        },
        quality: records::quality::QualitySettings {
            excitation: args.excitation,
            ..Default::default()
        },
        uncertainty: !args.no_uncertainty,
        refine: args.refine.then_some(args.parametrization),
        ..AnalysisSettings::default()
    };
    let analysis = analyze_located(&campaign, &ByLine(&files), &settings)?;
    if let Some(path) = &args.report {
        let names: Vec<String> = args.files.iter().map(|f| f.display().to_string()).collect();
        let command = std::env::args().collect::<Vec<_>>().join(" ");
        let page = study::campaign_report::time_report(&analysis, &settings, &names, &command);
        reports::render_campaign_to_file(&page, path)
            .with_context(|| format!("--report {}", path.display()))?;
    }
    Ok(IdentifyReport::from_analysis(&analysis))
}
