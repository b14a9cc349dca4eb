//! Stabilization diagram: the modes of the realizations of increasing
//! order, each compared with the closest mode of the previous order.
//! Structural modes appear at every order with the same frequency, damping
//! and shape; noise modes wander.

use serde::{Deserialize, Serialize};

use super::{Error, ValidIdentifier};
use crate::modal::Mode;
use crate::record::Record;

/// How a mode compares with the closest mode of the previous order. The
/// levels are cumulative: `Damping` means the frequency agrees too;
/// `Stable` means frequency, damping ratio and shape agree.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Stability {
    /// No mode of the previous order within the frequency tolerance.
    New,
    /// Frequency agrees.
    Frequency,
    /// Frequency and damping ratio agree.
    Damping,
    /// Frequency, damping ratio and mode shape (MAC) agree.
    Stable,
}

/// Tolerances between successive orders.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct StabilizationCriteria {
    /// Largest relative change of the natural frequency.
    pub frequency: f64,
    /// Largest relative change of the damping ratio.
    pub damping: f64,
    /// Smallest MAC between the shapes.
    pub mac: f64,
}

impl Default for StabilizationCriteria {
    /// The customary 1 % in frequency, 5 % in damping, MAC 0.98.
    fn default() -> Self {
        StabilizationCriteria {
            frequency: 0.01,
            damping: 0.05,
            mac: 0.98,
        }
    }
}

/// One pole of the diagram.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct StabilizationPoint {
    /// Model order of the realization (states, even).
    pub order: usize,
    /// Natural frequency of the mode (Hz).
    pub frequency_hz: f64,
    /// Damping ratio of the mode (fraction of critical, not percent).
    pub damping_ratio: f64,
    /// How the mode compares with the closest one of the previous order.
    pub status: Stability,
    /// Whether the structural rule accepts the mode at this order.
    pub structural: bool,
}

fn mac(a: &Mode, b: &Mode) -> f64 {
    let dot: num_complex::Complex64 = a
        .shape
        .iter()
        .zip(b.shape.iter())
        .map(|(x, y)| x.conj() * y)
        .sum();
    dot.norm_sqr() / (a.shape.norm_squared() * b.shape.norm_squared())
}

impl ValidIdentifier {
    /// Realizes every even order from 2 to `max_order` (capped by what the
    /// Markov parameters support) from one OKID/ERA decomposition of
    /// `records`, and classifies each mode against the previous order.
    pub fn stabilization(
        &self,
        records: &[Record],
        dt_s: f64,
        max_order: usize,
        criteria: StabilizationCriteria,
    ) -> Result<Vec<StabilizationPoint>, Error> {
        let d = self.decompose(records, dt_s)?;
        let max = max_order.min(d.state_limit).min(d.dec.max_order());
        let mut previous: Vec<Mode> = Vec::new();
        let mut points = Vec::new();
        for n in (2..=max).step_by(2) {
            let era = d.dec.realize(n)?;
            let modal = self.modal.fit(&era.realization, Some(&era))?;
            for mode in &modal.modes {
                let closest = previous.iter().min_by(|a, b| {
                    (a.frequency_hz - mode.frequency_hz)
                        .abs()
                        .total_cmp(&(b.frequency_hz - mode.frequency_hz).abs())
                });
                let status = match closest {
                    Some(p)
                        if (p.frequency_hz / mode.frequency_hz - 1.0).abs()
                            <= criteria.frequency =>
                    {
                        if (p.damping_ratio / mode.damping_ratio - 1.0).abs() > criteria.damping {
                            Stability::Frequency
                        } else if mac(p, mode) < criteria.mac {
                            Stability::Damping
                        } else {
                            Stability::Stable
                        }
                    }
                    _ => Stability::New,
                };
                points.push(StabilizationPoint {
                    order: n,
                    frequency_hz: mode.frequency_hz,
                    damping_ratio: mode.damping_ratio,
                    status,
                    structural: mode.structural,
                });
            }
            previous = modal.modes;
        }
        Ok(points)
    }
}
