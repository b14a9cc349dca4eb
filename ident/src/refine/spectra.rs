//! DFTs of the records, the frequency bins used by the likelihood, and noise-free responses
//! (for the Cramer-Rao bound).

use super::model::Model;
use crate::linalg::C64;
use crate::modal::Intersample;
use crate::record::Record;
use nalgebra::DMatrix;
use rayon::prelude::*;
use rustfft::{Fft, FftDirection, FftPlanner};
use std::cell::RefCell;
use std::collections::BTreeMap;
use std::f64::consts::PI;
use std::sync::Arc;

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

thread_local! {
    /// FFT plans are cached per thread (a plan is pure: the results do not depend on
    /// which thread made it, nor on whether it was cached).
    static PLANNER: RefCell<FftPlanner<f64>> = RefCell::new(FftPlanner::new());
    /// [`Kernel::new`]'s three long buffers (the frequency response, the padded spectrum
    /// and the FFT scratch), kept by the thread between kernels up to
    /// [`KEPT_KERNEL_BUFFER`] values each: every value read is written first, so they only
    /// spare the fresh pages (a Cramér–Rao bound of a paper-case campaign took about 180
    /// page faults for them).
    static KERNEL_BUFFERS: RefCell<[Vec<C64>; 3]> = const { RefCell::new([Vec::new(), Vec::new(), Vec::new()]) };
}

/// Largest buffer (values) that [`KERNEL_BUFFERS`] keeps: 8 MB each; the kernels of long
/// records use fresh ones.
const KEPT_KERNEL_BUFFER: usize = 1 << 19;

/// The cached forward or inverse FFT of length `len`.
fn plan(len: usize, direction: FftDirection) -> Arc<dyn Fft<f64>> {
    PLANNER.with(|p| p.borrow_mut().plan_fft(len, direction))
}

/// `fft` of `buf` in place with a scratch buffer kept by the caller (grown as needed), so
/// that repeated transforms allocate and zero nothing.
fn transform(fft: &dyn Fft<f64>, buf: &mut [C64], scratch: &mut Vec<C64>) {
    let need = fft.get_inplace_scratch_len();
    if scratch.len() < need {
        scratch.resize(need, C64::new(0.0, 0.0));
    }
    fft.process_with_scratch(buf, &mut scratch[..need]);
}

/// Forward DFT `X_k = sum_t x_t exp(-j 2 pi k t / N)` of each row of `x`, bins `0..keep`.
pub(crate) fn dft_rows(x: &DMatrix<f64>, keep: usize, scratch: &mut Vec<C64>) -> DMatrix<C64> {
    let len = x.ncols();
    let fft = plan(len, FftDirection::Forward);
    let mut out = DMatrix::zeros(x.nrows(), keep);
    let mut buf = vec![C64::new(0.0, 0.0); len];
    for row in 0..x.nrows() {
        for (t, b) in buf.iter_mut().enumerate() {
            *b = C64::new(x[(row, t)], 0.0);
        }
        transform(fft.as_ref(), &mut buf, scratch);
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
        // Hits in parallel; each transform is the same whatever the thread.
        let (y, u) = records
            .par_iter()
            .zip(&group_of)
            .map_init(Vec::new, |scratch, (rec, &g)| {
                let keep = groups[g].bins.len();
                (
                    dft_rows(&rec.outputs, keep, scratch),
                    dft_rows(&rec.inputs, keep, scratch),
                )
            })
            .unzip();
        Self { groups, y, u }
    }

    /// Every `stride`-th bin of each group, from its first: the same hits, a subset of their
    /// equations.
    pub(crate) fn every(&self, stride: usize) -> Self {
        let groups: Vec<Group> = self
            .groups
            .iter()
            .map(|g| Group {
                len: g.len,
                bins: g.bins.iter().step_by(stride).copied().collect(),
                hits: g.hits.clone(),
            })
            .collect();
        let pick = |x: &DMatrix<C64>| {
            let cols = x.ncols().div_ceil(stride);
            DMatrix::from_fn(x.nrows(), cols, |i, j| x[(i, j * stride)])
        };
        Self {
            groups,
            y: self.y.iter().map(pick).collect(),
            u: self.u.iter().map(pick).collect(),
        }
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
            // The response is `y_t = sum_tau g[(t - tau) mod P] u_tau` with `g` the inverse
            // DFT of `H` on the padded grid of length `P` (the band-limited impulse response,
            // aliased with period `P`, where it has decayed). Only the lags `-(len - 1)` to
            // `len - 1` enter, so `g` is computed once per padded length and the records are
            // convolved with those lags on a grid of `Q >= 2 len` points: the same sums as
            // multiplying each record's padded DFT by `H`, far fewer and shorter transforms.
            // The outputs are real, so two of them share one complex inverse transform (the
            // first in the real part, the second in the imaginary part).
            let mut kernels: BTreeMap<usize, Kernel> = BTreeMap::new();
            for u in inputs {
                let len = u.ncols();
                kernels
                    .entry(len)
                    .or_insert_with(|| Kernel::new(model, len, decay));
            }
            // Records in parallel, each with its own buffers (the same numbers on any thread).
            inputs
                .par_iter()
                .map_init(
                    || (Vec::new(), Vec::new(), Vec::new()),
                    |(scratch, uspec, spec): &mut (Vec<C64>, Vec<C64>, Vec<C64>), u| {
                        let len = u.ncols();
                        let kernel = &kernels[&len];
                        let q = kernel.q;
                        let fwd = plan(q, FftDirection::Forward);
                        let inv = plan(q, FftDirection::Inverse);
                        uspec.clear();
                        for l in 0..r {
                            uspec.extend((0..len).map(|t| C64::new(u[(l, t)], 0.0)));
                            uspec.resize((l + 1) * q, C64::new(0.0, 0.0));
                        }
                        for buf in uspec.chunks_exact_mut(q) {
                            transform(fwd.as_ref(), buf, scratch);
                        }
                        let mut y = DMatrix::zeros(n, len);
                        spec.resize(q, C64::new(0.0, 0.0));
                        for i in (0..n).step_by(2) {
                            let second = (i + 1 < n).then_some(i + 1);
                            // spec = sum_l (G_il + j G_i2l) U_l, input by input.
                            if r == 0 {
                                spec.fill(C64::new(0.0, 0.0));
                            }
                            for l in 0..r {
                                let g2 = second.map(|i2| kernel.spectra[i2 + l * n].as_slice());
                                response_terms(
                                    spec,
                                    &kernel.spectra[i + l * n],
                                    g2,
                                    &uspec[l * q..(l + 1) * q],
                                    l > 0,
                                );
                            }
                            transform(inv.as_ref(), spec, scratch);
                            let scale = 1.0 / q as f64;
                            for t in 0..len {
                                y[(i, t)] = spec[t].re * scale;
                                if let Some(i2) = second {
                                    y[(i2, t)] = spec[t].im * scale;
                                }
                            }
                        }
                        y
                    },
                )
                .collect()
        }
    }
}

/// `(g1 + j g2) u` bin by bin (`g2` zero if `None`) into `spec`, added to it if `add`:
/// the spectra of two real outputs in one complex one.
fn response_terms(spec: &mut [C64], g1: &[C64], g2: Option<&[C64]>, u: &[C64], add: bool) {
    match (g2, add) {
        (Some(g2), false) => {
            for (((v, a), b), u) in spec.iter_mut().zip(g1).zip(g2).zip(u) {
                let (x, y) = (a * u, b * u);
                *v = C64::new(x.re - y.im, x.im + y.re);
            }
        }
        (Some(g2), true) => {
            for (((v, a), b), u) in spec.iter_mut().zip(g1).zip(g2).zip(u) {
                let (x, y) = (a * u, b * u);
                *v += C64::new(x.re - y.im, x.im + y.re);
            }
        }
        (None, false) => {
            for ((v, a), u) in spec.iter_mut().zip(g1).zip(u) {
                *v = a * u;
            }
        }
        (None, true) => {
            for ((v, a), u) in spec.iter_mut().zip(g1).zip(u) {
                *v += a * u;
            }
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
    fn new(model: &Model, len: usize, decay: usize) -> Self {
        let [mut frf, mut spec, mut scratch] =
            KERNEL_BUFFERS.with(|b| std::mem::take(&mut *b.borrow_mut()));
        let kernel = Self::with_buffers(model, len, decay, [&mut frf, &mut spec, &mut scratch]);
        let keep = |v: Vec<C64>| {
            if v.capacity() <= KEPT_KERNEL_BUFFER {
                v
            } else {
                Vec::new()
            }
        };
        KERNEL_BUFFERS.with(|b| *b.borrow_mut() = [keep(frf), keep(spec), keep(scratch)]);
        kernel
    }

    fn with_buffers(
        model: &Model,
        len: usize,
        decay: usize,
        [frf, spec, scratch]: [&mut Vec<C64>; 3],
    ) -> Self {
        let (n, r) = (model.n, model.r);
        let padded = (2 * len)
            .saturating_add(decay)
            .min(1 << 22)
            .next_power_of_two();
        let pairs = n * r;
        frequency_response(model, padded, frf);
        let inv = plan(padded, FftDirection::Inverse);
        let q = (2 * len).next_power_of_two();
        let fwd = plan(q, FftDirection::Forward);
        spec.reserve(padded);
        // Pair index `i + l n` (outputs fastest), as in `frf`.
        let mut spectra = Vec::with_capacity(pairs);
        // The lags are real: two pairs share one complex inverse transform (the first in
        // the real part, the second in the imaginary part), each spectrum extended by
        // conjugate symmetry.
        for first in (0..pairs).step_by(2) {
            let second = (first + 1 < pairs).then_some(first + 1);
            // a + j b on bins 0 ..= padded / 2, conj(a) + j conj(b) on their mirrors.
            let both = |h: &[C64]| (h[first], second.map_or(C64::new(0.0, 0.0), |p| h[p]));
            spec.clear();
            spec.extend(frf.chunks_exact(pairs).map(|h| {
                let (a, b) = both(h);
                C64::new(a.re - b.im, a.im + b.re)
            }));
            spec.extend(
                frf.chunks_exact(pairs)
                    .rev()
                    .skip(1)
                    .take(padded / 2 - 1)
                    .map(|h| {
                        let (a, b) = both(h);
                        C64::new(a.re + b.im, b.re - a.im)
                    }),
            );
            transform(inv.as_ref(), spec, scratch);
            let scale = 1.0 / padded as f64;
            for (pair, part) in [(Some(first), false), (second, true)] {
                let Some(_) = pair else { continue };
                // Lag `j` of the aliased response is entry `j mod padded`.
                let lag = |j: usize| {
                    let v = spec[j % padded];
                    C64::new(if part { v.im } else { v.re } * scale, 0.0)
                };
                let mut lags = vec![C64::new(0.0, 0.0); q];
                for j in 0..len {
                    lags[j] = lag(j);
                }
                for j in 1..len {
                    lags[q - j] = lag(padded - j % padded);
                }
                transform(fwd.as_ref(), &mut lags, scratch);
                spectra.push(lags);
            }
        }
        Self { q, spectra }
    }
}

/// `H(j omega_k) = -omega^2 (K - omega^2 M + j omega R)^-1 B2` (n x r, column-major, at
/// `k n r`) for the bins `0..=padded/2` of a DFT of length `padded` (`padded` even; the
/// Nyquist bin's real part only, as for a band-limited response); zero where it does not
/// exist. Written over `out` (its length set).
fn frequency_response(model: &Model, padded: usize, out: &mut Vec<C64>) {
    let (n, r) = (model.n, model.r);
    let (k_n, m_n, d_n) = (
        model.stiffness.as_slice(),
        model.mass.as_slice(),
        model.damping.as_slice(),
    );
    let b2 = model.b2.as_slice();
    let pairs = n * r;
    let bins = padded / 2 + 1;
    out.clear();
    out.resize(bins * pairs, C64::new(0.0, 0.0));
    // The solve with the size as a constant (the common small frames), so that its loops
    // unroll: the same operations in the same order as for any size.
    let solve = |q: &mut [C64], h: &mut [C64]| match (n, r) {
        (2, 1) => super::dense::solve(q, 2, h, 1),
        (3, 1) => super::dense::solve(q, 3, h, 1),
        (4, 1) => super::dense::solve(q, 4, h, 1),
        _ => super::dense::solve(q, n, h, r),
    };
    // Bins in parallel, in chunks of `CHUNK` (each bin's numbers are its own).
    const CHUNK: usize = 1024;
    out.par_chunks_mut(CHUNK * pairs)
        .enumerate()
        .for_each(|(c, chunk)| {
            let mut q = vec![C64::new(0.0, 0.0); n * n];
            let mut h = vec![C64::new(0.0, 0.0); pairs];
            for (j, dst) in chunk.chunks_exact_mut(pairs).enumerate() {
                let k = c * CHUNK + j;
                let omega = 2.0 * PI * k as f64 / (padded as f64 * model.dt);
                for (((v, &kv), &mv), &dv) in q.iter_mut().zip(k_n).zip(m_n).zip(d_n) {
                    *v = C64::new(kv - omega * omega * mv, omega * dv);
                }
                h.copy_from_slice(b2);
                if solve(&mut q, &mut h) {
                    for (d, v) in dst.iter_mut().zip(&h) {
                        *d = v * (-omega * omega);
                    }
                }
            }
        });
    // The band-limited response is real at Nyquist.
    for v in &mut out[(bins - 1) * pairs..] {
        v.im = 0.0;
    }
}
