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
        None => identify_records(args)?,
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
fn identify_records(args: &IdentifyArgs) -> Result<IdentifyReport> {
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
        ),
        screening: if args.strict {
            Screening::Strict
        } else if args.drop_bad_hits {
            Screening::DropBad
        } else {
            Screening::Warn
        },
        uncertainty: !args.no_uncertainty,
        refine: args.refine.then_some(args.parametrization),
        ..AnalysisSettings::default()
    };
    let analysis = analyze_located(&campaign, &ByLine(&files), &settings)?;
    Ok(IdentifyReport::from_analysis(&analysis))
}
