//! One Monte Carlo trial: simulate a campaign, identify it (and refine
//! it), and the Cramér–Rao bound of a scenario; the scores are in
//! [`crate::score`].

use ident::refine::{Refinement, Refiner, SecondOrder};
use ident::{Identification, Identifier, RefineError};
use nalgebra::DMatrix;
use sim::{Campaign, ModalProperties, Model, NoiseSettings, Simulator};

use crate::score::{Quantity, ScoreKey};

/// The model a campaign was simulated from and its modes.
#[derive(Debug, Clone)]
pub struct TrueModel {
    /// M, K and damping.
    pub model: Model,
    /// Its modes (the truth of the modal scores).
    pub modal: ModalProperties,
}

impl TrueModel {
    /// The model and its modes.
    pub fn new(model: Model) -> Result<Self, sim::SimError> {
        let modal = model.modal()?;
        Ok(TrueModel { model, modal })
    }

    /// Degrees of freedom (floors).
    pub fn dofs(&self) -> usize {
        self.model.dofs()
    }
}

/// Noise settings of a sweep level: the scenario's noise with its fraction
/// replaced by the level.
pub fn noise_at(base: &NoiseSettings, level: f64) -> NoiseSettings {
    NoiseSettings {
        fraction: level,
        ..base.clone()
    }
}

/// What one trial produced.
#[derive(Debug)]
pub struct TrialResult {
    /// The simulated campaign.
    pub campaign: Campaign,
    /// The identification of all its hits.
    pub identification: Result<Identification, ident::Error>,
    /// With a refiner: its result, started from MKR's M and K with the
    /// Rayleigh damping.
    pub refinement: Option<Result<Refinement, RefineError>>,
}

/// Simulates and identifies one campaign (and refines it with `refiner`).
pub fn run_trial(
    simulator: &Simulator,
    identifier: &Identifier,
    refiner: Option<&Refiner>,
    noise: &NoiseSettings,
    seed: u64,
) -> TrialResult {
    let campaign = simulator.simulate_with_noise(seed, noise);
    let data = campaign.to_ident();
    let identification = identifier.identify(&data.records, data.dt_s);
    let refinement = match (&identification, refiner) {
        (Ok(id), Some(r)) => Some(r.refine(
            &data.records,
            data.dt_s,
            &SecondOrder::from_identification(id),
        )),
        _ => None,
    };
    TrialResult {
        campaign,
        identification,
        refinement,
    }
}

/// The Cramér–Rao bound of a scenario at one noise level, as relative
/// standard deviations: per mode of f and xi, and of M, K and the damping
/// matrix as `sqrt(sum of entry variances) / ||true||_F` (the RMS of a
/// relative Frobenius error of an efficient unbiased estimator).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Bound {
    /// Per mode: relative standard deviation of the natural frequency.
    pub frequencies: Vec<f64>,
    /// Per mode: relative standard deviation of the damping ratio.
    pub damping_ratios: Vec<f64>,
    /// Mass matrix, relative (Frobenius).
    pub mass: f64,
    /// Stiffness matrix, relative (Frobenius).
    pub stiffness: f64,
    /// Damping matrix, relative (Frobenius).
    pub damping: f64,
}

impl Bound {
    /// The bound that applies to a score, if any: every estimator of a
    /// quantity (ERA/MKR, Rayleigh, refined) shares the quantity's bound.
    pub fn for_score(&self, key: ScoreKey) -> Option<f64> {
        match key {
            ScoreKey::Frequency { mode, .. } => self.frequencies.get(mode - 1).copied(),
            ScoreKey::DampingRatio { mode, .. } => self.damping_ratios.get(mode - 1).copied(),
            ScoreKey::Matrix(m) => Some(match m.quantity() {
                Quantity::Mass => self.mass,
                Quantity::Stiffness => self.stiffness,
                Quantity::Damping => self.damping,
            }),
            _ => None,
        }
    }
}

/// Computes the bound for the campaign of `seed` (its pulses, noise free)
/// with every channel's noise at `level` of its RMS over the campaign (plus
/// the scenario's absolute noise), for records as acquired.
pub fn cramer_rao_bound(
    simulator: &Simulator,
    refiner: &Refiner,
    intersample: ident::Intersample,
    truth: &TrueModel,
    noise: &NoiseSettings,
    seed: u64,
) -> Result<Bound, RefineError> {
    // Noise-free records: hammer pulses through the analyzer chain, or the
    // shaker's signal. (The hammer path stays the one the bound always
    // used: without channel errors, which bias but do not inform.)
    let hits: Vec<Vec<Vec<f64>>> = if simulator.settings().excitation.is_hammer() {
        simulator
            .draw_pulses(seed)
            .iter()
            .map(|p| simulator.clean_response(p))
            .collect()
    } else {
        simulator.clean_records(seed)
    };
    let channel_rms = |c: usize| {
        let all: Vec<f64> = hits.iter().flat_map(|h| h[c].iter().copied()).collect();
        sim::noise::rms(&all)
    };
    let n = truth.dofs();
    let levels = ident::refine::NoiseLevels {
        outputs: (1..=n)
            .map(|c| noise.sigma(channel_rms(c), false))
            .collect(),
        inputs: vec![noise.sigma(channel_rms(0), true)],
    };
    let inputs: Vec<DMatrix<f64>> = hits
        .iter()
        .map(|h| DMatrix::from_row_slice(1, h[0].len(), &h[0]))
        .collect();
    let model = &truth.model;
    let second_order = SecondOrder::new(
        model.mass.clone(),
        model.stiffness.clone(),
        model.damping.clone(),
    );
    let u = refiner.clone().intersample(intersample).cramer_rao(
        &second_order,
        simulator.settings().sampling.dt_s(),
        &inputs,
        &levels,
    )?;
    Ok(Bound {
        frequencies: u
            .modes
            .iter()
            .map(|m| m.frequency_std_hz / m.frequency_hz)
            .collect(),
        damping_ratios: u
            .modes
            .iter()
            .map(|m| m.damping_ratio_std / m.damping_ratio)
            .collect(),
        mass: u.mass_std.norm() / model.mass.norm(),
        stiffness: u.stiffness_std.norm() / model.stiffness.norm(),
        damping: u.damping_std.norm() / model.damping.norm(),
    })
}
