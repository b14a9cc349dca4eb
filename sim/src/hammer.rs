//! Impact-hammer excitation: half-sine force pulses.

use rand::RngExt;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

use crate::error::{SimError, non_negative, positive};

/// A half-sine force pulse `peak_n * sin(pi (t - start_s) / duration_s)` on
/// `[start_s, start_s + duration_s]`, zero elsewhere.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Pulse {
    /// Start time from the start of the record, s.
    pub start_s: f64,
    /// Contact duration, s.
    pub duration_s: f64,
    /// Peak force, N.
    pub peak_n: f64,
}

impl Pulse {
    /// End time of the pulse, s.
    pub fn end_s(&self) -> f64 {
        self.start_s + self.duration_s
    }

    /// Force at time `t_s`, N.
    pub fn force_at(&self, t_s: f64) -> f64 {
        if t_s < self.start_s || t_s > self.end_s() {
            0.0
        } else {
            self.peak_n * (std::f64::consts::PI * (t_s - self.start_s) / self.duration_s).sin()
        }
    }

    /// Exact integral of the force over `[a_s, b_s]`, N s.
    pub fn integral(&self, a_s: f64, b_s: f64) -> f64 {
        let lo = a_s.max(self.start_s);
        let hi = b_s.min(self.end_s());
        if hi <= lo {
            return 0.0;
        }
        let w = std::f64::consts::PI / self.duration_s;
        self.peak_n / w * ((w * (lo - self.start_s)).cos() - (w * (hi - self.start_s)).cos())
    }

    /// Total impulse `2 peak duration / pi`, N s.
    pub fn impulse_ns(&self) -> f64 {
        2.0 * self.peak_n * self.duration_s / std::f64::consts::PI
    }
}

/// A second, weaker impact after the first (the hammer bouncing back).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DoubleHit {
    /// Time from the start of the first pulse to the start of the second, s.
    pub delay_s: f64,
    /// Peak of the second pulse relative to the first.
    pub ratio: f64,
}

/// Hammer settings for a campaign of hits.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HammerSettings {
    /// Floor hit by the hammer, 1-based (floor 1 is the lowest).
    pub floor: usize,
    /// Contact duration of the half-sine pulse, s.
    pub duration_s: f64,
    /// Nominal peak force, N.
    pub peak_n: f64,
    /// Hit-to-hit variation of the peak: the peak is `peak_n * exp(v z)`,
    /// z standard normal (relative standard deviation about v).
    #[serde(default)]
    pub peak_variation: f64,
    /// The pulse starts uniformly within this interval after the
    /// pre-trigger instant (trigger timing relative to the sampling grid), s.
    #[serde(default)]
    pub start_jitter_s: f64,
    /// Optional double hit.
    #[serde(default)]
    pub double_hit: Option<DoubleHit>,
}

impl HammerSettings {
    /// Checks the settings against a structure with `dofs` floors.
    pub fn check(&self, dofs: usize) -> Result<(), SimError> {
        if self.floor == 0 || self.floor > dofs {
            return Err(SimError::invalid(
                "hammer.floor",
                format!(
                    "floor {} does not exist; floors are numbered 1..={dofs}",
                    self.floor
                ),
            ));
        }
        positive("hammer.duration_s", self.duration_s)?;
        positive("hammer.peak_n", self.peak_n)?;
        non_negative("hammer.peak_variation", self.peak_variation)?;
        non_negative("hammer.start_jitter_s", self.start_jitter_s)?;
        if let Some(d) = &self.double_hit {
            positive("hammer.double_hit.delay_s", d.delay_s)?;
            positive("hammer.double_hit.ratio", d.ratio)?;
        }
        Ok(())
    }

    /// Draws the pulses of one hit whose nominal start is `trigger_s`.
    pub fn draw<R: rand::Rng + ?Sized>(&self, rng: &mut R, trigger_s: f64) -> Vec<Pulse> {
        let z: f64 = rng.sample(StandardNormal);
        let u: f64 = rng.random();
        let first = Pulse {
            start_s: trigger_s + u * self.start_jitter_s,
            duration_s: self.duration_s,
            peak_n: self.peak_n * (self.peak_variation * z).exp(),
        };
        let mut pulses = vec![first];
        if let Some(d) = &self.double_hit {
            pulses.push(Pulse {
                start_s: first.start_s + d.delay_s,
                duration_s: self.duration_s,
                peak_n: first.peak_n * d.ratio,
            });
        }
        pulses
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn integral_is_exact() {
        let p = Pulse {
            start_s: 0.1,
            duration_s: 0.003,
            peak_n: 20.0,
        };
        assert_relative_eq!(p.integral(0.0, 1.0), p.impulse_ns(), max_relative = 1e-14);
        // Half of a symmetric pulse is half the impulse.
        assert_relative_eq!(
            p.integral(0.0, 0.1015),
            p.impulse_ns() / 2.0,
            max_relative = 1e-12
        );
        assert_eq!(p.integral(0.2, 0.3), 0.0);
        // Midpoint-rule cross-check of a partial interval.
        let (a, b) = (0.1007, 0.1021);
        let n = 200_000;
        let h = (b - a) / n as f64;
        let mid: f64 = (0..n)
            .map(|i| p.force_at(a + (i as f64 + 0.5) * h) * h)
            .sum();
        assert_relative_eq!(p.integral(a, b), mid, max_relative = 1e-9);
    }
}
