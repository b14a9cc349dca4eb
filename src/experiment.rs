//! One Monte Carlo trial: simulate a campaign, identify it, score the
//! result against the model it was simulated from.

use ident::refine::{Refinement, Refiner, SecondOrder};
use ident::{Identification, Identifier, Record, RefineError};
use nalgebra::DMatrix;
use num_complex::Complex64;
use sim::{Campaign, ModalProperties, Model, NoiseSettings, Simulator};

/// The model a campaign was simulated from and its modes.
#[derive(Debug, Clone)]
pub struct TrueModel {
    pub model: Model,
    pub modal: ModalProperties,
}

impl TrueModel {
    pub fn new(model: Model) -> Result<Self, sim::SimError> {
        let modal = model.modal()?;
        Ok(TrueModel { model, modal })
    }

    pub fn dofs(&self) -> usize {
        self.model.dofs()
    }
}

/// The hits of a campaign as identifier records (force as the one input,
/// accelerations of every floor as outputs).
pub fn campaign_records(c: &Campaign) -> Vec<Record> {
    c.hits
        .iter()
        .map(|h| {
            let n = h.force.len();
            let inputs = DMatrix::from_row_slice(1, n, &h.force);
            let outputs = DMatrix::from_fn(h.accelerations.len(), n, |i, k| h.accelerations[i][k]);
            Record::new(inputs, outputs)
        })
        .collect()
}

/// Names of the scores of a trial, for `dofs` floors, in column order.
///
/// - `f{j}_err`, `xi{j}_err`: |relative error| of the natural frequency and
///   damping ratio of mode j (ascending frequency);
/// - `mac{j}_defect`: 1 - MAC between identified and true mode shape j;
/// - `mass_err`, `stiffness_err`, `damping_mkr_err`, `damping_rayleigh_err`:
///   relative Frobenius errors;
/// - `mass_{i}{j}_err` ... (i <= j, 1-based): signed entry errors
///   `(est_ij - true_ij) / sqrt(true_ii true_jj)`, the diagonal-scaled error
///   (the relative error on the diagonal, well defined where true_ij = 0);
/// - `consistency`: MKR's ||W W^T|| / ||W L W^T||;
/// - `model_order`, `warnings`: what the identifier did;
/// - with `refine`, the same for the maximum-likelihood refinement
///   (`f{j}_refined_err`, ..., `mass_refined_err`, `stiffness_refined_err`,
///   `damping_refined_err`, entries `damping_refined_{i}{j}_err`, ...), the
///   standard errors it reports as relative Frobenius norms
///   (`mass_refined_se` ...: sqrt(sum of entry variances) / ||true||),
///   `refine_failed` (0 or 1) and `refine_iterations`.
pub fn score_names(dofs: usize, refine: bool) -> Vec<String> {
    let mut names = Vec::new();
    for j in 1..=dofs {
        names.push(format!("f{j}_err"));
    }
    for j in 1..=dofs {
        names.push(format!("xi{j}_err"));
    }
    for j in 1..=dofs {
        names.push(format!("mac{j}_defect"));
    }
    for m in MATRICES {
        names.push(format!("{m}_err"));
    }
    for m in MATRICES {
        for i in 1..=dofs {
            for j in i..=dofs {
                names.push(format!("{m}_{i}{j}_err"));
            }
        }
    }
    names.extend(["consistency", "model_order", "warnings"].map(String::from));
    if refine {
        for j in 1..=dofs {
            names.push(format!("f{j}_refined_err"));
        }
        for j in 1..=dofs {
            names.push(format!("xi{j}_refined_err"));
        }
        for j in 1..=dofs {
            names.push(format!("mac{j}_refined_defect"));
        }
        for m in REFINED {
            names.push(format!("{m}_refined_err"));
        }
        for m in REFINED {
            for i in 1..=dofs {
                for j in i..=dofs {
                    names.push(format!("{m}_refined_{i}{j}_err"));
                }
            }
        }
        for m in REFINED {
            names.push(format!("{m}_refined_se"));
        }
        names.extend(["refine_failed", "refine_iterations"].map(String::from));
    }
    names
}

/// The matrices of the refined model, as named in score columns.
pub const REFINED: [&str; 3] = ["mass", "stiffness", "damping"];

/// The matrices scored, as named in score columns.
pub const MATRICES: [&str; 4] = ["mass", "stiffness", "damping_mkr", "damping_rayleigh"];

/// Relative Frobenius distance `||a - b|| / ||b||`.
pub fn rel_fro(a: &DMatrix<f64>, b: &DMatrix<f64>) -> f64 {
    (a - b).norm() / b.norm()
}

/// Modal assurance criterion of two complex shapes.
pub fn mac(a: &[Complex64], b: &[Complex64]) -> f64 {
    let dot: Complex64 = a.iter().zip(b).map(|(x, y)| x.conj() * y).sum();
    let na: f64 = a.iter().map(|x| x.norm_sqr()).sum();
    let nb: f64 = b.iter().map(|x| x.norm_sqr()).sum();
    dot.norm_sqr() / (na * nb)
}

/// Scores of one identification (and its refinement, if one was run)
/// against the truth, aligned with [`score_names`].
pub fn score(
    id: &Identification,
    refined: Option<&Result<Refinement, RefineError>>,
    truth: &TrueModel,
) -> Vec<f64> {
    let mut v = score_identification(id, truth);
    match refined {
        None => {}
        Some(Ok(r)) => v.extend(score_refinement(r, truth)),
        Some(Err(_)) => {
            // Every refined score NaN, then `refine_failed` = 1 and no
            // iteration count (the last two columns).
            let n = truth.dofs();
            let refined = score_names(n, true).len() - score_names(n, false).len();
            v.extend(std::iter::repeat_n(f64::NAN, refined - 2));
            v.extend([1.0, f64::NAN]);
        }
    }
    v
}

/// Signed entry errors `(est_ij - true_ij) / sqrt(true_ii true_jj)`, i <= j.
fn entry_errors(est: &DMatrix<f64>, truth: &DMatrix<f64>) -> impl Iterator<Item = f64> {
    let n = truth.nrows();
    (0..n).flat_map(move |i| {
        (i..n).map(move |j| {
            (est[(i, j)] - truth[(i, j)]) / (truth[(i, i)] * truth[(j, j)]).abs().sqrt()
        })
    })
}

fn score_refinement(r: &Refinement, truth: &TrueModel) -> Vec<f64> {
    let n = truth.dofs();
    let t = &truth.modal;
    let modes = &r.uncertainty.modes;
    let mut v = Vec::new();
    for j in 0..n {
        v.push(modes.get(j).map_or(f64::NAN, |m| {
            (m.frequency_hz / t.frequencies_hz[j] - 1.0).abs()
        }));
    }
    for j in 0..n {
        v.push(modes.get(j).map_or(f64::NAN, |m| {
            (m.damping_ratio / t.damping_ratios[j] - 1.0).abs()
        }));
    }
    for j in 0..n {
        v.push(modes.get(j).map_or(f64::NAN, |m| {
            let shape: Vec<Complex64> = m.shape.iter().copied().collect();
            1.0 - mac(&shape, &t.mode_shapes[j])
        }));
    }
    let estimates = [&r.mass, &r.stiffness, &r.damping];
    let references = [
        &truth.model.mass,
        &truth.model.stiffness,
        &truth.model.damping,
    ];
    for (e, t) in estimates.iter().zip(references) {
        v.push(rel_fro(e, t));
    }
    for (e, t) in estimates.iter().zip(references) {
        v.extend(entry_errors(e, t));
    }
    let u = &r.uncertainty;
    for (std, t) in [&u.mass_std, &u.stiffness_std, &u.damping_std]
        .iter()
        .zip(references)
    {
        v.push(std.norm() / t.norm());
    }
    v.push(0.0);
    v.push(r.iterations as f64);
    v
}

fn score_identification(id: &Identification, truth: &TrueModel) -> Vec<f64> {
    let n = truth.dofs();
    assert_eq!(
        id.frequencies_hz.len(),
        n,
        "the identifier returns one mode per DOF"
    );
    let t = &truth.modal;
    let mut v = Vec::with_capacity(score_names(n, false).len());
    for j in 0..n {
        v.push((id.frequencies_hz[j] / t.frequencies_hz[j] - 1.0).abs());
    }
    for j in 0..n {
        v.push((id.damping_ratios[j] / t.damping_ratios[j] - 1.0).abs());
    }
    for j in 0..n {
        let shape: Vec<Complex64> = id.mode_shapes.column(j).iter().copied().collect();
        v.push(1.0 - mac(&shape, &t.mode_shapes[j]));
    }
    let estimates = [
        &id.mass,
        &id.stiffness,
        &id.damping_mkr,
        &id.damping_rayleigh,
    ];
    let references = [
        &truth.model.mass,
        &truth.model.stiffness,
        &truth.model.damping,
        &truth.model.damping,
    ];
    for (e, r) in estimates.iter().zip(references) {
        v.push(rel_fro(e, r));
    }
    for (e, r) in estimates.iter().zip(references) {
        v.extend(entry_errors(e, r));
    }
    v.push(id.consistency);
    v.push(id.model_order as f64);
    v.push(id.warnings.len() as f64);
    v
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
    pub campaign: Campaign,
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
    let records = campaign_records(&campaign);
    let identification = identifier.identify(&records, campaign.dt_s);
    let refinement = match (&identification, refiner) {
        (Ok(id), Some(r)) => Some(r.refine(&records, campaign.dt_s, &initial_model(id))),
        _ => None,
    };
    TrialResult {
        campaign,
        identification,
        refinement,
    }
}

/// The refinement's starting point: MKR's M and K with the Rayleigh damping
/// (the MKR damping is far off at any noise, see NOTES).
pub fn initial_model(id: &Identification) -> SecondOrder {
    SecondOrder::new(
        id.mass.clone(),
        id.stiffness.clone(),
        id.damping_rayleigh.clone(),
    )
}

/// The Cramér–Rao bound of a scenario at one noise level, as relative
/// standard deviations: per mode of f and xi, and of M, K and the damping
/// matrix as `sqrt(sum of entry variances) / ||true||_F` (the RMS of a
/// relative Frobenius error of an efficient unbiased estimator).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Bound {
    pub frequencies: Vec<f64>,
    pub damping_ratios: Vec<f64>,
    pub mass: f64,
    pub stiffness: f64,
    pub damping: f64,
}

impl Bound {
    /// The bound that applies to a score column, if any: every estimator of
    /// a quantity (ERA/MKR, Rayleigh, refined) shares the quantity's bound.
    pub fn for_score(&self, name: &str) -> Option<f64> {
        let mode = |prefix: &str| -> Option<usize> {
            let rest = name.strip_prefix(prefix)?;
            let j = rest
                .strip_suffix("_refined_err")
                .or_else(|| rest.strip_suffix("_err"))?;
            j.parse::<usize>().ok().filter(|&j| j >= 1)
        };
        if let Some(j) = mode("f") {
            return self.frequencies.get(j - 1).copied();
        }
        if let Some(j) = mode("xi") {
            return self.damping_ratios.get(j - 1).copied();
        }
        match name {
            "mass_err" | "mass_refined_err" => Some(self.mass),
            "stiffness_err" | "stiffness_refined_err" => Some(self.stiffness),
            "damping_mkr_err" | "damping_rayleigh_err" | "damping_refined_err" => {
                Some(self.damping)
            }
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
    let hits: Vec<Vec<Vec<f64>>> = simulator
        .draw_pulses(seed)
        .iter()
        .map(|p| simulator.clean_response(p))
        .collect();
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mac_of_collinear_shapes_is_one() {
        let a = vec![Complex64::new(1.0, 0.0), Complex64::new(-0.5, 0.1)];
        let b: Vec<Complex64> = a.iter().map(|x| x * Complex64::new(0.3, -2.0)).collect();
        assert!((mac(&a, &b) - 1.0).abs() < 1e-15);
        let c = vec![Complex64::new(0.5, 0.0), Complex64::new(1.0, 0.0)];
        let d = vec![Complex64::new(-1.0, 0.0), Complex64::new(0.5, 0.0)];
        assert!(mac(&c, &d) < 1e-15);
    }

    #[test]
    fn score_names_match_score_length() {
        assert_eq!(score_names(2, false).len(), 3 * 2 + 4 + 4 * 3 + 3);
        assert_eq!(score_names(3, false).len(), 3 * 3 + 4 + 4 * 6 + 3);
        // Refined: 3 per mode, 3 Frobenius, 3 x entries, 3 SEs, 2 counters.
        assert_eq!(
            score_names(2, true).len() - score_names(2, false).len(),
            3 * 2 + 3 + 3 * 3 + 3 + 2
        );
    }
}
