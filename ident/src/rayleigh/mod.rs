//! Rayleigh (proportional) damping fitted to identified modes (paper eq. 16-19).
//!
//! `xi_i = alpha / (2 omega_i) + beta omega_i / 2` for every mode, solved for `alpha` and
//! `beta` in the least-squares sense (column-scaled SVD); the damping matrix is then
//! `alpha M + beta K`.

use crate::linalg;
use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// Rayleigh damping coefficients: `damping = alpha M + beta K`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Rayleigh {
    /// Mass-proportional coefficient (1/s).
    pub alpha: f64,
    /// Stiffness-proportional coefficient (s).
    pub beta: f64,
}

/// Ways the Rayleigh fit can fail.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum RayleighError {
    /// Fewer than two modes.
    #[error("Rayleigh damping needs at least 2 modes, {modes} given")]
    TooFewModes {
        /// Modes given.
        modes: usize,
    },
    /// A frequency or damping ratio is not finite or a frequency is not positive.
    #[error("mode {mode} has frequency {frequency_hz} Hz and damping ratio {damping_ratio}")]
    InvalidMode {
        /// Position of the mode in the lists given (0-based).
        mode: usize,
        /// Its natural frequency (Hz).
        frequency_hz: f64,
        /// Its damping ratio (fraction of critical).
        damping_ratio: f64,
    },
    /// All modes have the same frequency (to within `1e-10` relative, or so
    /// nearly that the coefficients overflow): alpha and beta cannot be
    /// separated.
    #[error("the modal frequencies do not separate alpha from beta")]
    Degenerate,
}

impl Rayleigh {
    /// Least-squares fit to natural frequencies (Hz) and damping ratios.
    pub fn fit(frequencies_hz: &[f64], damping_ratios: &[f64]) -> Result<Self, RayleighError> {
        assert_eq!(
            frequencies_hz.len(),
            damping_ratios.len(),
            "Rayleigh::fit: one damping ratio per frequency"
        );
        let n = frequencies_hz.len();
        if n < 2 {
            return Err(RayleighError::TooFewModes { modes: n });
        }
        for (mode, (&f, &xi)) in frequencies_hz.iter().zip(damping_ratios).enumerate() {
            if !(f.is_finite() && f > 0.0 && xi.is_finite()) {
                return Err(RayleighError::InvalidMode {
                    mode,
                    frequency_hz: f,
                    damping_ratio: xi,
                });
            }
        }
        let omega: Vec<f64> = frequencies_hz.iter().map(|f| 2.0 * PI * f).collect();
        let mut x = DMatrix::from_fn(n, 2, |i, j| {
            if j == 0 {
                0.5 / omega[i]
            } else {
                0.5 * omega[i]
            }
        });
        let scale: Vec<f64> = (0..2).map(|j| x.column(j).norm()).collect();
        for (j, s) in scale.iter().enumerate() {
            x.column_mut(j).unscale_mut(*s);
        }
        let y = DMatrix::from_column_slice(n, 1, damping_ratios);
        let svd = linalg::thin_svd(&x).map_err(|_| RayleighError::Degenerate)?;
        let (sol, rank) = linalg::lstsq_truncated(&svd, &y, 1e-10);
        let fit = Self {
            alpha: sol[0] / scale[0],
            beta: sol[1] / scale[1],
        };
        // Nearly equal frequencies under large damping ratios can overflow.
        if rank < 2 || !(fit.alpha.is_finite() && fit.beta.is_finite()) {
            return Err(RayleighError::Degenerate);
        }
        Ok(fit)
    }

    /// Damping matrix `alpha M + beta K`.
    pub fn damping(&self, mass: &DMatrix<f64>, stiffness: &DMatrix<f64>) -> DMatrix<f64> {
        assert_eq!(
            mass.shape(),
            stiffness.shape(),
            "Rayleigh::damping: M and K shapes"
        );
        mass * self.alpha + stiffness * self.beta
    }

    /// Damping ratio the fit gives at `frequency_hz`.
    pub fn damping_ratio(&self, frequency_hz: f64) -> f64 {
        let omega = 2.0 * PI * frequency_hz;
        0.5 * self.alpha / omega + 0.5 * self.beta * omega
    }
}

#[cfg(test)]
mod tests;
