//! Turns sweep directories into the report's data model.

use std::path::Path;

use records::numfmt::sig;
use reports::model as rm;
use sim::{Acquisition, DampingSpec};

use crate::error::StudyError;
use crate::fsutil::read_json;
use crate::representative::RepresentativeFile;
use crate::scenario::{Scenario, StructureSpec};
use crate::score::{FrfScore, MatrixEstimate, ScoreKey};
use crate::sweep::stats::Stats;
use crate::sweep::{LevelSummary, Summary};

/// Reads `summary.json` and (if present) `representative.json` of a sweep
/// directory and builds one study of the report.
pub fn study(dir: &Path) -> Result<rm::Study, StudyError> {
    let path = dir.join("summary.json");
    if !path.exists() {
        return Err(StudyError::bad_file(
            &path,
            None,
            "cannot read (a complete sweep directory, or merged shards?)",
        ));
    }
    let summary: Summary = read_json(&path, "a sweep summary")?;
    // The files of one directory must come from one run: a hand-made mix
    // (files copied from another sweep) is refused.
    let mixed = |file: &Path, what: &str| {
        StudyError::bad_file(
            file,
            None,
            format!(
                "{what} than {}: the directory mixes files of different runs; rerun the sweep",
                path.display()
            ),
        )
    };
    let manifest_path = dir.join("sweep.json");
    if manifest_path.exists() {
        let manifest: crate::sweep::Manifest = read_json(&manifest_path, "a sweep manifest")?;
        if manifest.plan != summary.plan {
            return Err(mixed(&manifest_path, "another sweep plan"));
        }
        if manifest.shard.is_some() {
            return Err(StudyError::bad_file(
                &manifest_path,
                None,
                "a shard of a sweep; merge the shards first (`frameid merge`)",
            ));
        }
    }
    let rep_path = dir.join("representative.json");
    let representative = if rep_path.exists() {
        let file: RepresentativeFile = read_json(&rep_path, "a representative campaign")?;
        if file.seed != sim::derive_seed(summary.plan.seed, crate::sweep::BOUND_TAG) {
            return Err(mixed(&rep_path, "a campaign of another seed"));
        }
        Some(file.representative)
    } else {
        None
    };
    let scenario = &summary.plan.scenario;
    Ok(rm::Study {
        name: scenario.name.clone(),
        description: scenario.description.clone(),
        seed: summary.plan.seed,
        setup: setup_rows(&summary).map_err(|error| StudyError::Simulation {
            context: path.display().to_string(),
            error,
        })?,
        representative,
        accuracy: accuracy(&summary),
    })
}

/// A report of several sweep directories; `command` is shown as the
/// command that produced it.
pub fn build(title: &str, command: &str, dirs: &[&Path]) -> Result<rm::Report, StudyError> {
    Ok(rm::Report {
        title: title.into(),
        frameid_version: env!("CARGO_PKG_VERSION").into(),
        command: command.into(),
        studies: dirs.iter().map(|d| study(d)).collect::<Result<_, _>>()?,
    })
}

fn row(label: &str, value: String) -> rm::SetupRow {
    rm::SetupRow {
        label: label.into(),
        value,
    }
}

fn list(v: impl IntoIterator<Item = f64>, digits: usize) -> String {
    v.into_iter()
        .map(|x| sig(x, digits))
        .collect::<Vec<_>>()
        .join(", ")
}

fn matrix_text(m: &nalgebra::DMatrix<f64>) -> String {
    (0..m.nrows())
        .map(|i| format!("[{}]", list(m.row(i).iter().copied(), 5)))
        .collect::<Vec<_>>()
        .join(" ")
}

/// The set-up table: structure, damping, truth modes, hammer, sampling,
/// acquisition, noise, trials, seed, identification.
fn setup_rows(summary: &Summary) -> Result<Vec<rm::SetupRow>, sim::SimError> {
    let plan = &summary.plan;
    let s: &Scenario = &plan.scenario;
    let model = s.model()?;
    let modal = model.modal()?;
    let mut rows = Vec::new();
    match &s.structure {
        StructureSpec::Matrices { .. } => rows.push(row(
            "Structure",
            format!("{} DOFs, M and K given directly", model.dofs()),
        )),
        StructureSpec::ShearFrame { storeys, floors } => {
            rows.push(row(
                "Structure",
                format!("shear frame, {} storeys", storeys.len()),
            ));
            for (i, st) in storeys.iter().enumerate() {
                rows.push(row(
                    &format!("Storey {}", i + 1),
                    format!(
                        "{} pillars {} x {} mm, {} mm long, E = {} GPa, {:?} -> {} N/m",
                        st.pillars,
                        sig(st.pillar_width_m * 1e3, 4),
                        sig(st.pillar_thickness_m * 1e3, 4),
                        sig(st.length_m * 1e3, 4),
                        sig(st.youngs_modulus_pa / 1e9, 4),
                        st.end_condition,
                        sig(st.lateral_stiffness_n_per_m(), 5)
                    ),
                ));
            }
            for (i, f) in floors.iter().enumerate() {
                rows.push(row(
                    &format!("Floor {}", i + 1),
                    format!(
                        "block {} kg, sensors {} kg, added {} kg",
                        sig(f.block_mass_kg(), 5),
                        sig(f.sensor_mass_kg, 3),
                        sig(f.added_mass_kg, 5)
                    ),
                ));
            }
        }
    }
    rows.push(row("Mass M [kg]", matrix_text(&model.mass)));
    rows.push(row("Stiffness K [N/m]", matrix_text(&model.stiffness)));
    rows.push(row(
        "Damping",
        match &s.damping {
            DampingSpec::None => "none".into(),
            DampingSpec::Rayleigh { alpha, beta } => format!(
                "Rayleigh, alpha = {} 1/s, beta = {} s",
                sig(*alpha, 5),
                sig(*beta, 5)
            ),
            DampingSpec::TargetRatios { modes, ratios } => format!(
                "Rayleigh with xi = {} % at modes {} and {}",
                list(ratios.iter().map(|r| 100.0 * r), 3),
                modes[0],
                modes[1]
            ),
            DampingSpec::Modal { ratios } => format!(
                "modal, xi = {} %",
                list(ratios.iter().map(|r| 100.0 * r), 3)
            ),
            DampingSpec::Matrix { .. } => "matrix given directly".into(),
        } + &s
            .dashpots
            .iter()
            .map(|d| {
                format!(
                    "; dashpot {} N s/m across storey {}",
                    sig(d.coefficient_ns_per_m, 4),
                    d.storey
                )
            })
            .collect::<String>(),
    ));
    rows.push(row("Damping matrix [N s/m]", matrix_text(&model.damping)));
    rows.push(row(
        "Natural frequencies (truth)",
        format!("{} Hz", list(modal.frequencies_hz.iter().copied(), 5)),
    ));
    rows.push(row(
        "Damping ratios (truth)",
        format!(
            "{} %",
            list(modal.damping_ratios.iter().map(|x| 100.0 * x), 3)
        ),
    ));
    let h = &s.campaign.hammer;
    rows.push(row(
        "Hammer",
        format!(
            "floor {}, half-sine {} ms, peak {} N +- {} %, start jitter {} ms{}",
            h.floor,
            sig(h.duration_s * 1e3, 3),
            sig(h.peak_n, 4),
            sig(100.0 * h.peak_variation, 3),
            sig(h.start_jitter_s * 1e3, 3),
            h.double_hit
                .as_ref()
                .map(|d| format!(
                    ", double hit {} ms later at {} of the peak",
                    sig(d.delay_s * 1e3, 3),
                    sig(d.ratio, 3)
                ))
                .unwrap_or_default()
        ),
    ));
    rows.push(row("Hits per campaign", s.campaign.hits.to_string()));
    let sp = &s.campaign.sampling;
    rows.push(row(
        "Sampling",
        format!(
            "{} Hz, {} samples ({} s), pre-trigger {} samples",
            sig(sp.sample_rate_hz, 5),
            sp.samples,
            sig(sp.samples as f64 / sp.sample_rate_hz, 4),
            sp.pretrigger_samples
        ),
    ));
    rows.push(row(
        "Acquisition",
        match &s.campaign.acquisition {
            Acquisition::Held => "force held per sample (zero-order hold), no analyzer chain".into(),
            Acquisition::Analyzer(a) => match a.design(sp.sample_rate_hz) {
                Ok(d) => format!(
                    "analyzer: Butterworth order {} at {} Hz, ADC at {} Hz, FIR pass {} Hz, stop {} Hz ({} dB)",
                    d.analog_order,
                    sig(d.analog_cutoff_hz, 4),
                    sig(d.internal_rate_hz, 5),
                    sig(d.passband_hz, 4),
                    sig(d.stopband_hz, 4),
                    sig(d.stopband_attenuation_db, 3)
                ),
                Err(e) => format!("analyzer ({e})"),
            },
        },
    ));
    let n = &s.campaign.noise;
    rows.push(row(
        "Noise levels",
        format!(
            "{} % of each channel's RMS{}{}",
            list(plan.noise_levels.iter().map(|x| 100.0 * x), 3),
            if n.absolute_force_n > 0.0 || n.absolute_acceleration_m_s2 > 0.0 {
                format!(
                    ", plus {} N and {} m/s^2 absolute",
                    sig(n.absolute_force_n, 3),
                    sig(n.absolute_acceleration_m_s2, 3)
                )
            } else {
                String::new()
            },
            n.adc
                .as_ref()
                .map(|a| format!(
                    ", ADC ranges {} N / {} m/s^2{}",
                    sig(a.force_range_n, 3),
                    sig(a.acceleration_range_m_s2, 3),
                    a.bits.map(|b| format!(", {b} bits")).unwrap_or_default()
                ))
                .unwrap_or_default()
        ),
    ));
    rows.push(row(
        "Representative campaign",
        format!("noise {} %", sig(100.0 * n.fraction, 3)),
    ));
    rows.push(row("Trials per level", plan.trials.to_string()));
    if s.identification.route.time() {
        rows.push(row(
            "Identification",
            format!(
                "OKID -> ERA/DC -> MKR, intersample {}, model order {}, observer order {}",
                s.intersample(),
                s.identification
                    .order
                    .map_or("automatic".into(), |o| o.to_string()),
                s.identification
                    .observer_order
                    .map_or("automatic".into(), |o| o.to_string())
            ),
        ));
    }
    if s.identification.route.frf() {
        let f = &s.identification.frf;
        let (low, high) = s.frf_band_hz();
        rows.push(row(
            "Identification, FRF route",
            format!(
                "{} across the hits, {}-{} Hz, {}{} -> pLSCF -> LSFD -> MKR{}",
                f.estimator,
                sig(low, 4),
                sig(high, 4),
                if f.exponential_end_amplitude < 1.0 {
                    format!(
                        "exponential window to {} at the record end (its damping taken out of the poles)",
                        sig(f.exponential_end_amplitude, 3)
                    )
                } else {
                    "no exponential window".into()
                },
                f.force_window
                    .map(|w| format!(
                        ", force window {} ms before to {} ms after the peak, tapers {} ms",
                        sig(w.before_peak_s * 1e3, 3),
                        sig(w.after_peak_s * 1e3, 3),
                        sig(w.taper_s * 1e3, 3)
                    ))
                    .unwrap_or_default(),
                if s.identification.route.time() {
                    ", on the same campaigns as the time route"
                } else {
                    ""
                }
            ),
        ));
    }
    if let Some(axis) = &plan.axis {
        rows.push(row(
            "Second axis",
            format!(
                "{} = {}",
                axis.setting.name(),
                axis.values
                    .iter()
                    .map(ToString::to_string)
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        ));
    }
    Ok(rows)
}

/// Label, unit and group of a score shown in the accuracy charts; `None`
/// for scores kept only in the files (signed entry errors, standard
/// errors, counters).
fn describe(key: ScoreKey) -> Option<(String, String, String)> {
    let suffix = |refined: bool| if refined { ", refined" } else { "" };
    let rel = "relative error".to_string();
    let fro = "relative Frobenius error".to_string();
    Some(match key {
        ScoreKey::Frequency { mode, refined } => (
            format!("Natural frequency f{mode}{}", suffix(refined)),
            rel,
            "frequency".into(),
        ),
        ScoreKey::DampingRatio { mode, refined } => (
            format!("Damping ratio xi{mode}{}", suffix(refined)),
            rel,
            "damping ratio".into(),
        ),
        ScoreKey::MacDefect { mode, refined } => (
            format!("Mode shape {mode}{}: 1 - MAC", suffix(refined)),
            "1 - MAC".into(),
            "mode shape".into(),
        ),
        ScoreKey::Matrix(m) => {
            let (label, group) = match m {
                MatrixEstimate::Mass => ("Mass matrix M", "matrices"),
                MatrixEstimate::Stiffness => ("Stiffness matrix K", "matrices"),
                MatrixEstimate::MassRefined => ("Mass matrix M, refined", "matrices"),
                MatrixEstimate::StiffnessRefined => ("Stiffness matrix K, refined", "matrices"),
                MatrixEstimate::DampingMkr => ("Damping, MKR", "damping matrices"),
                MatrixEstimate::DampingRayleigh => ("Damping, Rayleigh", "damping matrices"),
                MatrixEstimate::DampingRefined => {
                    ("Damping, refined (maximum likelihood)", "damping matrices")
                }
            };
            (label.to_string(), fro, group.into())
        }
        ScoreKey::Consistency => (
            "Second-order consistency ||W W^T|| / ||W L W^T||".into(),
            "ratio".into(),
            "diagnostics".into(),
        ),
        ScoreKey::Frf(score) => {
            let (label, unit, group) = describe(score.time_key())?;
            (format!("{label}, FRF route"), unit, group)
        }
        _ => return None,
    })
}

/// The accuracy section: one panel per axis value.
fn accuracy(summary: &Summary) -> rm::Accuracy {
    let plan = &summary.plan;
    let axis_values = plan.axis_values();
    let panels = axis_values
        .iter()
        .enumerate()
        .map(|(a, value)| {
            let levels: Vec<_> = summary
                .levels
                .iter()
                .filter(|l| &l.axis_value == value)
                .collect();
            let series = |key: ScoreKey, pick: fn(&Stats) -> Option<f64>| -> Vec<f64> {
                levels
                    .iter()
                    .map(|l| l.scores.get(&key).and_then(pick).unwrap_or(f64::NAN))
                    .collect()
            };
            let quantities = summary
                .score_names
                .iter()
                .filter_map(|&name| {
                    describe(name).map(|(label, unit, group)| rm::Quantity {
                        key: name.to_string(),
                        label,
                        unit,
                        group,
                        median: series(name, |s| s.median),
                        p5: series(name, |s| s.p5),
                        p95: series(name, |s| s.p95),
                        bound: {
                            let b: Vec<f64> = levels
                                .iter()
                                .map(|l| {
                                    l.bound
                                        .as_ref()
                                        .and_then(|b| b.for_score(name))
                                        .unwrap_or(f64::NAN)
                                })
                                .collect();
                            b.iter().any(|x| x.is_finite()).then_some(b)
                        },
                        scale: None,
                    })
                })
                .collect();
            rm::Panel {
                axis_value: value.as_ref().map(|_| plan.axis_label(a)),
                noise_levels: levels.iter().map(|l| l.noise).collect(),
                trials: levels.iter().map(|l| l.trials).collect(),
                failure_rate: levels.iter().map(|l| l.failure_rate).collect(),
                failure_reasons: levels
                    .iter()
                    .flat_map(|l| {
                        l.failure_reasons
                            .iter()
                            .map(|(reason, &count)| rm::FailureCount {
                                noise_level: l.noise,
                                reason: reason.clone(),
                                count,
                            })
                    })
                    .collect(),
                quantities,
            }
        })
        .collect();
    rm::Accuracy {
        axis_name: plan.axis.as_ref().map(|a| a.setting.name().to_string()),
        panels,
        efficiency: efficiency_rows(summary),
        routes: route_rows(summary),
    }
}

/// Root mean square of the values behind `s` from their mean and sample
/// standard deviation: `sqrt(mean^2 + std^2 (n - 1) / n)`.
fn rms(s: &Stats) -> f64 {
    match (s.n, s.mean, s.std) {
        (0, ..) | (_, None, _) => f64::NAN,
        (1, Some(mean), _) => mean.abs(),
        (n, Some(mean), Some(std)) => (mean * mean + std * std * (n - 1) as f64 / n as f64).sqrt(),
        (_, Some(_), None) => f64::NAN,
    }
}

/// What a row of the efficiency and route tables measures: with a second
/// axis the tables hold every panel, so the quantity names its axis value
/// ("mass matrix (excitation = shaker)").
fn quantity_at(summary: &Summary, level: &LevelSummary, quantity: &str) -> String {
    match (&summary.plan.axis, &level.axis_value) {
        (Some(axis), Some(value)) => format!("{quantity} ({} = {value})", axis.setting.name()),
        _ => quantity.to_string(),
    }
}

/// The time and FRF routes side by side (sweeps that ran both): M, K and
/// the MKR and Rayleigh damping at every noise level of every panel.
fn route_rows(summary: &Summary) -> Vec<rm::RouteRow> {
    let routes = summary.plan.scenario.identification.route;
    if !(routes.time() && routes.frf()) {
        return Vec::new();
    }
    let matrices = [
        (MatrixEstimate::Mass, "mass matrix"),
        (MatrixEstimate::Stiffness, "stiffness matrix"),
        (MatrixEstimate::DampingMkr, "damping matrix, MKR"),
        (MatrixEstimate::DampingRayleigh, "damping matrix, Rayleigh"),
    ];
    summary
        .levels
        .iter()
        .flat_map(|l| {
            matrices.iter().map(move |&(m, quantity)| {
                let errors = |key: ScoreKey| {
                    let stats = l.scores.get(&key);
                    rm::RouteErrors {
                        trials: stats.map_or(0, |s| s.n),
                        median: stats.and_then(|s| s.median).unwrap_or(f64::NAN),
                        rms: stats.map_or(f64::NAN, rms),
                        efficiency: l.efficiency.get(&key).copied().unwrap_or(f64::NAN),
                        median_se: stats.and_then(|s| s.median_se),
                        efficiency_se: l.efficiency_se.get(&key).copied(),
                    }
                };
                rm::RouteRow {
                    noise_level: l.noise,
                    quantity: quantity_at(summary, l, quantity),
                    time: errors(ScoreKey::Matrix(m)),
                    frf: errors(ScoreKey::Frf(FrfScore::Matrix(m))),
                }
            })
        })
        .collect()
}

/// The estimator and quantity a score column measures, for the efficiency
/// table.
fn estimator_of(key: ScoreKey) -> Option<(&'static str, String)> {
    let era = |refined: bool| if refined { "refined (ML)" } else { "ERA/DC" };
    match key {
        ScoreKey::Frequency { mode, refined } => {
            Some((era(refined), format!("natural frequency {mode}")))
        }
        ScoreKey::DampingRatio { mode, refined } => {
            Some((era(refined), format!("damping ratio {mode}")))
        }
        ScoreKey::Frf(score) => {
            let (estimator, quantity) = estimator_of(score.time_key())?;
            Some((
                match estimator {
                    "ERA/DC" => "pLSCF/LSFD (FRF)",
                    "MKR" => "MKR (FRF)",
                    "Rayleigh" => "Rayleigh (FRF)",
                    other => other,
                },
                quantity,
            ))
        }
        ScoreKey::Matrix(m) => Some(match m {
            MatrixEstimate::Mass => ("MKR", "mass matrix".into()),
            MatrixEstimate::Stiffness => ("MKR", "stiffness matrix".into()),
            MatrixEstimate::DampingMkr => ("MKR", "damping matrix".into()),
            MatrixEstimate::DampingRayleigh => ("Rayleigh", "damping matrix".into()),
            MatrixEstimate::MassRefined => ("refined (ML)", "mass matrix".into()),
            MatrixEstimate::StiffnessRefined => ("refined (ML)", "stiffness matrix".into()),
            MatrixEstimate::DampingRefined => ("refined (ML)", "damping matrix".into()),
        }),
        _ => None,
    }
}

/// Efficiency rows (bound / RMS error) of every panel, every level with a
/// bound.
fn efficiency_rows(summary: &Summary) -> Vec<rm::EfficiencyRow> {
    summary
        .levels
        .iter()
        .flat_map(|l| {
            summary.score_names.iter().filter_map(move |&name| {
                let eff = *l.efficiency.get(&name)?;
                let (estimator, quantity) = estimator_of(name)?;
                Some(rm::EfficiencyRow {
                    noise_level: l.noise,
                    estimator: estimator.into(),
                    quantity: quantity_at(summary, l, &quantity),
                    efficiency: eff,
                    se: l.efficiency_se.get(&name).copied(),
                })
            })
        })
        .collect()
}
