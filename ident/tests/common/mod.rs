//! Test data for the round trips, generated inside the test suite (no simulator crate):
//! shear frames (built by `testkit`), exact held (zero-order-hold) records, and band-limited records computed
//! in the frequency domain.

#![allow(dead_code)]

use ident::Record;
use nalgebra::{Complex, DMatrix, DVector};
use rand::RngExt;
use rand::rngs::ChaCha8Rng;
use rand_distr::StandardNormal;
use std::f64::consts::PI;

pub type C64 = Complex<f64>;

/// Sample interval of all round trips: 64 Hz.
pub const DT_S: f64 = 1.0 / 64.0;
/// Samples per record.
pub const SAMPLES: usize = 2048;

/// The frames of the round trips: [`testkit::ShearFrame`], a force at DOF 0 and an
/// accelerometer at every DOF.
pub use testkit::ShearFrame;

/// Two storeys close to the paper's frame (eq. 44-45): 2.73 and 9.16 Hz, 0.5 % Rayleigh
/// damping at both.
pub fn frame2() -> ShearFrame {
    testkit::paper_case1().rayleigh_ratio(0.005, 2.73, 9.16)
}

/// Three storeys, lumped masses 1.0, 0.9, 0.8 kg, storey stiffnesses 1000, 900, 800 N/m:
/// about 2.3, 6.2 and 9.2 Hz, Rayleigh damping 0.5 % at the first and last mode.
pub fn frame3() -> ShearFrame {
    let frame = ShearFrame::lumped(&[1.0, 0.9, 0.8], &[1000.0, 900.0, 800.0]);
    let f = frame.undamped_frequencies_hz();
    frame.rayleigh_ratio(0.005, f[0], f[f.len() - 1])
}

/// The shear-frame parametrization of the refinement for [`frame3`]: its Rayleigh
/// damping's `alpha M` needs ground dashpots at DOFs 1 and 2 besides the storey ones.
pub fn shear3() -> ident::refine::Parametrization {
    use ident::refine::{Dashpot, Node, Parametrization};
    Parametrization::ShearFrame {
        dashpots: vec![
            Dashpot::between(Node::Ground, Node::Dof(1)),
            Dashpot::between(Node::Ground, Node::Dof(2)),
        ],
    }
}

/// A hammer hit: half-sine force of `amplitude_n` newtons and `duration_s`, starting at
/// `onset_s`.
#[derive(Debug, Clone, Copy)]
pub struct Hit {
    pub amplitude_n: f64,
    pub duration_s: f64,
    pub onset_s: f64,
}

impl Hit {
    /// Random hit: 50-150 N, 2-4 ms, onset `pre` samples plus a random fraction.
    pub fn random(rng: &mut ChaCha8Rng, pre: usize) -> Self {
        Self {
            amplitude_n: 50.0 + 100.0 * rng.random::<f64>(),
            duration_s: 0.002 + 0.002 * rng.random::<f64>(),
            onset_s: (pre as f64 + rng.random::<f64>()) * DT_S,
        }
    }

    /// Average force over `[t0, t1]`.
    fn average(&self, t0: f64, t1: f64) -> f64 {
        let a = (t0.max(self.onset_s)) - self.onset_s;
        let b = (t1.min(self.onset_s + self.duration_s)) - self.onset_s;
        if b <= a {
            return 0.0;
        }
        let w = PI / self.duration_s;
        self.amplitude_n * ((w * a).cos() - (w * b).cos()) / w / (t1 - t0)
    }

    /// Continuous Fourier transform of the force at `omega` rad/s.
    fn spectrum(&self, omega: f64) -> C64 {
        let a = PI / self.duration_s;
        let shift = C64::from_polar(1.0, -omega * self.onset_s);
        let value = if (a * a - omega * omega).abs() < 1e-9 * a * a {
            // Removable singularity at omega = a (L'Hopital): -i tau / 2.
            C64::new(0.0, -0.5 * self.duration_s)
        } else {
            (C64::new(1.0, 0.0) + C64::from_polar(1.0, -omega * self.duration_s))
                * (a / (a * a - omega * omega))
        };
        self.amplitude_n * value * shift
    }
}

/// Held records: the force averaged over each sample and held (what a simulation that
/// holds its input per sample produces); exact discrete response from rest.
pub fn held_records(frame: &ShearFrame, hits: &[Hit]) -> Vec<Record> {
    let (a, b, c, d) = frame.continuous(0);
    let (ad, bd) = testkit::zoh(&a, &b, DT_S);
    hits.iter()
        .map(|hit| {
            let u = DMatrix::from_fn(1, SAMPLES, |_, k| {
                hit.average(k as f64 * DT_S, (k + 1) as f64 * DT_S)
            });
            let mut y = DMatrix::zeros(frame.dofs(), SAMPLES);
            let mut x = DVector::zeros(ad.nrows());
            for k in 0..SAMPLES {
                let uk = u[(0, k)];
                y.set_column(k, &(&c * &x + &d * uk));
                x = &ad * x + &bd * uk;
            }
            Record::new(u, y)
        })
        .collect()
}

/// Anti-alias filter of the band-limited records: 1 up to 25 Hz, a smooth (infinitely
/// differentiable) transition, 0 from 32 Hz (Nyquist at 64 Hz sampling). Zero phase.
pub fn lowpass(f_hz: f64) -> f64 {
    let (f1, f2) = (25.0, 32.0);
    if f_hz <= f1 {
        return 1.0;
    }
    if f_hz >= f2 {
        return 0.0;
    }
    let psi = |x: f64| if x > 0.0 { (-1.0 / x).exp() } else { 0.0 };
    let x = (f_hz - f1) / (f2 - f1);
    psi(1.0 - x) / (psi(x) + psi(1.0 - x))
}

/// Length of the frequency grid: 1024 s at 64 Hz, so the response (time constants below
/// 12 s) and the filter tails decay far below round-off before anything wraps around.
pub const FFT_LEN: usize = 1 << 16;

/// Band-limited records computed in the frequency domain: the force spectrum times the
/// low-pass filter, the response `H(j omega)` times that, both sampled at `DT_S` by an
/// inverse DFT over `FFT_LEN` points. The structure is at rest long before the hit, so the
/// record's zero initial state holds up to the filter's precursor before the record start.
pub fn bandlimited_records(frame: &ShearFrame, hits: &[Hit]) -> Vec<Record> {
    let (ac, bc, c, d) = frame.continuous(0);
    let n = frame.dofs();
    let half = FFT_LEN / 2;
    let ns = ac.nrows();
    // Frequency response for the nonnegative frequencies, by a direct complex solve.
    let h: Vec<DVector<C64>> = (0..=half)
        .map(|k| {
            let omega = 2.0 * PI * k as f64 / (FFT_LEN as f64 * DT_S);
            // j omega I - Ac
            let a = DMatrix::<C64>::from_fn(ns, ns, |i, j| {
                C64::new(-ac[(i, j)], if i == j { omega } else { 0.0 })
            });
            let x = a.lu().solve(&bc.map(|v| C64::new(v, 0.0))).unwrap();
            c.map(|v| C64::new(v, 0.0)) * x + d.map(|v| C64::new(v, 0.0))
        })
        .map(|m| m.column(0).into_owned())
        .collect();
    hits.iter()
        .map(|hit| {
            let mut u_spec = vec![C64::new(0.0, 0.0); FFT_LEN];
            let mut y_spec = vec![vec![C64::new(0.0, 0.0); FFT_LEN]; n];
            for k in 0..=half {
                let f = k as f64 / (FFT_LEN as f64 * DT_S);
                let gain = lowpass(f);
                if gain == 0.0 {
                    continue;
                }
                let uk = hit.spectrum(2.0 * PI * f) * gain / DT_S;
                u_spec[k] = uk;
                for (ch, spec) in y_spec.iter_mut().enumerate() {
                    spec[k] = h[k][ch] * uk;
                }
                if k > 0 && k < half {
                    u_spec[FFT_LEN - k] = uk.conj();
                    for spec in y_spec.iter_mut() {
                        spec[FFT_LEN - k] = spec[k].conj();
                    }
                }
            }
            let u = inverse_dft(u_spec);
            let ys: Vec<Vec<f64>> = y_spec.into_iter().map(inverse_dft).collect();
            let inputs = DMatrix::from_fn(1, SAMPLES, |_, k| u[k]);
            let outputs = DMatrix::from_fn(n, SAMPLES, |ch, k| ys[ch][k]);
            Record::new(inputs, outputs)
        })
        .collect()
}

/// Real part of `(1/N) sum_k X_k exp(2 pi i k n / N)`, by a radix-2 FFT.
pub fn inverse_dft(mut x: Vec<C64>) -> Vec<f64> {
    let n = x.len();
    for z in x.iter_mut() {
        *z = z.conj();
    }
    fft_in_place(&mut x);
    x.iter().map(|z| z.re / n as f64).collect()
}

/// Forward DFT `X_k = sum_n x_n exp(-2 pi i k n / N)`, iterative radix-2 (N a power of 2).
pub fn fft_in_place(x: &mut [C64]) {
    let n = x.len();
    assert!(n.is_power_of_two(), "FFT length must be a power of two");
    let bits = n.trailing_zeros();
    for i in 0..n {
        let j = i.reverse_bits() >> (usize::BITS - bits);
        if j > i {
            x.swap(i, j);
        }
    }
    let mut len = 2;
    while len <= n {
        let step = C64::from_polar(1.0, -2.0 * PI / len as f64);
        for start in (0..n).step_by(len) {
            let mut w = C64::new(1.0, 0.0);
            for k in 0..len / 2 {
                let a = x[start + k];
                let b = x[start + k + len / 2] * w;
                x[start + k] = a + b;
                x[start + k + len / 2] = a - b;
                w *= step;
            }
        }
        len <<= 1;
    }
}

/// Adds Gaussian noise of `fraction` times each output channel's RMS (per record).
pub fn add_output_noise(records: &mut [Record], fraction: f64, rng: &mut ChaCha8Rng) {
    for rec in records {
        for ch in 0..rec.outputs.nrows() {
            let rms = (rec.outputs.row(ch).norm_squared() / rec.len() as f64).sqrt();
            for k in 0..rec.len() {
                let e: f64 = rng.sample(StandardNormal);
                rec.outputs[(ch, k)] += fraction * rms * e;
            }
        }
    }
}

/// Relative Frobenius error.
pub fn rel(a: &DMatrix<f64>, b: &DMatrix<f64>) -> f64 {
    (a - b).norm() / b.norm()
}

/// MKR-like start: every M and K entry off by up to 2 % (symmetrically), damping x3.
pub fn perturbed(frame: &ShearFrame, rng: &mut ChaCha8Rng) -> ident::refine::SecondOrder {
    let n = frame.dofs();
    let mut jitter = |m: &DMatrix<f64>| {
        let mut out = m.clone();
        for i in 0..n {
            for j in i..n {
                let f = 1.0 + 0.02 * (2.0 * rng.random::<f64>() - 1.0);
                out[(i, j)] *= f;
                out[(j, i)] = out[(i, j)];
            }
        }
        out
    };
    ident::refine::SecondOrder::new(
        jitter(&frame.mass),
        jitter(&frame.stiffness),
        &frame.damping * 3.0,
    )
}
