//! Helpers shared by the simulator's integration tests: models (frames from
//! `testkit`), closed-form frequency responses, sine fits and spectra (all
//! independent of the simulator's state-space code).
#![allow(dead_code)]

use std::f64::consts::PI;

use num_complex::Complex64;
use rustfft::FftPlanner;
use sim::analyzer::kaiser_lowpass;
use sim::{AnalyzerSettings, CampaignSettings, Model, Simulator};

/// The simulator's checked model of a `testkit` frame.
pub fn model(frame: testkit::ShearFrame) -> Model {
    let (mass, stiffness, damping) = frame.into_parts();
    Model::new(mass, stiffness, damping).unwrap()
}

/// The paper's case 1 identified M and K with its Rayleigh damping
/// (modes 2.73 and 9.15 Hz).
pub fn paper_case1() -> Model {
    model(testkit::paper_case1())
}

/// Three floors (1.4, 1.3, 1.1 kg on storeys of 1800, 1200, 700 N/m) with
/// Rayleigh damping `alpha M + beta K`.
pub fn three_dof(alpha: f64, beta: f64) -> Model {
    model(
        testkit::ShearFrame::lumped(&[1.4, 1.3, 1.1], &[1800.0, 1200.0, 700.0])
            .rayleigh(alpha, beta),
    )
}

/// Accelerance of every floor for a force at `input` (zero-based) from
/// `-w^2 (K - w^2 M + i w R)^-1 e_input` ([`testkit::ShearFrame::accelerance`]).
pub fn accelerance(model: &Model, input: usize, frequency_hz: f64) -> Vec<Complex64> {
    testkit::ShearFrame::new(
        model.mass.clone(),
        model.stiffness.clone(),
        model.damping.clone(),
    )
    .accelerance(input, frequency_hz)
}

/// Butterworth gain from its pole product formula.
pub fn butterworth_gain(order: usize, cutoff_hz: f64, s: Complex64) -> Complex64 {
    let wc = 2.0 * PI * cutoff_hz;
    (1..=order).fold(Complex64::new(1.0, 0.0), |acc, k| {
        let p = Complex64::from_polar(wc, PI * (2 * k + order - 1) as f64 / (2 * order) as f64);
        acc * (-p) / (s - p)
    })
}

/// Gain of the default analyzer chain at `fs_hz` (analog Butterworth times
/// the centred decimation FIR) on a sinusoid of `frequency_hz`.
pub fn chain_gain(fs_hz: f64, frequency_hz: f64) -> Complex64 {
    let design = AnalyzerSettings::default().design(fs_hz).unwrap();
    let taps = kaiser_lowpass(
        design.internal_rate_hz,
        design.passband_hz,
        design.stopband_hz,
        design.stopband_attenuation_db,
    );
    let half = (taps.len() / 2) as f64;
    let w = 2.0 * PI * frequency_hz / design.internal_rate_hz;
    let fir: f64 = taps
        .iter()
        .enumerate()
        .map(|(k, &t)| t * (w * (k as f64 - half)).cos())
        .sum();
    butterworth_gain(
        design.analog_order,
        design.analog_cutoff_hz,
        Complex64::new(0.0, 2.0 * PI * frequency_hz),
    ) * fir
}

/// `(sin(pi x) / (pi x))^2`.
pub fn sinc2(x: f64) -> f64 {
    if x == 0.0 {
        1.0
    } else {
        ((PI * x).sin() / (PI * x)).powi(2)
    }
}

/// Least-squares fit `y[n] = Im(Y e^{i w (t_n - t0)})` over samples
/// `range`, `t_n = n dt`: returns Y.
pub fn fit_sine(
    y: &[f64],
    dt_s: f64,
    frequency_hz: f64,
    t0_s: f64,
    range: std::ops::Range<usize>,
) -> Complex64 {
    // y = Re(Y) sin(w tau) + Im(Y) cos(w tau): 2x2 normal equations.
    let w = 2.0 * PI * frequency_hz;
    let (mut ss, mut sc, mut cc, mut ys, mut yc) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for n in range {
        let tau = n as f64 * dt_s - t0_s;
        let (s, c) = (w * tau).sin_cos();
        ss += s * s;
        sc += s * c;
        cc += c * c;
        ys += y[n] * s;
        yc += y[n] * c;
    }
    let det = ss * cc - sc * sc;
    Complex64::new((ys * cc - yc * sc) / det, (yc * ss - ys * sc) / det)
}

/// Welch estimate of the one-sided power spectral density of several
/// records (Hann window, segments of `seg` samples, half overlap), unit^2/Hz
/// on bins `k fs / seg`, k = 0..=seg/2.
pub fn welch_psd(records: &[&[f64]], fs_hz: f64, seg: usize) -> Vec<f64> {
    let window: Vec<f64> = (0..seg)
        .map(|i| 0.5 - 0.5 * (2.0 * PI * i as f64 / seg as f64).cos())
        .collect();
    let wss: f64 = window.iter().map(|w| w * w).sum();
    let fft = FftPlanner::new().plan_fft_forward(seg);
    let mut psd = vec![0.0; seg / 2 + 1];
    let mut count = 0usize;
    for r in records {
        let mut start = 0;
        while start + seg <= r.len() {
            let mut buf: Vec<Complex64> = (0..seg)
                .map(|i| Complex64::new(r[start + i] * window[i], 0.0))
                .collect();
            fft.process(&mut buf);
            for (k, p) in psd.iter_mut().enumerate() {
                let scale = if k == 0 || k == seg / 2 { 1.0 } else { 2.0 };
                *p += scale * buf[k].norm_sqr() / (fs_hz * wss);
            }
            count += 1;
            start += seg / 2;
        }
    }
    psd.iter_mut().for_each(|p| *p /= count as f64);
    psd
}

/// A simulator from a `[campaign]` table written in TOML.
pub fn simulator(model: Model, campaign_toml: &str) -> Simulator {
    let settings: CampaignSettings = toml::from_str(campaign_toml).unwrap();
    Simulator::new(model, settings).unwrap()
}

/// The records of a campaign as channels (force first).
pub fn records(c: &sim::Campaign) -> Vec<Vec<Vec<f64>>> {
    c.hits
        .iter()
        .map(|h| {
            let mut r = vec![h.force.clone()];
            r.extend(h.accelerations.iter().cloned());
            r
        })
        .collect()
}

/// H1 estimate `sum(Y U*) / sum(|U|^2)` over records at every DFT bin,
/// channel `out` against channel 0.
pub fn h1(records: &[Vec<Vec<f64>>], out: usize) -> Vec<Complex64> {
    let n = records[0][0].len();
    let fft = FftPlanner::new().plan_fft_forward(n);
    let spectrum = |x: &[f64]| {
        let mut buf: Vec<Complex64> = x.iter().map(|&v| Complex64::new(v, 0.0)).collect();
        fft.process(&mut buf);
        buf
    };
    let mut num = vec![Complex64::new(0.0, 0.0); n];
    let mut den = vec![0.0; n];
    for rec in records {
        let u = spectrum(&rec[0]);
        let y = spectrum(&rec[out]);
        for k in 0..n {
            num[k] += y[k] * u[k].conj();
            den[k] += u[k].norm_sqr();
        }
    }
    num.iter().zip(&den).map(|(a, b)| a / b).collect()
}

/// Slowest modal decay rate `min(-Re(lambda))` of a model, 1/s.
pub fn slowest_decay_rate(model: &Model) -> f64 {
    let modal = model.modal().unwrap();
    modal
        .poles
        .iter()
        .map(|p| -p.re)
        .fold(f64::INFINITY, f64::min)
}

/// Closed-form modal data of a proportionally damped model: for each mode
/// (lambda, phi_j (phi_j^T e_input)) with mass-normalized phi, from the
/// undamped modes and xi = phi^T R phi / (2 w).
pub fn modal_terms(model: &Model, input: usize) -> Vec<(Complex64, Vec<f64>)> {
    let (w2, phi) = sim::model::undamped_modes(&model.mass, &model.stiffness);
    (0..model.dofs())
        .map(|j| {
            let w = w2[j].sqrt();
            let col = phi.column(j);
            let c_modal = (col.transpose() * &model.damping * col)[(0, 0)];
            let xi = c_modal / (2.0 * w);
            let lambda = Complex64::new(-xi * w, w * (1.0 - xi * xi).sqrt());
            let coef: Vec<f64> = col.iter().map(|p| p * col[input]).collect();
            (lambda, coef)
        })
        .collect()
}
