//! `frameid identify`: records (or a published realization) to modal
//! parameters and M, K, R, as readable tables or JSON.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, anyhow, bail};
use ident::refine::{Refinement, Refiner};
use ident::{Identification, Identifier, ModelOrder, ObserverOrder, Record};
use nalgebra::DMatrix;
use serde::Serialize;

use crate::cli::IdentifyArgs;
use crate::format::{matrix, sig};
use crate::quality::{self, HitQuality, QualitySettings};
use crate::records::{self, ChannelSpec, ReadOptions, RecordFile};
use crate::truth::rows;
use crate::uncertainty::{self, Uncertainty, matrix_table, plus_minus};

/// A campaign read from files: one [`Record`] per file.
#[derive(Debug, Clone)]
pub struct LoadedCampaign {
    pub files: Vec<PathBuf>,
    pub dt_s: f64,
    pub input_names: Vec<String>,
    pub output_names: Vec<String>,
    pub records: Vec<Record>,
}

impl LoadedCampaign {
    /// The campaign restricted to the hits `keep` (indices, in order).
    pub fn subset(&self, keep: &[usize]) -> LoadedCampaign {
        LoadedCampaign {
            files: keep.iter().map(|&i| self.files[i].clone()).collect(),
            records: keep.iter().map(|&i| self.records[i].clone()).collect(),
            ..self.clone()
        }
    }

    /// The file names as given, one per hit.
    pub fn labels(&self) -> Vec<String> {
        self.files.iter().map(|f| f.display().to_string()).collect()
    }
}

/// Reads record files and picks the input and output channels.
pub fn load_campaign(
    files: &[PathBuf],
    input: &str,
    outputs: Option<&str>,
    fs_hz: Option<f64>,
) -> Result<LoadedCampaign> {
    if files.is_empty() {
        bail!("no record files given");
    }
    let opts = ReadOptions { fs_hz };
    let recs: Vec<RecordFile> = files
        .iter()
        .map(|f| records::read_record(f, &opts))
        .collect::<Result<_, _>>()?;
    records::check_campaign(&recs)?;
    let input_specs = parse_specs("--input", input)?;
    let first = &recs[0];
    let input_idx: Vec<usize> = input_specs
        .iter()
        .map(|s| first.channel_index(s))
        .collect::<Result<_, _>>()?;
    let output_idx: Vec<usize> = match outputs {
        Some(list) => parse_specs("--outputs", list)?
            .iter()
            .map(|s| first.channel_index(s))
            .collect::<Result<_, _>>()?,
        None => (0..first.channels.len())
            .filter(|i| !input_idx.contains(i))
            .collect(),
    };
    if output_idx.is_empty() {
        bail!(
            "{}: no output channels besides the input",
            first.path.display()
        );
    }
    if let Some(i) = output_idx.iter().find(|i| input_idx.contains(i)) {
        bail!(
            "--outputs: channel '{}' is also the input",
            first.channels[*i].name
        );
    }
    // Every file must have the selected channels under the same names.
    let names = |r: &RecordFile, idx: &[usize]| -> Vec<String> {
        idx.iter().map(|&i| r.channels[i].name.clone()).collect()
    };
    let input_names = names(first, &input_idx);
    let output_names = names(first, &output_idx);
    let mut records = Vec::with_capacity(recs.len());
    for r in &recs {
        let pick = |specs: &[String]| -> Result<Vec<usize>> {
            specs
                .iter()
                .map(|n| {
                    r.channel_index(&ChannelSpec::Name(n.clone()))
                        .map_err(anyhow::Error::from)
                })
                .collect()
        };
        let ins = if std::ptr::eq(r, first) {
            input_idx.clone()
        } else {
            pick(&input_names)?
        };
        let outs = if std::ptr::eq(r, first) {
            output_idx.clone()
        } else {
            pick(&output_names)?
        };
        let n = r.len();
        let inputs = DMatrix::from_fn(ins.len(), n, |i, k| r.channels[ins[i]].values[k]);
        let outputs = DMatrix::from_fn(outs.len(), n, |i, k| r.channels[outs[i]].values[k]);
        records.push(Record::new(inputs, outputs));
    }
    Ok(LoadedCampaign {
        files: files.to_vec(),
        dt_s: first.dt_s,
        input_names,
        output_names,
        records,
    })
}

fn parse_specs(flag: &str, list: &str) -> Result<Vec<ChannelSpec>> {
    list.split(',')
        .map(|s| s.parse::<ChannelSpec>().map_err(|e| anyhow!("{flag}: {e}")))
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

/// The identifier configured from the command line.
fn identifier(args: &IdentifyArgs, collocated: (usize, usize)) -> Identifier {
    let mut id = Identifier::default()
        .intersample(args.intersample.into())
        .collocated(collocated.0, collocated.1);
    if let Some(n) = args.order {
        id = id.order(ModelOrder::Fixed(n));
    }
    if let Some(p) = args.observer_order {
        id = id.observer_order(ObserverOrder::Fixed(p));
    }
    id
}

/// Runs the command.
pub fn run(args: &IdentifyArgs) -> Result<()> {
    let report = match &args.realization {
        Some(path) => {
            let (realization, names) = read_realization(path)?;
            let collocated = match &args.collocated {
                Some(c) => parse_collocated(c, &names.0, &names.1)?,
                None => (0, 0),
            };
            let result = identifier(args, collocated)
                .from_state_space(&realization)
                .map_err(|e| anyhow!("{}: {e}", path.display()))?;
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
    if args.json {
        let mut text = serde_json::to_string_pretty(&report)?;
        text.push('\n');
        print!("{text}");
    } else {
        print!("{}", report.human());
    }
    Ok(())
}

/// Records to a report: quality checks, the hits to use, the joint
/// identification and its error bars.
fn identify_records(args: &IdentifyArgs) -> Result<IdentifyReport> {
    let all = load_campaign(&args.files, &args.input, args.outputs.as_deref(), args.fs)?;
    let collocated = match &args.collocated {
        Some(text) => parse_collocated(text, &all.output_names, &all.input_names)?,
        None => (0, 0),
    };
    let hit_quality = quality::assess_campaign(&all, &QualitySettings::default());
    let keep = screen_hits(&hit_quality, args)?;
    let dropped_idx: Vec<usize> = (0..all.records.len())
        .filter(|i| !keep.contains(i))
        .collect();
    let dropped: Vec<String> = dropped_idx
        .iter()
        .map(|&i| hit_quality[i].file.clone())
        .collect();
    let c = all.subset(&keep);
    check_orders(&c, args)?;
    let id = identifier(args, collocated);
    let result = id
        .identify(&c.records, c.dt_s)
        .map_err(|e| identification_error(e, &c, args, collocated))?;
    check_modes_against_outputs(&result, &c)?;
    let labels = c.labels();
    let (uncertainty, uncertainty_skipped) = if args.no_uncertainty {
        (None, Some("--no-uncertainty".to_string()))
    } else {
        match uncertainty::jackknife(&id, &c.records, c.dt_s, &result, &labels) {
            Ok(u) => (Some(u), None),
            Err(e) => (None, Some(e.to_string())),
        }
    };
    let source = Source {
        files: labels.clone(),
        realization: false,
        dt_s: c.dt_s,
        hits: c.records.len(),
        samples: c.records.iter().map(Record::len).max().unwrap_or(0),
        inputs: c.input_names.clone(),
        outputs: c.output_names.clone(),
        collocated: Collocated {
            output: collocated.0,
            input: collocated.1,
        },
    };
    let mut report = IdentifyReport::new(&result, source);
    // Warnings: the quality checks first (every hit, dropped or not), then
    // the identification's with hits named by file.
    let mut warnings = quality_warnings(&hit_quality);
    if !dropped.is_empty() {
        let reasons: Vec<String> = dropped_idx
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
    warnings.extend(result.warnings.iter().map(|w| ident_warning(w, &labels)));
    if let Some(u) = &uncertainty {
        for f in &u.failed {
            warnings.push(format!(
                "uncertainty: without {} the identification fails ({}); that resample is left out",
                f.left_out, f.error
            ));
        }
    } else if let Some(reason) = &uncertainty_skipped
        && !args.no_uncertainty
        && c.records.len() >= uncertainty::MIN_HITS
    {
        warnings.push(format!("no error bars: {reason}"));
    }
    report.warnings = warnings;
    report.hit_quality = hit_quality;
    report.dropped_hits = dropped;
    report.uncertainty = uncertainty;
    report.uncertainty_skipped = uncertainty_skipped;
    if args.refine {
        report.refined = Some(refine(args, &c, &result, collocated)?);
    }
    Ok(report)
}

/// `--refine`: maximum-likelihood M, K and damping from all hits, started
/// from MKR's M and K with the Rayleigh damping.
fn refine(
    args: &IdentifyArgs,
    c: &LoadedCampaign,
    result: &Identification,
    collocated: (usize, usize),
) -> Result<RefinedReport> {
    if c.input_names.len() != 1 {
        bail!(
            "--refine: supports one force input, got {} ({})",
            c.input_names.len(),
            c.input_names.join(", ")
        );
    }
    let refiner = Refiner::default()
        .parametrization(args.parametrization.parametrization(c.output_names.len()))
        .intersample(args.intersample.into())
        .input_dofs(vec![collocated.0]);
    let r = refiner
        .refine(
            &c.records,
            c.dt_s,
            &crate::experiment::initial_model(result),
        )
        .map_err(|e| anyhow!("--refine: {e}"))?;
    Ok(RefinedReport::new(&r))
}

/// The maximum-likelihood refinement in the JSON output.
#[derive(Debug, Clone, Serialize)]
pub struct RefinedReport {
    pub mass: Vec<Vec<f64>>,
    pub mass_std: Vec<Vec<f64>>,
    pub stiffness: Vec<Vec<f64>>,
    pub stiffness_std: Vec<Vec<f64>>,
    pub damping: Vec<Vec<f64>>,
    pub damping_std: Vec<Vec<f64>>,
    pub modes: Vec<RefinedMode>,
    /// Estimated noise standard deviations: per output, per input.
    pub noise_outputs: Vec<f64>,
    pub noise_inputs: Vec<f64>,
    pub iterations: usize,
    /// Why the optimizer stopped (`Gradient`, `Step`, `Cost`, `MaxIterations`, `NoProgress`).
    pub stop: String,
    pub converged: bool,
    pub initial_cost: f64,
    pub cost: f64,
}

/// A mode of the refined model with standard errors (delta method).
#[derive(Debug, Clone, Serialize)]
pub struct RefinedMode {
    pub frequency_hz: f64,
    pub frequency_std_hz: f64,
    pub damping_ratio: f64,
    pub damping_ratio_std: f64,
    pub mode_shape: Vec<[f64; 2]>,
}

impl RefinedReport {
    pub fn new(r: &Refinement) -> Self {
        let u = &r.uncertainty;
        RefinedReport {
            mass: rows(&r.mass),
            mass_std: rows(&u.mass_std),
            stiffness: rows(&r.stiffness),
            stiffness_std: rows(&u.stiffness_std),
            damping: rows(&r.damping),
            damping_std: rows(&u.damping_std),
            modes: u
                .modes
                .iter()
                .map(|m| RefinedMode {
                    frequency_hz: m.frequency_hz,
                    frequency_std_hz: m.frequency_std_hz,
                    damping_ratio: m.damping_ratio,
                    damping_ratio_std: m.damping_ratio_std,
                    mode_shape: m.shape.iter().map(|z| [z.re, z.im]).collect(),
                })
                .collect(),
            noise_outputs: r.noise.outputs.clone(),
            noise_inputs: r.noise.inputs.clone(),
            iterations: r.iterations,
            stop: format!("{:?}", r.stop),
            converged: r.stop.converged(),
            initial_cost: r.initial_cost,
            cost: r.cost,
        }
    }

    /// Readable tables (value ± standard error).
    pub fn human(&self) -> String {
        let mut out = String::from("\nRefined by maximum likelihood (value ± standard error)\n");
        for m in &self.modes {
            out.push_str(&format!(
                "  f = {} Hz, xi = {} %\n",
                plus_minus(m.frequency_hz, Some(m.frequency_std_hz), 6),
                plus_minus(
                    100.0 * m.damping_ratio,
                    Some(100.0 * m.damping_ratio_std),
                    4
                )
            ));
        }
        out.push_str(&matrix_table(
            "Mass M [kg]",
            &self.mass,
            Some(&self.mass_std),
        ));
        out.push_str(&matrix_table(
            "Stiffness K [N/m]",
            &self.stiffness,
            Some(&self.stiffness_std),
        ));
        out.push_str(&matrix_table(
            "Damping [N s/m]",
            &self.damping,
            Some(&self.damping_std),
        ));
        out.push_str(&format!(
            "  noise std: outputs {}, input {}; {} iterations, stopped on {} (cost {} -> {})\n",
            self.noise_outputs
                .iter()
                .map(|x| sig(*x, 3))
                .collect::<Vec<_>>()
                .join(", "),
            self.noise_inputs
                .iter()
                .map(|x| sig(*x, 3))
                .collect::<Vec<_>>()
                .join(", "),
            self.iterations,
            self.stop,
            sig(self.initial_cost, 4),
            sig(self.cost, 4)
        ));
        out
    }
}

/// One warning line per failed check (and note), naming the file.
pub fn quality_warnings(hits: &[HitQuality]) -> Vec<String> {
    hits.iter()
        .flat_map(|q| q.flags.iter().map(move |f| format!("{}: {f}", q.file)))
        .collect()
}

/// The hits to identify (indices). Refuses hits without a pulse (unless
/// they are dropped), and with `--strict` any hit that fails a check;
/// with `--drop-bad-hits` keeps only the hits that pass.
fn screen_hits(hits: &[HitQuality], args: &IdentifyArgs) -> Result<Vec<usize>> {
    let describe = |q: &HitQuality| -> String {
        q.flags
            .iter()
            .filter(|f| f.check.fails_hit())
            .map(|f| format!("  {}: {f}", q.file))
            .collect::<Vec<_>>()
            .join("\n")
    };
    let fatal: Vec<&HitQuality> = hits.iter().filter(|q| q.fatal()).collect();
    if !fatal.is_empty() && !args.drop_bad_hits {
        let lines: Vec<String> = fatal
            .iter()
            .flat_map(|q| {
                q.flags
                    .iter()
                    .filter(|f| f.check.is_fatal())
                    .map(|f| format!("{}: {f}", q.file))
            })
            .collect();
        bail!(
            "{}\n(remove the record, or pass --drop-bad-hits to identify without it)",
            lines.join("\n")
        );
    }
    let failing: Vec<&HitQuality> = hits.iter().filter(|q| !q.passed()).collect();
    if args.strict && !failing.is_empty() {
        let lines: Vec<String> = failing.iter().map(|q| describe(q)).collect();
        bail!(
            "--strict: {} of {} hits fail the quality checks:\n{}",
            failing.len(),
            hits.len(),
            lines.join("\n")
        );
    }
    if args.drop_bad_hits {
        let keep: Vec<usize> = (0..hits.len()).filter(|&i| hits[i].passed()).collect();
        if keep.is_empty() {
            let lines: Vec<String> = failing.iter().map(|q| describe(q)).collect();
            bail!(
                "--drop-bad-hits: all {} hits fail the quality checks, none remain to identify:\n{}",
                hits.len(),
                lines.join("\n")
            );
        }
        return Ok(keep);
    }
    Ok((0..hits.len()).collect())
}

/// Refuses output selections and orders that cannot give one mode per
/// output before running the identification.
fn check_orders(c: &LoadedCampaign, args: &IdentifyArgs) -> Result<()> {
    let m = c.output_names.len();
    if m < 2 {
        bail!(
            "only {m} output selected ({}): MKR needs an accelerometer on every floor (one output per degree of freedom) and the Rayleigh fit needs at least 2 modes; select every floor's accelerometer with --outputs",
            c.output_names.join(", ")
        );
    }
    if let Some(n) = args.order
        && n < 2 * m
    {
        bail!(
            "--order {n}: a realization of order {n} has at most {} mode(s), but {m} outputs (one per degree of freedom: {}) need {m}; use --order {} or more, or leave it out",
            n / 2,
            c.output_names.join(", "),
            2 * m
        );
    }
    Ok(())
}

/// The records showing more structural modes than there are outputs means
/// fewer outputs than degrees of freedom: MKR would build a model with the
/// wrong number of floors.
fn check_modes_against_outputs(r: &Identification, c: &LoadedCampaign) -> Result<()> {
    for w in &r.warnings {
        if let ident::Warning::ExtraStructuralModes {
            kept_hz,
            dropped_hz,
        } = w
        {
            let mut all: Vec<f64> = kept_hz.iter().chain(dropped_hz).copied().collect();
            all.sort_by(f64::total_cmp);
            let list: Vec<String> = all.iter().map(|f| sig(*f, 4)).collect();
            bail!(
                "{}: the records show {} structural modes ({} Hz) but only {} outputs are selected ({}): fewer outputs than degrees of freedom. MKR needs an accelerometer on every floor; select them all with --outputs (if a mode is spurious, set the model order with --order)",
                describe_files(&c.files),
                all.len(),
                list.join(", "),
                c.output_names.len(),
                c.output_names.join(", ")
            );
        }
    }
    Ok(())
}

/// An identification error with the files, channels and flags named.
fn identification_error(
    e: ident::Error,
    c: &LoadedCampaign,
    args: &IdentifyArgs,
    collocated: (usize, usize),
) -> anyhow::Error {
    use ident::{Channel, DataError, EraError, MkrError, OkidError};
    let file = |i: usize| {
        c.files
            .get(i)
            .map_or_else(|| format!("record {i}"), |f| f.display().to_string())
    };
    let channel = |ch: Channel| match ch {
        Channel::Input(i) => format!("input '{}'", c.input_names[i]),
        Channel::Output(i) => format!("output '{}'", c.output_names[i]),
    };
    let orders = || {
        let mut v = Vec::new();
        if let Some(n) = args.order {
            v.push(format!("--order {n}"));
        }
        if let Some(p) = args.observer_order {
            v.push(format!("--observer-order {p}"));
        }
        if v.is_empty() {
            "the automatic orders".to_string()
        } else {
            v.join(" and ")
        }
    };
    match e {
        ident::Error::Data(DataError::TooShort {
            record,
            samples,
            required,
            reason,
        }) => anyhow!(
            "{}: too short for {}: {samples} samples, {required} are needed ({reason}); record longer or lower the orders",
            file(record),
            orders()
        ),
        ident::Error::Okid(OkidError::Underdetermined {
            equations,
            unknowns,
        }) => anyhow!(
            "{}: too short for {}: {} hit(s) of {} samples give OKID {equations} equations for {unknowns} unknowns; record longer or lower --observer-order",
            describe_files(&c.files),
            orders(),
            c.records.len(),
            c.records.first().map_or(0, Record::len)
        ),
        ident::Error::Data(DataError::NoExcitation { record }) => anyhow!(
            "{}: no hit: every sample of the force is zero",
            file(record)
        ),
        ident::Error::Data(DataError::DeadChannel { channel: ch }) => anyhow!(
            "{}: {} is zero in every record (a dead or disconnected sensor)",
            describe_files(&c.files),
            channel(ch)
        ),
        ident::Error::Data(DataError::NonFinite {
            record,
            channel: ch,
            sample,
            value,
        }) => anyhow!(
            "{}: {}, sample {sample} is not finite ({value})",
            file(record),
            channel(ch)
        ),
        ident::Error::Era(EraError::OrderTooLarge { order, max }) if args.order.is_some() => {
            anyhow!(
                "--order {order}: larger than the largest order {max} that {} supports; lower it (or leave it out)",
                describe_files(&c.files)
            )
        }
        ident::Error::Era(EraError::RankDeficient { order, rank }) if args.order.is_some() => {
            anyhow!(
                "--order {order}: the Hankel matrix of {} has rank {rank} only, the records do not support that order; use --order {} or less (or leave it out)",
                describe_files(&c.files),
                rank - rank % 2
            )
        }
        ident::Error::Mkr(MkrError::InconsistentPolarity { imaginary_parts }) => {
            let parts: Vec<String> = imaginary_parts.iter().map(|v| format!("{v:.3e}")).collect();
            anyhow!(
                "{}: input '{}' is not collocated with output '{}': the driving-point residues of the modes have mixed signs ({}), which a force and an accelerometer at the same floor cannot give. Name the accelerometer at the hit floor with --collocated OUT:IN (outputs: {})",
                describe_files(&c.files),
                c.input_names[collocated.1],
                c.output_names[collocated.0],
                parts.join(", "),
                c.output_names.join(", ")
            )
        }
        other => anyhow!(
            "identification of {} failed: {other}",
            describe_files(&c.files)
        ),
    }
}

/// An identification warning with record indices replaced by file names.
fn ident_warning(w: &ident::Warning, labels: &[String]) -> String {
    match w {
        ident::Warning::ShortPretrigger {
            record,
            peak_sample,
            recommended,
        } => format!(
            "{}: the hit is at sample {peak_sample}, less than {recommended} samples after the record start; the band-limited precursor before the record is neglected",
            labels
                .get(*record)
                .cloned()
                .unwrap_or_else(|| format!("record {record}"))
        ),
        other => other.to_string(),
    }
}

fn describe_files(files: &[PathBuf]) -> String {
    match files {
        [one] => one.display().to_string(),
        [first, .., last] => format!(
            "{} records ({} .. {})",
            files.len(),
            first.display(),
            last.display()
        ),
        [] => "no records".into(),
    }
}

/// Default names of a realization's outputs and inputs (`y1`.., `u1`..).
pub type ChannelNames = (Vec<String>, Vec<String>);

/// Reads a realization JSON: `dt` or `dt_s`, `A`, `B`, `C`, `D` as arrays
/// of rows. Returns the realization and default channel names.
pub fn read_realization(path: &Path) -> Result<(ident::StateSpace, ChannelNames)> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("{}: cannot read", path.display()))?;
    let value: serde_json::Value = serde_json::from_str(&text)
        .map_err(|e| anyhow!("{}: not valid JSON: {e}", path.display()))?;
    let obj = value.as_object().ok_or_else(|| {
        anyhow!(
            "{}: expected a JSON object with dt, A, B, C, D",
            path.display()
        )
    })?;
    let field = |name: &str| -> Result<&serde_json::Value> {
        obj.get(name)
            .ok_or_else(|| anyhow!("{}: missing field `{name}`", path.display()))
    };
    let dt = match (obj.get("dt"), obj.get("dt_s")) {
        (Some(v), _) | (None, Some(v)) => v.as_f64(),
        (None, None) => bail!(
            "{}: missing field `dt` (sample interval in seconds)",
            path.display()
        ),
    }
    .filter(|d| d.is_finite() && *d > 0.0)
    .ok_or_else(|| {
        anyhow!(
            "{}: `dt` must be a positive number of seconds",
            path.display()
        )
    })?;
    let a = json_matrix(path, "A", field("A")?)?;
    let n = a.nrows();
    if a.ncols() != n || n == 0 {
        bail!(
            "{}: `A` must be square and non-empty, got {}x{}",
            path.display(),
            a.nrows(),
            a.ncols()
        );
    }
    let b = json_matrix(path, "B", field("B")?)?;
    let c = json_matrix(path, "C", field("C")?)?;
    let d = json_matrix(path, "D", field("D")?)?;
    if b.nrows() != n {
        bail!(
            "{}: `B` must have {n} rows (A is {n}x{n}), got {}",
            path.display(),
            b.nrows()
        );
    }
    if c.ncols() != n {
        bail!(
            "{}: `C` must have {n} columns (A is {n}x{n}), got {}",
            path.display(),
            c.ncols()
        );
    }
    if d.nrows() != c.nrows() || d.ncols() != b.ncols() {
        bail!(
            "{}: `D` must be {}x{} (outputs of C x inputs of B), got {}x{}",
            path.display(),
            c.nrows(),
            b.ncols(),
            d.nrows(),
            d.ncols()
        );
    }
    let outputs = (0..c.nrows()).map(|i| format!("y{}", i + 1)).collect();
    let inputs = (0..b.ncols()).map(|i| format!("u{}", i + 1)).collect();
    Ok((ident::StateSpace::new(a, b, c, d, dt), (outputs, inputs)))
}

fn json_matrix(path: &Path, name: &str, v: &serde_json::Value) -> Result<DMatrix<f64>> {
    let rows = v
        .as_array()
        .ok_or_else(|| anyhow!("{}: `{name}` must be an array of rows", path.display()))?;
    let mut data: Vec<Vec<f64>> = Vec::with_capacity(rows.len());
    for (i, row) in rows.iter().enumerate() {
        let row = row.as_array().ok_or_else(|| {
            anyhow!(
                "{}: `{name}[{i}]` must be an array of numbers",
                path.display()
            )
        })?;
        let vals: Vec<f64> = row
            .iter()
            .enumerate()
            .map(|(j, x)| {
                x.as_f64().filter(|v| v.is_finite()).ok_or_else(|| {
                    anyhow!(
                        "{}: `{name}[{i}][{j}]` is not a finite number",
                        path.display()
                    )
                })
            })
            .collect::<Result<_>>()?;
        if let Some(first) = data.first()
            && first.len() != vals.len()
        {
            bail!(
                "{}: `{name}[{i}]` has {} entries, row 0 has {}",
                path.display(),
                vals.len(),
                first.len()
            );
        }
        data.push(vals);
    }
    let ncols = data.first().map_or(0, Vec::len);
    Ok(DMatrix::from_fn(data.len(), ncols, |i, j| data[i][j]))
}

/// Where the identification came from.
#[derive(Debug, Clone, Serialize)]
pub struct Source {
    pub files: Vec<String>,
    pub realization: bool,
    pub dt_s: f64,
    pub hits: usize,
    pub samples: usize,
    pub inputs: Vec<String>,
    pub outputs: Vec<String>,
    pub collocated: Collocated,
}

/// Zero-based indices of the collocated pair among outputs and inputs.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Collocated {
    pub output: usize,
    pub input: usize,
}

/// One identified mode in the JSON output.
#[derive(Debug, Clone, Serialize)]
pub struct ModeReport {
    pub frequency_hz: f64,
    pub damping_ratio: f64,
    /// Output shape `C psi` as `[re, im]` per output, largest component `[1, 0]`.
    pub mode_shape: Vec<[f64; 2]>,
    /// Output EMAC x input EMAC (null for a given realization).
    pub emac: Option<f64>,
    pub emac_output: Option<f64>,
    pub emac_input: Option<f64>,
    pub mpc: f64,
    pub msv: f64,
    pub cmi: f64,
    pub structural: bool,
    /// Used by MKR and the Rayleigh fit.
    pub used: bool,
}

/// Rayleigh coefficients.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct RayleighReport {
    pub alpha: f64,
    pub beta: f64,
}

/// The JSON document of `frameid identify --json` (schema in the README).
#[derive(Debug, Clone, Serialize)]
pub struct IdentifyReport {
    pub frameid_version: String,
    pub source: Source,
    pub intersample: String,
    pub model_order: usize,
    pub observer: Option<ident::pipeline::ObserverSummary>,
    pub hankel_singular_values: Vec<f64>,
    pub modes: Vec<ModeReport>,
    pub rayleigh: RayleighReport,
    pub mass: Vec<Vec<f64>>,
    pub stiffness: Vec<Vec<f64>>,
    pub damping_mkr: Vec<Vec<f64>>,
    pub damping_rayleigh: Vec<Vec<f64>>,
    pub consistency: f64,
    pub polarity_flipped: bool,
    pub warnings: Vec<String>,
    /// Quality checks of every hit given (empty for a realization).
    pub hit_quality: Vec<HitQuality>,
    /// Files of the hits left out by `--drop-bad-hits`.
    pub dropped_hits: Vec<String>,
    /// Error bars over the hits (null for a realization, with
    /// `--no-uncertainty`, or with fewer than 3 hits).
    pub uncertainty: Option<Uncertainty>,
    /// Why there are no error bars, if there are none for records.
    pub uncertainty_skipped: Option<String>,
    /// Indices into `modes` of the modes used, in the order of the
    /// uncertainty's per-mode lists.
    #[serde(skip)]
    pub mkr_modes: Vec<usize>,
    /// The maximum-likelihood refinement (with `--refine`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub refined: Option<RefinedReport>,
}

impl IdentifyReport {
    pub fn new(r: &Identification, source: Source) -> Self {
        let modes = r
            .modes
            .iter()
            .enumerate()
            .map(|(i, m)| ModeReport {
                frequency_hz: m.frequency_hz,
                damping_ratio: m.damping_ratio,
                mode_shape: m.shape.iter().map(|z| [z.re, z.im]).collect(),
                emac: m
                    .indicators
                    .emac_output
                    .zip(m.indicators.emac_input)
                    .map(|(o, i)| o * i),
                emac_output: m.indicators.emac_output,
                emac_input: m.indicators.emac_input,
                mpc: m.indicators.mpc,
                msv: m.indicators.msv,
                cmi: m.indicators.cmi,
                structural: m.structural,
                used: r.mkr_modes.contains(&i),
            })
            .collect();
        IdentifyReport {
            frameid_version: env!("CARGO_PKG_VERSION").into(),
            source,
            intersample: match r.intersample {
                ident::Intersample::Zoh => "zoh".into(),
                ident::Intersample::Bandlimited => "bandlimited".into(),
            },
            model_order: r.model_order,
            observer: r.observer,
            hankel_singular_values: r.hankel_singular_values.iter().copied().collect(),
            modes,
            rayleigh: RayleighReport {
                alpha: r.rayleigh.alpha,
                beta: r.rayleigh.beta,
            },
            mass: rows(&r.mass),
            stiffness: rows(&r.stiffness),
            damping_mkr: rows(&r.damping_mkr),
            damping_rayleigh: rows(&r.damping_rayleigh),
            consistency: r.consistency,
            polarity_flipped: r.polarity_flipped,
            warnings: r.warnings.iter().map(ToString::to_string).collect(),
            hit_quality: Vec::new(),
            dropped_hits: Vec::new(),
            uncertainty: None,
            uncertainty_skipped: None,
            mkr_modes: r.mkr_modes.clone(),
            refined: None,
        }
    }

    /// Readable tables.
    pub fn human(&self) -> String {
        let s = &self.source;
        let mut out = String::new();
        if s.realization {
            out.push_str(&format!(
                "realization {} (dt = {} s)\n",
                s.files.join(", "),
                sig(s.dt_s, 6)
            ));
        } else {
            out.push_str(&format!(
                "{} record(s), {} samples, dt = {} s ({} Hz)\n",
                s.hits,
                s.samples,
                sig(s.dt_s, 6),
                sig(1.0 / s.dt_s, 6)
            ));
        }
        out.push_str(&format!(
            "inputs: {}; outputs (DOF order): {}; collocated: {} / {}; intersample: {}\n",
            s.inputs.join(", "),
            s.outputs.join(", "),
            s.outputs[s.collocated.output],
            s.inputs[s.collocated.input],
            self.intersample
        ));
        if let Some(o) = &self.observer {
            out.push_str(&format!(
                "OKID: observer order {}, input leads {}, rank {}/{}, rcond {:.1e}, relative residual {:.2e}\n",
                o.order, o.leads, o.rank, o.unknowns, o.rcond, o.relative_residual
            ));
        }
        if !self.hit_quality.is_empty() {
            out.push_str(&self.quality_table());
        }
        out.push_str(&format!("model order {}\n", self.model_order));
        let u = self.uncertainty.as_ref();
        match (u, &self.uncertainty_skipped) {
            (Some(u), _) => out.push_str(&format!(
                "error bars: +- one standard error, {} over {} hits ({} resamples at model order {})\n",
                u.method, u.hits, u.resamples, u.model_order
            )),
            (None, Some(why)) if !s.realization => {
                out.push_str(&format!("no error bars: {why}\n"));
            }
            _ => {}
        }
        out.push_str("\nModes\n");
        let rows: Vec<[String; 8]> = self
            .modes
            .iter()
            .enumerate()
            .map(|(i, m)| {
                let k = self.mkr_modes.iter().position(|&j| j == i);
                let f_std = u.zip(k).map(|(u, k)| u.frequencies_hz.std[k]);
                let xi_std = u.zip(k).map(|(u, k)| 100.0 * u.damping_ratios.std[k]);
                [
                    format!("{}", i + 1),
                    plus_minus(m.frequency_hz, f_std, 6),
                    plus_minus(100.0 * m.damping_ratio, xi_std, 4),
                    m.emac.map_or("-".to_string(), |e| format!("{e:.3}")),
                    format!("{:.3}", m.mpc),
                    format!("{:.3}", m.cmi),
                    if m.structural { "yes" } else { "no" }.to_string(),
                    if m.used { "yes" } else { "" }.to_string(),
                ]
            })
            .collect();
        let head = [
            "#",
            "f [Hz]",
            "xi [%]",
            "EMAC",
            "MPC",
            "CMI",
            "structural",
            "used",
        ];
        let widths: Vec<usize> = (0..head.len())
            .map(|c| {
                rows.iter()
                    .map(|r| r[c].chars().count())
                    .chain([head[c].len()])
                    .max()
                    .unwrap_or(0)
            })
            .collect();
        out.push(' ');
        for (c, h) in head.iter().enumerate() {
            out.push_str(&format!(" {h:>w$}", w = widths[c] + 1));
        }
        out.push('\n');
        for r in &rows {
            out.push(' ');
            for (c, cell) in r.iter().enumerate() {
                out.push_str(&format!(" {cell:>w$}", w = widths[c] + 1));
            }
            out.push('\n');
        }
        out.push_str("\nMode shapes of the modes used (outputs, magnitude and phase in degrees)\n");
        for m in self.modes.iter().filter(|m| m.used) {
            out.push_str(&format!("  {} Hz:", sig(m.frequency_hz, 5)));
            for (name, z) in s.outputs.iter().zip(&m.mode_shape) {
                let mag = z[0].hypot(z[1]);
                let ph = z[1].atan2(z[0]).to_degrees();
                out.push_str(&format!("  {name} {} at {:.1} deg", sig(mag, 4), ph));
            }
            out.push('\n');
        }
        out.push_str(&format!(
            "\nRayleigh: alpha = {} 1/s, beta = {} s\n\n",
            plus_minus(self.rayleigh.alpha, u.map(|u| u.rayleigh_alpha.std), 5),
            plus_minus(self.rayleigh.beta, u.map(|u| u.rayleigh_beta.std), 5)
        ));
        match u {
            Some(u) => {
                out.push_str(&matrix_table("Mass M [kg]", &self.mass, Some(&u.mass.std)));
                out.push_str(&matrix_table(
                    "Stiffness K [N/m]",
                    &self.stiffness,
                    Some(&u.stiffness.std),
                ));
                out.push_str(&matrix_table(
                    "Damping, MKR [N s/m]",
                    &self.damping_mkr,
                    Some(&u.damping_mkr.std),
                ));
                out.push_str(&matrix_table(
                    "Damping, Rayleigh alpha M + beta K [N s/m]",
                    &self.damping_rayleigh,
                    Some(&u.damping_rayleigh.std),
                ));
            }
            None => {
                let m = |rows: &Vec<Vec<f64>>| {
                    DMatrix::from_fn(rows.len(), rows.len(), |i, j| rows[i][j])
                };
                out.push_str(&matrix("Mass M [kg]", &m(&self.mass)));
                out.push_str(&matrix("Stiffness K [N/m]", &m(&self.stiffness)));
                out.push_str(&matrix("Damping, MKR [N s/m]", &m(&self.damping_mkr)));
                out.push_str(&matrix(
                    "Damping, Rayleigh alpha M + beta K [N s/m]",
                    &m(&self.damping_rayleigh),
                ));
            }
        }
        out.push_str(&format!(
            "\nSecond-order consistency ||W W^T|| / ||W L W^T|| = {:.3e} (0 for an exact second-order system)\n",
            self.consistency
        ));
        if self.polarity_flipped {
            out.push_str("Input polarity was inverted and has been flipped.\n");
        }
        if let Some(r) = &self.refined {
            out.push_str(&r.human());
        }
        if !self.warnings.is_empty() {
            out.push_str("\nWarnings\n");
            for w in &self.warnings {
                out.push_str(&format!("  - {w}\n"));
            }
        }
        out
    }

    /// The hit quality table of the human output.
    fn quality_table(&self) -> String {
        let names: Vec<&str> = self
            .hit_quality
            .first()
            .map(|q| q.channels.iter().map(|c| c.name.as_str()).collect())
            .unwrap_or_default();
        let head = [
            "hit".to_string(),
            "file".to_string(),
            "t [s]".to_string(),
            "2nd pulse".to_string(),
            "fall [dB]".to_string(),
            format!("SNR [dB] {}", names.join("/")),
            "tail".to_string(),
            "checks".to_string(),
        ];
        let rows: Vec<Vec<String>> = self
            .hit_quality
            .iter()
            .map(|q| {
                let p = q.pulse.as_ref();
                let snr: Vec<String> = q
                    .channels
                    .iter()
                    .map(|c| c.snr_db.map_or("-".to_string(), |v| format!("{v:.0}")))
                    .collect();
                let checks: Vec<&str> = q.flags.iter().map(|f| f.check.label()).collect();
                let mut checks_text = if checks.is_empty() {
                    "ok".to_string()
                } else {
                    let mut v: Vec<&str> = Vec::new();
                    for c in checks {
                        if !v.contains(&c) {
                            v.push(c);
                        }
                    }
                    v.join(", ")
                };
                if self.dropped_hits.contains(&q.file) {
                    checks_text.push_str(" (dropped)");
                }
                vec![
                    q.hit.to_string(),
                    q.file.clone(),
                    q.hit_time_s.map_or("-".into(), |t| format!("{t:.3}")),
                    p.map_or("-".into(), |p| format!("{:.2}", p.double_hit_ratio)),
                    p.map_or("-".into(), |p| format!("{:.1}", p.spectrum_drop_db)),
                    snr.join("/"),
                    q.max_tail_ratio()
                        .map_or("-".into(), |t| format!("{:.3}", t)),
                    checks_text,
                ]
            })
            .collect();
        let widths: Vec<usize> = (0..head.len())
            .map(|c| {
                rows.iter()
                    .map(|r| r[c].chars().count())
                    .chain([head[c].chars().count()])
                    .max()
                    .unwrap_or(0)
            })
            .collect();
        let mut out = String::from(
            "\nHit quality (2nd pulse: second force pulse over the first; fall: force spectrum over the band; tail: end RMS over peak)\n",
        );
        let line = |cells: &[String]| -> String {
            let mut l = String::from(" ");
            for (c, cell) in cells.iter().enumerate() {
                if c == 1 || c + 1 == cells.len() {
                    l.push_str(&format!("  {cell:<w$}", w = widths[c]));
                } else {
                    l.push_str(&format!("  {cell:>w$}", w = widths[c]));
                }
            }
            l.trim_end().to_string() + "\n"
        };
        out.push_str(&line(&head));
        for r in &rows {
            out.push_str(&line(r));
        }
        out.push('\n');
        out
    }
}
