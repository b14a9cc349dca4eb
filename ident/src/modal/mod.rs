//! Modal parameters of a discrete realization and accuracy indicators.
//!
//! The eigendecomposition `A Psi = Psi Lambda` gives the discrete eigenvalues `lambda`, the
//! continuous poles `lambda_c = ln(lambda) / dt` (rad/s), natural frequencies
//! `|lambda_c| / (2 pi)` (Hz) and damping ratios `-Re(lambda_c) / |lambda_c|` (paper eq. 15),
//! the output shapes `C psi` and the discrete modal inputs `b_d = (Psi^-1 B)_j`.
//!
//! # Intersample assumption
//!
//! The continuous modal input `b_c` (and so the residues `C psi b_c^T` used by MKR) depends on
//! what the input did between samples:
//!
//! * [`Intersample::Zoh`]: the input is held over each sample (the paper's assumption):
//!   `b_c = b_d lambda_c / (lambda - 1)`.
//! * [`Intersample::Bandlimited`]: the records are band-limited (anti-alias filtered, then
//!   sampled), so the discrete impulse response is `dt` times the sampled continuous one
//!   (impulse invariance): `b_c = b_d / (dt lambda)`.
//!
//! # Indicators
//!
//! * EMAC (extended modal amplitude coherence, Juang and Pappa): how well each mode's
//!   history is predicted across the Hankel matrix. Output EMAC compares the last block row
//!   of the identified observability matrix (modal coordinates) with `C psi lambda^(alpha-1)`;
//!   input EMAC compares the last block column of the identified controllability matrix with
//!   its first block column times `lambda^(beta-1)`. Per element, the magnitude ratio (at
//!   most one) times a phase weight `max(0, 1 - |phase error| / (pi/4))`, averaged with weights
//!   `|predicted|^2`. Only available when the realization comes from ERA.
//! * MPC (modal phase collinearity, Pappa): `|c^T c|^2 / (c^H c)^2` for the output shape
//!   `c`; 1 for a real (monophase) shape.
//! * MSV (modal singular value): `sqrt(|c| |b_d| sum_k |lambda|^k)`, the mode's share of the
//!   Markov parameters, with `k` over the Hankel span (`k0 .. k0 + alpha + beta - 2`), or
//!   `k = 0..1000` for a realization without Hankel data; `msv_relative` divides by the
//!   largest MSV of the realization.
//! * CMI (consistent-mode indicator) `= EMAC_output * EMAC_input * MPC` (just MPC without
//!   Hankel data).
//!
//! # Structural rule
//!
//! A mode is flagged structural ([`StructuralRule`]) when its damping ratio lies in
//! `(0, max_damping_ratio]`, its frequency is below `max_nyquist_fraction` of the Nyquist
//! frequency (and inside the optional band), its CMI is at least `min_cmi` and its relative
//! MSV at least `min_msv_relative`. Noise modes of over-specified realizations typically fail
//! on CMI (erratic histories, complex shapes) or on MSV (negligible contribution).

use crate::era::Era;
use crate::linalg::{self, C64, LinalgError};
use crate::statespace::StateSpace;
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

#[cfg(test)]
mod tests;

/// What the input did between samples. Written `zoh` or `bandlimited` in
/// files, on the command line and in JSON ([`std::str::FromStr`] and
/// [`std::fmt::Display`] use the same words as serde).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Intersample {
    /// Held over each sample (zero-order hold).
    Zoh,
    /// Band-limited (analyzer anti-alias filter, then sampling).
    Bandlimited,
}

impl Intersample {
    /// Every assumption, as written in files.
    pub const ALL: [Intersample; 2] = [Intersample::Bandlimited, Intersample::Zoh];

    /// The word used in files, on the command line and in JSON.
    pub fn name(self) -> &'static str {
        match self {
            Intersample::Zoh => "zoh",
            Intersample::Bandlimited => "bandlimited",
        }
    }
}

impl std::fmt::Display for Intersample {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Intersample {
    type Err = String;

    /// Parses `zoh` or `bandlimited` (case-insensitive).
    fn from_str(s: &str) -> Result<Self, String> {
        Intersample::ALL
            .into_iter()
            .find(|i| i.name().eq_ignore_ascii_case(s.trim()))
            .ok_or_else(|| format!("expected `zoh` or `bandlimited`, got `{s}`"))
    }
}

/// Thresholds that tell structural modes from noise modes.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct StructuralRule {
    /// Largest damping ratio of a structural mode.
    pub max_damping_ratio: f64,
    /// Smallest consistent-mode indicator.
    pub min_cmi: f64,
    /// Smallest modal singular value relative to the largest.
    pub min_msv_relative: f64,
    /// Largest frequency as a fraction of the Nyquist frequency.
    pub max_nyquist_fraction: f64,
    /// Optional frequency band (Hz) outside which no mode is structural.
    pub band_hz: Option<(f64, f64)>,
}

impl Default for StructuralRule {
    fn default() -> Self {
        Self {
            max_damping_ratio: 0.2,
            min_cmi: 0.5,
            min_msv_relative: 1e-3,
            max_nyquist_fraction: 0.9,
            band_hz: None,
        }
    }
}

impl StructuralRule {
    /// Validates the thresholds.
    pub fn check(&self) -> Result<(), ModalError> {
        let bad = |reason: String| Err(ModalError::InvalidParams { reason });
        if !(self.max_damping_ratio > 0.0 && self.max_damping_ratio <= 1.0) {
            return bad(format!(
                "max_damping_ratio = {} must be in (0, 1]",
                self.max_damping_ratio
            ));
        }
        if !(0.0..=1.0).contains(&self.min_cmi) {
            return bad(format!("min_cmi = {} must be in [0, 1]", self.min_cmi));
        }
        if !(0.0..=1.0).contains(&self.min_msv_relative) {
            return bad(format!(
                "min_msv_relative = {} must be in [0, 1]",
                self.min_msv_relative
            ));
        }
        if !(self.max_nyquist_fraction > 0.0 && self.max_nyquist_fraction <= 1.0) {
            return bad(format!(
                "max_nyquist_fraction = {} must be in (0, 1]",
                self.max_nyquist_fraction
            ));
        }
        if let Some((lo, hi)) = self.band_hz
            && !(lo.is_finite() && hi.is_finite() && lo >= 0.0 && hi > lo)
        {
            return bad(format!("band ({lo}, {hi}) Hz is not a valid band"));
        }
        Ok(())
    }

    /// Whether a mode with these properties is structural.
    pub fn is_structural(&self, mode: &Mode, dt_s: f64) -> bool {
        let nyquist_hz = 0.5 / dt_s;
        let in_band = match self.band_hz {
            Some((lo, hi)) => mode.frequency_hz >= lo && mode.frequency_hz <= hi,
            None => true,
        };
        mode.damping_ratio > 0.0
            && mode.damping_ratio <= self.max_damping_ratio
            && mode.frequency_hz < self.max_nyquist_fraction * nyquist_hz
            && in_band
            && mode.indicators.cmi >= self.min_cmi
            && mode.indicators.msv_relative >= self.min_msv_relative
    }
}

/// Modal-analysis parameters.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ModalParams {
    /// Intersample assumption for the discrete-to-continuous conversion.
    pub intersample: Intersample,
    /// Structural-mode rule.
    pub rule: StructuralRule,
}

impl ModalParams {
    /// Parameters with the default rule.
    pub fn new(intersample: Intersample) -> Self {
        Self {
            intersample,
            rule: StructuralRule::default(),
        }
    }

    /// Validates the parameters.
    pub fn check(&self) -> Result<(), ModalError> {
        self.rule.check()
    }

    /// Modal model of `realization`; `hankel` (the ERA result it came from) enables EMAC and
    /// the Hankel-span MSV.
    pub fn fit(
        &self,
        realization: &StateSpace,
        hankel: Option<&Era>,
    ) -> Result<ModalModel, ModalError> {
        self.check()?;
        realization.assert_shapes();
        let dt = realization.dt_s;
        if !(dt.is_finite() && dt > 0.0) {
            return Err(ModalError::InvalidParams {
                reason: format!("sample interval dt_s = {dt} must be positive and finite"),
            });
        }
        if let Some(era) = hankel {
            assert_eq!(
                era.observability.ncols(),
                realization.order(),
                "Hankel data must belong to the realization"
            );
        }
        let (m, r) = (realization.outputs(), realization.inputs());
        let eig = linalg::eig(&realization.a)?;
        let psi = &eig.vectors;
        let psi_inv = linalg::inverse_complex(psi, "eigenvector matrix")
            .map_err(|_| ModalError::DefectiveEigenvectors)?;
        let to_c = |x: &DMatrix<f64>| x.map(|v| C64::new(v, 0.0));
        let bm = &psi_inv * to_c(&realization.b);
        let cm = to_c(&realization.c) * psi;
        let hankel_modal = hankel.map(|era| {
            (
                to_c(&era.observability) * psi,
                &psi_inv * to_c(&era.controllability),
                era.shape,
            )
        });
        let im_tol = 1e3 * f64::EPSILON * realization.a.norm().max(1.0);

        let mut modes = Vec::new();
        let mut real_eigenvalues = Vec::new();
        for j in 0..eig.values.len() {
            let lambda = eig.values[j];
            if lambda.im.abs() <= im_tol {
                real_eigenvalues.push(lambda.re);
                continue;
            }
            if lambda.im < 0.0 {
                continue;
            }
            let pole = lambda.ln() / dt;
            let frequency_hz = pole.norm() / (2.0 * PI);
            let damping_ratio = -pole.re / pole.norm();
            let c = cm.column(j).into_owned();
            let b_d = bm.row(j).transpose();
            let b_c = match self.intersample {
                Intersample::Zoh => b_d.map(|x| x * pole / (lambda - 1.0)),
                Intersample::Bandlimited => b_d.map(|x| x / (lambda * dt)),
            };
            let residue = &c * b_c.transpose();
            let (emac_output, emac_input, msv_terms) = match &hankel_modal {
                Some((obs, ctrl, shape)) => {
                    let alpha = shape.block_rows;
                    let beta = shape.block_cols;
                    let last_out = obs.view(((alpha - 1) * m, j), (m, 1)).into_owned();
                    let predicted_out = obs.view((0, j), (m, 1)) * lambda.powu(alpha as u32 - 1);
                    let first_in = ctrl.view((j, 0), (1, r)).into_owned();
                    let last_in = ctrl.view((j, (beta - 1) * r), (1, r)).into_owned();
                    let predicted_in = first_in * lambda.powu(beta as u32 - 1);
                    (
                        Some(emac(last_out.as_slice(), predicted_out.as_slice())),
                        Some(emac(last_in.as_slice(), predicted_in.as_slice())),
                        (shape.offset, shape.span()),
                    )
                }
                None => (None, None, (0, 1000)),
            };
            let msv = modal_singular_value(&c, &b_d, lambda, msv_terms.0, msv_terms.1);
            let mpc = mpc(c.as_slice());
            let cmi = match (emac_output, emac_input) {
                (Some(o), Some(i)) => o * i * mpc,
                _ => mpc,
            };
            let shape = normalize_shape(&c);
            modes.push(Mode {
                frequency_hz,
                damping_ratio,
                eigenvalue: lambda,
                pole,
                shape,
                residue,
                indicators: Indicators {
                    emac_output,
                    emac_input,
                    mpc,
                    msv,
                    msv_relative: 0.0,
                    cmi,
                },
                structural: false,
            });
        }
        let msv_max = modes.iter().map(|md| md.indicators.msv).fold(0.0, f64::max);
        for md in &mut modes {
            md.indicators.msv_relative = if msv_max > 0.0 {
                md.indicators.msv / msv_max
            } else {
                0.0
            };
            md.structural = self.rule.is_structural(md, dt);
        }
        modes.sort_by(|a, b| a.frequency_hz.total_cmp(&b.frequency_hz));
        real_eigenvalues.sort_by(f64::total_cmp);
        for md in &modes {
            let finite = [md.frequency_hz, md.damping_ratio, md.pole.re, md.pole.im]
                .iter()
                .all(|x| x.is_finite())
                && md
                    .residue
                    .iter()
                    .all(|z| z.re.is_finite() && z.im.is_finite());
            if !finite {
                return Err(ModalError::NonFinite {
                    frequency_hz: md.frequency_hz,
                });
            }
        }
        Ok(ModalModel {
            dt_s: dt,
            intersample: self.intersample,
            modes,
            real_eigenvalues,
        })
    }
}

/// Accuracy indicators of one mode (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Indicators {
    /// Output EMAC in [0, 1] (ERA realizations only).
    pub emac_output: Option<f64>,
    /// Input EMAC in [0, 1] (ERA realizations only).
    pub emac_input: Option<f64>,
    /// Modal phase collinearity in [0, 1].
    pub mpc: f64,
    /// Modal singular value.
    pub msv: f64,
    /// Modal singular value relative to the largest of the realization.
    pub msv_relative: f64,
    /// Consistent-mode indicator in [0, 1].
    pub cmi: f64,
}

/// One mode (a complex-conjugate pair, represented by its member with `Im(lambda) > 0`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Mode {
    /// Natural frequency `|lambda_c| / (2 pi)` in Hz.
    pub frequency_hz: f64,
    /// Damping ratio `-Re(lambda_c) / |lambda_c|`.
    pub damping_ratio: f64,
    /// Discrete eigenvalue `lambda`.
    pub eigenvalue: C64,
    /// Continuous pole `lambda_c = ln(lambda) / dt` in rad/s.
    pub pole: C64,
    /// Output shape `C psi`, scaled so that its largest-magnitude component is `1 + 0i`.
    pub shape: DVector<C64>,
    /// Continuous residue `C psi b_c^T` (m x r): the transfer function is
    /// `sum over poles of residue / (s - lambda_c)` plus the conjugates plus `D`.
    pub residue: DMatrix<C64>,
    /// Accuracy indicators.
    pub indicators: Indicators,
    /// Whether the structural rule accepts this mode.
    pub structural: bool,
}

/// Modal model of a realization.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModalModel {
    /// Sample interval of the realization.
    pub dt_s: f64,
    /// Intersample assumption used for the residues.
    pub intersample: Intersample,
    /// Oscillatory modes in ascending frequency.
    pub modes: Vec<Mode>,
    /// Real eigenvalues of `A` (discrete), ascending.
    pub real_eigenvalues: Vec<f64>,
}

impl ModalModel {
    /// Indices of the structural modes.
    pub fn structural(&self) -> Vec<usize> {
        (0..self.modes.len())
            .filter(|&j| self.modes[j].structural)
            .collect()
    }

    /// Up to `count` structural modes for MKR, in ascending frequency. With more structural
    /// modes than `count`, the ones with the largest `cmi * msv_relative` (consistent and
    /// significant) are kept.
    pub fn select(&self, count: usize) -> Vec<usize> {
        let mut idx = self.structural();
        let score = |j: usize| self.modes[j].indicators.cmi * self.modes[j].indicators.msv_relative;
        idx.sort_by(|&a, &b| score(b).total_cmp(&score(a)));
        idx.truncate(count);
        idx.sort_unstable();
        idx
    }

    /// Negates every residue (the input polarity flipped).
    pub fn negate_inputs(&mut self) {
        for md in &mut self.modes {
            md.residue.neg_mut();
        }
    }
}

/// Ways the modal analysis can fail.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ModalError {
    /// Parameters out of range.
    #[error("invalid modal parameters: {reason}")]
    InvalidParams {
        /// Which parameter is out of range and what it must be.
        reason: String,
    },
    /// The eigenvector matrix is singular (defective `A`).
    #[error("the state matrix is defective: its eigenvector matrix is singular")]
    DefectiveEigenvectors,
    /// A modal quantity is not finite.
    #[error("mode near {frequency_hz} Hz has non-finite parameters")]
    NonFinite {
        /// Natural frequency of the offending mode (Hz; itself possibly NaN).
        frequency_hz: f64,
    },
    /// A decomposition failed.
    #[error(transparent)]
    Linalg(#[from] LinalgError),
}

/// Extended modal amplitude coherence of an identified vector against its prediction.
pub fn emac(identified: &[C64], predicted: &[C64]) -> f64 {
    assert_eq!(identified.len(), predicted.len(), "emac: length mismatch");
    let mut num = 0.0;
    let mut den = 0.0;
    for (q_hat, q) in identified.iter().zip(predicted) {
        let weight = q.norm_sqr();
        den += weight;
        let (a, b) = (q_hat.norm(), q.norm());
        if a == 0.0 || b == 0.0 {
            continue;
        }
        let ratio = (a / b).min(b / a);
        let phase = (q_hat / q).arg().abs();
        let phase_weight = (1.0 - phase / (PI / 4.0)).max(0.0);
        num += weight * ratio * phase_weight;
    }
    if den > 0.0 { num / den } else { 0.0 }
}

/// Modal phase collinearity `|c^T c|^2 / (c^H c)^2`.
pub fn mpc(c: &[C64]) -> f64 {
    let tt: C64 = c.iter().map(|z| z * z).sum();
    let hh: f64 = c.iter().map(|z| z.norm_sqr()).sum();
    if hh > 0.0 {
        tt.norm_sqr() / (hh * hh)
    } else {
        0.0
    }
}

fn modal_singular_value(
    c: &DVector<C64>,
    b: &DVector<C64>,
    lambda: C64,
    first: usize,
    count: usize,
) -> f64 {
    let rho = lambda.norm();
    // sum_{k=first}^{first+count-1} rho^k
    let sum = if (rho - 1.0).abs() < 1e-12 {
        count as f64
    } else {
        rho.powi(first as i32) * (1.0 - rho.powi(count as i32)) / (1.0 - rho)
    };
    (c.norm() * b.norm() * sum).sqrt()
}

/// Scales a complex vector so that its largest-magnitude component is `1 + 0i`.
pub fn normalize_shape(c: &DVector<C64>) -> DVector<C64> {
    let (imax, _) = c.iter().enumerate().fold((0, -1.0), |acc, (i, z)| {
        if z.norm() > acc.1 { (i, z.norm()) } else { acc }
    });
    let pivot = c[imax];
    if pivot.norm() == 0.0 {
        return c.clone();
    }
    let mut s = c.map(|z| z / pivot);
    s[imax] = C64::new(1.0, 0.0);
    s
}
