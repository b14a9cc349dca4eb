//! Shaker excitation: band-limited random, burst random and chirps, as
//! alternatives to the impact hammer (`[campaign.excitation]`).
//!
//! A shaker signal is generated as samples on a uniform grid (the ADC's
//! internal grid for analyzer records, the analysis grid for held
//! records). What the structure receives between grid points is defined by
//! the acquisition: piecewise linear between the internal samples for the
//! analyzer (see [`crate::response::SignalEngine`]), held for held records.
//! The force channel records the same force, so the input-output relation
//! is exact whatever the interpolation; the interpolation only shapes the
//! force spectrum (by `sinc^2(f / f_grid)` for the linear one: 5e-4 at
//! 25 Hz on a 2048 Hz grid; see [`crate::response::SignalEngine`] for the
//! aliased images, about 1e-7).
//!
//! Time origin: `t = 0` is the first sample of the record, the trigger
//! instant `t0` is `pretrigger_samples / sample_rate_hz`. Every signal
//! starts at `t0` (random excitation optionally earlier, by `lead_in_s`).

use std::f64::consts::PI;

use num_complex::Complex64;
use rand::RngExt;
use rand_distr::StandardNormal;
use rustfft::FftPlanner;
use serde::{Deserialize, Serialize};

use crate::error::{SimError, non_negative, positive};

/// How the structure is excited. The hammer (`[campaign.hammer]`) is the
/// default; a shaker kind replaces it.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case", deny_unknown_fields)]
pub enum Excitation {
    /// Impact hammer, as set by `[campaign.hammer]`.
    #[default]
    Hammer,
    /// Continuous band-limited Gaussian random force.
    Random(RandomExcitation),
    /// Band-limited Gaussian random force for part of the record, then
    /// silence so that the response decays within the record.
    BurstRandom(BurstRandomExcitation),
    /// Swept sine.
    Chirp(ChirpExcitation),
}

/// Stationary Gaussian force with a flat spectrum between two frequencies.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RandomExcitation {
    /// Floor driven by the shaker, 1-based.
    pub floor: usize,
    /// Expected RMS of the force, N.
    pub rms_n: f64,
    /// Lower edge of the flat band, Hz (> 0).
    pub min_frequency_hz: f64,
    /// Upper edge of the flat band, Hz.
    pub max_frequency_hz: f64,
    /// The force starts this long before the trigger instant, s, so that
    /// the record starts in (near) steady state. 0 (the default) starts it
    /// at the trigger with the structure at rest.
    #[serde(default)]
    pub lead_in_s: f64,
}

/// Random force during a burst starting at the trigger instant.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BurstRandomExcitation {
    /// Floor driven by the shaker, 1-based.
    pub floor: usize,
    /// Expected RMS of the force during the burst, N.
    pub rms_n: f64,
    /// Lower edge of the flat band, Hz (> 0).
    pub min_frequency_hz: f64,
    /// Upper edge of the flat band, Hz.
    pub max_frequency_hz: f64,
    /// Burst length as a fraction of the record length (0 < fraction; the
    /// burst must end within the record).
    pub burst_fraction: f64,
}

/// How a chirp's frequency moves from start to end.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ChirpSweep {
    /// `f(tau) = f0 + (f1 - f0) tau / T`.
    #[default]
    Linear,
    /// `f(tau) = f0 (f1 / f0)^(tau / T)` (constant octaves per second).
    Logarithmic,
}

/// Swept sine `amplitude_n * sin(phase(tau))`, `tau = t - t0` in `[0, T]`,
/// zero afterwards; `phase' = 2 pi f(tau)`, `phase(0) = 0`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ChirpExcitation {
    /// Floor driven by the shaker, 1-based.
    pub floor: usize,
    /// Force amplitude, N.
    pub amplitude_n: f64,
    /// Frequency at the start of the sweep, Hz.
    pub start_frequency_hz: f64,
    /// Frequency at the end of the sweep, Hz (equal to the start for a
    /// stepped sine).
    pub end_frequency_hz: f64,
    /// Sweep law.
    #[serde(default)]
    pub sweep: ChirpSweep,
    /// Sweep duration T, s; default: from the trigger to the end of the
    /// record.
    #[serde(default)]
    pub duration_s: Option<f64>,
}

/// Timing of a record for signal generation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RecordTiming {
    /// Trigger instant from the record start, s.
    pub trigger_s: f64,
    /// Record length `samples * dt`, s.
    pub record_s: f64,
}

impl Excitation {
    /// True for the hammer.
    pub fn is_hammer(&self) -> bool {
        matches!(self, Excitation::Hammer)
    }

    /// Driven floor of a shaker kind (1-based), `None` for the hammer.
    pub fn floor(&self) -> Option<usize> {
        match self {
            Excitation::Hammer => None,
            Excitation::Random(r) => Some(r.floor),
            Excitation::BurstRandom(b) => Some(b.floor),
            Excitation::Chirp(c) => Some(c.floor),
        }
    }

    /// Checks the settings; `grid_rate_hz` is the rate the signal is
    /// generated at. Errors name the field as `excitation.…`.
    pub fn check(
        &self,
        floors: usize,
        grid_rate_hz: f64,
        timing: RecordTiming,
    ) -> Result<(), SimError> {
        if let Some(f) = self.floor()
            && (f == 0 || f > floors)
        {
            return Err(SimError::invalid(
                "excitation.floor",
                format!("floor {f} does not exist; floors are numbered 1..={floors}"),
            ));
        }
        let nyquist = grid_rate_hz / 2.0;
        let band = |lo: f64, hi: f64| -> Result<(), SimError> {
            positive("excitation.min_frequency_hz", lo)?;
            positive("excitation.max_frequency_hz", hi)?;
            if hi <= lo {
                return Err(SimError::invalid(
                    "excitation.max_frequency_hz",
                    format!("must exceed min_frequency_hz ({lo} Hz), got {hi} Hz"),
                ));
            }
            if hi >= nyquist {
                return Err(SimError::invalid(
                    "excitation.max_frequency_hz",
                    format!(
                        "must be below the Nyquist frequency of the generation grid ({nyquist} Hz), got {hi} Hz"
                    ),
                ));
            }
            Ok(())
        };
        match self {
            Excitation::Hammer => {}
            Excitation::Random(r) => {
                positive("excitation.rms_n", r.rms_n)?;
                band(r.min_frequency_hz, r.max_frequency_hz)?;
                non_negative("excitation.lead_in_s", r.lead_in_s)?;
            }
            Excitation::BurstRandom(b) => {
                positive("excitation.rms_n", b.rms_n)?;
                band(b.min_frequency_hz, b.max_frequency_hz)?;
                let f = positive("excitation.burst_fraction", b.burst_fraction)?;
                if timing.trigger_s + f * timing.record_s > timing.record_s {
                    return Err(SimError::invalid(
                        "excitation.burst_fraction",
                        format!(
                            "a burst of {f} of the record starting at the trigger ({} s) ends after the record ({} s)",
                            timing.trigger_s, timing.record_s
                        ),
                    ));
                }
            }
            Excitation::Chirp(c) => {
                positive("excitation.amplitude_n", c.amplitude_n)?;
                positive("excitation.start_frequency_hz", c.start_frequency_hz)?;
                positive("excitation.end_frequency_hz", c.end_frequency_hz)?;
                for (name, f) in [
                    ("excitation.start_frequency_hz", c.start_frequency_hz),
                    ("excitation.end_frequency_hz", c.end_frequency_hz),
                ] {
                    if f >= nyquist {
                        return Err(SimError::invalid(
                            name,
                            format!(
                                "must be below the Nyquist frequency of the generation grid ({nyquist} Hz), got {f} Hz"
                            ),
                        ));
                    }
                }
                if let Some(d) = c.duration_s {
                    positive("excitation.duration_s", d)?;
                }
            }
        }
        Ok(())
    }

    /// The force on grid points `t_i = (first + i) / rate_hz`,
    /// `i = 0..count`, N. Random kinds draw from `rng` (about two standard
    /// normals per in-band frequency line); the chirp draws nothing.
    ///
    /// # Panics
    /// For the hammer (its pulses are drawn by [`crate::HammerSettings`]).
    pub fn force_samples<R: rand::Rng + ?Sized>(
        &self,
        rate_hz: f64,
        first: i64,
        count: usize,
        timing: RecordTiming,
        rng: &mut R,
    ) -> Vec<f64> {
        let t = |i: usize| (first + i as i64) as f64 / rate_hz;
        match self {
            Excitation::Hammer => panic!("the hammer has no shaker signal"),
            Excitation::Random(r) => {
                let start = timing.trigger_s - r.lead_in_s;
                let mut x = band_limited_gaussian(
                    rate_hz,
                    count,
                    r.min_frequency_hz,
                    r.max_frequency_hz,
                    r.rms_n,
                    rng,
                );
                for (i, v) in x.iter_mut().enumerate() {
                    if t(i) < start {
                        *v = 0.0;
                    }
                }
                x
            }
            Excitation::BurstRandom(b) => {
                let (start, end) = (
                    timing.trigger_s,
                    timing.trigger_s + b.burst_fraction * timing.record_s,
                );
                let mut x = band_limited_gaussian(
                    rate_hz,
                    count,
                    b.min_frequency_hz,
                    b.max_frequency_hz,
                    b.rms_n,
                    rng,
                );
                for (i, v) in x.iter_mut().enumerate() {
                    if t(i) < start || t(i) >= end {
                        *v = 0.0;
                    }
                }
                x
            }
            Excitation::Chirp(c) => {
                let duration = c.duration_s.unwrap_or(timing.record_s - timing.trigger_s);
                (0..count)
                    .map(|i| {
                        let tau = t(i) - timing.trigger_s;
                        if (0.0..=duration).contains(&tau) {
                            c.amplitude_n * c.phase(tau, duration).sin()
                        } else {
                            0.0
                        }
                    })
                    .collect()
            }
        }
    }
}

impl ChirpExcitation {
    /// Instantaneous frequency `tau` after the start of a sweep of length
    /// `duration_s`, Hz.
    pub fn frequency_hz(&self, tau_s: f64, duration_s: f64) -> f64 {
        let (f0, f1) = (self.start_frequency_hz, self.end_frequency_hz);
        match self.sweep {
            ChirpSweep::Linear => f0 + (f1 - f0) * tau_s / duration_s,
            ChirpSweep::Logarithmic => f0 * (f1 / f0).powf(tau_s / duration_s),
        }
    }

    /// Phase `2 pi int_0^tau f`, rad.
    pub fn phase(&self, tau_s: f64, duration_s: f64) -> f64 {
        let (f0, f1) = (self.start_frequency_hz, self.end_frequency_hz);
        match self.sweep {
            ChirpSweep::Linear => {
                2.0 * PI * (f0 * tau_s + (f1 - f0) * tau_s * tau_s / (2.0 * duration_s))
            }
            ChirpSweep::Logarithmic => {
                let k = (f1 / f0).ln() / duration_s;
                if k == 0.0 {
                    2.0 * PI * f0 * tau_s
                } else {
                    // exp_m1 keeps the phase accurate for small k tau.
                    2.0 * PI * f0 * (k * tau_s).exp_m1() / k
                }
            }
        }
    }
}

/// `count` samples at `rate_hz` of a stationary Gaussian process whose
/// spectrum is flat between `lo_hz` and `hi_hz` and zero outside, with
/// expected RMS `rms`.
///
/// The process is a sum of sinusoids on the frequency lines `k rate / N`
/// of an FFT of length `N` (the next power of two at or above twice
/// `count`, so the record is at most half a period and not periodic) in the
/// band, each with independent standard normal cosine and sine amplitudes:
/// Gaussian, stationary, with variance `rms^2` exactly in expectation.
pub fn band_limited_gaussian<R: rand::Rng + ?Sized>(
    rate_hz: f64,
    count: usize,
    lo_hz: f64,
    hi_hz: f64,
    rms: f64,
    rng: &mut R,
) -> Vec<f64> {
    let n = (2 * count).next_power_of_two().max(2);
    let df = rate_hz / n as f64;
    let k_lo = ((lo_hz / df).ceil() as usize).max(1);
    // A band narrower than the line spacing keeps one line (a sine of
    // random amplitude and phase).
    let k_hi = ((hi_hz / df).floor() as usize).min(n / 2 - 1).max(k_lo);
    let mut spec = vec![Complex64::new(0.0, 0.0); n];
    let mut lines = 0usize;
    for line in spec.iter_mut().take(k_hi + 1).skip(k_lo) {
        let re: f64 = rng.sample(StandardNormal);
        let im: f64 = rng.sample(StandardNormal);
        *line = Complex64::new(re, im);
        lines += 1;
    }
    FftPlanner::new().plan_fft_inverse(n).process(&mut spec);
    // Re(sum_k (a_k + i b_k) e^{i w_k t}) has variance sum_k 1 = lines.
    let scale = rms / (lines as f64).sqrt();
    spec[..count].iter().map(|z| z.re * scale).collect()
}
