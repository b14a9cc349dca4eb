//! One Monte Carlo trial: simulate a campaign, identify it by the time
//! route (and refine it) and/or the FRF route ([`FrfRoute`]), and the
//! Cramér–Rao bound of a scenario; the scores are in [`crate::score`].

use ident::frf::FrfIdentification;
use ident::frf::estimate::FrfParams;
use ident::refine::{Refinement, Refiner, SecondOrder};
use ident::{Identification, Identifier, RefineError};
use nalgebra::DMatrix;
use rayon::prelude::*;
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

/// The FRF route: FRFs estimated from the hits of a campaign, then pLSCF,
/// LSFD and MKR. The exponential window's time constant, known once the
/// records' length is, goes from the estimate to the identifier.
#[derive(Debug, Clone, PartialEq)]
pub struct FrfRoute {
    /// FRF estimation (estimator, averaging across hits, windows, band).
    pub estimation: FrfParams,
    /// pLSCF, LSFD and MKR (its `exponential_tau_s` is replaced by the
    /// estimate's).
    pub identifier: ident::frf::FrfIdentifier,
}

/// Why the FRF route failed. The messages are self-contained (the error of
/// `ident` is kept as a field, not chained).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum FrfRouteError {
    /// The FRFs could not be estimated from the records.
    #[error("FRF estimation: {error}")]
    Estimate {
        /// The estimator's error (names the record, channel or line).
        error: ident::frf::estimate::FrfEstimateError,
    },
    /// The FRFs could not be identified.
    #[error("FRF identification: {error}")]
    Identify {
        /// The identifier's error.
        error: ident::frf::FrfIdentError,
    },
}

impl FrfRoute {
    /// Estimates the FRFs of `records` (forces and accelerations sampled
    /// every `dt_s` seconds) and identifies M, K and damping from them.
    pub fn identify(
        &self,
        records: &[ident::Record],
        dt_s: f64,
    ) -> Result<FrfIdentification, FrfRouteError> {
        let estimate = self
            .estimation
            .estimate(records, dt_s)
            .map_err(|error| FrfRouteError::Estimate { error })?;
        let identifier = ident::frf::FrfIdentifier {
            exponential_tau_s: estimate.windows.exponential_tau_s,
            ..self.identifier.clone()
        };
        identifier
            .identify(&estimate.frf)
            .map_err(|error| FrfRouteError::Identify { error })
    }
}

/// The routes a trial runs.
#[derive(Debug, Clone, Copy)]
pub struct Routes<'a> {
    /// The time route's identifier, if it runs.
    pub time: Option<&'a Identifier>,
    /// The refiner of the time route's estimate, if it runs.
    pub refiner: Option<&'a Refiner>,
    /// The FRF route, if it runs.
    pub frf: Option<&'a FrfRoute>,
}

/// What one trial produced.
#[derive(Debug)]
pub struct TrialResult {
    /// The simulated campaign.
    pub campaign: Campaign,
    /// The time route's identification of all its hits (`None` if that
    /// route did not run).
    pub identification: Option<Result<Identification, ident::Error>>,
    /// With a refiner: its result, started from MKR's M and K with the
    /// Rayleigh damping.
    pub refinement: Option<Result<Refinement, RefineError>>,
    /// The FRF route's identification of the same hits (`None` if that
    /// route did not run).
    pub frf: Option<Result<FrfIdentification, FrfRouteError>>,
}

/// Simulates one campaign and identifies it by the routes set (refining
/// the time route's estimate with `routes.refiner`); every route sees the
/// same records.
pub fn run_trial(
    simulator: &Simulator,
    routes: Routes<'_>,
    noise: &NoiseSettings,
    seed: u64,
) -> TrialResult {
    let campaign = simulator.simulate_with_noise(seed, noise);
    let data = campaign.to_ident();
    let identification = routes
        .time
        .map(|identifier| identifier.identify(&data.records, data.dt_s));
    let refinement = match (&identification, routes.refiner) {
        (Some(Ok(id)), Some(r)) => Some(r.refine(
            &data.records,
            data.dt_s,
            &SecondOrder::from_identification(id),
        )),
        _ => None,
    };
    let frf = routes
        .frf
        .map(|route| route.identify(&data.records, data.dt_s));
    TrialResult {
        campaign,
        identification,
        refinement,
        frf,
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
    /// Whether every value is a finite number > 0 (a relative standard
    /// deviation): not so when a true value it is relative to is zero.
    pub fn is_usable(&self) -> bool {
        self.frequencies
            .iter()
            .chain(&self.damping_ratios)
            .chain([&self.mass, &self.stiffness, &self.damping])
            .all(|&x| x.is_finite() && x > 0.0)
    }

    /// The bound that applies to a score, if any: every estimator of a
    /// quantity (ERA/MKR, Rayleigh, refined, either route) shares the
    /// quantity's bound.
    pub fn for_score(&self, key: ScoreKey) -> Option<f64> {
        match key {
            ScoreKey::Frequency { mode, .. } => self.frequencies.get(mode - 1).copied(),
            ScoreKey::DampingRatio { mode, .. } => self.damping_ratios.get(mode - 1).copied(),
            ScoreKey::Matrix(m) => Some(match m.quantity() {
                Quantity::Mass => self.mass,
                Quantity::Stiffness => self.stiffness,
                Quantity::Damping => self.damping,
            }),
            ScoreKey::Frf(s) => self.for_score(s.time_key()),
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
        // Hits in parallel (each response is its own numbers).
        simulator
            .draw_pulses(seed)
            .par_iter()
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
