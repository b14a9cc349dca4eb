//! Errors of the simulator: every one names the setting and what is wrong with it.

use thiserror::Error;

/// Why a model or a campaign cannot be built from the given settings.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum SimError {
    /// A setting is out of its valid range. `field` is the setting's path
    /// (for example `storeys[1].length_m`), `problem` says what is wrong.
    #[error("{field}: {problem}")]
    Invalid {
        /// Path of the setting.
        field: String,
        /// What is wrong with it.
        problem: String,
    },

    /// A matrix that must be symmetric positive definite is not.
    #[error("{matrix} matrix is not positive definite (Cholesky pivot {pivot} is not positive)")]
    NotPositiveDefinite {
        /// `mass` or `stiffness`.
        matrix: &'static str,
        /// Zero-based index of the failing Cholesky pivot.
        pivot: usize,
    },

    /// A matrix that must be symmetric is not.
    #[error(
        "{matrix} matrix is not symmetric: entry ({row},{col}) differs from ({col},{row}) by {difference:.3e}"
    )]
    NotSymmetric {
        /// `mass`, `stiffness` or `damping`.
        matrix: &'static str,
        /// Row of the first asymmetric entry, zero-based.
        row: usize,
        /// Column of the first asymmetric entry, zero-based.
        col: usize,
        /// Absolute difference between the entry and its transpose.
        difference: f64,
    },

    /// The damping matrix has a negative eigenvalue: the model would create energy.
    #[error("damping matrix is not positive semidefinite (smallest eigenvalue {eigenvalue:.3e})")]
    DampingNotSemidefinite {
        /// The smallest eigenvalue of the damping matrix, N s/m.
        eigenvalue: f64,
    },
}

impl SimError {
    pub(crate) fn invalid(field: impl Into<String>, problem: impl Into<String>) -> Self {
        SimError::Invalid {
            field: field.into(),
            problem: problem.into(),
        }
    }
}

/// Checks that `value` is finite and strictly positive.
pub(crate) fn positive(field: &str, value: f64) -> Result<f64, SimError> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(SimError::invalid(
            field,
            format!("must be a finite number > 0, got {value}"),
        ))
    }
}

/// Checks that `value` is finite and not negative.
pub(crate) fn non_negative(field: &str, value: f64) -> Result<f64, SimError> {
    if value.is_finite() && value >= 0.0 {
        Ok(value)
    } else {
        Err(SimError::invalid(
            field,
            format!("must be a finite number >= 0, got {value}"),
        ))
    }
}
