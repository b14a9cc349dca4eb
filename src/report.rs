//! Turns sweep directories into the report's data model.

use std::path::Path;

use anyhow::{Context, Result, anyhow};
use reports::model as rm;
use sim::{Acquisition, DampingSpec};

use crate::format::sig;
use crate::representative::RepresentativeFile;
use crate::scenario::{Scenario, StructureSpec};
use crate::sweep::Summary;

/// Reads `summary.json` and (if present) `representative.json` of a sweep
/// directory and builds one study of the report.
pub fn study(dir: &Path) -> Result<rm::Study> {
    let path = dir.join("summary.json");
    let text = std::fs::read_to_string(&path).with_context(|| {
        format!(
            "{}: cannot read (a complete sweep directory, or merged shards?)",
            path.display()
        )
    })?;
    let summary: Summary = serde_json::from_str(&text)
        .with_context(|| format!("{}: not a sweep summary", path.display()))?;
    let rep_path = dir.join("representative.json");
    let representative = if rep_path.exists() {
        let text = std::fs::read_to_string(&rep_path)
            .with_context(|| format!("{}: cannot read", rep_path.display()))?;
        let file: RepresentativeFile = serde_json::from_str(&text)
            .with_context(|| format!("{}: not a representative campaign", rep_path.display()))?;
        Some(file.representative)
    } else {
        None
    };
    let scenario = &summary.plan.scenario;
    Ok(rm::Study {
        name: scenario.name.clone(),
        description: scenario.description.clone(),
        seed: summary.plan.seed,
        setup: setup_rows(&summary).map_err(|e| anyhow!("{}: {e}", path.display()))?,
        representative,
        accuracy: accuracy(&summary),
    })
}

/// A report of several sweep directories.
pub fn build(title: &str, command: &str, dirs: &[&Path]) -> Result<rm::Report> {
    Ok(rm::Report {
        title: title.into(),
        frameid_version: env!("CARGO_PKG_VERSION").into(),
        command: command.into(),
        studies: dirs.iter().map(|d| study(d)).collect::<Result<_>>()?,
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
fn setup_rows(summary: &Summary) -> Result<Vec<rm::SetupRow>> {
    let plan = &summary.plan;
    let s: &Scenario = &plan.scenario;
    let model = s.model().map_err(|e| anyhow!("{e}"))?;
    let modal = model.modal().map_err(|e| anyhow!("{e}"))?;
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
    rows.push(row(
        "Identification",
        format!(
            "OKID -> ERA/DC -> MKR, intersample {}, model order {}, observer order {}",
            match s.intersample() {
                ident::Intersample::Zoh => "zoh",
                ident::Intersample::Bandlimited => "bandlimited",
            },
            s.identification
                .order
                .map_or("automatic".into(), |o| o.to_string()),
            s.identification
                .observer_order
                .map_or("automatic".into(), |o| o.to_string())
        ),
    ));
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
fn describe(name: &str) -> Option<(String, String, String)> {
    let (base, refined) = match name.split_once("_refined") {
        Some((b, rest)) => (format!("{b}{rest}"), true),
        None => (name.to_string(), false),
    };
    let suffix = if refined { ", refined" } else { "" };
    let mode = |prefix: &str, tail: &str| {
        base.strip_prefix(prefix)
            .and_then(|r| r.strip_suffix(tail))
            .and_then(|j| j.parse::<usize>().ok())
    };
    let rel = "relative error".to_string();
    let fro = "relative Frobenius error".to_string();
    if let Some(j) = mode("f", "_err") {
        return Some((
            format!("Natural frequency f{j}{suffix}"),
            rel,
            "frequency".into(),
        ));
    }
    if let Some(j) = mode("xi", "_err") {
        return Some((
            format!("Damping ratio xi{j}{suffix}"),
            rel,
            "damping ratio".into(),
        ));
    }
    if let Some(j) = mode("mac", "_defect") {
        return Some((
            format!("Mode shape {j}{suffix}: 1 - MAC"),
            "1 - MAC".into(),
            "mode shape".into(),
        ));
    }
    let (label, group) = match (base.as_str(), refined) {
        ("mass_err", _) => ("Mass matrix M", "matrices"),
        ("stiffness_err", _) => ("Stiffness matrix K", "matrices"),
        ("damping_mkr_err", false) => ("Damping, MKR", "damping matrices"),
        ("damping_rayleigh_err", false) => ("Damping, Rayleigh", "damping matrices"),
        ("damping_err", true) => ("Damping, refined (maximum likelihood)", "damping matrices"),
        ("consistency", false) => {
            return Some((
                "Second-order consistency ||W W^T|| / ||W L W^T||".into(),
                "ratio".into(),
                "diagnostics".into(),
            ));
        }
        _ => return None,
    };
    let label = if refined && group == "matrices" {
        format!("{label}, refined")
    } else {
        label.to_string()
    };
    Some((label, fro, group.into()))
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
            let series =
                |name: &str, pick: fn(&crate::sweep::stats::Stats) -> Option<f64>| -> Vec<f64> {
                    levels
                        .iter()
                        .map(|l| l.scores.get(name).and_then(pick).unwrap_or(f64::NAN))
                        .collect()
                };
            let quantities = summary
                .score_names
                .iter()
                .filter_map(|name| {
                    describe(name).map(|(label, unit, group)| rm::Quantity {
                        key: name.clone(),
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
    }
}

/// The estimator and quantity a score column measures, for the efficiency
/// table.
fn estimator_of(name: &str) -> Option<(&'static str, String)> {
    let modal = |prefix: &str, what: &str| -> Option<(&'static str, String)> {
        let rest = name.strip_prefix(prefix)?;
        if let Some(j) = rest.strip_suffix("_refined_err") {
            return Some(("refined (ML)", format!("{what} {j}")));
        }
        rest.strip_suffix("_err")
            .map(|j| ("ERA/DC", format!("{what} {j}")))
    };
    modal("f", "natural frequency")
        .or_else(|| modal("xi", "damping ratio"))
        .or(match name {
            "mass_err" => Some(("MKR", "mass matrix".into())),
            "stiffness_err" => Some(("MKR", "stiffness matrix".into())),
            "damping_mkr_err" => Some(("MKR", "damping matrix".into())),
            "damping_rayleigh_err" => Some(("Rayleigh", "damping matrix".into())),
            "mass_refined_err" => Some(("refined (ML)", "mass matrix".into())),
            "stiffness_refined_err" => Some(("refined (ML)", "stiffness matrix".into())),
            "damping_refined_err" => Some(("refined (ML)", "damping matrix".into())),
            _ => None,
        })
}

/// Efficiency rows (bound / RMS error) of the first panel, every level with
/// a bound.
fn efficiency_rows(summary: &Summary) -> Vec<rm::EfficiencyRow> {
    let first_axis = summary.levels.first().map(|l| l.axis_value.clone());
    summary
        .levels
        .iter()
        .filter(|l| Some(l.axis_value.clone()) == first_axis)
        .flat_map(|l| {
            summary.score_names.iter().filter_map(move |name| {
                let eff = *l.efficiency.get(name)?;
                let (estimator, quantity) = estimator_of(name)?;
                Some(rm::EfficiencyRow {
                    noise_level: l.noise,
                    estimator: estimator.into(),
                    quantity,
                    efficiency: eff,
                })
            })
        })
        .collect()
}
