//! `frameid identify`: records (or a published realization) to modal
//! parameters and M, K, R, as readable tables or JSON.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, anyhow, bail};
use ident::{Identification, Identifier, ModelOrder, ObserverOrder, Record};
use nalgebra::DMatrix;
use serde::Serialize;

use crate::cli::IdentifyArgs;
use crate::format::{matrix, sig};
use crate::records::{self, ChannelSpec, ReadOptions, RecordFile};
use crate::truth::rows;

/// A campaign read from files: one [`Record`] per file.
#[derive(Debug, Clone)]
pub struct LoadedCampaign {
    pub files: Vec<PathBuf>,
    pub dt_s: f64,
    pub input_names: Vec<String>,
    pub output_names: Vec<String>,
    pub records: Vec<Record>,
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
    let (result, source) = match &args.realization {
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
            (result, source)
        }
        None => {
            let c = load_campaign(&args.files, &args.input, args.outputs.as_deref(), args.fs)?;
            let collocated = match &args.collocated {
                Some(text) => parse_collocated(text, &c.output_names, &c.input_names)?,
                None => (0, 0),
            };
            let result = identifier(args, collocated)
                .identify(&c.records, c.dt_s)
                .map_err(|e| {
                    anyhow!("identification of {} failed: {e}", describe_files(&c.files))
                })?;
            let source = Source {
                files: c.files.iter().map(|f| f.display().to_string()).collect(),
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
            (result, source)
        }
    };
    let report = IdentifyReport::new(&result, source);
    if args.json {
        let mut text = serde_json::to_string_pretty(&report)?;
        text.push('\n');
        print!("{text}");
    } else {
        print!("{}", report.human());
    }
    Ok(())
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
        out.push_str(&format!("model order {}\n\nModes\n", self.model_order));
        out.push_str("   #      f [Hz]    xi [%]    EMAC     MPC     CMI  structural  used\n");
        for (i, m) in self.modes.iter().enumerate() {
            let emac = m.emac.map_or("-".to_string(), |e| format!("{e:.3}"));
            out.push_str(&format!(
                "  {:>2}  {:>10}  {:>8}  {:>6}  {:>6.3}  {:>6.3}  {:>10}  {:>4}\n",
                i + 1,
                sig(m.frequency_hz, 6),
                sig(100.0 * m.damping_ratio, 4),
                emac,
                m.mpc,
                m.cmi,
                if m.structural { "yes" } else { "no" },
                if m.used { "yes" } else { "" }
            ));
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
            sig(self.rayleigh.alpha, 5),
            sig(self.rayleigh.beta, 5)
        ));
        let m = |rows: &Vec<Vec<f64>>| DMatrix::from_fn(rows.len(), rows.len(), |i, j| rows[i][j]);
        out.push_str(&matrix("Mass M [kg]", &m(&self.mass)));
        out.push_str(&matrix("Stiffness K [N/m]", &m(&self.stiffness)));
        out.push_str(&matrix("Damping, MKR [N s/m]", &m(&self.damping_mkr)));
        out.push_str(&matrix(
            "Damping, Rayleigh alpha M + beta K [N s/m]",
            &m(&self.damping_rayleigh),
        ));
        out.push_str(&format!(
            "\nSecond-order consistency ||W W^T|| / ||W L W^T|| = {:.3e} (0 for an exact second-order system)\n",
            self.consistency
        ));
        if self.polarity_flipped {
            out.push_str("Input polarity was inverted and has been flipped.\n");
        }
        if !self.warnings.is_empty() {
            out.push_str("\nWarnings\n");
            for w in &self.warnings {
                out.push_str(&format!("  - {w}\n"));
            }
        }
        out
    }
}
