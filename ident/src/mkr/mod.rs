//! Mass, stiffness and damping from a continuous modal realization (MKR, paper eq. 20-30).
//!
//! Assumptions: `n_dof` degrees of freedom, an accelerometer at every one (output `i` is DOF
//! `i`), and one collocated force/accelerometer pair (output `k`, input `l`).
//!
//! With the eq. 28 scaling `Psi^T Vc Psi = I`, the state eigenvectors are `Psi = [W; W Lc]`,
//! the modal output matrix is `W Lc^2` (accelerations) and the modal input for a force at DOF
//! `k` is row `k` of `W`. An identified modal realization carries an unknown scale per mode,
//! but its residues `C psi_j b_j` are scale free, so per mode
//!
//! ```text
//! W[k,j]^2 = residue_j[k,l] / lambda_j^2,   W[:,j] = residue_j[:,l] / (lambda_j^2 W[k,j])
//! ```
//!
//! (the sign of `W[k,j]` is irrelevant), and eq. 30 gives
//! `M = (W Lc W^T)^-1`, `K = -(W Lc^-1 W^T)^-1`, `damping = -M W Lc^2 W^T M`, real for a
//! conjugate-closed set of modes. For an exact second-order system `W W^T = 0`; the
//! reported `consistency = ||W W^T||_F / ||W Lc W^T||_F` measures how far the identified
//! realization is from one.
//!
//! # Polarity
//!
//! For a physical system, every mode with `Im(lambda) > 0` has `Im(W[k,j]^2) < 0` (a single
//! DOF gives `W^2 = 1 / (2 i omega_d m)`); with non-proportional damping this can fail for a
//! mode near a node of the driving point, so only modes with at least
//! [`POLARITY_VOTE_SHARE`] of the driving-point accelerance vote. All of the opposite sign
//! means the force or the collocated accelerometer was wired inverted; [`PolarityPolicy`]
//! decides whether to flip the input sign (with a warning) or refuse. Mixed signs are an
//! error. The driving-point feedthrough `D[k,l] = (M^-1)[k,k] > 0` is reported as a second opinion.

use crate::linalg::{self, C64};
use crate::modal::Mode;
use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};
use std::fmt;

#[cfg(test)]
mod tests;

/// The collocated force/accelerometer pair.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct CollocatedPair {
    /// Output (accelerometer, = DOF) index `k`.
    pub output: usize,
    /// Input (force) index `l`.
    pub input: usize,
}

/// What to do when the driving-point residues say the polarity is inverted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum PolarityPolicy {
    /// Flip the input sign (B and D) and report a warning.
    #[default]
    FlipWithWarning,
    /// Return [`MkrError::PolarityInverted`].
    Refuse,
}

/// Which matrix a diagnostic refers to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum MatrixKind {
    /// Mass matrix.
    Mass,
    /// Stiffness matrix.
    Stiffness,
    /// MKR damping matrix.
    Damping,
}

impl fmt::Display for MatrixKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            MatrixKind::Mass => "mass",
            MatrixKind::Stiffness => "stiffness",
            MatrixKind::Damping => "damping",
        })
    }
}

/// MKR parameters.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct MkrParams {
    /// Collocated pair.
    pub collocated: CollocatedPair,
    /// Polarity policy.
    pub polarity: PolarityPolicy,
}

/// Largest relative imaginary part tolerated in `W Lc^p W^T`.
pub const MAX_IMAGINARY_RATIO: f64 = 1e-8;

/// Smallest share of the driving-point `(M^-1)[k,k]` (in `|W[k,j]^2 lambda_j|`) with which a
/// mode votes on the polarity; modes near a node of the driving point do not. A wired-inverted
/// channel turns every mode's sign, the well-excited ones included, so the vote of the modes
/// that carry the driving point decides it; a mode below a thousandth of it is near a node,
/// where non-proportional damping can give its `W^2` any phase (the 7.1 Hz mode of the test
/// frame: a share of 1.3e-5, `Im(W^2) > 0` on exact data, which MKR refused before).
pub const POLARITY_VOTE_SHARE: f64 = 1e-3;

/// Ways MKR can fail.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum MkrError {
    /// The collocated pair does not exist in the data.
    #[error(
        "collocated pair (output {output}, input {input}) is out of range for {outputs} outputs and {inputs} inputs"
    )]
    CollocatedOutOfRange {
        /// The requested collocated output (0-based).
        output: usize,
        /// The requested collocated input (0-based).
        input: usize,
        /// Outputs of the realization (rows of `D`).
        outputs: usize,
        /// Inputs of the realization (columns of `D`).
        inputs: usize,
    },
    /// MKR needs exactly one mode per degree of freedom.
    #[error("MKR needs {dofs} modes (one per degree of freedom), {modes} given")]
    ModeCountMismatch {
        /// Modes given (one per complex-conjugate pair).
        modes: usize,
        /// Degrees of freedom, i.e. outputs (an accelerometer at every DOF).
        dofs: usize,
    },
    /// A pole is not in the upper half plane or is zero.
    #[error("mode {mode} has pole {pole}, expected Im > 0")]
    InvalidPole {
        /// Position of the mode in the list given (0-based).
        mode: usize,
        /// Its continuous pole (rad/s): non-finite or with `Im <= 0`.
        pole: C64,
    },
    /// The driving-point residues disagree on the polarity.
    #[error(
        "driving-point residues have mixed polarity: Im(W[k,j]^2) per mode = {imaginary_parts:?} (all must be negative)"
    )]
    InconsistentPolarity {
        /// `Im(W[k,j]^2)` per mode, in the order given; a physical system has all of them
        /// negative, an inverted sensor or force all positive.
        imaginary_parts: Vec<f64>,
    },
    /// The polarity is inverted and the policy refuses to flip it.
    #[error(
        "input or collocated output polarity is inverted (Im(W[k,j]^2) > 0 for every mode, D[k,l] = {driving_point}); flip the sign of the force or of the accelerometer"
    )]
    PolarityInverted {
        /// The driving-point feedthrough `D[k,l]` (m/s^2 per N, `(M^-1)[k,k]`, positive for
        /// a correctly wired pair).
        driving_point: f64,
    },
    /// A matrix that must be inverted is singular.
    #[error("W Lc^{power} W^T is singular")]
    Singular {
        /// The power `p` of `W Lc^p W^T` (1 for the mass, -1 for the stiffness).
        power: i32,
    },
    /// Complex parts that should cancel do not.
    #[error("W Lc^{power} W^T has a relative imaginary part {ratio:e}")]
    NotReal {
        /// The power `p` of `W Lc^p W^T` (1, -1 or 2).
        power: i32,
        /// `||Im||_F / ||Re||_F` of the product, above [`MAX_IMAGINARY_RATIO`] or non-finite.
        ratio: f64,
    },
    /// M or K is not symmetric positive definite.
    #[error("{matrix} matrix is not positive definite (Cholesky pivot {pivot} = {value:e})")]
    NotPositiveDefinite {
        /// The mass or the stiffness matrix.
        matrix: MatrixKind,
        /// The first non-positive Cholesky pivot (0-based DOF).
        pivot: usize,
        /// Its value (the Schur-complement diagonal entry, in kg or N/m).
        value: f64,
    },
    /// A result is not finite.
    #[error("{matrix} matrix has non-finite entries")]
    NonFinite {
        /// The matrix with NaN or infinite entries.
        matrix: MatrixKind,
    },
}

/// Result of MKR.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Mkr {
    /// Mass matrix (kg).
    pub mass: DMatrix<f64>,
    /// Stiffness matrix (N/m).
    pub stiffness: DMatrix<f64>,
    /// Damping matrix from eq. 30 (N s/m).
    pub damping: DMatrix<f64>,
    /// `W` (n_dof x 2 n_dof): modes in the given order, each followed by its conjugate.
    pub w: DMatrix<C64>,
    /// `||W W^T||_F / ||W Lc W^T||_F` (0 for an exact second-order system).
    pub consistency: f64,
    /// Whether the input polarity was flipped.
    pub polarity_flipped: bool,
    /// `W[k,j]^2` per mode (after any polarity flip).
    pub w_squared: Vec<C64>,
    /// Driving-point feedthrough `D[k,l]` after any polarity flip (> 0 if physical).
    pub driving_point: f64,
    /// Each mode's share of the driving point, `|W[k,j]^2 lambda_j|` over their sum (the
    /// polarity vote's weights, see [`POLARITY_VOTE_SHARE`]); not finite when a residue
    /// is not.
    pub driving_point_shares: Vec<f64>,
}

impl MkrParams {
    /// Validates the pair against the data's channel counts.
    pub fn check(&self, outputs: usize, inputs: usize) -> Result<(), MkrError> {
        let CollocatedPair { output, input } = self.collocated;
        if output >= outputs || input >= inputs {
            return Err(MkrError::CollocatedOutOfRange {
                output,
                input,
                outputs,
                inputs,
            });
        }
        Ok(())
    }

    /// Mass, stiffness and damping from `modes` (one per DOF, `Im(pole) > 0`) and the
    /// feedthrough `d` (m x r) of the realization.
    pub fn fit(&self, modes: &[Mode], d: &DMatrix<f64>) -> Result<Mkr, MkrError> {
        let (m, r) = d.shape();
        self.check(m, r)?;
        for md in modes {
            assert_eq!(
                md.residue.shape(),
                (m, r),
                "MKR: residues must be outputs x inputs like D"
            );
        }
        if modes.len() != m {
            return Err(MkrError::ModeCountMismatch {
                modes: modes.len(),
                dofs: m,
            });
        }
        let CollocatedPair {
            output: k,
            input: l,
        } = self.collocated;
        for (mode, md) in modes.iter().enumerate() {
            if !(md.pole.im > 0.0 && md.pole.re.is_finite() && md.pole.im.is_finite()) {
                return Err(MkrError::InvalidPole {
                    mode,
                    pole: md.pole,
                });
            }
        }
        let mut w_squared: Vec<C64> = modes
            .iter()
            .map(|md| md.residue[(k, l)] / (md.pole * md.pole))
            .collect();
        // Each mode's share of the driving-point `(M^-1)[k,k] = sum_j 2 Re(W[k,j]^2 lambda_j)`.
        // With non-proportional damping a mode near a node of the driving point can have any
        // phase there (a 3-DOF frame with 2 % damping gives `W^2 = 2.8e-7 + 6.1e-8 i` next to
        // `-0.013 i`), so modes below `POLARITY_VOTE_SHARE` of the total do not vote.
        let shares: Vec<f64> = w_squared
            .iter()
            .zip(modes)
            .map(|(z, md)| (z * md.pole).norm())
            .collect();
        let total: f64 = shares.iter().sum();
        // Written so that non-finite residues keep every mode voting (and so an error).
        let voting = |j: &usize| shares[*j] >= POLARITY_VOTE_SHARE * total || !total.is_finite();
        let voters = (0..m).filter(voting).count();
        let negative = (0..m)
            .filter(voting)
            .filter(|&j| w_squared[j].im < 0.0)
            .count();
        let positive = (0..m)
            .filter(voting)
            .filter(|&j| w_squared[j].im > 0.0)
            .count();
        let sign = if negative == voters {
            1.0
        } else if positive == voters {
            match self.polarity {
                PolarityPolicy::Refuse => {
                    return Err(MkrError::PolarityInverted {
                        driving_point: d[(k, l)],
                    });
                }
                PolarityPolicy::FlipWithWarning => -1.0,
            }
        } else {
            return Err(MkrError::InconsistentPolarity {
                imaginary_parts: w_squared.iter().map(|z| z.im).collect(),
            });
        };
        for z in &mut w_squared {
            *z *= sign;
        }

        // W with each mode followed by its conjugate, and the matching poles.
        let mut w = DMatrix::<C64>::zeros(m, 2 * m);
        let mut poles = Vec::with_capacity(2 * m);
        for (j, md) in modes.iter().enumerate() {
            let wk = w_squared[j].sqrt();
            let lambda2 = md.pole * md.pole;
            for i in 0..m {
                let value = if i == k {
                    wk
                } else {
                    md.residue[(i, l)] * sign / (lambda2 * wk)
                };
                w[(i, 2 * j)] = value;
                w[(i, 2 * j + 1)] = value.conj();
            }
            poles.push(md.pole);
            poles.push(md.pole.conj());
        }
        let product = |power: i32| -> DMatrix<C64> {
            let mut scaled = w.clone();
            for (j, p) in poles.iter().enumerate() {
                let f = p.powi(power);
                scaled.column_mut(j).iter_mut().for_each(|z| *z *= f);
            }
            &scaled * w.transpose()
        };
        let real = |power: i32| -> Result<DMatrix<f64>, MkrError> {
            let g = product(power);
            let re = g.map(|z| z.re);
            let im = g.map(|z| z.im);
            let ratio = im.norm() / re.norm();
            if !ratio.is_finite() || ratio > MAX_IMAGINARY_RATIO {
                return Err(MkrError::NotReal { power, ratio });
            }
            Ok(symmetric_part(&re))
        };
        let g1 = real(1)?;
        let g_inv = real(-1)?;
        let g2 = real(2)?;
        let mass = symmetric_part(
            &linalg::inverse(&g1, "W Lc W^T").map_err(|_| MkrError::Singular { power: 1 })?,
        );
        let stiffness = symmetric_part(
            &-linalg::inverse(&g_inv, "W Lc^-1 W^T")
                .map_err(|_| MkrError::Singular { power: -1 })?,
        );
        let damping = symmetric_part(&-(&mass * &g2 * &mass));
        for (matrix, value) in [
            (MatrixKind::Mass, &mass),
            (MatrixKind::Stiffness, &stiffness),
            (MatrixKind::Damping, &damping),
        ] {
            if linalg::first_non_finite(value).is_some() {
                return Err(MkrError::NonFinite { matrix });
            }
        }
        for (matrix, value) in [
            (MatrixKind::Mass, &mass),
            (MatrixKind::Stiffness, &stiffness),
        ] {
            if let Err((pivot, v)) = linalg::cholesky(value) {
                return Err(MkrError::NotPositiveDefinite {
                    matrix,
                    pivot,
                    value: v,
                });
            }
        }
        let wwt = &w * w.transpose();
        let consistency = wwt.norm() / g1.norm();
        Ok(Mkr {
            mass,
            stiffness,
            damping,
            w,
            consistency,
            polarity_flipped: sign < 0.0,
            w_squared,
            driving_point: sign * d[(k, l)],
            driving_point_shares: shares.iter().map(|v| v / total).collect(),
        })
    }
}

fn symmetric_part(a: &DMatrix<f64>) -> DMatrix<f64> {
    (a + a.transpose()) * 0.5
}
