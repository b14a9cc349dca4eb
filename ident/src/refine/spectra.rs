//! DFTs of the records, the frequency bins used by the likelihood, and noise-free responses
//! (for the Cramer-Rao bound).

use super::model::Model;
use crate::linalg::C64;
use crate::modal::Intersample;
use crate::record::Record;
use nalgebra::DMatrix;
use rustfft::FftPlanner;
use std::collections::BTreeMap;
use std::f64::consts::PI;

/// One DFT bin of a record of `len` samples.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Bin {
    /// Index `k` (0 to `len / 2`).
    pub k: usize,
    /// `z_k = exp(j 2 pi k / len)`.
    pub z: C64,
    /// `omega_k = 2 pi k / (len dt)` in rad/s.
    pub omega: f64,
    /// Likelihood weight: 1 for the real bins (DC, and Nyquist for even lengths), 2 for the
    /// others (they stand for bin `k` and its mirror `len - k`). Dividing by `len` gives the
    /// scale of `|residual|^2 / sigma^2` terms: their sum over all bins equals the time-domain
    /// sum of squares (Parseval).
    pub weight: f64,
}

/// Records of one length share their bins and the model evaluated on them.
#[derive(Debug, Clone)]
pub(crate) struct Group {
    pub len: usize,
    pub bins: Vec<Bin>,
    pub hits: Vec<usize>,
}

/// DFTs of all records on the bins the likelihood uses.
#[derive(Debug, Clone)]
pub(crate) struct Spectra {
    pub groups: Vec<Group>,
    /// Per hit, output DFTs (m x bins of its group).
    pub y: Vec<DMatrix<C64>>,
    /// Per hit, input DFTs (r x bins of its group).
    pub u: Vec<DMatrix<C64>>,
}

/// Bins of a record of `len` samples: all of `0..=len/2` for held inputs, those with
/// frequency at most `band_edge` times Nyquist for band-limited records.
pub(crate) fn bins(len: usize, dt: f64, intersample: Intersample, band_edge: f64) -> Vec<Bin> {
    let last = match intersample {
        Intersample::Zoh => len / 2,
        Intersample::Bandlimited => ((band_edge * len as f64 / 2.0).floor() as usize).min(len / 2),
    };
    (0..=last)
        .map(|k| {
            let real = k == 0 || 2 * k == len;
            Bin {
                k,
                z: C64::from_polar(1.0, 2.0 * PI * k as f64 / len as f64),
                omega: 2.0 * PI * k as f64 / (len as f64 * dt),
                weight: if real { 1.0 } else { 2.0 },
            }
        })
        .collect()
}

/// Forward DFT `X_k = sum_t x_t exp(-j 2 pi k t / N)` of each row of `x`, bins `0..keep`.
pub(crate) fn dft_rows(
    planner: &mut FftPlanner<f64>,
    x: &DMatrix<f64>,
    keep: usize,
) -> DMatrix<C64> {
    let len = x.ncols();
    let fft = planner.plan_fft_forward(len);
    let mut out = DMatrix::zeros(x.nrows(), keep);
    let mut buf = vec![C64::new(0.0, 0.0); len];
    for row in 0..x.nrows() {
        for (t, b) in buf.iter_mut().enumerate() {
            *b = C64::new(x[(row, t)], 0.0);
        }
        fft.process(&mut buf);
        for k in 0..keep {
            out[(row, k)] = buf[k];
        }
    }
    out
}

impl Spectra {
    /// DFTs of `records` (already validated) on the likelihood's bins.
    pub(crate) fn new(
        records: &[Record],
        dt: f64,
        intersample: Intersample,
        band_edge: f64,
    ) -> Self {
        let mut by_len: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
        for (h, rec) in records.iter().enumerate() {
            by_len.entry(rec.len()).or_default().push(h);
        }
        let mut groups = Vec::new();
        let mut group_of = vec![0; records.len()];
        for (len, hits) in by_len {
            for &h in &hits {
                group_of[h] = groups.len();
            }
            groups.push(Group {
                len,
                bins: bins(len, dt, intersample, band_edge),
                hits,
            });
        }
        let mut planner = FftPlanner::new();
        let mut y = Vec::with_capacity(records.len());
        let mut u = Vec::with_capacity(records.len());
        for (h, rec) in records.iter().enumerate() {
            let keep = groups[group_of[h]].bins.len();
            y.push(dft_rows(&mut planner, &rec.outputs, keep));
            u.push(dft_rows(&mut planner, &rec.inputs, keep));
        }
        Self { groups, y, u }
    }

    /// Number of hits.
    pub(crate) fn hits(&self) -> usize {
        self.y.len()
    }
}

/// Noise-free outputs of `model` for each input record (r x N, the structure at rest
/// before the record): exact discrete simulation for held inputs; for band-limited inputs,
/// the product of the input's DFT with `H(j omega)` on a zero-padded grid long enough for
/// the response to decay (the band-limited convolution of the record with the structure),
/// evaluated as the convolution with the impulse response's lags.
pub(crate) fn noise_free_outputs(model: &Model, inputs: &[DMatrix<f64>]) -> Vec<DMatrix<f64>> {
    let n = model.n;
    match model.intersample {
        Intersample::Zoh => {
            let ad = model.ad.map(|z| z.re);
            let bd = model.bd.map(|z| z.re);
            let c = model.c.map(|z| z.re);
            let d = model.d.map(|z| z.re);
            inputs
                .iter()
                .map(|u| {
                    let mut y = DMatrix::zeros(n, u.ncols());
                    let mut x = nalgebra::DVector::zeros(2 * n);
                    for t in 0..u.ncols() {
                        let ut = u.column(t);
                        y.set_column(t, &(&c * &x + &d * ut));
                        x = &ad * x + &bd * ut;
                    }
                    y
                })
                .collect()
        }
        Intersample::Bandlimited => {
            // Slowest decay rate of the structure: pad so that it decays by e^-40.
            let slowest = crate::linalg::eigenvalues(&model.a)
                .map(|ev| ev.iter().map(|l| -l.re).fold(f64::INFINITY, f64::min))
                .unwrap_or(0.0);
            let decay = if slowest > 0.0 {
                (40.0 / (slowest * model.dt)).ceil() as usize
            } else {
                usize::MAX
            };
            let r = model.r;
            let mut planner = FftPlanner::new();
            // The response is `y_t = sum_tau g[(t - tau) mod P] u_tau` with `g` the inverse
            // DFT of `H` on the padded grid of length `P` (the band-limited impulse response,
            // aliased with period `P`, where it has decayed). Only the lags `-(len - 1)` to
            // `len - 1` enter, so `g` is computed once per padded length and the records are
            // convolved with those lags on a grid of `Q >= 2 len` points: the same sums as
            // multiplying each record's padded DFT by `H`, far fewer and shorter transforms.
            let mut kernels: BTreeMap<usize, Kernel> = BTreeMap::new();
            let mut out = Vec::with_capacity(inputs.len());
            for u in inputs {
                let len = u.ncols();
                let kernel = kernels
                    .entry(len)
                    .or_insert_with(|| Kernel::new(model, &mut planner, len, decay));
                let q = kernel.q;
                let fwd = planner.plan_fft_forward(q);
                let inv = planner.plan_fft_inverse(q);
                let mut uspec = Vec::with_capacity(r);
                for l in 0..r {
                    let mut buf = vec![C64::new(0.0, 0.0); q];
                    for t in 0..len {
                        buf[t] = C64::new(u[(l, t)], 0.0);
                    }
                    fwd.process(&mut buf);
                    uspec.push(buf);
                }
                let mut y = DMatrix::zeros(n, len);
                let mut spec = vec![C64::new(0.0, 0.0); q];
                for i in 0..n {
                    spec.fill(C64::new(0.0, 0.0));
                    for l in 0..r {
                        let g = &kernel.spectra[i + l * n];
                        for ((v, &a), &b) in spec.iter_mut().zip(g).zip(&uspec[l]) {
                            *v += a * b;
                        }
                    }
                    inv.process(&mut spec);
                    for t in 0..len {
                        y[(i, t)] = spec[t].re / q as f64;
                    }
                }
                out.push(y);
            }
            out
        }
    }
}

/// The band-limited impulse response of every output-input pair for records of one length,
/// on a convolution grid: its lags `-(len - 1)..len` placed circularly on `q` points and
/// transformed.
struct Kernel {
    /// Convolution grid (a power of two, at least `2 len`).
    q: usize,
    /// Per pair `i + l n`, the DFT of the lags on the grid.
    spectra: Vec<Vec<C64>>,
}

impl Kernel {
    fn new(model: &Model, planner: &mut FftPlanner<f64>, len: usize, decay: usize) -> Self {
        let (n, r) = (model.n, model.r);
        let padded = (2 * len)
            .saturating_add(decay)
            .min(1 << 22)
            .next_power_of_two();
        let frf = frequency_response(model, padded);
        let inv = planner.plan_fft_inverse(padded);
        let q = (2 * len).next_power_of_two();
        let fwd = planner.plan_fft_forward(q);
        let mut spec = vec![C64::new(0.0, 0.0); padded];
        let mut spectra = Vec::with_capacity(n * r);
        for l in 0..r {
            for i in 0..n {
                spec.fill(C64::new(0.0, 0.0));
                for (k, h) in frf.iter().enumerate() {
                    let Some(h) = h else { continue };
                    let mut v = h[i + l * n];
                    if 2 * k == padded {
                        // The band-limited response is real at Nyquist.
                        v = C64::new(v.re, 0.0);
                    }
                    spec[k] = v;
                    if k > 0 && 2 * k < padded {
                        spec[padded - k] = v.conj();
                    }
                }
                inv.process(&mut spec);
                // Lag `j` of the aliased response is entry `j mod padded`.
                let lag = |j: usize| C64::new(spec[j % padded].re / padded as f64, 0.0);
                let mut lags = vec![C64::new(0.0, 0.0); q];
                for j in 0..len {
                    lags[j] = lag(j);
                }
                for j in 1..len {
                    lags[q - j] = lag(padded - j % padded);
                }
                fwd.process(&mut lags);
                spectra.push(lags);
            }
        }
        // Pair index `i + l n` (outputs fastest).
        let mut ordered = vec![Vec::new(); n * r];
        for l in 0..r {
            for i in 0..n {
                ordered[i + l * n] = std::mem::take(&mut spectra[l * n + i]);
            }
        }
        Self {
            q,
            spectra: ordered,
        }
    }
}

/// `H(j omega_k) = -omega^2 (K - omega^2 M + j omega R)^-1 B2` (n x r, column-major) for the
/// bins `0..=padded/2` of a DFT of length `padded`; `None` where it does not exist.
fn frequency_response(model: &Model, padded: usize) -> Vec<Option<Vec<C64>>> {
    let (n, r) = (model.n, model.r);
    let (k_n, m_n, d_n) = (
        model.stiffness.as_slice(),
        model.mass.as_slice(),
        model.damping.as_slice(),
    );
    let mut q = vec![C64::new(0.0, 0.0); n * n];
    (0..=padded / 2)
        .map(|k| {
            let omega = 2.0 * PI * k as f64 / (padded as f64 * model.dt);
            for (((v, &kv), &mv), &dv) in q.iter_mut().zip(k_n).zip(m_n).zip(d_n) {
                *v = C64::new(kv - omega * omega * mv, omega * dv);
            }
            let mut h = model.b2.as_slice().to_vec();
            if !super::dense::solve(&mut q, n, &mut h, r) {
                return None;
            }
            h.iter_mut().for_each(|v| *v *= -omega * omega);
            Some(h)
        })
        .collect()
}
