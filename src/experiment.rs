//! One Monte Carlo trial: simulate a campaign, identify it, score the
//! result against the model it was simulated from.

use ident::{Identification, Identifier, Record};
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
/// - `model_order`, `warnings`: what the identifier did.
pub fn score_names(dofs: usize) -> Vec<String> {
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
    names
}

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

/// Scores of one identification against the truth, aligned with
/// [`score_names`].
pub fn score(id: &Identification, truth: &TrueModel) -> Vec<f64> {
    let n = truth.dofs();
    assert_eq!(
        id.frequencies_hz.len(),
        n,
        "the identifier returns one mode per DOF"
    );
    let t = &truth.modal;
    let mut v = Vec::with_capacity(score_names(n).len());
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
        for i in 0..n {
            for j in i..n {
                v.push((e[(i, j)] - r[(i, j)]) / (r[(i, i)] * r[(j, j)]).abs().sqrt());
            }
        }
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

/// Simulates and identifies one campaign.
pub fn run_trial(
    simulator: &Simulator,
    identifier: &Identifier,
    noise: &NoiseSettings,
    seed: u64,
) -> (Campaign, Result<Identification, ident::Error>) {
    let campaign = simulator.simulate_with_noise(seed, noise);
    let result = identifier.identify(&campaign_records(&campaign), campaign.dt_s);
    (campaign, result)
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
        assert_eq!(score_names(2).len(), 3 * 2 + 4 + 4 * 3 + 3);
        assert_eq!(score_names(3).len(), 3 * 3 + 4 + 4 * 6 + 3);
    }
}
