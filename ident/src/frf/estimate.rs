//! Estimation of FRFs and coherence from time records of forces and responses.
//!
//! [`FrfParams`] (estimator, averaging, windows, band) is checked once
//! ([`FrfParams::check`]) and then [`FrfParams::estimate`] turns a set of
//! [`Record`]s (forces `r x N` in N, accelerations `m x N` in m/s^2, shared
//! sample interval `dt_s`) into an [`FrfEstimate`]: an [`Frf`] of
//! [accelerance](FrfQuantity::Accelerance) with ordinary coherence and the
//! number of averages, the multiple coherence, the averaged
//! [`CrossSpectra`] every estimator derives from, and the windows that were
//! applied (so that they can be reported and the exponential window removed
//! from identified damping with [`correct_exponential_window`]).
//!
//! # Example
//!
//! ```
//! use ident::Record;
//! use ident::frf::estimate::{Estimator, FrfParams};
//! use nalgebra::DMatrix;
//! use num_complex::Complex;
//!
//! // One hit through a gain of 2 with one sample of delay, dt = 10 ms.
//! let dt_s = 0.01;
//! let mut force = DMatrix::zeros(1, 64);
//! force[(0, 3)] = 1.0;
//! force[(0, 4)] = 0.5;
//! let accel = DMatrix::from_fn(1, 64, |_, t| if t > 0 { 2.0 * force[(0, t - 1)] } else { 0.0 });
//! let est = FrfParams::hits()
//!     .estimator(Estimator::H1)
//!     .estimate(&[Record::new(force, accel)], dt_s)
//!     .unwrap();
//! let (f, h) = (est.frf.frequency_hz[5], est.frf.values[5][(0, 0)]);
//! let want = Complex::from_polar(2.0, -2.0 * std::f64::consts::PI * f * dt_s);
//! assert!((h - want).norm() < 1e-12);
//! assert_eq!(est.frf.averages, Some(1));
//! assert!(est.frf.coherence.unwrap()[5][(0, 0)] > 1.0 - 1e-12);
//! ```
//!
//! # Conventions
//!
//! * DFT of a block of `N` samples: `X_k = sum_{n=0}^{N-1} x_n e^{-i 2 pi k n / N}`
//!   (RustFFT's forward transform), on the lines `f_k = k / (N dt_s)`,
//!   `k = 0 ..= N/2`, restricted to [`FrfParams::band_hz`] if given. With the
//!   time convention `x(t) = Re(X e^{+i 2 pi f t})` of [`crate::frf`], a
//!   linear system gives `Y_k = H(f_k) X_k`.
//! * Per block, `x` is the `r`-vector of force DFTs and `y` the `m`-vector of
//!   response DFTs at one line. Averaging over the `n_avg` blocks (`E[.]`):
//!
//!   ```text
//!   Gxx = c_k E[x x^H]   (r x r, Hermitian)
//!   Gyx = c_k E[y x^H]   (m x r)            Gxy = Gyx^H
//!   Gyy = c_k E[|y_i|^2] (m, the diagonal; the full m x m matrix is kept
//!                         only where H2 with several references needs it)
//!   ```
//!
//!   For one reference `Gyx_i = c_k E[Y_i X*]`, which Bendat and Piersol write
//!   `G_xy`. The one-sided scale `c_k` ([`SpectrumScaling`]) doubles every line
//!   except 0 Hz and Nyquist. It cancels in every FRF and coherence; it only
//!   gives the auto-spectra physical units:
//!   - Welch segments: power spectral density,
//!     `c_k = 2 dt_s / sum_n w_n^2` (1 instead of 2 at 0 Hz and Nyquist), in
//!     unit^2/Hz. Normalizing by the window's power `sum w^2` (not its sum)
//!     preserves the density of broadband signals: white noise of variance
//!     `s^2` gives `2 s^2 dt_s` for any window.
//!   - Hits: energy spectral density per hit, `c_k = 2 dt_s^2` (1 instead of 2
//!     at 0 Hz and Nyquist), in unit^2 s/Hz: `dt_s X_k` approximates the
//!     continuous Fourier transform of a transient.
//!
//! # Estimators
//!
//! * [`Estimator::H1`] `= Gyx Gxx^-1`: least squares with noise on the
//!   responses only. Unbiased by output noise; uncorrelated input noise of
//!   auto-spectrum `Gnn` biases it (one reference) by the real factor
//!   `Gxx / (Gxx + Gnn)`: low wherever the force is weak (force drop-out at
//!   resonances in shaker tests, above a hammer tip's bandwidth).
//! * [`Estimator::H2`]: for one reference `H2_i = Gyy_ii / Gxy_i` with
//!   `Gxy_i = conj(Gyx_i)`: unbiased by input noise, biased high by output
//!   noise (`H (1 + Gnn / Gyy_signal)`), which matters where the response is
//!   weak (antiresonances); the better estimate at resonances.
//!   For `r > 1` references it is defined as in the modal-testing literature
//!   (e.g. Allemang's treatment of multiple-input FRF estimation),
//!   `H2 = Gyy Gxy^-1` with the full `m x m` response cross-spectral matrix,
//!   which needs `Gxy` (`r x m`) to be square: only with as many responses as
//!   references. Any other shape is ill-posed (a pseudo-inverse would make each
//!   response's estimate depend on which other responses were measured) and is
//!   refused with [`FrfEstimateError::H2NotSquare`].
//! * [`Estimator::Hv`]: total least squares, noise on both. For each response
//!   `i`, the Hermitian matrix `G_i = [[Gxx, Gxy_i], [Gyx_i, Gyy_ii]]`
//!   (`(r+1) x (r+1)`, the cross-spectra of `[x; y_i]`) has a smallest
//!   eigenvalue with eigenvector `a`; the row is `H_ij = -conj(a_j / a_r)`.
//!   For one reference this is the closed form (with `d = Gyy - Gxx`,
//!   `q = sqrt(d^2 + 4 |Gyx|^2)`) `Hv = (d + q) / (2 conj(Gyx))`, evaluated
//!   as `2 Gyx / (q - d)` when `d < 0` to avoid cancellation. Its magnitude
//!   lies between those of H1 and H2 at every line. Hv is unbiased when the
//!   force and the response carry noise of equal auto-spectra *in the units of
//!   the records* (N^2 and (m/s^2)^2); the eigenproblem is not invariant to
//!   rescaling a channel, so with other noise ratios it is only "between".
//!
//! # Coherence
//!
//! * Ordinary coherence of response `i` and reference `j`
//!   `g2_ij = |Gyx_ij|^2 / (Gxx_jj Gyy_ii)`, stored in [`Frf::coherence`]. For
//!   a noise-free linear system it is 1; uncorrelated noise of auto-spectrum
//!   `Gnn` on the response makes it `Gyy_signal / (Gyy_signal + Gnn)`. With
//!   several references it is still defined, but only meaningful if the
//!   references are uncorrelated; use the multiple coherence then.
//! * Multiple coherence of response `i`:
//!   `g2_i = (Gyx Gxx^-1 Gxy)_ii / Gyy_ii`, the fraction of the response's
//!   power explained linearly by all references ([`FrfEstimate::multiple_coherence`]).
//!   It equals the ordinary coherence for one reference.
//! * Coherences are clamped to `[0, 1]` (round-off can exceed 1 by a few ulps);
//!   a response with no power at a line (`Gyy_ii = 0`) has coherence 0 there
//!   (nothing about the structure is measured) and every estimator gives 0.
//!
//! # Averaging
//!
//! * [`Averaging::Hits`] (impact hammer): every record is one average, the
//!   whole record one FFT block, optionally zero-padded at the end to a
//!   common [`HitAveraging::block_len`] (which then also allows records of
//!   different lengths). No segment window: a hit is a transient that decays
//!   within its record. Two windows are available:
//!   - a [`ForceWindow`] on the force channels only: 1 from
//!     `before_peak_s` before to `after_peak_s` after the sample of largest
//!     `|force|` of that channel and record, a half-cosine taper of
//!     `taper_s` on each side, 0 elsewhere (removes the force channel's noise
//!     outside the pulse);
//!   - an [`ExponentialWindow`] `w(t) = exp(-t / tau)`, `t = n dt_s` from the
//!     first sample of the record, on every channel (responses and forces).
//!     It reduces the leakage of a response that has not decayed within the
//!     record, at the price of added damping: applied to both input and
//!     output, the windowed records are related exactly by the FRF of the
//!     same system with every pole shifted by `-1 / tau`, i.e. a mode of
//!     natural frequency `w_n` and damping ratio `xi` appears with damping
//!     ratio about `xi + 1 / (tau w_n)`. [`correct_exponential_window`]
//!     removes the shift exactly. (Windowing the force as well is what makes
//!     the relation exact; the pulse is short, so it hardly changes the force.)
//!     Given as [`ExponentialWindow::EndAmplitude`], `tau` is set so that the
//!     last sample of the longest record has that amplitude:
//!     `tau = -(N_max - 1) dt_s / ln(end_amplitude)`; the `tau` used is
//!     recorded in [`AppliedWindows::exponential_tau_s`].
//! * [`Averaging::Welch`] (continuous records, random or other stationary
//!   excitation): every record is cut into segments of `segment_len`
//!   samples, consecutive segments `step = segment_len - round(overlap *
//!   segment_len)` apart, as many as fit (segments never cross records); each
//!   segment is multiplied by the [`SegmentWindow`] (periodic Hann by default,
//!   `w_n = sin^2(pi n / L)`, `n = 0..L-1`, which sums to a constant at 50 %
//!   overlap) and is one average. There is no detrending: offsets go to the
//!   0 Hz line.
//!
//! The number of averages is the number of blocks (hits or segments over all
//! records), stored in [`Frf::averages`] and [`CrossSpectra::averages`].
//!
//! # Errors
//!
//! Records are checked by [`record::validate`] (consistent shapes, finite
//! samples, excited, no dead response), then: no force channel may be zero in
//! every record, every record must hold a segment (Welch) or fit the block
//! (hits), and at every line in the band the force cross-spectral matrix must
//! be nonsingular (reciprocal condition number above [`FORCE_RCOND_MIN`]).
//! Each error names the record, channel or line.
//!
//! # Cost
//!
//! One FFT plan per call, reused for every block; the per-block accumulation
//! works on flat buffers allocated once (for one reference the per-line work
//! is scalar arithmetic; the only per-line allocations are the returned
//! matrices).

use super::{Frf, FrfQuantity};
use crate::linalg::C64;
use crate::record::{self, DataError, Record};
use nalgebra::{DMatrix, DVector, SymmetricEigen};
use rustfft::FftPlanner;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;
use std::fmt;

#[cfg(test)]
mod tests;

/// Smallest reciprocal condition number (smallest over largest eigenvalue) of
/// the force cross-spectral matrix `Gxx` accepted at a line with several
/// references. Below it the references are linearly dependent to within
/// round-off of the spectral sums (about `1e-16` times the number of
/// averages) amplified well beyond the accuracy any FRF needs.
pub const FORCE_RCOND_MIN: f64 = 1e-12;

/// Which FRF estimator to return in [`FrfEstimate::frf`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Estimator {
    /// `Gyx Gxx^-1`: noise on the responses.
    H1,
    /// `Gyy Gxy^-1`: noise on the forces (one reference, or as many responses
    /// as references).
    H2,
    /// Total least squares (smallest eigenvector): noise on both.
    Hv,
}

impl fmt::Display for Estimator {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Estimator::H1 => "H1",
            Estimator::H2 => "H2",
            Estimator::Hv => "Hv",
        })
    }
}

/// Window applied to every channel of a Welch segment.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SegmentWindow {
    /// Periodic Hann, `w_n = sin^2(pi n / L)`, `n = 0..L-1`.
    Hann,
    /// All ones (only for signals periodic in the segment, or transients
    /// contained in it).
    Rectangular,
}

impl SegmentWindow {
    /// Weight of sample `n` of a segment of `len` samples.
    pub fn weight(self, n: usize, len: usize) -> f64 {
        match self {
            SegmentWindow::Hann => {
                let s = (PI * n as f64 / len as f64).sin();
                s * s
            }
            SegmentWindow::Rectangular => 1.0,
        }
    }
}

/// Welch averaging of continuous records.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct WelchAveraging {
    /// Samples per segment (the FFT length): the line spacing is
    /// `1 / (segment_len dt_s)`.
    pub segment_len: usize,
    /// Overlap of consecutive segments as a fraction of `segment_len`, in `[0, 1)`.
    pub overlap: f64,
    /// Window applied to every channel of a segment.
    pub window: SegmentWindow,
}

impl WelchAveraging {
    /// Segments of `segment_len` samples, 50 % overlap, Hann window.
    pub fn new(segment_len: usize) -> Self {
        Self {
            segment_len,
            overlap: 0.5,
            window: SegmentWindow::Hann,
        }
    }

    /// Samples between the starts of consecutive segments:
    /// `segment_len - round(overlap * segment_len)` (0 for invalid parameters).
    pub fn step(&self) -> usize {
        let shared = (self.overlap * self.segment_len as f64).round();
        if shared.is_finite() && shared >= 0.0 {
            self.segment_len.saturating_sub(shared as usize)
        } else {
            0
        }
    }

    /// Number of segments in a record of `samples` samples.
    pub fn segments(&self, samples: usize) -> usize {
        let step = self.step();
        if step == 0 || samples < self.segment_len {
            0
        } else {
            (samples - self.segment_len) / step + 1
        }
    }
}

/// Rectangular window with cosine tapers around the force pulse, applied to
/// the force channels of hammer records only.
///
/// As a function of the time `t` from the pulse peak (the sample of largest
/// `|force|` of the channel in the record):
///
/// ```text
/// w(t) = 1                                            -before <= t <= after
///      = (1 + cos(pi (t - after) / taper)) / 2        after < t < after + taper
///      = (1 + cos(pi (-before - t) / taper)) / 2      -before - taper < t < -before
///      = 0                                            elsewhere
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ForceWindow {
    /// Flat part before the peak, s.
    pub before_peak_s: f64,
    /// Flat part after the peak, s.
    pub after_peak_s: f64,
    /// Length of each half-cosine taper, s (0 for a sharp rectangle).
    pub taper_s: f64,
}

impl ForceWindow {
    /// Weight at time `t_s` from the pulse peak (see the type's docs).
    pub fn weight(&self, t_s: f64) -> f64 {
        let (before, after, taper) = (self.before_peak_s, self.after_peak_s, self.taper_s);
        if (-before..=after).contains(&t_s) {
            1.0
        } else if t_s > after && t_s < after + taper {
            0.5 * (1.0 + (PI * (t_s - after) / taper).cos())
        } else if t_s < -before && t_s > -before - taper {
            0.5 * (1.0 + (PI * (-before - t_s) / taper).cos())
        } else {
            0.0
        }
    }
}

/// Exponential window `w(t) = exp(-t / tau)` on every channel of a hammer
/// record, `t = n dt_s` from the record's first sample.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum ExponentialWindow {
    /// Amplitude left at the last sample of the longest record, in `(0, 1)`.
    EndAmplitude(f64),
    /// Time constant `tau`, s.
    TimeConstant(f64),
}

impl ExponentialWindow {
    /// Time constant for records whose longest has `samples` samples:
    /// `-(samples - 1) dt_s / ln(end_amplitude)` or the given `tau`.
    pub fn tau_s(self, samples: usize, dt_s: f64) -> f64 {
        match self {
            ExponentialWindow::EndAmplitude(a) => {
                -(samples.saturating_sub(1) as f64) * dt_s / a.ln()
            }
            ExponentialWindow::TimeConstant(tau_s) => tau_s,
        }
    }
}

/// Averaging across hammer hits: each record is one FFT block and one average.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct HitAveraging {
    /// FFT length: records are zero-padded at the end to it (it must be at
    /// least the longest record). `None`: every record must have the same
    /// length, which is the FFT length.
    pub block_len: Option<usize>,
    /// Window on the force channels around the pulse.
    pub force_window: Option<ForceWindow>,
    /// Exponential window on every channel.
    pub exponential_window: Option<ExponentialWindow>,
}

/// How blocks are formed and averaged.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Averaging {
    /// One block per record (impact hammer hits).
    Hits(HitAveraging),
    /// Overlapping windowed segments of continuous records.
    Welch(WelchAveraging),
}

/// Parameters of FRF estimation: check with [`check`](Self::check), run with
/// [`estimate`](Self::estimate).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FrfParams {
    /// Estimator returned in [`FrfEstimate::frf`] (all can be recomputed from
    /// [`FrfEstimate::spectra`]).
    pub estimator: Estimator,
    /// Blocks and windows.
    pub averaging: Averaging,
    /// Keep only the lines with `low <= f <= high` (Hz); `None`: 0 to Nyquist.
    pub band_hz: Option<(f64, f64)>,
}

impl FrfParams {
    /// H1 across hammer hits of equal length, no windows, 0 Hz to Nyquist.
    pub fn hits() -> Self {
        Self {
            estimator: Estimator::H1,
            averaging: Averaging::Hits(HitAveraging::default()),
            band_hz: None,
        }
    }

    /// H1 by Welch averaging: `segment_len` samples, 50 % overlap, Hann window,
    /// 0 Hz to Nyquist.
    pub fn welch(segment_len: usize) -> Self {
        Self {
            estimator: Estimator::H1,
            averaging: Averaging::Welch(WelchAveraging::new(segment_len)),
            band_hz: None,
        }
    }

    /// Sets the estimator.
    pub fn estimator(mut self, estimator: Estimator) -> Self {
        self.estimator = estimator;
        self
    }

    /// Sets the averaging.
    pub fn averaging(mut self, averaging: Averaging) -> Self {
        self.averaging = averaging;
        self
    }

    /// Keeps only the lines in `[low_hz, high_hz]`.
    pub fn band_hz(mut self, low_hz: f64, high_hz: f64) -> Self {
        self.band_hz = Some((low_hz, high_hz));
        self
    }

    /// Validates the parameters.
    pub fn check(&self) -> Result<(), FrfEstimateError> {
        let bad = |reason: String| Err(FrfEstimateError::InvalidParams { reason });
        if let Some((lo, hi)) = self.band_hz
            && !(lo.is_finite() && hi.is_finite() && lo >= 0.0 && hi > lo)
        {
            return bad(format!(
                "band {lo}..{hi} Hz must be finite with 0 <= low < high"
            ));
        }
        match self.averaging {
            Averaging::Welch(w) => {
                if w.segment_len < 2 {
                    return bad(format!(
                        "segment_len = {} must be at least 2",
                        w.segment_len
                    ));
                }
                if !(w.overlap.is_finite() && (0.0..1.0).contains(&w.overlap)) {
                    return bad(format!("overlap = {} must be in [0, 1)", w.overlap));
                }
                if w.step() == 0 {
                    return bad(format!(
                        "overlap = {} of {} samples leaves no step between segments",
                        w.overlap, w.segment_len
                    ));
                }
            }
            Averaging::Hits(h) => {
                if let Some(n) = h.block_len
                    && n < 2
                {
                    return bad(format!("block_len = {n} must be at least 2"));
                }
                if let Some(fw) = h.force_window {
                    for (name, v) in [
                        ("before_peak_s", fw.before_peak_s),
                        ("after_peak_s", fw.after_peak_s),
                        ("taper_s", fw.taper_s),
                    ] {
                        if !(v.is_finite() && v >= 0.0) {
                            return bad(format!(
                                "force window {name} = {v} must be finite and non-negative"
                            ));
                        }
                    }
                }
                match h.exponential_window {
                    Some(ExponentialWindow::EndAmplitude(a)) if !(a > 0.0 && a < 1.0) => {
                        return bad(format!(
                            "exponential window end amplitude {a} must be in (0, 1)"
                        ));
                    }
                    Some(ExponentialWindow::TimeConstant(tau))
                        if !(tau.is_finite() && tau > 0.0) =>
                    {
                        return bad(format!(
                            "exponential window time constant {tau} s must be positive and finite"
                        ));
                    }
                    _ => {}
                }
            }
        }
        Ok(())
    }

    /// Estimates the FRFs (accelerance), coherences and cross-spectra of
    /// `records` sampled every `dt_s` seconds.
    pub fn estimate(&self, records: &[Record], dt_s: f64) -> Result<FrfEstimate, FrfEstimateError> {
        self.check()?;
        record::validate_dt(dt_s)?;
        let shape = record::validate(records)?;
        let (r, m) = (shape.inputs, shape.outputs);
        for channel in 0..r {
            if records
                .iter()
                .all(|rec| rec.inputs.row(channel).iter().all(|&v| v == 0.0))
            {
                return Err(FrfEstimateError::DeadReference { channel });
            }
        }
        if self.estimator == Estimator::H2 && r > 1 && m != r {
            return Err(FrfEstimateError::H2NotSquare {
                outputs: m,
                references: r,
            });
        }
        let plan = BlockPlan::new(&self.averaging, records, dt_s, shape.longest)?;
        let nfft = plan.block_len;
        let resolution_hz = 1.0 / (nfft as f64 * dt_s);
        let bins: Vec<usize> = (0..=nfft / 2)
            .filter(|&k| match self.band_hz {
                Some((lo, hi)) => {
                    let f = k as f64 * resolution_hz;
                    f >= lo && f <= hi
                }
                None => true,
            })
            .collect();
        let (Some(&k0), Some(&k1)) = (bins.first(), bins.last()) else {
            let (low_hz, high_hz) = self.band_hz.unwrap_or((0.0, 0.0));
            return Err(FrfEstimateError::EmptyBand {
                low_hz,
                high_hz,
                resolution_hz,
                nyquist_hz: 0.5 / dt_s,
            });
        };
        let mut acc = Accumulator::new(r, m, k0, k1 - k0 + 1, r > 1 && m == r);
        let mut planner = FftPlanner::<f64>::new();
        let fft = planner.plan_fft_forward(nfft);
        let mut scratch = vec![C64::new(0.0, 0.0); fft.get_inplace_scratch_len()];
        let mut buffers = vec![C64::new(0.0, 0.0); (r + m) * nfft];
        let mut force_peaks = Vec::new();
        for block in &plan.blocks {
            let rec = &records[block.record];
            let peaks = plan.fill(rec, block, &mut buffers);
            if plan.force_window.is_some() {
                force_peaks.push(peaks);
            }
            for chunk in buffers.chunks_exact_mut(nfft) {
                fft.process_with_scratch(chunk, &mut scratch);
            }
            acc.add(&buffers, nfft);
        }
        let averages = plan.blocks.len();
        let spectra = acc.finish(averages, nfft, dt_s, (plan.scaling, plan.window_power));
        let values = match self.estimator {
            Estimator::H1 => spectra.h1()?,
            Estimator::H2 => spectra.h2()?,
            Estimator::Hv => spectra.hv()?,
        };
        let multiple_coherence = spectra.multiple_coherence()?;
        let frf = Frf {
            frequency_hz: spectra.frequency_hz.clone(),
            values,
            quantity: FrfQuantity::Accelerance,
            coherence: Some(spectra.ordinary_coherence()),
            averages: Some(averages),
            outputs: (0..m).map(|i| format!("output {i}")).collect(),
            references: (0..r).map(|j| format!("input {j}")).collect(),
        };
        debug_assert!(frf.validate().is_ok(), "{:?}", frf.validate());
        Ok(FrfEstimate {
            frf,
            estimator: self.estimator,
            multiple_coherence,
            spectra,
            windows: AppliedWindows {
                block_len: nfft,
                segment_window: plan.segment_window,
                segment_step: plan.segment_step,
                force_window: plan.force_window,
                force_peaks,
                exponential_tau_s: plan.tau_s,
            },
        })
    }
}

/// How the auto- and cross-spectra are scaled (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SpectrumScaling {
    /// One-sided power spectral density, `2 dt_s / sum w^2 E[..]`, unit^2/Hz.
    PowerDensity,
    /// One-sided energy spectral density per hit, `2 dt_s^2 E[..]`, unit^2 s/Hz.
    EnergyDensityPerHit,
}

/// Averaged one-sided auto- and cross-spectra on the estimate's lines; every
/// estimator and coherence derives from them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CrossSpectra {
    /// Frequency lines, Hz.
    pub frequency_hz: Vec<f64>,
    /// Force cross-spectral matrix per line, `r x r` Hermitian.
    pub gxx: Vec<DMatrix<C64>>,
    /// Response-force cross-spectra per line, `m x r`: `c E[y x^H]`.
    pub gyx: Vec<DMatrix<C64>>,
    /// Response auto-spectra per line, `m`.
    pub gyy: Vec<DVector<f64>>,
    /// Full response cross-spectral matrix per line (`m x m`), kept only with
    /// several references and as many responses (what H2 then needs).
    pub output_cross: Option<Vec<DMatrix<C64>>>,
    /// Number of blocks averaged.
    pub averages: usize,
    /// Units of the spectra.
    pub scaling: SpectrumScaling,
}

impl CrossSpectra {
    /// Number of lines.
    pub fn lines(&self) -> usize {
        self.frequency_hz.len()
    }

    /// Number of references `r`.
    pub fn references(&self) -> usize {
        self.gxx.first().map_or(0, |g| g.nrows())
    }

    /// Number of responses `m`.
    pub fn outputs(&self) -> usize {
        self.gyy.first().map_or(0, |g| g.len())
    }

    /// `Gxx^-1` at a line, or the error naming the line if it is singular.
    fn gxx_inverse(&self, line: usize) -> Result<DMatrix<C64>, FrfEstimateError> {
        let g = &self.gxx[line];
        let frequency_hz = self.frequency_hz[line];
        if g.nrows() == 1 {
            let p = g[(0, 0)].re;
            if p > 0.0 {
                return Ok(DMatrix::from_element(1, 1, C64::new(1.0 / p, 0.0)));
            }
            return Err(FrfEstimateError::NoForcePower {
                line,
                frequency_hz,
                reference: 0,
            });
        }
        let eig = SymmetricEigen::new(g.clone());
        let max = eig.eigenvalues.max();
        let min = eig.eigenvalues.min();
        let rcond = if max > 0.0 { min / max } else { 0.0 };
        if rcond.is_nan() || rcond <= FORCE_RCOND_MIN {
            return Err(FrfEstimateError::SingularForces {
                line,
                frequency_hz,
                reciprocal_condition: rcond,
            });
        }
        let inv_diag = eig.eigenvalues.map(|l| C64::new(1.0 / l, 0.0));
        let v = &eig.eigenvectors;
        Ok(v * DMatrix::from_diagonal(&inv_diag) * v.adjoint())
    }

    /// H1 `= Gyx Gxx^-1` per line.
    pub fn h1(&self) -> Result<Vec<DMatrix<C64>>, FrfEstimateError> {
        let (m, r) = (self.outputs(), self.references());
        (0..self.lines())
            .map(|line| {
                if r == 1 {
                    let gxx = self.gxx[line][(0, 0)].re;
                    if !is_positive(gxx) {
                        return Err(FrfEstimateError::NoForcePower {
                            line,
                            frequency_hz: self.frequency_hz[line],
                            reference: 0,
                        });
                    }
                    let h = self.gyx[line].map(|s| s / gxx);
                    self.check_finite(Estimator::H1, line, &h)?;
                    Ok(h)
                } else {
                    let h = &self.gyx[line] * self.gxx_inverse(line)?;
                    debug_assert_eq!(h.shape(), (m, r));
                    self.check_finite(Estimator::H1, line, &h)?;
                    Ok(h)
                }
            })
            .collect()
    }

    /// H2 per line: `Gyy_ii / conj(Gyx_i)` for one reference,
    /// `Gyy Gxy^-1` for as many responses as references (see the module docs).
    ///
    /// Panics if several references and as many responses come without
    /// [`output_cross`](Self::output_cross) (spectra not built by
    /// [`FrfParams::estimate`]): a shape contract, not a data error.
    pub fn h2(&self) -> Result<Vec<DMatrix<C64>>, FrfEstimateError> {
        let (m, r) = (self.outputs(), self.references());
        if r > 1 && m != r {
            return Err(FrfEstimateError::H2NotSquare {
                outputs: m,
                references: r,
            });
        }
        (0..self.lines())
            .map(|line| {
                let frequency_hz = self.frequency_hz[line];
                let undefined = |output, reason| FrfEstimateError::UndefinedEstimate {
                    estimator: Estimator::H2,
                    line,
                    frequency_hz,
                    output,
                    reason,
                };
                if r == 1 {
                    if !is_positive(self.gxx[line][(0, 0)].re) {
                        return Err(FrfEstimateError::NoForcePower {
                            line,
                            frequency_hz,
                            reference: 0,
                        });
                    }
                    let gyx = &self.gyx[line];
                    let gyy = &self.gyy[line];
                    let mut h = DMatrix::zeros(m, 1);
                    for i in 0..m {
                        if gyy[i] == 0.0 {
                            continue;
                        }
                        if gyx[i] == C64::new(0.0, 0.0) {
                            return Err(undefined(
                                i,
                                "the response has power but no cross-spectrum with the force",
                            ));
                        }
                        h[i] = gyy[i] / gyx[i].conj();
                    }
                    self.check_finite(Estimator::H2, line, &h)?;
                    Ok(h)
                } else {
                    let gyy = &self.output_cross.as_ref().expect(
                        "CrossSpectra: output_cross is kept whenever outputs == references > 1",
                    )[line];
                    let gyx = &self.gyx[line];
                    // H2 Gxy = Gyy with Gxy = Gyx^H, i.e. Gyx H2^H = Gyy.
                    let sv = gyx.singular_values();
                    let (max, min) = (sv.max(), sv.min());
                    if !(max > 0.0 && min / max > FORCE_RCOND_MIN) {
                        return Err(undefined(
                            0,
                            "the response-force cross-spectral matrix is singular",
                        ));
                    }
                    let h = gyx
                        .clone()
                        .lu()
                        .solve(gyy)
                        .ok_or_else(|| {
                            undefined(0, "the response-force cross-spectral matrix is singular")
                        })?
                        .adjoint();
                    self.check_finite(Estimator::H2, line, &h)?;
                    Ok(h)
                }
            })
            .collect()
    }

    /// Hv (total least squares) per line, response by response (see the
    /// module docs).
    pub fn hv(&self) -> Result<Vec<DMatrix<C64>>, FrfEstimateError> {
        let (m, r) = (self.outputs(), self.references());
        (0..self.lines())
            .map(|line| {
                let frequency_hz = self.frequency_hz[line];
                let undefined = |output, reason| FrfEstimateError::UndefinedEstimate {
                    estimator: Estimator::Hv,
                    line,
                    frequency_hz,
                    output,
                    reason,
                };
                let gxx = &self.gxx[line];
                let gyx = &self.gyx[line];
                let gyy = &self.gyy[line];
                let mut h = DMatrix::zeros(m, r);
                if r == 1 {
                    let p = gxx[(0, 0)].re;
                    if !is_positive(p) {
                        return Err(FrfEstimateError::NoForcePower {
                            line,
                            frequency_hz,
                            reference: 0,
                        });
                    }
                    for i in 0..m {
                        h[i] = hv_one_reference(p, gyx[i], gyy[i])
                            .ok_or_else(|| undefined(i, HV_UNDEFINED))?;
                    }
                } else {
                    // Conditioning of the references, as for H1.
                    self.gxx_inverse(line)?;
                    for i in 0..m {
                        let row = hv_eigen(gxx, &gyx.row(i).transpose(), gyy[i])
                            .ok_or_else(|| undefined(i, HV_UNDEFINED))?;
                        h.set_row(i, &row.transpose());
                    }
                }
                self.check_finite(Estimator::Hv, line, &h)?;
                Ok(h)
            })
            .collect()
    }

    /// Ordinary coherence `|Gyx_ij|^2 / (Gxx_jj Gyy_ii)` per line (`m x r`),
    /// clamped to `[0, 1]`, 0 where either auto-spectrum is zero.
    pub fn ordinary_coherence(&self) -> Vec<DMatrix<f64>> {
        (0..self.lines())
            .map(|line| {
                let (gxx, gyx, gyy) = (&self.gxx[line], &self.gyx[line], &self.gyy[line]);
                DMatrix::from_fn(gyx.nrows(), gyx.ncols(), |i, j| {
                    let den = gxx[(j, j)].re * gyy[i];
                    if den > 0.0 {
                        (gyx[(i, j)].norm_sqr() / den).clamp(0.0, 1.0)
                    } else {
                        0.0
                    }
                })
            })
            .collect()
    }

    /// Multiple coherence `(Gyx Gxx^-1 Gxy)_ii / Gyy_ii` of every response per
    /// line, clamped to `[0, 1]`, 0 where the response has no power.
    pub fn multiple_coherence(&self) -> Result<Vec<DVector<f64>>, FrfEstimateError> {
        let (m, r) = (self.outputs(), self.references());
        (0..self.lines())
            .map(|line| {
                let (gyx, gyy) = (&self.gyx[line], &self.gyy[line]);
                if r == 1 {
                    // The ordinary coherence, without matrix temporaries.
                    let gxx = self.gxx[line][(0, 0)].re;
                    if !is_positive(gxx) {
                        return Err(FrfEstimateError::NoForcePower {
                            line,
                            frequency_hz: self.frequency_hz[line],
                            reference: 0,
                        });
                    }
                    return Ok(DVector::from_fn(m, |i, _| {
                        if gyy[i] > 0.0 {
                            (gyx[i].norm_sqr() / (gxx * gyy[i])).clamp(0.0, 1.0)
                        } else {
                            0.0
                        }
                    }));
                }
                let inv = self.gxx_inverse(line)?;
                Ok(DVector::from_fn(m, |i, _| {
                    if gyy[i] > 0.0 {
                        let row = gyx.row(i);
                        let explained = (row * &inv * row.adjoint())[(0, 0)].re;
                        (explained / gyy[i]).clamp(0.0, 1.0)
                    } else {
                        0.0
                    }
                }))
            })
            .collect()
    }

    fn check_finite(
        &self,
        estimator: Estimator,
        line: usize,
        h: &DMatrix<C64>,
    ) -> Result<(), FrfEstimateError> {
        for i in 0..h.nrows() {
            if h.row(i)
                .iter()
                .any(|z| !(z.re.is_finite() && z.im.is_finite()))
            {
                return Err(FrfEstimateError::UndefinedEstimate {
                    estimator,
                    line,
                    frequency_hz: self.frequency_hz[line],
                    output: i,
                    reason: "the estimate overflows (the spectra are nearly degenerate)",
                });
            }
        }
        Ok(())
    }
}

/// `x > 0`, false for NaN.
fn is_positive(x: f64) -> bool {
    x > 0.0
}

const HV_UNDEFINED: &str =
    "the response has no cross-spectrum with the forces and at least their power";

/// Hv for one reference from `Gxx` (positive), `Gyx` and `Gyy`; `None` where
/// the smallest eigenvector has no response component.
fn hv_one_reference(gxx: f64, gyx: C64, gyy: f64) -> Option<C64> {
    let d = gyy - gxx;
    let q = d.hypot(2.0 * gyx.norm());
    if d < 0.0 {
        // q - d > 0; also covers gyy = 0 (then gyx = 0 and Hv = 0).
        Some(gyx * (2.0 / (q - d)))
    } else if gyx != C64::new(0.0, 0.0) {
        Some(C64::new(d + q, 0.0) / (2.0 * gyx.conj()))
    } else {
        None
    }
}

/// Hv row of one response by the eigenvector of the smallest eigenvalue of
/// `[[Gxx, Gxy_i], [Gyx_i, Gyy_ii]]`; `gyx_i` is the response's `Gyx` row as a
/// column.
fn hv_eigen(gxx: &DMatrix<C64>, gyx_i: &DVector<C64>, gyy_i: f64) -> Option<DVector<C64>> {
    let r = gxx.nrows();
    if gyy_i == 0.0 {
        return Some(DVector::zeros(r));
    }
    let mut g = DMatrix::zeros(r + 1, r + 1);
    g.view_mut((0, 0), (r, r)).copy_from(gxx);
    g.view_mut((r, 0), (1, r)).copy_from(&gyx_i.transpose());
    g.view_mut((0, r), (r, 1)).copy_from(&gyx_i.conjugate());
    g[(r, r)] = C64::new(gyy_i, 0.0);
    let eig = SymmetricEigen::new(g);
    let smallest = eig.eigenvalues.imin();
    let a = eig.eigenvectors.column(smallest);
    let ar = a[r];
    if ar.norm() <= 1e-14 * a.norm() {
        return None;
    }
    Some(DVector::from_fn(r, |j, _| -(a[j] / ar).conj()))
}

/// Result of [`FrfParams::estimate`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FrfEstimate {
    /// Accelerance by the chosen estimator, with the ordinary coherence and
    /// the number of averages. Channels are named `output i` and `input j`.
    pub frf: Frf,
    /// Estimator behind `frf.values`.
    pub estimator: Estimator,
    /// Multiple coherence of each response per line (`m`).
    pub multiple_coherence: Vec<DVector<f64>>,
    /// The averaged spectra (any other estimator can be computed from them).
    pub spectra: CrossSpectra,
    /// Windows and blocks that were used.
    pub windows: AppliedWindows,
}

impl FrfEstimate {
    /// Removes the exponential window's damping from a mode identified on
    /// these FRFs (the identity if no exponential window was applied); see
    /// [`correct_exponential_window`].
    pub fn correct_exponential_window(
        &self,
        frequency_hz: f64,
        damping_ratio: f64,
    ) -> Result<(f64, f64), FrfEstimateError> {
        match self.windows.exponential_tau_s {
            Some(tau_s) => correct_exponential_window(frequency_hz, damping_ratio, tau_s),
            None => Ok((frequency_hz, damping_ratio)),
        }
    }
}

/// The blocks and windows behind an estimate, for reports.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AppliedWindows {
    /// FFT length, samples.
    pub block_len: usize,
    /// Window of Welch segments (`None` for hits).
    pub segment_window: Option<SegmentWindow>,
    /// Samples between Welch segments (`None` for hits).
    pub segment_step: Option<usize>,
    /// Force window of hammer records.
    pub force_window: Option<ForceWindow>,
    /// With a force window, per record and reference, the sample of the pulse
    /// peak it was centred on (`None` for a channel that is zero in that
    /// record). Empty without a force window.
    pub force_peaks: Vec<Vec<Option<usize>>>,
    /// Time constant of the exponential window, s.
    pub exponential_tau_s: Option<f64>,
}

/// Removes the damping added by an exponential window `exp(-t / tau_s)` from
/// a mode identified on windowed records.
///
/// The windowed mode has the continuous pole
/// `lambda_w = -xi_w w_w + i w_w sqrt(1 - xi_w^2)` with `w_w = 2 pi frequency_hz`
/// and `xi_w = damping_ratio` (the crate's convention: `f = |lambda| / 2 pi`,
/// `xi = -Re(lambda) / |lambda|`). The window shifts every pole by exactly
/// `-1 / tau_s`, so the true pole is `lambda = lambda_w + 1 / tau_s`, and the
/// result is `(|lambda| / 2 pi, -Re(lambda) / |lambda|)`. This is exact, not
/// the small-damping approximation `xi = xi_w - 1 / (tau_s w_w)`. A negative
/// returned damping ratio means the identified damping was below what the
/// window alone adds (it is returned, not clamped, so that it can be seen).
///
/// Needs `frequency_hz > 0`, `-1 < damping_ratio < 1` (an underdamped
/// complex pole), `tau_s > 0`, all finite.
pub fn correct_exponential_window(
    frequency_hz: f64,
    damping_ratio: f64,
    tau_s: f64,
) -> Result<(f64, f64), FrfEstimateError> {
    let invalid = |reason| FrfEstimateError::InvalidMode {
        frequency_hz,
        damping_ratio,
        tau_s,
        reason,
    };
    if !(frequency_hz.is_finite() && frequency_hz > 0.0) {
        return Err(invalid("the frequency must be positive and finite"));
    }
    if !(damping_ratio > -1.0 && damping_ratio < 1.0) {
        return Err(invalid("the damping ratio must be in (-1, 1)"));
    }
    if !(tau_s.is_finite() && tau_s > 0.0) {
        return Err(invalid("the time constant must be positive and finite"));
    }
    let w = 2.0 * PI * frequency_hz;
    let re = -damping_ratio * w + 1.0 / tau_s;
    let im = w * (1.0 - damping_ratio * damping_ratio).sqrt();
    let norm = re.hypot(im);
    Ok((norm / (2.0 * PI), -re / norm))
}

/// Why FRFs could not be estimated.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum FrfEstimateError {
    /// Parameters out of range.
    #[error("invalid FRF estimation parameters: {reason}")]
    InvalidParams {
        /// What is wrong.
        reason: String,
    },
    /// The records are unusable (shapes, non-finite samples, no excitation,
    /// dead response, too short for a segment, bad sample interval).
    #[error(transparent)]
    Data(#[from] DataError),
    /// A force channel is zero in every record.
    #[error("input {channel} is zero in every record: that reference is never excited")]
    DeadReference {
        /// Zero-based input channel.
        channel: usize,
    },
    /// Hits without zero padding must all have the length of record 0.
    #[error(
        "record {record} has {samples} samples, record 0 has {expected}: hits averaged without \
         zero padding must have one length (set a block length to zero-pad them)"
    )]
    UnequalHitLengths {
        /// Zero-based record.
        record: usize,
        /// Its samples.
        samples: usize,
        /// Samples of record 0.
        expected: usize,
    },
    /// A hit is longer than the zero-padded block.
    #[error("record {record} has {samples} samples, more than the block of {block_len}")]
    HitLongerThanBlock {
        /// Zero-based record.
        record: usize,
        /// Its samples.
        samples: usize,
        /// Block (FFT) length.
        block_len: usize,
    },
    /// No frequency line falls in the band.
    #[error(
        "the band {low_hz}..{high_hz} Hz holds no frequency line (resolution {resolution_hz} Hz, \
         Nyquist {nyquist_hz} Hz)"
    )]
    EmptyBand {
        /// Lower edge, Hz.
        low_hz: f64,
        /// Upper edge, Hz.
        high_hz: f64,
        /// Line spacing, Hz.
        resolution_hz: f64,
        /// Nyquist frequency, Hz.
        nyquist_hz: f64,
    },
    /// With one reference, the force auto-spectrum is zero at a line.
    #[error(
        "line {line} ({frequency_hz} Hz): input {reference} has no power, the FRF is undefined \
         there (exclude the line with a band)"
    )]
    NoForcePower {
        /// Zero-based line of the estimate.
        line: usize,
        /// Its frequency.
        frequency_hz: f64,
        /// Zero-based input channel.
        reference: usize,
    },
    /// With several references, their cross-spectral matrix is singular at a line.
    #[error(
        "line {line} ({frequency_hz} Hz): the force cross-spectral matrix is singular \
         (reciprocal condition {reciprocal_condition:e}); the references are linearly dependent \
         there"
    )]
    SingularForces {
        /// Zero-based line of the estimate.
        line: usize,
        /// Its frequency.
        frequency_hz: f64,
        /// Smallest over largest eigenvalue of `Gxx`.
        reciprocal_condition: f64,
    },
    /// H2 with several references needs as many responses as references.
    #[error(
        "H2 with {references} references needs as many responses, got {outputs} (H2 = Gyy Gxy^-1 \
         inverts the references x responses cross-spectrum); use H1 or Hv"
    )]
    H2NotSquare {
        /// Responses.
        outputs: usize,
        /// References.
        references: usize,
    },
    /// An estimator has no finite value at a line.
    #[error("line {line} ({frequency_hz} Hz), output {output}: {estimator} is undefined: {reason}")]
    UndefinedEstimate {
        /// The estimator.
        estimator: Estimator,
        /// Zero-based line of the estimate.
        line: usize,
        /// Its frequency.
        frequency_hz: f64,
        /// Zero-based output channel.
        output: usize,
        /// Why.
        reason: &'static str,
    },
    /// [`correct_exponential_window`] was given an unusable mode or window.
    #[error(
        "cannot remove an exponential window (tau = {tau_s} s) from the mode at {frequency_hz} Hz \
         with damping ratio {damping_ratio}: {reason}"
    )]
    InvalidMode {
        /// Identified frequency, Hz.
        frequency_hz: f64,
        /// Identified damping ratio.
        damping_ratio: f64,
        /// Window time constant, s.
        tau_s: f64,
        /// What is wrong.
        reason: &'static str,
    },
}

/// One FFT block: samples `start .. start + len` of a record.
#[derive(Debug, Clone, Copy)]
struct Block {
    record: usize,
    start: usize,
    len: usize,
}

/// Blocks and windows resolved against the records.
struct BlockPlan {
    block_len: usize,
    blocks: Vec<Block>,
    dt_s: f64,
    /// Welch window weights (length `block_len`), empty for hits.
    segment_weights: Vec<f64>,
    segment_window: Option<SegmentWindow>,
    segment_step: Option<usize>,
    force_window: Option<ForceWindow>,
    tau_s: Option<f64>,
    scaling: SpectrumScaling,
    /// Sum of squared window weights (`block_len` for hits: no segment window).
    window_power: f64,
}

impl BlockPlan {
    fn new(
        averaging: &Averaging,
        records: &[Record],
        dt_s: f64,
        longest: usize,
    ) -> Result<Self, FrfEstimateError> {
        match *averaging {
            Averaging::Welch(w) => {
                let len = w.segment_len;
                let step = w.step();
                let mut blocks = Vec::new();
                for (index, rec) in records.iter().enumerate() {
                    let count = w.segments(rec.len());
                    if count == 0 {
                        return Err(DataError::TooShort {
                            record: index,
                            samples: rec.len(),
                            required: len,
                            reason: "one Welch segment",
                        }
                        .into());
                    }
                    blocks.extend((0..count).map(|s| Block {
                        record: index,
                        start: s * step,
                        len,
                    }));
                }
                let segment_weights: Vec<f64> = (0..len).map(|n| w.window.weight(n, len)).collect();
                let window_power = segment_weights.iter().map(|v| v * v).sum();
                Ok(Self {
                    block_len: len,
                    blocks,
                    dt_s,
                    segment_weights,
                    segment_window: Some(w.window),
                    segment_step: Some(step),
                    force_window: None,
                    tau_s: None,
                    scaling: SpectrumScaling::PowerDensity,
                    window_power,
                })
            }
            Averaging::Hits(h) => {
                let block_len = match h.block_len {
                    Some(n) => {
                        if let Some((index, rec)) =
                            records.iter().enumerate().find(|(_, rec)| rec.len() > n)
                        {
                            return Err(FrfEstimateError::HitLongerThanBlock {
                                record: index,
                                samples: rec.len(),
                                block_len: n,
                            });
                        }
                        n
                    }
                    None => {
                        let expected = records[0].len();
                        if let Some((index, rec)) = records
                            .iter()
                            .enumerate()
                            .find(|(_, rec)| rec.len() != expected)
                        {
                            return Err(FrfEstimateError::UnequalHitLengths {
                                record: index,
                                samples: rec.len(),
                                expected,
                            });
                        }
                        if expected < 2 {
                            return Err(DataError::TooShort {
                                record: 0,
                                samples: expected,
                                required: 2,
                                reason: "one FFT block",
                            }
                            .into());
                        }
                        expected
                    }
                };
                if let Some((index, rec)) =
                    records.iter().enumerate().find(|(_, rec)| rec.len() < 2)
                {
                    return Err(DataError::TooShort {
                        record: index,
                        samples: rec.len(),
                        required: 2,
                        reason: "one FFT block",
                    }
                    .into());
                }
                let blocks = records
                    .iter()
                    .enumerate()
                    .map(|(index, rec)| Block {
                        record: index,
                        start: 0,
                        len: rec.len(),
                    })
                    .collect();
                Ok(Self {
                    block_len,
                    blocks,
                    dt_s,
                    segment_weights: Vec::new(),
                    segment_window: None,
                    segment_step: None,
                    force_window: h.force_window,
                    tau_s: h.exponential_window.map(|e| e.tau_s(longest, dt_s)),
                    scaling: SpectrumScaling::EnergyDensityPerHit,
                    window_power: block_len as f64,
                })
            }
        }
    }

    /// Writes the windowed, zero-padded block of every channel (inputs first)
    /// into `buffers` (`(r + m) x block_len`, channel-major). Returns the
    /// force-window peak of each input channel.
    fn fill(&self, rec: &Record, block: &Block, buffers: &mut [C64]) -> Vec<Option<usize>> {
        let n = self.block_len;
        let r = rec.inputs.nrows();
        let mut peaks = Vec::new();
        for (c, buf) in buffers.chunks_exact_mut(n).enumerate() {
            let (data, ch) = if c < r {
                (&rec.inputs, c)
            } else {
                (&rec.outputs, c - r)
            };
            let row = data.row(ch);
            let samples = row.columns(block.start, block.len);
            for (t, b) in buf.iter_mut().take(block.len).enumerate() {
                *b = C64::new(samples[t], 0.0);
            }
            for b in buf.iter_mut().skip(block.len) {
                *b = C64::new(0.0, 0.0);
            }
            if !self.segment_weights.is_empty() {
                for (b, &w) in buf.iter_mut().zip(&self.segment_weights) {
                    *b *= w;
                }
            }
            if let Some(tau_s) = self.tau_s {
                // Evaluated directly: repeated products would drift over long records.
                let rate = -self.dt_s / tau_s;
                for (t, b) in buf.iter_mut().take(block.len).enumerate() {
                    *b *= (rate * t as f64).exp();
                }
            }
            if c < r
                && let Some(fw) = self.force_window
            {
                let peak = samples
                    .iter()
                    .enumerate()
                    .filter(|(_, v)| **v != 0.0)
                    .fold(None::<(usize, f64)>, |best, (t, v)| match best {
                        Some((_, b)) if b >= v.abs() => best,
                        _ => Some((t, v.abs())),
                    })
                    .map(|(t, _)| t);
                if let Some(p) = peak {
                    for (t, b) in buf.iter_mut().take(block.len).enumerate() {
                        *b *= fw.weight((t as f64 - p as f64) * self.dt_s);
                    }
                }
                peaks.push(peak);
            }
        }
        peaks
    }
}

/// Running sums of the spectral products over blocks, on lines `k0 .. k0 + nk`.
/// Flat, line-contiguous layout: entry `(a, b)` of line `k` is at
/// `(a * cols + b) * nk + k`.
struct Accumulator {
    r: usize,
    m: usize,
    k0: usize,
    nk: usize,
    gxx: Vec<C64>,
    gyx: Vec<C64>,
    gyy: Vec<f64>,
    gyy_full: Option<Vec<C64>>,
}

impl Accumulator {
    fn new(r: usize, m: usize, k0: usize, nk: usize, full_outputs: bool) -> Self {
        let zero = C64::new(0.0, 0.0);
        Self {
            r,
            m,
            k0,
            nk,
            gxx: vec![zero; r * r * nk],
            gyx: vec![zero; m * r * nk],
            gyy: vec![0.0; m * nk],
            gyy_full: full_outputs.then(|| vec![zero; m * m * nk]),
        }
    }

    /// Adds the products of one block's DFTs (`(r + m) x nfft`, channel-major).
    fn add(&mut self, spectra: &[C64], nfft: usize) {
        let (r, m, k0, nk) = (self.r, self.m, self.k0, self.nk);
        let line = |c: usize| &spectra[c * nfft + k0..c * nfft + k0 + nk];
        for a in 0..r {
            let xa = line(a);
            for b in 0..r {
                let xb = line(b);
                let dst = &mut self.gxx[(a * r + b) * nk..(a * r + b + 1) * nk];
                for ((d, &u), &v) in dst.iter_mut().zip(xa).zip(xb) {
                    *d += u * v.conj();
                }
            }
        }
        for i in 0..m {
            let yi = line(r + i);
            for j in 0..r {
                let xj = line(j);
                let dst = &mut self.gyx[(i * r + j) * nk..(i * r + j + 1) * nk];
                for ((d, &u), &v) in dst.iter_mut().zip(yi).zip(xj) {
                    *d += u * v.conj();
                }
            }
            let dst = &mut self.gyy[i * nk..(i + 1) * nk];
            for (d, &u) in dst.iter_mut().zip(yi) {
                *d += u.norm_sqr();
            }
            if let Some(full) = self.gyy_full.as_mut() {
                for l in 0..m {
                    let yl = line(r + l);
                    let dst = &mut full[(i * m + l) * nk..(i * m + l + 1) * nk];
                    for ((d, &u), &v) in dst.iter_mut().zip(yi).zip(yl) {
                        *d += u * v.conj();
                    }
                }
            }
        }
    }

    /// Scales the sums into one-sided spectra and splits them per line.
    fn finish(
        self,
        averages: usize,
        nfft: usize,
        dt_s: f64,
        plan_scaling: (SpectrumScaling, f64),
    ) -> CrossSpectra {
        let (scaling, window_power) = plan_scaling;
        let (r, m, k0, nk) = (self.r, self.m, self.k0, self.nk);
        let base = match scaling {
            SpectrumScaling::PowerDensity => dt_s / window_power,
            SpectrumScaling::EnergyDensityPerHit => dt_s * dt_s,
        } / averages as f64;
        let scale = |k: usize| {
            let bin = k0 + k;
            if bin == 0 || 2 * bin == nfft {
                base
            } else {
                2.0 * base
            }
        };
        let frequency_hz = (0..nk)
            .map(|k| (k0 + k) as f64 / (nfft as f64 * dt_s))
            .collect();
        let gxx = (0..nk)
            .map(|k| DMatrix::from_fn(r, r, |a, b| self.gxx[(a * r + b) * nk + k] * scale(k)))
            .collect();
        let gyx = (0..nk)
            .map(|k| DMatrix::from_fn(m, r, |i, j| self.gyx[(i * r + j) * nk + k] * scale(k)))
            .collect();
        let gyy = (0..nk)
            .map(|k| DVector::from_fn(m, |i, _| self.gyy[i * nk + k] * scale(k)))
            .collect();
        let output_cross = self.gyy_full.as_ref().map(|full| {
            (0..nk)
                .map(|k| DMatrix::from_fn(m, m, |i, l| full[(i * m + l) * nk + k] * scale(k)))
                .collect()
        });
        CrossSpectra {
            frequency_hz,
            gxx,
            gyx,
            gyy,
            output_cross,
            averages,
            scaling,
        }
    }
}
