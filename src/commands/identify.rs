//! `frameid identify`: records (or a published realization) to modal
//! parameters and M, K, R, as readable tables or JSON.

use std::io::Write;

use anyhow::{Context, Result, anyhow, bail};
use records::consistency::ByLine;
use records::{ChannelSpec, ReadOptions, RecordFile};
use study::analysis::{AnalysisSettings, Screening, analyze_located, identifier};

use crate::cli::{IdentifyArgs, SelectArgs};
use crate::output::Human as _;
use study::document::{Collocated, IdentifyReport, Source};

/// Parses a comma-separated list of channel selectors given to `flag`.
fn parse_specs(flag: &str, list: &str) -> Result<Vec<ChannelSpec>> {
    list.split(',')
        .map(|s| s.parse::<ChannelSpec>().with_context(|| flag.to_string()))
        .collect()
}

/// Parses `OUT:IN` with zero-based indices or channel names.
pub(crate) fn parse_collocated(
    text: &str,
    outputs: &[String],
    inputs: &[String],
) -> Result<(usize, usize)> {
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

/// A frequency in Hz given to `flag`: finite, not negative.
fn frequency(flag: &str, t: &str) -> Result<f64> {
    let v: f64 = t
        .trim()
        .parse()
        .map_err(|_| anyhow!("{flag}: '{}' is not a number (Hz)", t.trim()))?;
    if !(v.is_finite() && v >= 0.0) {
        bail!("{flag}: {v} is not a frequency in Hz (finite, not negative)");
    }
    Ok(v)
}

/// `LOW:HIGH` in Hz given to `flag`, low below high.
pub(crate) fn parse_band(flag: &str, band: &str) -> Result<(f64, f64)> {
    let (lo, hi) = band
        .split_once(':')
        .ok_or_else(|| anyhow!("{flag}: expected LOW:HIGH in Hz (e.g. 1:12), got '{band}'"))?;
    let (low_hz, high_hz) = (frequency(flag, lo)?, frequency(flag, hi)?);
    if low_hz >= high_hz {
        bail!("{flag}: the low edge {low_hz} Hz must be below the high edge {high_hz} Hz");
    }
    Ok((low_hz, high_hz))
}

/// `--modes F1,F2,...` or `--band LOW:HIGH` (Hz) as a mode selection.
fn mode_selection(args: &IdentifyArgs) -> Result<ident::ModeSelection> {
    let number = frequency;
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
        let (low_hz, high_hz) = parse_band("--band", band)?;
        return Ok(ident::ModeSelection::Band { low_hz, high_hz });
    }
    Ok(ident::ModeSelection::Auto)
}

/// Checks the numeric flags before any file is read, so that an error
/// names the flag.
fn check_flags(args: &IdentifyArgs) -> Result<()> {
    if args.observer_order == Some(0) {
        bail!("--observer-order: must be at least 1");
    }
    Ok(())
}

/// Refuses flags of the other route: a flag that would be ignored is a
/// mistake the user should hear of.
fn check_route_flags(args: &IdentifyArgs, first: &std::path::Path, frf: bool) -> Result<()> {
    let given: Vec<&str> = if frf {
        [
            ("--observer-order", args.observer_order.is_some()),
            ("--outputs", args.select.outputs.is_some()),
            ("--fs", args.select.fs.is_some()),
            ("--drop-bad-hits", args.drop_bad_hits),
        ]
        .into_iter()
        .filter_map(|(f, on)| on.then_some(f))
        .collect()
    } else {
        [
            ("--frf-quantity", args.frf_quantity.is_some()),
            ("--frf-unit", args.frf_unit.is_some()),
            ("--reference", !args.reference.is_empty()),
            ("--responses", args.responses.is_some()),
            ("--exponential-tau", args.exponential_tau.is_some()),
        ]
        .into_iter()
        .filter_map(|(f, on)| on.then_some(f))
        .collect()
    };
    if !given.is_empty() {
        bail!(
            "{}: {} only to {}, but {} holds {}",
            given.join(", "),
            if given.len() == 1 { "applies" } else { "apply" },
            if frf { "time records" } else { "FRF files" },
            first.display(),
            if frf { "FRFs" } else { "time records" }
        );
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
        None => {
            let Some(first) = args.files.first() else {
                bail!("no record files given");
            };
            // A file that cannot be read goes to the record reader, whose
            // message names it as for every other file (and as the Python
            // package's `read_records` does).
            let frf = records::frf::read_content_kind(first)
                .is_ok_and(|kind| kind == records::frf::ContentKind::Frf);
            check_route_flags(args, first, frf)?;
            if frf {
                return identify_frfs(args, out);
            }
            identify_records(args, modes)?
        }
    };
    let mut report = report;
    if let Some(s) = &args.sensor_mass {
        let rows_to =
            |r: &Vec<Vec<f64>>| nalgebra::DMatrix::from_fn(r.len(), r.len(), |i, j| r[i][j]);
        let refined = report.refined.as_ref().map(|r| rows_to(&r.mass));
        report.without_sensors = Some(
            study::document::WithoutSensors::new(s, &rows_to(&report.mass), refined.as_ref())
                .map_err(|e| anyhow::anyhow!("--sensor-mass: {e}"))?,
        );
    }
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

/// Reads the record files and selects their channels into one campaign.
pub(crate) fn load_campaign(
    select: &SelectArgs,
    paths: &[std::path::PathBuf],
) -> Result<(Vec<RecordFile>, ident::Campaign)> {
    if let Some(fs) = select.fs
        && !(fs.is_finite() && fs > 0.0)
    {
        bail!("--fs: must be a positive sampling rate in Hz, got {fs}");
    }
    let opts = ReadOptions { fs_hz: select.fs };
    let files: Vec<RecordFile> = records::read_records(paths, &opts)?;
    let inputs = parse_specs("--input", &select.input)?;
    let outputs = select
        .outputs
        .as_deref()
        .map(|list| parse_specs("--outputs", list))
        .transpose()?;
    let campaign = records::select(&files, &inputs, outputs.as_deref())?;
    Ok((files, campaign))
}

/// Reads the record files, selects the channels and runs the analysis.
fn identify_records(args: &IdentifyArgs, modes: ident::ModeSelection) -> Result<IdentifyReport> {
    if args.files.is_empty() {
        bail!("no record files given");
    }
    let (mut files, campaign) = load_campaign(&args.select, &args.files)?;
    // The samples are in the campaign now; the files stay for what the
    // messages and the export take from them (channel names, nodes, lines,
    // sampling), so a long record's samples are not held twice.
    for channel in files.iter_mut().flat_map(|f| f.channels.iter_mut()) {
        channel.values = Vec::new();
    }
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
        decimation: args.decimate,
        initial_state: args.initial_state,
        ..AnalysisSettings::default()
    };
    let analysis = analyze_located(&campaign, &ByLine(&files), &settings)?;
    if let Some(dir) = &args.export {
        let id = &analysis.identification;
        let (responses, inputs) =
            study::export::record_points(&files, &analysis.campaign, collocated);
        let grid = {
            let n = analysis.campaign.longest();
            let df = 1.0 / (n as f64 * analysis.campaign.dt_s);
            (0..=n / 2).map(|k| k as f64 * df).collect::<Vec<f64>>()
        };
        let model = match &analysis.refinement {
            Some(r) => (&r.mass, &r.stiffness, &r.damping),
            None => (&id.mass, &id.stiffness, &id.damping_rayleigh),
        };
        study::export::write_export(
            dir,
            &responses,
            &[(inputs[collocated.1].clone(), collocated.0)],
            &id.frequencies_hz,
            &id.damping_ratios,
            &id.mode_shapes,
            model,
            &grid,
        )?;
    }
    if let Some(path) = &args.report {
        let names: Vec<String> = args.files.iter().map(|f| f.display().to_string()).collect();
        let command = std::env::args().collect::<Vec<_>>().join(" ");
        let page = study::campaign_report::time_report(&analysis, &settings, &names, &command);
        reports::render_campaign_to_file(&page, path)
            .with_context(|| format!("--report {}", path.display()))?;
    }
    Ok(IdentifyReport::from_analysis(&analysis))
}

/// A point `NAME` or `NAME@NODE:DIR` given to `flag`.
fn parse_point(flag: &str, text: &str) -> Result<records::frf::FrfPoint> {
    text.parse().map_err(|e: String| anyhow!("{flag}: {e}"))
}

/// Reads FRF files, identifies them and renders the result.
fn identify_frfs(args: &IdentifyArgs, out: &mut dyn Write) -> Result<()> {
    use study::frf_analysis::{FrfAnalysisSettings, analyze_frfs};

    if args.strict && args.drop_bad_hits {
        bail!("--strict and --drop-bad-hits cannot be used together");
    }
    if let Some(tau) = args.exponential_tau
        && !(tau.is_finite() && tau > 0.0)
    {
        bail!("--exponential-tau: must be a positive time constant in seconds, got {tau}");
    }
    let quantity = args.frf_quantity.as_deref().map(|q| match q {
        "receptance" => ident::FrfQuantity::Receptance,
        "mobility" => ident::FrfQuantity::Mobility,
        _ => ident::FrfQuantity::Accelerance,
    });
    let references = args
        .reference
        .iter()
        .map(|r| parse_point("--reference", r))
        .collect::<Result<Vec<_>>>()?;
    if references.len() > 1 && references.len() != args.files.len() {
        bail!(
            "--reference: give one for every file ({} files) or one for all, got {}",
            args.files.len(),
            references.len()
        );
    }
    let responses = args
        .responses
        .as_deref()
        .map(|list| {
            list.split(',')
                .map(|p| parse_point("--responses", p))
                .collect::<Result<Vec<_>>>()
        })
        .transpose()?;
    let set = study::frf_analysis::read_frfs(
        &args.files,
        quantity,
        args.frf_unit.as_deref(),
        &references,
        responses.as_deref(),
    )?;
    let frf = &set.frf;
    let outputs: Vec<String> = frf.outputs.clone();
    let collocated = match &args.collocated {
        Some(text) => parse_collocated(text, &outputs, &frf.references)?,
        None => set.collocated.first().map(|c| (c.output, c.input)).ok_or_else(|| {
            anyhow!(
                "no response point is at a reference point (node and direction), so the collocated pair is unknown; give it with --collocated OUT:IN (outputs: {}; references: {})",
                outputs.join(", "),
                frf.references.join(", ")
            )
        })?,
    };
    let mut identifier =
        ident::frf::FrfIdentifier::default().collocated(collocated.0, collocated.1);
    if let Some(band) = &args.band {
        let (lo, hi) = parse_band("--band", band)?;
        identifier = identifier.band_hz(lo, hi);
    }
    if let Some(order) = args.order {
        identifier = identifier.order(ident::frf::FrfOrder::Fixed(order));
    }
    if let Some(list) = &args.modes {
        let frequency_hz = list
            .split(',')
            .map(|t| frequency("--modes", t))
            .collect::<Result<Vec<f64>>>()?;
        // A target names the mode within 10 % of it: modes of a frame are
        // further apart than that, a target off by more is a mistake.
        identifier = identifier.selection(ident::frf::ModeSelection::Nearest {
            frequency_hz,
            tolerance: 0.1,
        });
    }
    if frf.coherence.is_some() {
        identifier = identifier.weighting(ident::frf::Weighting::Coherence);
    }
    if let Some(tau) = args.exponential_tau.or(set.exponential_tau_s) {
        identifier = identifier.exponential_window(tau);
    }
    let reference_outputs =
        study::frf_analysis::reference_outputs(&set.responses, &set.references, collocated);
    let settings = FrfAnalysisSettings {
        identifier,
        strict: args.strict,
        uncertainty: !args.no_uncertainty,
        refine: args.refine.then_some(args.parametrization),
    };
    let analysis = analyze_frfs(frf, &reference_outputs, &settings)?;
    let point = |p: &records::frf::FrfPoint| study::document::PointReport {
        name: p.name.clone(),
        node: p.node,
        direction: p.direction,
    };
    let names: Vec<String> = args.files.iter().map(|f| f.display().to_string()).collect();
    let source = study::document::FrfSource {
        files: names.clone(),
        quantity: frf.quantity.to_string(),
        lines: frf.frequency_hz.len(),
        band_hz: [
            frf.frequency_hz[0],
            frf.frequency_hz[frf.frequency_hz.len() - 1],
        ],
        averages: frf.averages,
        coherence: frf.coherence.is_some(),
        outputs: set.responses.iter().map(point).collect(),
        references: set.references.iter().map(point).collect(),
        collocated: Collocated {
            output: collocated.0,
            input: collocated.1,
        },
    };
    let mut report = study::document::FrfIdentifyReport::new(&analysis, source);
    if let Some(s) = &args.sensor_mass {
        report.without_sensors = Some(
            study::document::WithoutSensors::new(
                s,
                &analysis.identification.mass,
                analysis.refinement.as_ref().map(|r| &r.mass),
            )
            .map_err(|e| anyhow::anyhow!("--sensor-mass: {e}"))?,
        );
    }
    if let Some(dir) = &args.export {
        let id = &analysis.identification;
        let placed: Vec<(records::frf::FrfPoint, usize)> = match &analysis.refinement {
            Some(r) => set
                .references
                .iter()
                .cloned()
                .zip(r.reference_dofs.iter().copied())
                .collect(),
            None => set
                .references
                .iter()
                .cloned()
                .zip(&reference_outputs)
                .filter_map(|(p, d)| d.map(|d| (p, d)))
                .collect(),
        };
        let model = match &analysis.refinement {
            Some(r) => (&r.mass, &r.stiffness, &r.damping),
            None => (&id.mass, &id.stiffness, &id.damping_rayleigh),
        };
        study::export::write_export(
            dir,
            &set.responses,
            &placed,
            &id.frequencies_hz,
            &id.damping_ratios,
            &id.mode_shapes,
            model,
            &frf.frequency_hz,
        )?;
    }
    if let Some(path) = &args.report {
        let command = std::env::args().collect::<Vec<_>>().join(" ");
        let dofs: Vec<Option<usize>> = match &analysis.refinement {
            Some(r) => r.reference_dofs.iter().map(|&d| Some(d)).collect(),
            None => reference_outputs.clone(),
        };
        let page =
            study::campaign_report::frf_report(&analysis, frf, &dofs, &names, collocated, &command);
        reports::render_campaign_to_file(&page, path)
            .with_context(|| format!("--report {}", path.display()))?;
    }
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
