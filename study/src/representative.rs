//! One representative campaign of a scenario, identified and compared with
//! the truth, as the report shows it: time histories (the paper's Figs.
//! 2-3), Hankel singular values (Fig. 4), mode shapes (Fig. 5), a
//! stabilization diagram, measured against identified FRFs, and tables.

use ident::pipeline::StabilizationCriteria;
use ident::refine::SecondOrder;
use ident::{Jackknife, jackknife};
use nalgebra::DMatrix;
use num_complex::Complex64;
use records::quality::{QualitySettings, assess_campaign};
use reports::model as rm;
use rustfft::FftPlanner;
use serde::{Deserialize, Serialize};
use sim::{Campaign, Model, derive_seed};

use crate::campaign_report::{accelerance, hit_quality_rows, stabilization_point};
use crate::experiment::{TrueModel, noise_at};
use crate::scenario::Scenario;

/// The representative campaign's data (`representative.json`).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RepresentativeFile {
    /// Seed of the campaign.
    pub seed: u64,
    /// What the report shows of it.
    pub representative: rm::Representative,
}

/// Why the representative campaign could not be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum RepresentativeError {
    /// The simulator refused the scenario.
    #[error("{scenario}: {error}")]
    Simulation {
        /// The scenario's name.
        scenario: String,
        /// The simulator's error.
        error: sim::SimError,
    },
    /// The campaign could not be identified.
    #[error("representative campaign of {scenario}: {error}")]
    Identification {
        /// The scenario's name.
        scenario: String,
        /// The identifier's error.
        error: ident::Error,
    },
    /// The stabilization diagram could not be computed.
    #[error("stabilization diagram of {scenario}: {error}")]
    Stabilization {
        /// The scenario's name.
        scenario: String,
        /// The identifier's error.
        error: ident::Error,
    },
}

/// Largest model order of the stabilization diagram.
const STABILIZATION_MAX_ORDER: usize = 24;

/// Simulates the representative campaign (seed derived from the sweep
/// seed, the scenario's own noise) and identifies it.
pub fn representative(
    scenario: &Scenario,
    truth: &TrueModel,
    sweep_seed: u64,
) -> Result<RepresentativeFile, RepresentativeError> {
    // The campaign whose pulses the sweep's Cramér–Rao bound is computed for.
    let seed = derive_seed(sweep_seed, crate::sweep::BOUND_TAG);
    let name = || scenario.name.clone();
    let simulator = scenario.simulator(truth.model.clone()).map_err(|error| {
        RepresentativeError::Simulation {
            scenario: name(),
            error,
        }
    })?;
    let noise = noise_at(&scenario.campaign.noise, scenario.campaign.noise.fraction);
    let campaign = simulator.simulate_with_noise(seed, &noise);
    let data = campaign.to_ident();
    let identifier = scenario.identifier();
    let id = identifier
        .identify(&data.records, data.dt_s)
        .map_err(|error| RepresentativeError::Identification {
            scenario: name(),
            error,
        })?;
    let stabilization = identifier
        .check()
        .and_then(|v| {
            v.stabilization(
                &data.records,
                data.dt_s,
                STABILIZATION_MAX_ORDER,
                StabilizationCriteria::default(),
            )
        })
        .map_err(|error| RepresentativeError::Stabilization {
            scenario: name(),
            error,
        })?;
    let n = truth.dofs();
    let input = scenario.campaign.hammer.floor - 1;
    let modes = (0..n)
        .map(|j| rm::ModeShape {
            frequency_hz: id.frequencies_hz[j],
            damping_ratio: id.damping_ratios[j],
            shape: id
                .mode_shapes
                .column(j)
                .iter()
                .map(|z| [z.re, z.im])
                .collect(),
            truth: Some(
                truth.modal.mode_shapes[j]
                    .iter()
                    .map(|z| [z.re, z.im])
                    .collect(),
            ),
        })
        .collect();
    let stabilization = stabilization.iter().map(stabilization_point).collect();
    let identified = Model {
        mass: id.mass.clone(),
        stiffness: id.stiffness.clone(),
        damping: id.damping_rayleigh.clone(),
    };
    let frf = frfs(&campaign, &identified, &truth.model, input);
    let hit_quality = hit_quality_rows(&assess_campaign(&data, &QualitySettings::default()));
    // Error bars from the hits themselves (leave-one-out); a campaign too
    // small or too noisy for them still gets its tables.
    let spread = jackknife(&identifier, &data, &id).ok();
    let refined = scenario.identification.refine.then(|| {
        scenario.refiner().refine(
            &data.records,
            data.dt_s,
            &SecondOrder::from_identification(&id),
        )
    });
    let mut warnings: Vec<String> = id.warnings.iter().map(ToString::to_string).collect();
    let mut tables = tables(&id, truth, spread.as_ref());
    match &refined {
        Some(Ok(r)) => tables.extend(refined_tables(r, truth)),
        Some(Err(e)) => warnings.push(format!("refinement failed: {e}")),
        None => {}
    }
    Ok(RepresentativeFile {
        seed,
        representative: rm::Representative {
            noise_fraction: noise.fraction,
            dt_s: campaign.dt_s,
            hit_floor: campaign.hit_floor,
            force: campaign.hits[0].force.clone(),
            accelerations: campaign.hits[0].accelerations.clone(),
            hankel_singular_values: id.hankel_singular_values.iter().copied().collect(),
            order: id.model_order,
            modes,
            stabilization,
            frf,
            tables,
            warnings,
            hit_quality,
        },
    })
}

/// Acceleration FRF of a model at `omega` (rad/s) for a force at `input`:
/// `-omega^2 (K - omega^2 M + i omega R)^-1 e_input`.
pub fn model_frf(model: &Model, input: usize, omega: f64) -> Vec<Complex64> {
    accelerance(&model.mass, &model.stiffness, &model.damping, input, omega)
}

/// H1 estimates from all hits (sum Y U* / sum |U|^2) against the
/// identified and true models, up to 0.8 of the Nyquist frequency.
fn frfs(c: &Campaign, identified: &Model, truth: &Model, input: usize) -> Vec<rm::Frf> {
    let n = c.hits[0].force.len();
    let fft = FftPlanner::<f64>::new().plan_fft_forward(n);
    let spectrum = |x: &[f64]| {
        let mut b: Vec<Complex64> = x.iter().map(|&v| Complex64::new(v, 0.0)).collect();
        fft.process(&mut b);
        b
    };
    let fs = 1.0 / c.dt_s;
    let kmax = ((0.8 * fs / 2.0) / (fs / n as f64)).floor() as usize;
    let bins: Vec<usize> = (1..=kmax.min(n / 2)).collect();
    let dofs = c.hits[0].accelerations.len();
    let mut num = vec![vec![Complex64::new(0.0, 0.0); bins.len()]; dofs];
    let mut den = vec![0.0; bins.len()];
    for h in &c.hits {
        let u = spectrum(&h.force);
        for (b, &k) in bins.iter().enumerate() {
            den[b] += u[k].norm_sqr();
        }
        for (i, acc) in h.accelerations.iter().enumerate() {
            let y = spectrum(acc);
            for (b, &k) in bins.iter().enumerate() {
                num[i][b] += y[k] * u[k].conj();
            }
        }
    }
    let freqs: Vec<f64> = bins.iter().map(|&k| k as f64 * fs / n as f64).collect();
    let model_at = |m: &Model| -> Vec<Vec<Complex64>> {
        freqs
            .iter()
            .map(|f| model_frf(m, input, 2.0 * std::f64::consts::PI * f))
            .collect()
    };
    let (hid, htrue) = (model_at(identified), model_at(truth));
    let pair = |z: Complex64| [z.re, z.im];
    (0..dofs)
        .map(|i| rm::Frf {
            output: format!("acc{} / force", i + 1),
            frequency_hz: freqs.clone(),
            measured: (0..bins.len()).map(|b| pair(num[i][b] / den[b])).collect(),
            identified: hid.iter().map(|h| pair(h[i])).collect(),
            truth: Some(htrue.iter().map(|h| pair(h[i])).collect()),
            reference: None,
            coherence: None,
        })
        .collect()
}

/// Rows `{prefix}ij` (i <= j) of a matrix against the truth, with the
/// standard deviation `std(i, j)` where known.
fn matrix_rows(
    prefix: &str,
    est: &DMatrix<f64>,
    truth: &DMatrix<f64>,
    std: impl Fn(usize, usize) -> Option<f64>,
) -> Vec<rm::ComparisonRow> {
    let n = truth.nrows();
    let mut rows = Vec::new();
    for i in 0..n {
        for j in i..n {
            rows.push(rm::ComparisonRow {
                label: format!("{prefix}{}{}", i + 1, j + 1),
                truth: truth[(i, j)],
                identified: est[(i, j)],
                std: std(i, j),
            });
        }
    }
    rows
}

fn tables(
    id: &ident::Identification,
    truth: &TrueModel,
    spread: Option<&Jackknife>,
) -> Vec<rm::ComparisonTable> {
    let n = truth.dofs();
    let table = |title: &str, unit: &str, rows| rm::ComparisonTable {
        title: title.into(),
        unit: unit.into(),
        rows,
    };
    let mode_rows =
        |label: &str, scale: f64, truth: &[f64], est: &[f64], std: Option<&Vec<f64>>| {
            (0..n)
                .map(|j| rm::ComparisonRow {
                    label: format!("{label}{}", j + 1),
                    truth: scale * truth[j],
                    identified: scale * est[j],
                    std: std.map(|s| scale * s[j]),
                })
                .collect()
        };
    vec![
        table(
            "Natural frequencies",
            "Hz",
            mode_rows(
                "f",
                1.0,
                &truth.modal.frequencies_hz,
                &id.frequencies_hz,
                spread.map(|s| &s.frequencies_hz.std),
            ),
        ),
        table(
            "Damping ratios",
            "%",
            mode_rows(
                "xi",
                100.0,
                &truth.modal.damping_ratios,
                &id.damping_ratios,
                spread.map(|s| &s.damping_ratios.std),
            ),
        ),
        table(
            "Mass matrix M",
            "kg",
            matrix_rows("M", &id.mass, &truth.model.mass, |i, j| {
                spread.map(|s| s.mass.std[i][j])
            }),
        ),
        table(
            "Stiffness matrix K",
            "N/m",
            matrix_rows("K", &id.stiffness, &truth.model.stiffness, |i, j| {
                spread.map(|s| s.stiffness.std[i][j])
            }),
        ),
        table(
            "Damping matrix, MKR (eq. 30)",
            "N s/m",
            matrix_rows("R", &id.damping_mkr, &truth.model.damping, |i, j| {
                spread.map(|s| s.damping_mkr.std[i][j])
            }),
        ),
        table(
            "Damping matrix, Rayleigh alpha M + beta K (eq. 16-19)",
            "N s/m",
            matrix_rows("R", &id.damping_rayleigh, &truth.model.damping, |i, j| {
                spread.map(|s| s.damping_rayleigh.std[i][j])
            }),
        ),
    ]
}

/// Tables of the maximum-likelihood refinement, with the standard errors it
/// reports (from the Fisher information at its optimum).
fn refined_tables(r: &ident::refine::Refinement, truth: &TrueModel) -> Vec<rm::ComparisonTable> {
    let n = truth.dofs();
    let u = &r.uncertainty;
    let modes = |label: &str,
                 scale: f64,
                 truth: &[f64],
                 pick: fn(&ident::refine::ModalEstimate) -> (f64, f64)| {
        (0..n.min(u.modes.len()))
            .map(|j| {
                let (value, std) = pick(&u.modes[j]);
                rm::ComparisonRow {
                    label: format!("{label}{}", j + 1),
                    truth: scale * truth[j],
                    identified: scale * value,
                    std: Some(scale * std),
                }
            })
            .collect()
    };
    let matrix = |prefix: &str, est: &DMatrix<f64>, std: &DMatrix<f64>, truth: &DMatrix<f64>| {
        matrix_rows(prefix, est, truth, |i, j| Some(std[(i, j)]))
    };
    let table = |title: &str, unit: &str, rows| rm::ComparisonTable {
        title: title.into(),
        unit: unit.into(),
        rows,
    };
    vec![
        table(
            "Natural frequencies, refined (ML)",
            "Hz",
            modes("f", 1.0, &truth.modal.frequencies_hz, |m| {
                (m.frequency_hz, m.frequency_std_hz)
            }),
        ),
        table(
            "Damping ratios, refined (ML)",
            "%",
            modes("xi", 100.0, &truth.modal.damping_ratios, |m| {
                (m.damping_ratio, m.damping_ratio_std)
            }),
        ),
        table(
            "Mass matrix M, refined (ML)",
            "kg",
            matrix("M", &r.mass, &u.mass_std, &truth.model.mass),
        ),
        table(
            "Stiffness matrix K, refined (ML)",
            "N/m",
            matrix("K", &r.stiffness, &u.stiffness_std, &truth.model.stiffness),
        ),
        table(
            "Damping matrix, refined (ML)",
            "N s/m",
            matrix("R", &r.damping, &u.damping_std, &truth.model.damping),
        ),
    ]
}
