//! The analyzer chain: an analog anti-alias low-pass on every channel, a
//! high-rate ADC, and a digital low-pass decimating to the analysis rate.
//!
//! The analog filter is a Butterworth low-pass modelled as a continuous
//! state space (its response is computed exactly together with the
//! structure). The decimation filter is a linear-phase Kaiser-window FIR,
//! applied with its delay compensated (centred), as analyzers do so that
//! all channels stay aligned with the trigger.

use std::f64::consts::PI;

use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

use crate::error::{SimError, positive};

/// Settings of the analyzer chain. Unset frequencies take defaults from
/// the analysis sample rate `fs`: passband `fs / 2.56` (the analyzer span),
/// stop band at `fs / 2` (no aliasing at all), analog cut-off a quarter of
/// the internal rate.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AnalyzerSettings {
    /// Internal (ADC) rate as a multiple of the analysis rate.
    #[serde(default = "default_oversampling")]
    pub oversampling: usize,
    /// Order of the analog Butterworth anti-alias filter.
    #[serde(default = "default_analog_order")]
    pub analog_order: usize,
    /// -3 dB cut-off of the analog filter, Hz; default a quarter of the
    /// internal rate.
    #[serde(default)]
    pub analog_cutoff_hz: Option<f64>,
    /// Passband edge of the decimation filter, Hz; default `fs / 2.56`.
    #[serde(default)]
    pub passband_hz: Option<f64>,
    /// Stop-band edge of the decimation filter, Hz; default `fs / 2`.
    #[serde(default)]
    pub stopband_hz: Option<f64>,
    /// Stop-band attenuation of the decimation filter, dB.
    #[serde(default = "default_attenuation")]
    pub stopband_attenuation_db: f64,
}

fn default_oversampling() -> usize {
    32
}
fn default_analog_order() -> usize {
    4
}
fn default_attenuation() -> f64 {
    100.0
}

impl Default for AnalyzerSettings {
    fn default() -> Self {
        AnalyzerSettings {
            oversampling: default_oversampling(),
            analog_order: default_analog_order(),
            analog_cutoff_hz: None,
            passband_hz: None,
            stopband_hz: None,
            stopband_attenuation_db: default_attenuation(),
        }
    }
}

/// Resolved analyzer parameters (all defaults applied and checked).
#[derive(Debug, Clone, PartialEq)]
pub struct AnalyzerDesign {
    /// Internal samples per analysis sample.
    pub oversampling: usize,
    /// Internal (ADC) rate, Hz.
    pub internal_rate_hz: f64,
    /// Order of the analog Butterworth filter.
    pub analog_order: usize,
    /// -3 dB cut-off of the analog filter, Hz.
    pub analog_cutoff_hz: f64,
    /// Passband edge of the decimation FIR, Hz.
    pub passband_hz: f64,
    /// Stop-band edge of the decimation FIR, Hz.
    pub stopband_hz: f64,
    /// Stop-band attenuation of the decimation FIR, dB.
    pub stopband_attenuation_db: f64,
}

impl AnalyzerSettings {
    /// Applies defaults for analysis rate `fs_hz` and checks the result.
    pub fn design(&self, fs_hz: f64) -> Result<AnalyzerDesign, SimError> {
        if self.oversampling < 2 {
            return Err(SimError::invalid(
                "analyzer.oversampling",
                format!("must be at least 2, got {}", self.oversampling),
            ));
        }
        if self.analog_order == 0 || self.analog_order > 12 {
            return Err(SimError::invalid(
                "analyzer.analog_order",
                format!("must be between 1 and 12, got {}", self.analog_order),
            ));
        }
        let internal = fs_hz * self.oversampling as f64;
        let cutoff = positive(
            "analyzer.analog_cutoff_hz",
            self.analog_cutoff_hz.unwrap_or(internal / 4.0),
        )?;
        let pass = positive(
            "analyzer.passband_hz",
            self.passband_hz.unwrap_or(fs_hz / 2.56),
        )?;
        let stop = positive(
            "analyzer.stopband_hz",
            self.stopband_hz.unwrap_or(fs_hz / 2.0),
        )?;
        if stop <= pass {
            return Err(SimError::invalid(
                "analyzer.stopband_hz",
                format!("must exceed the passband edge {pass} Hz, got {stop} Hz"),
            ));
        }
        if stop >= fs_hz {
            return Err(SimError::invalid(
                "analyzer.stopband_hz",
                format!(
                    "must be below the analysis rate {fs_hz} Hz or the pass band aliases onto itself"
                ),
            ));
        }
        if cutoff < 2.0 * pass || cutoff >= internal / 2.0 {
            return Err(SimError::invalid(
                "analyzer.analog_cutoff_hz",
                format!(
                    "must lie between twice the passband ({} Hz) and the internal Nyquist frequency ({} Hz), got {cutoff} Hz",
                    2.0 * pass,
                    internal / 2.0
                ),
            ));
        }
        let att = self.stopband_attenuation_db;
        if !(att.is_finite() && (20.0..=200.0).contains(&att)) {
            return Err(SimError::invalid(
                "analyzer.stopband_attenuation_db",
                format!("must be between 20 and 200 dB, got {att}"),
            ));
        }
        Ok(AnalyzerDesign {
            oversampling: self.oversampling,
            internal_rate_hz: internal,
            analog_order: self.analog_order,
            analog_cutoff_hz: cutoff,
            passband_hz: pass,
            stopband_hz: stop,
            stopband_attenuation_db: att,
        })
    }
}

/// Strictly proper SISO state space `x' = a x + b u`, `y = c x`.
#[derive(Debug, Clone, PartialEq)]
pub struct AnalogFilter {
    /// State matrix.
    pub a: DMatrix<f64>,
    /// Input column.
    pub b: DMatrix<f64>,
    /// Output row.
    pub c: DMatrix<f64>,
}

/// Butterworth low-pass of the given order and -3 dB cut-off, unit DC gain,
/// as a cascade of second-order sections (and one first-order section for
/// odd orders) with states scaled by the section frequency.
pub fn butterworth(order: usize, cutoff_hz: f64) -> AnalogFilter {
    assert!(order >= 1);
    let wc = 2.0 * PI * cutoff_hz;
    let mut a = DMatrix::zeros(order, order);
    let mut b = DMatrix::zeros(order, 1);
    let mut c = DMatrix::zeros(1, order);
    // Section input: the filter input for the first section, the previous
    // section's output state (index `prev`) afterwards.
    let mut prev: Option<usize> = None;
    let mut idx = 0;
    let connect =
        |a: &mut DMatrix<f64>, b: &mut DMatrix<f64>, row: usize, gain: f64, prev: Option<usize>| {
            match prev {
                None => b[(row, 0)] = gain,
                Some(p) => a[(row, p)] = gain,
            }
        };
    for k in 0..order / 2 {
        // Pole pair at wc exp(i (pi/2 + (2k+1) pi / (2 order))): damping
        // zeta = sin((2k+1) pi / (2 order)).
        let zeta = ((2 * k + 1) as f64 * PI / (2 * order) as f64).sin();
        let (x1, x2) = (idx, idx + 1);
        a[(x1, x2)] = wc;
        a[(x2, x1)] = -wc;
        a[(x2, x2)] = -2.0 * zeta * wc;
        connect(&mut a, &mut b, x2, wc, prev);
        prev = Some(x1);
        idx += 2;
    }
    if order % 2 == 1 {
        a[(idx, idx)] = -wc;
        connect(&mut a, &mut b, idx, wc, prev);
        prev = Some(idx);
    }
    c[(0, prev.expect("order >= 1"))] = 1.0;
    AnalogFilter { a, b, c }
}

/// Zeroth-order modified Bessel function of the first kind (power series;
/// converges for every argument used by Kaiser windows, beta < 30).
pub fn bessel_i0(x: f64) -> f64 {
    let q = x * x / 4.0;
    let (mut term, mut sum, mut k) = (1.0, 1.0, 0.0);
    loop {
        k += 1.0;
        term *= q / (k * k);
        sum += term;
        if term < 1e-17 * sum {
            return sum;
        }
    }
}

/// Linear-phase low-pass FIR by the Kaiser window method: cut-off halfway
/// between the passband and stop-band edges, length and window shape from
/// Kaiser's formulas for the requested attenuation. Returns the odd-length,
/// symmetric taps normalized to unit DC gain; tap `L = len / 2` is the centre.
pub fn kaiser_lowpass(rate_hz: f64, pass_hz: f64, stop_hz: f64, attenuation_db: f64) -> Vec<f64> {
    let a = attenuation_db;
    let beta = if a > 50.0 {
        0.1102 * (a - 8.7)
    } else if a >= 21.0 {
        0.5842 * (a - 21.0).powf(0.4) + 0.07886 * (a - 21.0)
    } else {
        0.0
    };
    let width = 2.0 * PI * (stop_hz - pass_hz) / rate_hz;
    let mut len = ((a - 7.95) / (2.285 * width)).ceil() as usize + 1;
    if len.is_multiple_of(2) {
        len += 1;
    }
    let half = (len / 2) as f64;
    let fc = 0.5 * (pass_hz + stop_hz) / rate_hz;
    let i0b = bessel_i0(beta);
    let mut taps: Vec<f64> = (0..len)
        .map(|i| {
            let m = i as f64 - half;
            let ideal = if m == 0.0 {
                2.0 * fc
            } else {
                (2.0 * PI * fc * m).sin() / (PI * m)
            };
            let r = m / half;
            ideal * bessel_i0(beta * (1.0 - r * r).max(0.0).sqrt()) / i0b
        })
        .collect();
    let dc: f64 = taps.iter().sum();
    taps.iter_mut().for_each(|t| *t /= dc);
    taps
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use num_complex::Complex64;

    fn analog_response(f: &AnalogFilter, w: f64) -> Complex64 {
        let n = f.a.nrows();
        let to_c = |m: &DMatrix<f64>| m.map(|v| Complex64::new(v, 0.0));
        let si = DMatrix::<Complex64>::identity(n, n) * Complex64::new(0.0, w) - to_c(&f.a);
        let x = si.lu().solve(&to_c(&f.b)).unwrap();
        (to_c(&f.c) * x)[(0, 0)]
    }

    #[test]
    fn butterworth_magnitude_matches_closed_form() {
        for order in [1, 2, 3, 4, 7] {
            let f = butterworth(order, 500.0);
            for hz in [0.0, 25.0, 250.0, 500.0, 1000.0, 4000.0] {
                let h = analog_response(&f, 2.0 * PI * hz);
                // |H|^2 = 1 / (1 + (f / fc)^(2n)) for a Butterworth filter;
                // the state-space evaluation is exact to rounding.
                let expect = 1.0 / (1.0 + (hz / 500.0f64).powi(2 * order as i32));
                assert_relative_eq!(h.norm_sqr(), expect, max_relative = 1e-10);
            }
        }
    }

    #[test]
    fn bessel_i0_matches_tabulated_values() {
        // Abramowitz & Stegun table 9.8: I0(1) = 1.266065878, I0(5) = 27.23987182,
        // I0(10) = 2815.716628; e^-x I0(x) at x=10 is 0.1278333371.
        assert_relative_eq!(bessel_i0(1.0), 1.266_065_878, max_relative = 1e-9);
        assert_relative_eq!(bessel_i0(5.0), 27.239_871_82, max_relative = 1e-9);
        assert_relative_eq!(bessel_i0(10.0), 2_815.716_628, max_relative = 1e-9);
    }

    #[test]
    fn kaiser_lowpass_meets_its_specification() {
        let (rate, pass, stop, att) = (2048.0, 25.0, 32.0, 100.0);
        let h = kaiser_lowpass(rate, pass, stop, att);
        let half = (h.len() / 2) as f64;
        let response = |hz: f64| -> f64 {
            // Zero-phase response of the centred symmetric filter (real).
            h.iter()
                .enumerate()
                .map(|(i, &t)| t * (2.0 * PI * hz / rate * (i as f64 - half)).cos())
                .sum()
        };
        // Kaiser's design gives ripple delta = 10^(-A/20) = 1e-5 in both bands;
        // allow 3x for the approximate length formula.
        let delta = 3.0 * 10f64.powf(-att / 20.0);
        for k in 0..=250 {
            let hz = pass * k as f64 / 250.0;
            assert!(
                (response(hz) - 1.0).abs() < delta,
                "passband {hz} Hz: {}",
                response(hz)
            );
        }
        for k in 0..=2000 {
            let hz = stop + (rate / 2.0 - stop) * k as f64 / 2000.0;
            assert!(
                response(hz).abs() < delta,
                "stop band {hz} Hz: {}",
                response(hz)
            );
        }
        for (i, t) in h.iter().enumerate() {
            assert_eq!(*t, h[h.len() - 1 - i], "taps must be symmetric");
        }
    }
}
