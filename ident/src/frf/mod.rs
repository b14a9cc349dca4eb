//! Frequency response functions (FRFs): the measured transfer from references
//! (forces) to responses, line by line in frequency.
//!
//! # Conventions
//!
//! * `values[k]` is the `outputs x references` matrix `H(f_k)` at
//!   `frequency_hz[k]`, in SI units of the [`FrfQuantity`]: receptance in m/N,
//!   mobility in (m/s)/N, accelerance in (m/s^2)/N.
//! * Time convention `x(t) = Re(X e^{+i 2 pi f t})`: a single degree of freedom
//!   has receptance `1 / (k - w^2 m + i w c)`, mobility `i w` times it and
//!   accelerance `-w^2` times it.
//! * Frequencies are strictly ascending and non-negative; they need not be
//!   uniformly spaced.
//! * `coherence[k]` (if known) is the ordinary coherence of every
//!   response/reference pair at line `k`, in `[0, 1]`.
//!
//! [`estimate`] computes FRFs and coherence from time records (H1, H2, Hv;
//! averaged across hammer hits or over Welch segments). [`identify`] turns
//! FRFs into modes ([`lscf`]: pLSCF poles and stabilization diagram,
//! [`lsfd`]: residues and residual terms) and then into M, K and damping;
//! [`refine`] refines those by maximum likelihood on the FRFs themselves
//! (weights from the coherence and the number of averages, standard errors).

pub mod estimate;
pub mod identify;
pub mod lscf;
pub mod lsfd;
pub mod refine;
#[cfg(test)]
pub(crate) mod synth;

pub use identify::{
    FrfIdentError, FrfIdentification, FrfIdentifier, FrfModal, FrfOrder, ModeSelection,
    RejectReason, RejectedMode, Weighting,
};
pub use lscf::{Lscf, LscfParams, LscfPole};
pub use lsfd::{Lsfd, LsfdParams, PoleRefinement, RefineStop, ResidualTerms};
pub use refine::{
    FrfNoise, FrfNoiseReport, FrfRefineError, FrfRefineWarning, FrfRefinement, FrfRefiner,
    FrfStart, NoiseSource, SubtractedMode,
};

use crate::linalg::C64;
use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};
use std::fmt;

/// What an FRF relates to the force: displacement, velocity or acceleration.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FrfQuantity {
    /// Displacement over force, m/N.
    Receptance,
    /// Velocity over force, (m/s)/N.
    Mobility,
    /// Acceleration over force, (m/s^2)/N.
    Accelerance,
}

impl FrfQuantity {
    /// Power of `i w` that turns a receptance into this quantity (0, 1, 2).
    pub fn derivative_order(self) -> i32 {
        match self {
            FrfQuantity::Receptance => 0,
            FrfQuantity::Mobility => 1,
            FrfQuantity::Accelerance => 2,
        }
    }

    /// SI unit of the quantity.
    pub fn unit(self) -> &'static str {
        match self {
            FrfQuantity::Receptance => "m/N",
            FrfQuantity::Mobility => "(m/s)/N",
            FrfQuantity::Accelerance => "(m/s^2)/N",
        }
    }
}

impl fmt::Display for FrfQuantity {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            FrfQuantity::Receptance => "receptance",
            FrfQuantity::Mobility => "mobility",
            FrfQuantity::Accelerance => "accelerance",
        })
    }
}

/// A set of FRFs: every response against every reference on one frequency grid.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Frf {
    /// Frequency lines, Hz (strictly ascending, non-negative).
    pub frequency_hz: Vec<f64>,
    /// `values[k]`: `outputs x references` at line `k`.
    pub values: Vec<DMatrix<C64>>,
    /// What the FRFs relate to the force.
    pub quantity: FrfQuantity,
    /// Ordinary coherence per line (`outputs x references`), if known.
    pub coherence: Option<Vec<DMatrix<f64>>>,
    /// Number of averages behind each estimate, if known.
    pub averages: Option<usize>,
    /// Names of the responses (one per output row).
    pub outputs: Vec<String>,
    /// Names of the references (one per input column).
    pub references: Vec<String>,
}

/// Why a set of FRFs is unusable.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum FrfError {
    /// No frequency line.
    #[error("an FRF needs at least one frequency line")]
    Empty,
    /// The frequency grid is not strictly ascending, or a frequency is negative or not finite.
    #[error("frequency line {line} ({frequency_hz} Hz) {problem}")]
    BadFrequency {
        /// Zero-based line.
        line: usize,
        /// Its frequency.
        frequency_hz: f64,
        /// What is wrong.
        problem: &'static str,
    },
    /// Counts of lines, outputs or references disagree.
    #[error("shape mismatch: {reason}")]
    Shape {
        /// What disagrees.
        reason: String,
    },
    /// A value or coherence is not finite, or a coherence is outside [0, 1].
    #[error("line {line} ({frequency_hz} Hz), output {output}, reference {reference}: {problem}")]
    BadValue {
        /// Zero-based line.
        line: usize,
        /// Its frequency.
        frequency_hz: f64,
        /// Zero-based output.
        output: usize,
        /// Zero-based reference.
        reference: usize,
        /// What is wrong.
        problem: String,
    },
}

impl Frf {
    /// Number of responses (rows).
    pub fn outputs_count(&self) -> usize {
        self.outputs.len()
    }

    /// Number of references (columns).
    pub fn references_count(&self) -> usize {
        self.references.len()
    }

    /// Number of frequency lines.
    pub fn lines(&self) -> usize {
        self.frequency_hz.len()
    }

    /// Checks the invariants listed in the module docs.
    pub fn validate(&self) -> Result<(), FrfError> {
        let nf = self.frequency_hz.len();
        if nf == 0 {
            return Err(FrfError::Empty);
        }
        for (line, &f) in self.frequency_hz.iter().enumerate() {
            let problem = if !f.is_finite() {
                Some("is not finite")
            } else if f < 0.0 {
                Some("is negative")
            } else if line > 0 && f <= self.frequency_hz[line - 1] {
                Some("is not above the previous line")
            } else {
                None
            };
            if let Some(problem) = problem {
                return Err(FrfError::BadFrequency {
                    line,
                    frequency_hz: f,
                    problem,
                });
            }
        }
        let (m, r) = (self.outputs.len(), self.references.len());
        if m == 0 || r == 0 {
            return Err(FrfError::Shape {
                reason: format!("{m} outputs and {r} references; both must be at least 1"),
            });
        }
        if self.values.len() != nf {
            return Err(FrfError::Shape {
                reason: format!("{} value matrices for {nf} lines", self.values.len()),
            });
        }
        if let Some(c) = &self.coherence
            && c.len() != nf
        {
            return Err(FrfError::Shape {
                reason: format!("{} coherence matrices for {nf} lines", c.len()),
            });
        }
        for line in 0..nf {
            let h = &self.values[line];
            if h.shape() != (m, r) {
                return Err(FrfError::Shape {
                    reason: format!(
                        "line {line} is {}x{}, expected {m}x{r} (outputs x references)",
                        h.nrows(),
                        h.ncols()
                    ),
                });
            }
            let coh = self.coherence.as_ref().map(|c| &c[line]);
            if let Some(c) = coh
                && c.shape() != (m, r)
            {
                return Err(FrfError::Shape {
                    reason: format!(
                        "coherence at line {line} is {}x{}, expected {m}x{r}",
                        c.nrows(),
                        c.ncols()
                    ),
                });
            }
            for i in 0..m {
                for j in 0..r {
                    let bad = |problem: String| FrfError::BadValue {
                        line,
                        frequency_hz: self.frequency_hz[line],
                        output: i,
                        reference: j,
                        problem,
                    };
                    let z = h[(i, j)];
                    if !(z.re.is_finite() && z.im.is_finite()) {
                        return Err(bad(format!("value {z} is not finite")));
                    }
                    if let Some(c) = coh {
                        let g = c[(i, j)];
                        if !(0.0..=1.0).contains(&g) {
                            return Err(bad(format!("coherence {g} is outside [0, 1]")));
                        }
                    }
                }
            }
        }
        Ok(())
    }

    /// The same FRFs as another quantity: multiplies line `k` by
    /// `(i 2 pi f_k)^(target - self)`. Converting down (e.g. accelerance to
    /// receptance) divides by `i w`, which is infinite at 0 Hz: such a line
    /// becomes 0 (its value carries no information about the modes).
    pub fn to_quantity(&self, target: FrfQuantity) -> Frf {
        let power = target.derivative_order() - self.quantity.derivative_order();
        let values = self
            .frequency_hz
            .iter()
            .zip(&self.values)
            .map(|(&f, h)| {
                let iw = C64::new(0.0, 2.0 * std::f64::consts::PI * f);
                let factor = if power < 0 && f == 0.0 {
                    C64::new(0.0, 0.0)
                } else {
                    iw.powi(power)
                };
                h.map(|z| z * factor)
            })
            .collect();
        Frf {
            values,
            quantity: target,
            ..self.clone()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sdof(quantity: FrfQuantity) -> Frf {
        // m = 1 kg, k = 100 N/m, c = 0.2 N s/m.
        let frequency_hz: Vec<f64> = (0..50).map(|k| 0.1 * k as f64).collect();
        let values = frequency_hz
            .iter()
            .map(|&f| {
                let w = 2.0 * std::f64::consts::PI * f;
                let rec = C64::new(1.0, 0.0) / C64::new(100.0 - w * w, 0.2 * w);
                let iw = C64::new(0.0, w);
                DMatrix::from_element(1, 1, rec * iw.powi(quantity.derivative_order()))
            })
            .collect();
        Frf {
            frequency_hz,
            values,
            quantity,
            coherence: None,
            averages: None,
            outputs: vec!["x".into()],
            references: vec!["f".into()],
        }
    }

    #[test]
    fn quantities_convert_into_each_other() {
        let acc = sdof(FrfQuantity::Accelerance);
        acc.validate().unwrap();
        for q in [FrfQuantity::Receptance, FrfQuantity::Mobility] {
            let want = sdof(q);
            let got = acc.to_quantity(q);
            // Skip line 0: down-conversion zeroes it by definition.
            for k in 1..want.lines() {
                let (g, w) = (got.values[k][(0, 0)], want.values[k][(0, 0)]);
                // A product and a quotient of exactly representable factors:
                // a few ulps.
                assert!(
                    (g - w).norm() <= 1e-12 * w.norm(),
                    "{q} line {k}: {g} vs {w}"
                );
            }
        }
    }

    #[test]
    fn validation_names_the_line() {
        let mut f = sdof(FrfQuantity::Receptance);
        f.frequency_hz[3] = f.frequency_hz[2];
        assert!(matches!(
            f.validate(),
            Err(FrfError::BadFrequency { line: 3, .. })
        ));
        let mut f = sdof(FrfQuantity::Receptance);
        f.values[7][(0, 0)] = C64::new(f64::NAN, 0.0);
        assert!(matches!(
            f.validate(),
            Err(FrfError::BadValue { line: 7, .. })
        ));
        let mut f = sdof(FrfQuantity::Receptance);
        f.coherence = Some(vec![DMatrix::from_element(1, 1, 1.5); f.lines()]);
        assert!(matches!(
            f.validate(),
            Err(FrfError::BadValue { line: 0, .. })
        ));
    }
}
