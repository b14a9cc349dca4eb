//! The page of a campaign without a known truth ([`reports::CampaignReport`]):
//! what `frameid identify --report` shows of an [`Analysis`] of rig records.
//!
//! Measured FRFs are H1 estimates with their ordinary coherence from the
//! hits identified ([`ident::frf::estimate`]: averaged across hits for
//! hammer records, Welch segments for continuous ones); the model's FRFs are
//! those of the identified M, K and damping (the refined ones when the
//! campaign was refined, otherwise MKR's M and K with Rayleigh damping) for
//! a force at the collocated output's floor.

use ident::frf::estimate::FrfParams;
use ident::pipeline::{Stability, StabilizationCriteria};
use nalgebra::DMatrix;
use num_complex::Complex64;
use records::numfmt::sig;
use records::quality::{Excitation, HitQuality};
use reports::model as rm;

use crate::analysis::{Analysis, AnalysisSettings};

/// Largest model order of the stabilization diagram.
const STABILIZATION_MAX_ORDER: usize = 24;

/// Shortest Welch segment for continuous records, samples.
const MIN_WELCH_SEGMENT: usize = 256;

/// Welch segments wanted over a continuous record (with 50 % overlap, about
/// twice as many averages): enough for a coherence estimate whose bias
/// `(1 - gamma^2) / n` stays a few percent.
const WELCH_SEGMENTS: usize = 16;

/// Accelerance of `(mass, stiffness, damping)` at `omega` (rad/s) for a unit
/// force at DOF `input`: `-omega^2 (K - omega^2 M + i omega damping)^-1 e_input`,
/// one value per DOF (NaN where the dynamic stiffness is singular).
pub fn accelerance(
    mass: &DMatrix<f64>,
    stiffness: &DMatrix<f64>,
    damping: &DMatrix<f64>,
    input: usize,
    omega: f64,
) -> Vec<Complex64> {
    let n = mass.nrows();
    let q = DMatrix::from_fn(n, n, |i, j| {
        Complex64::new(
            stiffness[(i, j)] - omega * omega * mass[(i, j)],
            omega * damping[(i, j)],
        )
    });
    let mut e = DMatrix::zeros(n, 1);
    e[(input, 0)] = Complex64::new(1.0, 0.0);
    match q.lu().solve(&e) {
        Some(x) => x.iter().map(|v| v * (-omega * omega)).collect(),
        None => vec![Complex64::new(f64::NAN, f64::NAN); n],
    }
}

/// The report's rows of the hit quality checks.
pub fn hit_quality_rows(hits: &[HitQuality]) -> Vec<rm::HitQualityRow> {
    hits.iter()
        .map(|q| rm::HitQualityRow {
            hit: q.hit,
            peak_force_n: q.channels.first().map_or(f64::NAN, |c| c.peak),
            pulse_duration_s: q
                .pulse
                .as_ref()
                .map_or(f64::NAN, |p| p.equivalent_duration_s),
            min_snr_db: q.min_snr_db().unwrap_or(f64::NAN),
            tail_ratio: q.max_tail_ratio().unwrap_or(f64::NAN),
            flags: q.flags.iter().map(|f| f.message.clone()).collect(),
        })
        .collect()
}

/// A stabilization point of the identifier in the report's terms.
pub fn stabilization_point(p: &ident::pipeline::StabilizationPoint) -> rm::StabilizationPoint {
    rm::StabilizationPoint {
        order: p.order,
        frequency_hz: p.frequency_hz,
        damping_ratio: p.damping_ratio,
        status: match p.status {
            Stability::New => rm::Stability::New,
            Stability::Frequency => rm::Stability::Frequency,
            Stability::Damping => rm::Stability::Damping,
            Stability::Stable => rm::Stability::Stable,
        },
    }
}

/// A mode in the report's terms: shape scaled so that its largest
/// component is 1 + 0i.
pub fn mode_shape(frequency_hz: f64, damping_ratio: f64, shape: &[Complex64]) -> rm::ModeShape {
    let big = shape
        .iter()
        .copied()
        .max_by(|a, b| a.norm().total_cmp(&b.norm()))
        .unwrap_or(Complex64::new(1.0, 0.0));
    let scale = if big.norm() > 0.0 {
        big
    } else {
        Complex64::new(1.0, 0.0)
    };
    rm::ModeShape {
        frequency_hz,
        damping_ratio,
        shape: shape
            .iter()
            .map(|z| {
                let v = z / scale;
                [v.re, v.im]
            })
            .collect(),
        truth: None,
    }
}

/// Rows `{prefix}ij` (i <= j) of a symmetric matrix with standard errors.
pub fn matrix_rows(
    prefix: &str,
    value: &DMatrix<f64>,
    std: impl Fn(usize, usize) -> Option<f64>,
) -> Vec<rm::ValueRow> {
    let n = value.nrows();
    let mut rows = Vec::new();
    for i in 0..n {
        for j in i..n {
            rows.push(rm::ValueRow {
                label: format!("{prefix}{}{}", i + 1, j + 1),
                value: value[(i, j)],
                std: std(i, j),
            });
        }
    }
    rows
}

/// A row of the source table.
pub fn setup_row(label: &str, value: impl Into<String>) -> rm::SetupRow {
    rm::SetupRow {
        label: label.into(),
        value: value.into(),
    }
}

fn table(title: &str, unit: &str, rows: Vec<rm::ValueRow>) -> rm::ValueTable {
    rm::ValueTable {
        title: title.into(),
        unit: unit.into(),
        rows,
    }
}

/// The page of an analysis of rig records. `files` are the record files
/// given (in order), `command` the command line.
pub fn time_report(
    analysis: &Analysis,
    settings: &AnalysisSettings,
    files: &[String],
    command: &str,
) -> rm::CampaignReport {
    let id = &analysis.identification;
    let c = &analysis.campaign;
    let mut warnings = analysis.warnings.clone();
    let lengths: Vec<usize> = c.records.iter().map(|r| r.outputs.ncols()).collect();
    // Runs of different lengths: Welch segments fit the shortest, hits are
    // zero-padded to the longest.
    let samples = lengths.iter().copied().min().unwrap_or(0);
    let longest = lengths.iter().copied().max().unwrap_or(0);
    let samples_text = if samples == longest {
        format!("{samples} samples per record")
    } else {
        format!("{samples}-{longest} samples per record")
    };
    let continuous = analysis
        .hit_quality
        .iter()
        .any(|q| q.excitation == Excitation::Continuous);
    let excitation = {
        let hammer = analysis
            .hit_quality
            .iter()
            .filter(|q| q.excitation == Excitation::Hammer)
            .count();
        let shaker = analysis.hit_quality.len() - hammer;
        format!(
            "{} ({}; asked: {})",
            if continuous { "continuous" } else { "hammer" },
            match (hammer, shaker) {
                (h, 0) => format!("{h} hammer record(s)"),
                (0, s) => format!("{s} continuous record(s)"),
                (h, s) => format!("{h} hammer and {s} continuous record(s)"),
            },
            format!("{:?}", settings.quality.excitation).to_lowercase()
        )
    };
    let mut source = vec![
        setup_row("Files", files.join(", ")),
        setup_row(
            "Records identified",
            format!(
                "{} of {} given{}",
                c.records.len(),
                analysis.hit_quality.len(),
                if analysis.dropped.is_empty() {
                    String::new()
                } else {
                    format!(
                        " (dropped: {})",
                        analysis
                            .dropped
                            .iter()
                            .map(|&k| files.get(k).cloned().unwrap_or_else(|| format!("#{k}")))
                            .collect::<Vec<_>>()
                            .join(", ")
                    )
                }
            ),
        ),
        setup_row(
            "Sampling",
            format!(
                "{} Hz ({} s), {samples_text}",
                sig(1.0 / c.dt_s, 6),
                sig(c.dt_s, 6)
            ),
        ),
        setup_row("Inputs", c.inputs.join(", ")),
        setup_row("Outputs (DOF order)", c.outputs.join(", ")),
        setup_row(
            "Collocated pair",
            format!(
                "{} / {}",
                c.outputs
                    .get(analysis.collocated.output)
                    .map_or("?", String::as_str),
                c.inputs
                    .get(analysis.collocated.input)
                    .map_or("?", String::as_str)
            ),
        ),
        setup_row("Excitation", excitation),
        setup_row(
            "Method",
            format!(
                "OKID → ERA/DC (state order {}), {:?} intersample, MKR + Rayleigh{}",
                id.model_order,
                id.intersample,
                if analysis.refinement.is_some() {
                    ", maximum-likelihood refinement"
                } else {
                    ""
                }
            ),
        ),
        setup_row("Mode selection", format!("{:?}", id.mode_selection)),
        setup_row(
            "Error bars",
            match (&analysis.uncertainty, &analysis.uncertainty_skipped) {
                (Some(j), _) => format!("{} over {} resamples", j.method, j.resamples),
                (None, Some(why)) => format!("none: {why}"),
                (None, None) => "not asked for".into(),
            },
        ),
    ];
    let d = &analysis.decimation;
    if d.factor > 1 {
        source.push(setup_row(
            "Decimation",
            format!(
                "by {} from {} Hz{}: {}",
                d.factor,
                sig(d.original_rate_hz, 6),
                d.filter.as_ref().map_or(String::new(), |f| format!(
                    " (zero-phase Kaiser FIR, {} taps, pass band to {} Hz, {} dB from {} Hz)",
                    f.taps,
                    sig(f.passband_hz, 6),
                    f.attenuation_db,
                    sig(f.stopband_hz, 6)
                )),
                d.reason
            ),
        ));
    }
    // The identifier as run: with the initial state the analysis assumed.
    let mut identifier = settings.identifier.clone();
    if let Some(state) = &analysis.initial_state {
        identifier = identifier.initial_state(state.assumed);
        source.push(setup_row("Initial state", state.reason.clone()));
    }

    let stabilization = match identifier.check().and_then(|v| {
        v.stabilization(
            &c.records,
            c.dt_s,
            STABILIZATION_MAX_ORDER,
            StabilizationCriteria::default(),
        )
    }) {
        Ok(points) => points.iter().map(stabilization_point).collect(),
        Err(e) => {
            warnings.push(format!("stabilization diagram not drawn: {e}"));
            Vec::new()
        }
    };
    let shape_of = |m: &ident::modal::Mode| -> Vec<Complex64> { m.shape.iter().copied().collect() };
    let modes = id
        .mkr_modes
        .iter()
        .map(|&j| {
            let m = &id.modes[j];
            mode_shape(m.frequency_hz, m.damping_ratio, &shape_of(m))
        })
        .collect();
    let out_of_model = id
        .out_of_model_modes()
        .iter()
        .map(|&j| {
            let m = &id.modes[j];
            mode_shape(m.frequency_hz, m.damping_ratio, &shape_of(m))
        })
        .collect();

    // The model drawn against the measured FRFs.
    let (mass, stiffness, damping, drawn) = match &analysis.refinement {
        Some(r) => (
            &r.mass,
            &r.stiffness,
            &r.damping,
            "refined M, K and damping",
        ),
        None => (
            &id.mass,
            &id.stiffness,
            &id.damping_rayleigh,
            "MKR's M and K with Rayleigh damping",
        ),
    };
    let params = if continuous {
        let segment = (samples / WELCH_SEGMENTS)
            .max(MIN_WELCH_SEGMENT)
            .min(samples);
        FrfParams::welch(segment)
    } else if samples != longest {
        FrfParams::hits().averaging(ident::frf::estimate::Averaging::Hits(
            ident::frf::estimate::HitAveraging {
                block_len: Some(longest),
                ..Default::default()
            },
        ))
    } else {
        FrfParams::hits()
    };
    let frf = match params.estimate(&c.records, c.dt_s) {
        Ok(est) => {
            source.push(setup_row(
                "Measured FRFs",
                format!(
                    "{} with ordinary coherence, {} average(s) ({}); model drawn: {drawn}",
                    est.estimator,
                    est.frf.averages.unwrap_or(0),
                    if continuous {
                        "Welch segments, Hann window, 50 % overlap"
                    } else {
                        "one block per hit, no window"
                    }
                ),
            ));
            measured_against_model(&est.frf, c, analysis.collocated, (mass, stiffness, damping))
        }
        Err(e) => {
            warnings.push(format!("measured FRFs not estimated: {e}"));
            Vec::new()
        }
    };

    let mut tables = identified_tables(
        &id.frequencies_hz,
        &id.damping_ratios,
        [
            &id.mass,
            &id.stiffness,
            &id.damping_mkr,
            &id.damping_rayleigh,
        ],
        analysis.uncertainty.as_ref().map(|s| {
            (
                [
                    s.frequencies_hz.std.as_slice(),
                    s.damping_ratios.std.as_slice(),
                ],
                [
                    s.mass.std.as_slice(),
                    s.stiffness.std.as_slice(),
                    s.damping_mkr.std.as_slice(),
                    s.damping_rayleigh.std.as_slice(),
                ],
            )
        }),
    );
    if let Some(r) = &analysis.refinement {
        tables.extend(refined_tables(
            &r.mass,
            &r.stiffness,
            &r.damping,
            &r.uncertainty,
        ));
    }
    rm::CampaignReport {
        title: "frameid identification".into(),
        frameid_version: env!("CARGO_PKG_VERSION").into(),
        command: command.into(),
        source,
        warnings,
        hit_quality: hit_quality_rows(&analysis.hit_quality),
        order: id.model_order,
        stabilization,
        modes,
        out_of_model,
        frf,
        tables,
    }
}

/// One report FRF per response/reference pair of `measured` (lines above
/// 0 Hz), against the model's accelerance where the reference's floor is
/// known (the collocated reference); coherence kept.
fn measured_against_model(
    measured: &ident::frf::Frf,
    c: &ident::Campaign,
    collocated: ident::CollocatedPair,
    (mass, stiffness, damping): (&DMatrix<f64>, &DMatrix<f64>, &DMatrix<f64>),
) -> Vec<rm::Frf> {
    let lines: Vec<usize> = (0..measured.frequency_hz.len())
        .filter(|&k| measured.frequency_hz[k] > 0.0)
        .collect();
    let frequency_hz: Vec<f64> = lines.iter().map(|&k| measured.frequency_hz[k]).collect();
    let model: Vec<Vec<Complex64>> = frequency_hz
        .iter()
        .map(|f| {
            accelerance(
                mass,
                stiffness,
                damping,
                collocated.output,
                2.0 * std::f64::consts::PI * f,
            )
        })
        .collect();
    let mut out = Vec::new();
    for l in 0..measured.references.len() {
        for i in 0..measured.outputs.len() {
            let identified = if l == collocated.input && i < mass.nrows() {
                model.iter().map(|h| [h[i].re, h[i].im]).collect()
            } else {
                Vec::new()
            };
            out.push(rm::Frf {
                output: c
                    .outputs
                    .get(i)
                    .cloned()
                    .unwrap_or_else(|| format!("output {}", i + 1)),
                frequency_hz: frequency_hz.clone(),
                measured: lines
                    .iter()
                    .map(|&k| {
                        let z = measured.values[k][(i, l)];
                        [z.re, z.im]
                    })
                    .collect(),
                identified,
                truth: None,
                reference: Some(
                    c.inputs
                        .get(l)
                        .cloned()
                        .unwrap_or_else(|| format!("input {}", l + 1)),
                ),
                coherence: measured
                    .coherence
                    .as_ref()
                    .map(|g| lines.iter().map(|&k| g[k][(i, l)]).collect()),
            });
        }
    }
    out
}

/// Standard errors of an identification: frequencies and damping ratios;
/// M, K, MKR and Rayleigh damping as rows.
type Spreads<'a> = ([&'a [f64]; 2], [&'a [Vec<f64>]; 4]);

/// The tables of an identification: frequencies, damping ratios (in %),
/// M, K, MKR and Rayleigh damping, with standard errors where `std` gives
/// them (frequencies and damping ratios; the four matrices as rows).
fn identified_tables(
    frequencies_hz: &[f64],
    damping_ratios: &[f64],
    [mass, stiffness, damping_mkr, damping_rayleigh]: [&DMatrix<f64>; 4],
    std: Option<Spreads<'_>>,
) -> Vec<rm::ValueTable> {
    let modal = |label: &str, scale: f64, values: &[f64], which: usize| -> Vec<rm::ValueRow> {
        values
            .iter()
            .enumerate()
            .map(|(j, &v)| rm::ValueRow {
                label: format!("{label}{}", j + 1),
                value: scale * v,
                std: std.and_then(|(m, _)| m[which].get(j).map(|s| scale * s)),
            })
            .collect()
    };
    let matrix = |prefix: &str, m: &DMatrix<f64>, which: usize| {
        matrix_rows(prefix, m, |i, j| std.map(|(_, s)| s[which][i][j]))
    };
    vec![
        table(
            "Natural frequencies",
            "Hz",
            modal("f", 1.0, frequencies_hz, 0),
        ),
        table("Damping ratios", "%", modal("xi", 100.0, damping_ratios, 1)),
        table("Mass matrix M", "kg", matrix("M", mass, 0)),
        table("Stiffness matrix K", "N/m", matrix("K", stiffness, 1)),
        table("Damping matrix, MKR", "N s/m", matrix("R", damping_mkr, 2)),
        table(
            "Damping matrix, Rayleigh",
            "N s/m",
            matrix("R", damping_rayleigh, 3),
        ),
    ]
}

/// Tables of a maximum-likelihood refinement with its standard errors.
fn refined_tables(
    mass: &DMatrix<f64>,
    stiffness: &DMatrix<f64>,
    damping: &DMatrix<f64>,
    u: &ident::refine::Uncertainty,
) -> Vec<rm::ValueTable> {
    let modes = |label: &str, scale: f64, pick: fn(&ident::refine::ModalEstimate) -> (f64, f64)| {
        u.modes
            .iter()
            .enumerate()
            .map(|(j, m)| {
                let (value, std) = pick(m);
                rm::ValueRow {
                    label: format!("{label}{}", j + 1),
                    value: scale * value,
                    std: Some(scale * std),
                }
            })
            .collect()
    };
    vec![
        table(
            "Natural frequencies, refined (ML)",
            "Hz",
            modes("f", 1.0, |m| (m.frequency_hz, m.frequency_std_hz)),
        ),
        table(
            "Damping ratios, refined (ML)",
            "%",
            modes("xi", 100.0, |m| (m.damping_ratio, m.damping_ratio_std)),
        ),
        table(
            "Mass matrix M, refined (ML)",
            "kg",
            matrix_rows("M", mass, |i, j| Some(u.mass_std[(i, j)])),
        ),
        table(
            "Stiffness matrix K, refined (ML)",
            "N/m",
            matrix_rows("K", stiffness, |i, j| Some(u.stiffness_std[(i, j)])),
        ),
        table(
            "Damping matrix, refined (ML)",
            "N s/m",
            matrix_rows("R", damping, |i, j| Some(u.damping_std[(i, j)])),
        ),
    ]
}

/// The page of an identification from measured FRFs read from `files`;
/// `reference_dofs` is the floor (0-based) of each reference force where
/// known, for the model's FRFs; `collocated` is (output, reference).
pub fn frf_report(
    analysis: &crate::frf_analysis::FrfAnalysis,
    frf: &ident::frf::Frf,
    reference_dofs: &[Option<usize>],
    files: &[String],
    collocated: (usize, usize),
    command: &str,
) -> rm::CampaignReport {
    let id = &analysis.identification;
    let mut source = vec![
        setup_row("Files", files.join(", ")),
        setup_row(
            "FRFs",
            format!(
                "{} of {} responses to {} reference(s), {} lines {}-{} Hz, {} average(s), coherence {}",
                frf.quantity,
                frf.outputs.len(),
                frf.references.len(),
                frf.frequency_hz.len(),
                sig(frf.frequency_hz[0], 6),
                sig(frf.frequency_hz[frf.frequency_hz.len() - 1], 6),
                frf.averages.map_or("unknown".into(), |n| n.to_string()),
                if frf.coherence.is_some() {
                    "given (lines weighted by it)"
                } else {
                    "not given"
                }
            ),
        ),
        setup_row(
            "Collocated pair",
            format!(
                "{} / {}",
                frf.outputs[collocated.0], frf.references[collocated.1]
            ),
        ),
    ];
    let mut warnings = analysis.warnings.clone();
    source.push(setup_row(
        "Method",
        format!(
            "pLSCF (order {}) → LSFD with residual terms → MKR + Rayleigh{}",
            id.order,
            if analysis.refinement.is_some() {
                ", maximum-likelihood refinement on the FRFs"
            } else {
                ""
            }
        ),
    ));
    source.push(setup_row(
        "Error bars",
        match (&analysis.uncertainty, &analysis.uncertainty_skipped) {
            (Some(u), _) => u.method.clone(),
            (None, Some(why)) => format!("none: {why}"),
            (None, None) => "not asked for".into(),
        },
    ));
    if let Some(tau) = id.exponential_tau_s {
        source.push(setup_row(
            "Exponential window",
            format!(
                "tau = {} s: its damping (1 / (tau omega) of critical) is removed from the modes, M, K and damping",
                sig(tau, 4)
            ),
        ));
    }
    for c in &analysis.checks.reciprocity {
        source.push(setup_row(
            "Reciprocity",
            format!(
                "{} against {}: {} % relative difference over the band",
                c.a,
                c.b,
                sig(100.0 * c.relative_difference, 3)
            ),
        ));
    }
    let mode = |j: &usize| {
        let m = &id.modes[*j];
        mode_shape(
            m.frequency_hz,
            m.damping_ratio,
            &m.shape.iter().copied().collect::<Vec<_>>(),
        )
    };
    let (mass, stiffness, damping) = match &analysis.refinement {
        Some(r) => (&r.mass, &r.stiffness, &r.damping),
        None => (&id.mass, &id.stiffness, &id.damping_rayleigh),
    };
    // Shown as accelerance whatever the quantity: (i w)^(2 - d) H.
    let d = frf.quantity.derivative_order();
    let lines: Vec<usize> = (0..frf.frequency_hz.len())
        .filter(|&k| frf.frequency_hz[k] > 0.0)
        .collect();
    let to_accelerance = |k: usize, z: Complex64| {
        let w = Complex64::new(0.0, 2.0 * std::f64::consts::PI * frf.frequency_hz[k]);
        z * w.powi(2 - d)
    };
    let mut frfs = Vec::new();
    for l in 0..frf.references.len() {
        let model: Option<Vec<Vec<Complex64>>> = reference_dofs
            .get(l)
            .copied()
            .flatten()
            .filter(|&dof| dof < mass.nrows())
            .map(|dof| {
                lines
                    .iter()
                    .map(|&k| {
                        accelerance(
                            mass,
                            stiffness,
                            damping,
                            dof,
                            2.0 * std::f64::consts::PI * frf.frequency_hz[k],
                        )
                    })
                    .collect()
            });
        for i in 0..frf.outputs.len() {
            frfs.push(rm::Frf {
                output: frf.outputs[i].clone(),
                frequency_hz: lines.iter().map(|&k| frf.frequency_hz[k]).collect(),
                measured: lines
                    .iter()
                    .map(|&k| {
                        let z = to_accelerance(k, frf.values[k][(i, l)]);
                        [z.re, z.im]
                    })
                    .collect(),
                identified: model
                    .as_ref()
                    .filter(|_| i < mass.nrows())
                    .map(|m| m.iter().map(|h| [h[i].re, h[i].im]).collect())
                    .unwrap_or_default(),
                truth: None,
                reference: Some(frf.references[l].clone()),
                coherence: frf
                    .coherence
                    .as_ref()
                    .map(|g| lines.iter().map(|&k| g[k][(i, l)]).collect()),
            });
        }
    }
    if frfs.iter().all(|f| f.identified.is_empty()) {
        warnings.push("the model's FRFs are not drawn: no reference is placed on a floor".into());
    }
    let mut tables = identified_tables(
        &id.frequencies_hz,
        &id.damping_ratios,
        [
            &id.mass,
            &id.stiffness,
            &id.damping_mkr,
            &id.damping_rayleigh,
        ],
        analysis.uncertainty.as_ref().map(|u| {
            (
                [
                    u.frequencies_hz_std.as_slice(),
                    u.damping_ratios_std.as_slice(),
                ],
                [
                    u.mass_std.as_slice(),
                    u.stiffness_std.as_slice(),
                    u.damping_mkr_std.as_slice(),
                    u.damping_rayleigh_std.as_slice(),
                ],
            )
        }),
    );
    if let Some(r) = &analysis.refinement {
        tables.extend(refined_tables(
            &r.mass,
            &r.stiffness,
            &r.damping,
            &r.uncertainty,
        ));
    }
    rm::CampaignReport {
        title: "frameid identification from FRFs".into(),
        frameid_version: env!("CARGO_PKG_VERSION").into(),
        command: command.into(),
        source,
        warnings,
        hit_quality: Vec::new(),
        order: id.order,
        stabilization: id
            .diagram
            .points()
            .iter()
            .map(stabilization_point)
            .collect(),
        modes: id.mkr_modes.iter().map(mode).collect(),
        out_of_model: id.out_of_model.iter().map(mode).collect(),
        frf: frfs,
        tables,
    }
}
