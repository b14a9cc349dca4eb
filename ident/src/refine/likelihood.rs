//! The frequency-domain likelihood: model per bin, whitening, variable projection of the
//! per-hit transients and the Gauss-Newton (Fisher) matrix.
//!
//! Per hit `h` and bin `k` the residual is
//! `e_hk = Y_hk - G_k U_hk - T_k xi_h`, `T_k = C (I - A_d / z_k)^-1 = z_k C (z_k I - A_d)^-1`,
//! with covariance `N (Sy + G_k Su G_k^H)` (`Sy`, `Su` diagonal noise variances of the
//! outputs and inputs; errors-in-variables, the true input eliminated). With the Cholesky
//! factor `L_k L_k^H = Sy + G_k Su G_k^H` the whitened residual is
//! `r_hk = sqrt(w_k / N) L_k^-1 e_hk`, split into real and imaginary parts; the cost is
//! `sum |r|^2` (twice the negative log-likelihood up to a constant, each real term of unit
//! variance at the truth).
//!
//! The transient vector `xi_h` (2n real numbers per hit) enters linearly: for given
//! parameters it is solved by least squares (variable projection), and the Gauss-Newton
//! matrix is the Schur complement `J^T J - J^T X (X^T X)^-1 X^T J` (`X = dr/dxi`), the
//! information about the parameters with the transients eliminated. The gradient `J^T r`
//! of the projected cost is exact (`X^T r = 0` at the projected solution).
//!
//! For band-limited models with a well-conditioned eigendecomposition the transient is
//! parametrized in the model's eigenbasis instead, `xi = W xi'` (see [`Eigenbasis`]): the same
//! projected cost, Gauss-Newton matrix and gradient, without the per-bin `s x s` inverse and
//! with far fewer per-bin products in the Jacobian; [`Evaluation::xi`] is converted back.
//!
//! Both passes over the bins (residuals and transient regressors; Jacobian rows reduced to
//! `J^T J`, `J^T X` and `J^T r`) run blocks of [`BLOCK_BINS`] bins as parallel tasks. Each
//! block sums its own bins in order and the blocks' sums are added in block order, so the
//! numbers do not depend on the number of threads or on how rayon splits the work.

use super::dense;
use super::eigenbasis::{EigenDerivatives, Eigenbasis};
use super::model::Model;
use super::param::Parameter;
use super::spectra::{Bin, Spectra};
use crate::linalg::{C64, cross_products, dot};
use crate::mkr::MatrixKind;
use crate::modal::Intersample;
use nalgebra::{DMatrix, DVector, SymmetricEigen};
use rayon::prelude::*;
use std::sync::Arc;

const ZERO: C64 = C64::new(0.0, 0.0);

/// Noise standard deviations (time domain, per sample).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Noise {
    /// Per output channel.
    pub outputs: Vec<f64>,
    /// Per input channel (0 for a noise-free force).
    pub inputs: Vec<f64>,
}

impl Noise {
    pub(crate) fn errors_in_variables(&self) -> bool {
        self.inputs.iter().any(|&s| s > 0.0)
    }
}

/// What to compute besides the cost.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Want {
    /// Cost and transients only.
    Cost,
    /// Also the Gauss-Newton matrix and gradient. With `weight_derivative`, the Jacobian
    /// includes the parameter dependence of the errors-in-variables weighting (exact
    /// Jacobian of the cost); without it, the matrix is the expected Fisher information.
    Jacobian { weight_derivative: bool },
    /// `Jacobian { weight_derivative: true }` and, from the same pass, the expected Fisher
    /// information: bit for bit the matrix of `Jacobian { weight_derivative: false }` at the
    /// same point (the same rows without their weight-derivative terms).
    JacobianAndFisher,
}

/// Result of one evaluation.
#[derive(Debug, Clone)]
pub(crate) struct Evaluation {
    /// `sum |r|^2`.
    pub cost: f64,
    /// Transient vector per hit.
    pub xi: Vec<DVector<f64>>,
    /// Gauss-Newton matrix `J^T J` with the transients eliminated.
    pub fisher: Option<DMatrix<f64>>,
    /// `J^T r` (half the gradient of the cost).
    pub gradient: Option<DVector<f64>>,
    /// With [`Want::JacobianAndFisher`], the expected Fisher information.
    pub expected_fisher: Option<DMatrix<f64>>,
    /// Unwhitened residuals per hit (m x bins), if kept.
    pub residuals: Option<Vec<DMatrix<C64>>>,
    /// Per group, `|G_il|^2` (row `i + l m`) per bin, if residuals are kept.
    pub gains: Option<Vec<DMatrix<f64>>>,
    /// The per-bin model, if every group kept it whole (see [`BinModels`]).
    pub models: Option<BinModels>,
    /// Per hit, the realified whitened matrices before elimination (tests).
    #[cfg(test)]
    pub matrices: Vec<HitMatrices>,
}

/// Realified whitened residual (projected), transient regressors and Jacobian of one hit.
#[cfg(test)]
#[derive(Debug, Clone)]
pub(crate) struct HitMatrices {
    /// Before the projection (without the transient).
    pub r0: DVector<f64>,
    /// The transient regressors in the coordinates of the evaluation (the eigenbasis' where
    /// it is used, see [`Eigenbasis`]).
    pub x: DMatrix<f64>,
    /// The transient in those coordinates (`Evaluation::xi` is in the state's).
    pub xi: DVector<f64>,
    pub j: Option<DMatrix<f64>>,
}

/// The model has no finite response at some bin.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Singular;

/// Per-bin model quantities.
struct BinWork<'a> {
    /// The eigenbasis of the transient, if used: `cr` is then `C (z I - A_d)^-1 W` and `res`
    /// is not computed (empty).
    eigen: Option<&'a Eigenbasis>,
    n: usize,
    m: usize,
    s: usize,
    r: usize,
    tmp: Vec<C64>,
    /// `(z I - A_d)^-1`, s x s.
    res: Vec<C64>,
    /// `C (z I - A_d)^-1`, m x s.
    cr: Vec<C64>,
    /// `(z I - A_d)^-1 B_d`, s x r (held inputs).
    rb: Vec<C64>,
    /// `(K - w^2 M + j w R)^-1`, n x n (band-limited).
    qi: Vec<C64>,
    /// FRF, m x r.
    g: Vec<C64>,
    /// Whitening factor, m x m lower triangular.
    l: Vec<C64>,
    cov: Vec<C64>,
}

impl<'a> BinWork<'a> {
    fn new(model: &Model, eigen: Option<&'a Eigenbasis>) -> Self {
        let (n, r) = (model.n, model.r);
        let (m, s) = (n, 2 * n);
        Self {
            eigen,
            n,
            m,
            s,
            r,
            tmp: vec![ZERO; s * s],
            res: vec![ZERO; if eigen.is_some() { 0 } else { s * s }],
            cr: vec![ZERO; m * s],
            rb: vec![ZERO; s * r],
            qi: vec![ZERO; n * n],
            g: vec![ZERO; m * r],
            l: vec![ZERO; m * m],
            cov: vec![ZERO; m * m],
        }
    }

    /// The model and the weights at `bin`.
    fn compute(&mut self, model: &Model, bin: &Bin, noise: &Noise) -> Result<(), Singular> {
        self.compute_model(model, bin)?;
        self.compute_weights(noise)
    }

    /// The noise-independent part: the resolvent and its products (in the eigenbasis, if
    /// used), the FRF.
    fn compute_model(&mut self, model: &Model, bin: &Bin) -> Result<(), Singular> {
        let (n, m, s, r) = (self.n, self.m, self.s, self.r);
        if let Some(eigen) = self.eigen {
            if !eigen.resolvent_product(bin.z, &mut self.cr) {
                return Err(Singular);
            }
        } else {
            let ad = model.ad.as_slice();
            for (t, a) in self.tmp.iter_mut().zip(ad) {
                *t = -a;
            }
            for i in 0..s {
                self.tmp[i + i * s] += bin.z;
            }
            if !dense::invert(&mut self.tmp, s, &mut self.res) {
                return Err(Singular);
            }
            dense::mul(model.c.as_slice(), m, s, &self.res, s, &mut self.cr);
        }
        match model.intersample {
            Intersample::Zoh => {
                dense::mul(&self.res, s, s, model.bd.as_slice(), r, &mut self.rb);
                self.g.copy_from_slice(model.d.as_slice());
                dense::mul_add(model.c.as_slice(), m, s, &self.rb, r, &mut self.g);
            }
            Intersample::Bandlimited => {
                let w = bin.omega;
                let q = &mut self.tmp[..n * n];
                for j in 0..n {
                    for i in 0..n {
                        q[i + j * n] = C64::new(
                            model.stiffness[(i, j)] - w * w * model.mass[(i, j)],
                            w * model.damping[(i, j)],
                        );
                    }
                }
                if !dense::invert(q, n, &mut self.qi) {
                    return Err(Singular);
                }
                dense::mul(&self.qi, n, n, model.b2.as_slice(), r, &mut self.g);
                for v in self.g.iter_mut() {
                    *v *= -w * w;
                }
            }
        }
        if self
            .g
            .iter()
            .any(|v| !(v.re.is_finite() && v.im.is_finite()))
        {
            return Err(Singular);
        }
        Ok(())
    }

    /// The whitening factor `L` of `Sy + G Su G^H` from the FRF `g` (set by
    /// [`BinWork::compute_model`] or copied from a kept [`ModelBlock`]).
    fn compute_weights(&mut self, noise: &Noise) -> Result<(), Singular> {
        let (m, r) = (self.m, self.r);
        if noise.errors_in_variables() {
            for j in 0..m {
                for i in j..m {
                    let mut v = ZERO;
                    for l in 0..r {
                        let su2 = noise.inputs[l] * noise.inputs[l];
                        v += self.g[i + l * m] * self.g[j + l * m].conj() * su2;
                    }
                    if i == j {
                        v += noise.outputs[i] * noise.outputs[i];
                    }
                    self.cov[i + j * m] = v;
                }
            }
            if !dense::cholesky(&self.cov, m, &mut self.l) {
                return Err(Singular);
            }
        } else {
            self.l.fill(ZERO);
            for i in 0..m {
                self.l[i + i * m] = C64::new(noise.outputs[i], 0.0);
            }
        }
        Ok(())
    }
}

/// Inverse of a symmetric positive semi-definite matrix after diagonal (Jacobi) scaling,
/// dropping eigenvalues below `1e-13` of the largest (pseudo-inverse).
pub(crate) fn spd_inverse(a: &DMatrix<f64>) -> DMatrix<f64> {
    let k = a.nrows();
    let d: Vec<f64> = (0..k)
        .map(|i| {
            let v = a[(i, i)];
            if v > 0.0 { 1.0 / v.sqrt() } else { 1.0 }
        })
        .collect();
    let scaled = DMatrix::from_fn(k, k, |i, j| a[(i, j)] * d[i] * d[j]);
    let eig = SymmetricEigen::new(scaled);
    let top = eig.eigenvalues.iter().cloned().fold(0.0, f64::max);
    let mut inv = DMatrix::zeros(k, k);
    for (idx, &lambda) in eig.eigenvalues.iter().enumerate() {
        if lambda > 1e-13 * top {
            let v = eig.eigenvectors.column(idx);
            inv += (v * v.transpose()) / lambda;
        }
    }
    DMatrix::from_fn(k, k, |i, j| inv[(i, j)] * d[i] * d[j])
}

/// Information and gradient of one hit from its realified, whitened Jacobian and nuisance
/// Jacobian, both transposed (`jt = J^T`, `xt = X^T`, one column per real observation),
/// `(X^T X)^-1` and the projected residual `r`: `J^T J - J^T X (X^T X)^-1 X^T J` and
/// `J^T r`.
pub(crate) fn eliminate_nuisance(
    jt: &DMatrix<f64>,
    xt: &DMatrix<f64>,
    xtx_inv: &DMatrix<f64>,
    r: &DVector<f64>,
) -> (DMatrix<f64>, DVector<f64>) {
    let jtj = jt * jt.transpose();
    let jtx = jt * xt.transpose();
    let mut f = jtj - &jtx * xtx_inv * jtx.transpose();
    f = (&f + f.transpose()) * 0.5;
    (f, jt * r)
}

/// `jtj -= J^T X (X^T X)^-1 X^T J` on the upper triangle (`np` x `np`, row-major) for one
/// hit's `J^T X` (`np` x `s`, row-major); `t` is scratch of its size.
fn subtract_nuisance(jtx_h: &[f64], xtx_inv: &DMatrix<f64>, t: &mut [f64], jtj: &mut [f64]) {
    let s = xtx_inv.nrows();
    let np = jtx_h.len() / s;
    for p in 0..np {
        for k in 0..s {
            let mut acc = 0.0;
            for q in 0..s {
                acc += jtx_h[p * s + q] * xtx_inv[(q, k)];
            }
            t[p * s + k] = acc;
        }
    }
    for p in 0..np {
        for q in p..np {
            let mut acc = 0.0;
            for k in 0..s {
                acc += t[p * s + k] * jtx_h[q * s + k];
            }
            jtj[p * np + q] -= acc;
        }
    }
}

/// Hit `slot`'s rows of a block's `np` Jacobian columns (column `p` at `p * cap`, each hit's
/// `seg` rows one after another).
fn hit_columns(jb: &[f64], np: usize, cap: usize, slot: usize, seg: usize) -> Vec<&[f64]> {
    (0..np)
        .map(|p| &jb[p * cap + slot * seg..p * cap + (slot + 1) * seg])
        .collect()
}

/// Adds one hit's share of a block to `J^T J` (upper triangle, row-major, `np` x `np`),
/// `J^T X` (`np` x `s`, row-major) and, with a residual `r`, `J^T r` (`jtr`, given with it):
/// the products of its Jacobian columns `j` (`np` of them) with themselves, the transient
/// regressors `x` and the residual, in pairs of Jacobian columns against all the others from
/// the pair's first on ([`cross_products`]); `out` is scratch.
fn reduce_hit(
    j: &[&[f64]],
    x: &[&[f64]],
    mut residual: Option<(&[f64], &mut [f64])>,
    out: &mut Vec<f64>,
    jtj: &mut [f64],
    jtx: &mut [f64],
) {
    let (np, s) = (j.len(), x.len());
    let r = residual.as_ref().map(|(r, _)| *r);
    let partners: Vec<&[f64]> = j.iter().chain(x).copied().chain(r).collect();
    for p0 in (0..np).step_by(2) {
        let pair = &j[p0..(p0 + 2).min(np)];
        let b = &partners[p0..];
        out.clear();
        out.resize(pair.len() * b.len(), 0.0);
        cross_products(pair, b, out);
        for (i, row) in out.chunks_exact(b.len()).enumerate() {
            let p = p0 + i;
            // Row `p` of the pair against columns `p0..`: `J^T J` from the diagonal on.
            for (q, v) in row[..np - p0].iter().enumerate().skip(i) {
                jtj[p * np + p0 + q] += v;
            }
            for (t, v) in jtx[p * s..(p + 1) * s]
                .iter_mut()
                .zip(&row[np - p0..np - p0 + s])
            {
                *t += v;
            }
            if let Some((_, jtr)) = residual.as_mut() {
                jtr[p] += row[np - p0 + s];
            }
        }
    }
}

/// One output's Jacobian rows of every hit at one line, written into the block's columns
/// `out` (column `p` at `p * cap`; hit `h`'s real and imaginary parts at rows `h * seg + ro`
/// and the next): per hit `sum_q xi_q S_q + sum_t c_t W_t` with the real transient terms `S_q`
/// and the complex terms `W_t`, both laid out per chunk of `LANES` parameters (`sw`: `s`
/// terms per chunk, `ww`: `nc` terms per chunk of which the first `used` are used). `xis`
/// holds the hits' transients (`s` each), `coefs` their complex coefficients (`nc` each, so
/// many hits as `coefs` holds; `s` is 0 when the transient terms are complex ones). A chunk's
/// sums stay in registers; each element is summed in term order. With `partial`, the sums
/// after the first `k` complex terms are also written into `partial`'s columns (at the same
/// rows): bit for bit the rows of a call with `k` terms used, as they are the same sums.
fn hit_rows(
    (sw, s): (&[f64], usize),
    w: (&[f64], usize, usize),
    xis: &[f64],
    coefs: &[C64],
    out: (&mut [f64], usize, usize, usize),
    partial: Option<(&mut [f64], usize)>,
    np: usize,
) {
    // The transient counts of the common frames (two to four storeys) as constants, so that
    // the loops over the transient terms unroll: the same operations in the same order.
    match s {
        4 => hit_rows_with((sw, 4), w, xis, coefs, out, partial, np),
        6 => hit_rows_with((sw, 6), w, xis, coefs, out, partial, np),
        8 => hit_rows_with((sw, 8), w, xis, coefs, out, partial, np),
        _ => hit_rows_with((sw, s), w, xis, coefs, out, partial, np),
    }
}

/// [`hit_rows`] itself, inlined into each of its calls so that a constant `s` unrolls it.
#[inline(always)]
fn hit_rows_with(
    sw: (&[f64], usize),
    w: (&[f64], usize, usize),
    xis: &[f64],
    coefs: &[C64],
    out: (&mut [f64], usize, usize, usize),
    partial: Option<(&mut [f64], usize)>,
    np: usize,
) {
    match partial {
        Some((part, mid)) => rows_of::<true>(sw, w, xis, coefs, out, (part, mid), np),
        None => rows_of::<false>(sw, w, xis, coefs, out, (&mut [], 0), np),
    }
}

/// [`hit_rows`] with (`PARTIAL`) or without the partial sums.
#[inline(always)]
fn rows_of<const PARTIAL: bool>(
    (sw, s): (&[f64], usize),
    (ww, nc, used): (&[f64], usize, usize),
    xis: &[f64],
    coefs: &[C64],
    (out, cap, seg, ro): (&mut [f64], usize, usize, usize),
    (part, mid): (&mut [f64], usize),
    np: usize,
) {
    // Per hit `s` transients (a constant in the common frames' calls) or, when the transient
    // terms are complex ones (`s` 0), `nc` coefficients.
    let hits = xis
        .len()
        .checked_div(s)
        .unwrap_or_else(|| coefs.len() / nc.max(1));
    for c in 0..np.div_ceil(LANES) {
        let s_blk = &sw[c * s * 2 * LANES..(c + 1) * s * 2 * LANES];
        let w_blk = &ww[c * nc * 2 * LANES..(c * nc + used) * 2 * LANES];
        let lanes = (np - c * LANES).min(LANES);
        for h in 0..hits {
            let xi = &xis[h * s..(h + 1) * s];
            let coef = &coefs[h * nc..h * nc + used];
            let (re, im) = if PARTIAL {
                let (w0, w1) = w_blk.split_at(mid * 2 * LANES);
                let (c0, c1) = coef.split_at(mid);
                let (re, im) = complex_terms(real_terms(s_blk, xi), w0, c0);
                for k in 0..lanes {
                    let at = (c * LANES + k) * cap + h * seg + ro;
                    part[at] = re[k];
                    part[at + 1] = im[k];
                }
                complex_terms((re, im), w1, c1)
            } else {
                complex_terms(real_terms(s_blk, xi), w_blk, coef)
            };
            for k in 0..lanes {
                let at = (c * LANES + k) * cap + h * seg + ro;
                out[at] = re[k];
                out[at + 1] = im[k];
            }
        }
    }
}

/// Real and imaginary parts of `LANES` parameters' derivatives.
type Lanes = ([f64; LANES], [f64; LANES]);

/// The real transient terms of one chunk of [`hit_rows`] for one hit: the real and imaginary
/// parts of `LANES` parameters' derivatives.
#[inline(always)]
fn real_terms(s_blk: &[f64], xi: &[f64]) -> Lanes {
    let mut re = [0.0; LANES];
    let mut im = [0.0; LANES];
    let mut terms = s_blk.chunks_exact(2 * LANES).zip(xi);
    if let Some((w, &x)) = terms.next() {
        for k in 0..LANES {
            re[k] = w[k] * x;
            im[k] = w[LANES + k] * x;
        }
    }
    for (w, &x) in terms {
        let (wr, wi) = w.split_at(LANES);
        for k in 0..LANES {
            re[k] += wr[k] * x;
        }
        for k in 0..LANES {
            im[k] += wi[k] * x;
        }
    }
    (re, im)
}

/// [`real_terms`]' sums with the complex terms `w_blk` (coefficients `coef`) added in order.
#[inline(always)]
fn complex_terms((mut re, mut im): Lanes, w_blk: &[f64], coef: &[C64]) -> Lanes {
    for (w, c) in w_blk.chunks_exact(2 * LANES).zip(coef) {
        let (wr, wi) = w.split_at(LANES);
        let (cr, ci) = (c.re, c.im);
        for k in 0..LANES {
            re[k] += wr[k] * cr - wi[k] * ci;
        }
        for k in 0..LANES {
            im[k] += wr[k] * ci + wi[k] * cr;
        }
    }
    (re, im)
}

/// Row of the real and imaginary parts of channel `i` at bin index `bi`.
#[inline]
fn row(bi: usize, m: usize, i: usize) -> usize {
    2 * (bi * m + i)
}

/// Parameter vectors of the per-bin products are padded with zeros to a multiple of this
/// (whole chunks, no remainder loops; the padding is never stored): a 256-bit vector of
/// doubles where the build has AVX (the x86-64 default, see [`crate::cpu`]), else a 128-bit
/// one. Every element is the same sum in the same order either way (each parameter's lane is
/// summed on its own, in term order): only the instruction count changes. Measured on
/// `frameid sweep scenarios/paper-case1.toml --trials 4 --threads 1` (callgrind), the row
/// lines took 237M instructions with 2 lanes and SSE2, 120M with 4 and AVX.
pub(crate) const LANES: usize = if cfg!(target_feature = "avx") { 4 } else { 2 };

/// Rows of a group's realified residual from which a hit's projection is split across the
/// threads when the group has fewer hits than threads (a 10^6-sample record has 1.5 million),
/// and the rows of one part. On that record the projection took about 25 instead of 43 ms an
/// evaluation (two threads).
const SPLIT_PROJECTION_ROWS: usize = 1 << 16;

/// Cells (channel and line) of one part of the noise fit's sums ([`estimate_noise`]): a part
/// per thread's job; the 10^6-sample record's 750 002 cells make 46.
const NOISE_PART_CELLS: usize = 1 << 14;

/// Hits of a group up to which the Jacobian pass treats the transient terms per hit (see
/// `few` in [`evaluate`]). Measured on paper-case-1 campaigns of 2^17-sample hits (`frameid
/// identify --refine --no-uncertainty`, one thread, medians of three runs, the per-hit form for
/// every group against none): 3.8 % and 3.3 % faster with one and two hits, 0.6 %, 1.0 % and
/// 2.0 % slower with three, four and six. On a 10^6-sample record (one hit) the Jacobian pass
/// took about 225 instead of 250 ms an evaluation (two threads).
const FEW_HITS: usize = 2;

/// Bins whose Jacobian rows are reduced together (bounds the memory of long records).
pub(crate) const BLOCK_BINS: usize = 64;

/// Largest per-bin model cache of a group, bytes. A group with more bins
/// (a long record: 10^6 samples give 375 001 bins, 228 MB of cache for a
/// 2-DOF model) keeps only `G` and `L` (for the residuals and gains) and
/// recomputes the rest per bin in the Jacobian pass: the same function of
/// the same inputs, so the same numbers bit for bit, and far less memory.
const CACHE_BYTES: usize = 64 << 20;

#[cfg(test)]
thread_local! {
    /// [`CACHE_BYTES`] in tests, lowered to run the recomputing path on small data.
    pub(crate) static CACHE_LIMIT: std::cell::Cell<usize> = const { std::cell::Cell::new(CACHE_BYTES) };
    /// [`FEW_HITS`] in tests, changed to run either form of the transient terms on the same
    /// data.
    pub(crate) static FEW_HITS_LIMIT: std::cell::Cell<usize> = const { std::cell::Cell::new(FEW_HITS) };
    /// [`SPLIT_PROJECTION_ROWS`] in tests, lowered to split the projections of small data.
    pub(crate) static SPLIT_ROWS: std::cell::Cell<usize> = const { std::cell::Cell::new(SPLIT_PROJECTION_ROWS) };
    /// Whether the transient may take the eigenbasis form ([`Eigenbasis`]); tests turn it off
    /// to run the resolvent form on the same data.
    pub(crate) static EIGENBASIS: std::cell::Cell<bool> = const { std::cell::Cell::new(true) };
    /// Evaluations in the eigenbasis form on this thread (tests check which form ran).
    pub(crate) static EIGENBASIS_EVALUATIONS: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
    /// [`NOISE_PART_CELLS`] in tests, lowered to sum small data's noise fit in parts.
    pub(crate) static NOISE_PART_LIMIT: std::cell::Cell<usize> = const { std::cell::Cell::new(NOISE_PART_CELLS) };
    /// Groups evaluated without the full cache on this thread (tests check that the
    /// recomputing path ran).
    pub(crate) static RECOMPUTED_GROUPS: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
    /// Groups whose projections were split on this thread (tests check that they were).
    pub(crate) static SPLIT_GROUPS: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
    /// Groups evaluated with a kept per-bin model on this thread (tests check that they were).
    pub(crate) static REUSED_GROUPS: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
}

/// The constant `$value`; in tests the thread-local `$cell` that stands for it (set by a test
/// to run a path on small data).
macro_rules! tunable {
    ($cell:ident, $value:expr) => {{
        #[cfg(test)]
        let value = $cell.with(|c| c.get());
        #[cfg(not(test))]
        let value = $value;
        value
    }};
}

/// Per-bin model quantities of a group, kept between the passes: all of
/// them (`full`), or `G` and `L` only; one [`CacheBlock`] per block of
/// [`BLOCK_BINS`] bins, filled by the block's task in pass 1.
struct Cache {
    full: bool,
    blocks: Vec<CacheBlock>,
}

/// The cached quantities of one block's bins: the model's, which do not depend on the noise
/// (shared with later evaluations at the same parameters, see [`BinModels`]), and `L`.
struct CacheBlock {
    model: Arc<ModelBlock>,
    l: Vec<C64>,
}

/// The noise-independent per-bin quantities of one block of a group's bins, one bin after
/// another: `(z I - A_d)^-1`, `C (z I - A_d)^-1`, `(z I - A_d)^-1 B_d` and `Q^-1` if the group
/// keeps everything (empty otherwise), and the FRF `G`. In the eigenbasis form (`eigen`)
/// `C (z I - A_d)^-1 W` stands for `C (z I - A_d)^-1` and the resolvent is not kept.
#[derive(Debug)]
pub(crate) struct ModelBlock {
    eigen: bool,
    res: Vec<C64>,
    cr: Vec<C64>,
    rb: Vec<C64>,
    qi: Vec<C64>,
    g: Vec<C64>,
}

/// The noise-independent per-bin model of every group of an evaluation whose groups all keep
/// everything (per group, per block). Given back to [`evaluate`] at the same parameters, its
/// first pass computes only the weights: the same numbers (the same function of the same
/// inputs), without the per-line inverses.
pub(crate) type BinModels = Vec<Vec<Arc<ModelBlock>>>;

/// Bytes held by `models`.
pub(crate) fn model_bytes(models: &BinModels) -> usize {
    models
        .iter()
        .flatten()
        .map(|b| {
            (b.res.len() + b.cr.len() + b.rb.len() + b.qi.len() + b.g.len())
                * std::mem::size_of::<C64>()
        })
        .sum()
}

impl Cache {
    /// Whether a group of `nb` bins keeps everything (within [`CACHE_BYTES`]).
    fn full(work: &BinWork<'_>, nb: usize) -> bool {
        let per_bin = work.res.len()
            + work.cr.len()
            + work.rb.len()
            + work.qi.len()
            + work.g.len()
            + work.l.len();
        nb.saturating_mul(per_bin * std::mem::size_of::<C64>())
            <= tunable!(CACHE_LIMIT, CACHE_BYTES)
    }

    /// The quantity `pick` (`len` values per bin) of bin `bi`.
    fn get(&self, bi: usize, pick: fn(&CacheBlock) -> &Vec<C64>, len: usize) -> &[C64] {
        slice(pick(&self.blocks[bi / BLOCK_BINS]), bi % BLOCK_BINS, len)
    }
}

impl ModelBlock {
    fn new(work: &BinWork, bins: usize, full: bool) -> Self {
        let of = |len: usize| Vec::with_capacity(if full { bins * len } else { 0 });
        Self {
            eigen: work.eigen.is_some(),
            res: of(work.res.len()),
            cr: of(work.cr.len()),
            rb: of(work.rb.len()),
            qi: of(work.qi.len()),
            g: Vec::with_capacity(bins * work.g.len()),
        }
    }

    fn push(&mut self, work: &BinWork, full: bool) {
        if full {
            self.res.extend_from_slice(&work.res);
            self.cr.extend_from_slice(&work.cr);
            self.rb.extend_from_slice(&work.rb);
            self.qi.extend_from_slice(&work.qi);
        }
        self.g.extend_from_slice(&work.g);
    }
}

fn slice(v: &[C64], bi: usize, len: usize) -> &[C64] {
    &v[bi * len..(bi + 1) * len]
}

/// Evaluates the projected cost (and the Gauss-Newton matrix) at `model`.
///
/// `kept_models`: the [`Evaluation::models`] of an earlier evaluation at the same `model`
/// (the same parameters), whose per-bin model is then not computed again.
pub(crate) fn evaluate(
    model: &Model,
    params: &[Parameter],
    spectra: &Spectra,
    noise: &Noise,
    want: Want,
    keep_residuals: bool,
    kept_models: Option<&BinModels>,
) -> Result<Evaluation, Singular> {
    let (n, r) = (model.n, model.r);
    let (m, s) = (n, 2 * n);
    let np = params.len();
    let eiv = noise.errors_in_variables();
    // The transient in the model's eigenbasis where that is well conditioned (band-limited
    // models), else in the state's coordinates through the resolvent.
    let eigen = if tunable!(EIGENBASIS, true) {
        Eigenbasis::new(model)
    } else {
        None
    };
    #[cfg(test)]
    if eigen.is_some() {
        EIGENBASIS_EVALUATIONS.with(|c| c.set(c.get() + 1));
    }
    let eigen = eigen.as_ref();
    let work = BinWork::new(model, eigen);
    let hits = spectra.hits();
    let mut xi = vec![DVector::zeros(s); hits];
    let mut cost = 0.0;
    let mut fisher = DMatrix::zeros(np, np);
    let mut gradient = DVector::zeros(np);
    let mut residuals = keep_residuals.then(|| vec![DMatrix::zeros(0, 0); hits]);
    let mut gains = keep_residuals.then(Vec::new);
    let jac = match want {
        Want::Cost => None,
        Want::Jacobian { weight_derivative } => Some(weight_derivative && eiv),
        Want::JacobianAndFisher => Some(eiv),
    };
    // The expected Fisher information as a second matrix, from the rows without the weight
    // derivative; without errors in variables it is the first one.
    let second = want == Want::JacobianAndFisher && eiv;
    let derivs = jac.map(|_| {
        model
            .derivatives
            .as_ref()
            .expect("Jacobian requested from a model built without derivatives")
    });
    // Parameters padded to whole chunks of `LANES` in the Jacobian pass's per-bin products.
    let npp = np.div_ceil(LANES) * LANES;
    // The eigenbasis' transient derivatives, the same for every bin and group.
    let eigen_derivatives: Option<EigenDerivatives> = eigen
        .filter(|_| derivs.is_some())
        .map(|e| e.derivatives(model, npp));

    #[cfg(test)]
    let mut matrices = vec![
        HitMatrices {
            r0: DVector::zeros(0),
            x: DMatrix::zeros(0, 0),
            xi: DVector::zeros(0),
            j: None,
        };
        hits
    ];
    // Upper triangle of `sum_h J_h^T J_h` over all groups; the nuisance terms are
    // subtracted per hit and the lower triangle mirrored at the end.
    let mut jtj = vec![0.0; np * np];
    let mut jtj2 = vec![0.0; if second { np * np } else { 0 }];
    // The evaluation's models, to be kept for the next one at the same parameters, while
    // every group keeps everything.
    let mut models_out: Option<BinModels> = Some(Vec::with_capacity(spectra.groups.len()));
    for (gi, group) in spectra.groups.iter().enumerate() {
        let nb = group.bins.len();
        let rows = 2 * nb * m;
        let hits_here = group.hits.len();
        let sc_of = |bin: &Bin| (bin.weight / group.len as f64).sqrt();
        // The whitened, scaled transient regressors `X` do not depend on the hit: one copy
        // per group, realified and column-major (`rows` x `s`, rows `row(bi, m, i)` and the
        // next: real and imaginary parts, column `q`), and one `X^T X`. `X^T v` and
        // `v - X sol` are dot products and axpys over whole columns.
        let mut xreal = vec![0.0; rows * s];
        // Whitened, scaled residuals, `rows` values per hit (slot).
        let mut rs = vec![0.0; hits_here * rows];
        let full = Cache::full(&work, nb);
        #[cfg(test)]
        if !full {
            RECOMPUTED_GROUPS.with(|c| c.set(c.get() + 1));
        }
        // Kept models are made by groups that keep everything, as this one then does, in the
        // same form (the same parameters give the same form, but tests switch it).
        let given = kept_models
            .map(|all| &all[gi])
            .filter(|_| full)
            .filter(|blocks| blocks.iter().all(|b| b.eigen == eigen.is_some()));
        #[cfg(test)]
        if given.is_some() {
            REUSED_GROUPS.with(|c| c.set(c.get() + 1));
        }
        let nblocks = nb.div_ceil(BLOCK_BINS);
        // Rows of one block in a column of `X` or a hit's residual.
        let block_rows = 2 * m * BLOCK_BINS;
        let mut x_blocks: Vec<Vec<&mut [f64]>> = (0..nblocks).map(|_| Vec::new()).collect();
        for col in xreal.chunks_mut(rows) {
            for (blk, part) in x_blocks.iter_mut().zip(col.chunks_mut(block_rows)) {
                blk.push(part);
            }
        }
        let mut r_blocks: Vec<Vec<&mut [f64]>> = (0..nblocks).map(|_| Vec::new()).collect();
        for hit in rs.chunks_mut(rows) {
            for (blk, part) in r_blocks.iter_mut().zip(hit.chunks_mut(block_rows)) {
                blk.push(part);
            }
        }

        // Pass 1: residual without transient, transient regressors. Blocks of bins run in
        // parallel, each writing its own rows; `X^T X` (upper triangle, column-major) is
        // summed per block and the blocks' sums are added in block order, so the result
        // does not depend on the number of threads.
        let pass1 = |(b0, mut xcols, mut rcols): (usize, Vec<&mut [f64]>, Vec<&mut [f64]>)|
         -> Result<(Vec<f64>, CacheBlock), Singular> {
            let mut work = BinWork::new(model, eigen);
            let mut tx = vec![ZERO; m * s];
            let mut xb = vec![ZERO; m * s];
            let mut e = vec![ZERO; m * hits_here];
            let mut xtx_upper = vec![0.0; s * s];
            let end = (b0 + BLOCK_BINS).min(nb);
            // The block's model as kept from an evaluation at the same parameters, or
            // computed here.
            let kept = given.map(|blocks| Arc::clone(&blocks[b0 / BLOCK_BINS]));
            let mut made = kept
                .is_none()
                .then(|| ModelBlock::new(&work, end - b0, full));
            let mut block_l = Vec::with_capacity((end - b0) * m * m);
            for (lb, bin) in group.bins[b0..end].iter().enumerate() {
                let bi = b0 + lb;
                let cr = match (&kept, made.as_mut()) {
                    (Some(kept), _) => {
                        work.g.copy_from_slice(slice(&kept.g, lb, m * r));
                        work.compute_weights(noise)?;
                        slice(&kept.cr, lb, m * s)
                    }
                    (None, Some(made)) => {
                        work.compute(model, bin, noise)?;
                        made.push(&work, full);
                        &work.cr[..]
                    }
                    (None, None) => unreachable!("a block's model is kept or made"),
                };
                block_l.extend_from_slice(&work.l);
                let sc = sc_of(bin);
                for (v, c) in tx.iter_mut().zip(cr) {
                    *v = c * bin.z;
                }
                dense::forward_solve(&work.l, m, &mut tx, s);
                for (x, t) in xb.iter_mut().zip(&tx) {
                    *x = t * sc;
                }
                for (q, col) in xcols.iter_mut().enumerate() {
                    let col = &mut col[2 * lb * m..2 * (lb + 1) * m];
                    for (pair, x) in col.chunks_exact_mut(2).zip(&xb[q * m..(q + 1) * m]) {
                        pair[0] = x.re;
                        pair[1] = x.im;
                    }
                }
                for q2 in 0..s {
                    let b = &xb[q2 * m..(q2 + 1) * m];
                    for q1 in 0..=q2 {
                        let a = &xb[q1 * m..(q1 + 1) * m];
                        let mut acc = 0.0;
                        for (a, b) in a.iter().zip(b) {
                            acc += a.re * b.re + a.im * b.im;
                        }
                        xtx_upper[q1 + q2 * s] += acc;
                    }
                }
                // The hits' residuals of the bin as the columns of one right-hand side, whitened
                // by one forward substitution (each column the same operations as alone).
                let g = &work.g;
                for (e, &h) in e.chunks_exact_mut(m).zip(&group.hits) {
                    let y = &spectra.y[h].as_slice()[bi * m..(bi + 1) * m];
                    let u = &spectra.u[h].as_slice()[bi * r..(bi + 1) * r];
                    for i in 0..m {
                        let mut v = y[i];
                        for (l, &ul) in u.iter().enumerate() {
                            v -= g[i + l * m] * ul;
                        }
                        e[i] = v;
                    }
                }
                dense::forward_solve(&work.l, m, &mut e, hits_here);
                for (rv, e) in rcols.iter_mut().zip(e.chunks_exact(m)) {
                    let rv = &mut rv[2 * lb * m..2 * (lb + 1) * m];
                    for (pair, ei) in rv.chunks_exact_mut(2).zip(e) {
                        pair[0] = sc * ei.re;
                        pair[1] = sc * ei.im;
                    }
                }
            }
            let block = CacheBlock {
                model: kept.unwrap_or_else(|| Arc::new(made.expect("made when not kept"))),
                l: block_l,
            };
            Ok((xtx_upper, block))
        };
        let sums: Vec<Result<(Vec<f64>, CacheBlock), Singular>> = x_blocks
            .into_iter()
            .zip(r_blocks)
            .enumerate()
            .map(|(b, (x, rr))| (b * BLOCK_BINS, x, rr))
            .collect::<Vec<_>>()
            .into_par_iter()
            .map(pass1)
            .collect();
        let mut xtx_upper = vec![0.0; s * s];
        let mut cache = Cache {
            full,
            blocks: Vec::with_capacity(nblocks),
        };
        for sum in sums {
            let (sum, block) = sum?;
            for (a, b) in xtx_upper.iter_mut().zip(&sum) {
                *a += b;
            }
            cache.blocks.push(block);
        }
        if !full {
            models_out = None;
        }
        if let Some(out) = models_out.as_mut() {
            out.push(cache.blocks.iter().map(|b| Arc::clone(&b.model)).collect());
        }
        let xtx = DMatrix::from_fn(s, s, |a, b| {
            if a <= b {
                xtx_upper[a + b * s]
            } else {
                xtx_upper[b + a * s]
            }
        });
        if let Some(all) = gains.as_mut() {
            all.push(DMatrix::from_fn(m * r, nb, |idx, bi| {
                cache.get(bi, |b| &b.model.g, m * r)[idx].norm_sqr()
            }));
        }
        // A hit's projection runs on one thread when the group has hits enough to keep the
        // threads busy; a group of fewer hits (a long record is one) splits each hit's passes
        // instead: the columns' dot products over the columns, the updates and the unwhitened
        // residuals over blocks of rows or bins. Every value is the same arithmetic either way.
        let part = tunable!(SPLIT_ROWS, SPLIT_PROJECTION_ROWS).max(2 * m);
        let split = hits_here < rayon::current_num_threads() && rows >= part;
        #[cfg(test)]
        if split {
            SPLIT_GROUPS.with(|c| c.set(c.get() + 1));
        }
        let xt_mul = |v: &[f64], out: &mut [f64]| {
            let col = |q: usize| dot(&xreal[q * rows..(q + 1) * rows], v);
            if split {
                out.par_iter_mut()
                    .enumerate()
                    .for_each(|(q, o)| *o = col(q));
            } else {
                for (q, o) in out.iter_mut().enumerate() {
                    *o = col(q);
                }
            }
        };
        let sub_x = |v: &mut [f64], sol: &[f64]| {
            let update = |start: usize, v: &mut [f64]| {
                for (q, &sq) in sol.iter().enumerate() {
                    let x = &xreal[q * rows + start..q * rows + start + v.len()];
                    for (a, &x) in v.iter_mut().zip(x) {
                        *a -= x * sq;
                    }
                }
            };
            if split {
                v.par_chunks_mut(part)
                    .enumerate()
                    .for_each(|(c, v)| update(c * part, v));
            } else {
                update(0, v);
            }
        };
        let inv_mul = |inv: &DMatrix<f64>, v: &[f64], out: &mut [f64]| {
            for (a, o) in out.iter_mut().enumerate() {
                *o = (0..s).map(|b| inv[(a, b)] * v[b]).sum();
            }
        };

        #[cfg(test)]
        let r0s = rs.clone();
        // Transients by least squares, projected residuals: hits in parallel, each the same
        // arithmetic whatever the thread, their costs added in hit order below.
        let xtx_inv = spd_inverse(&xtx);
        // The unwhitened residuals of a projected hit, if kept.
        let keep = residuals.is_some();
        let unwhiten = |rv: &[f64]| {
            let mut out = DMatrix::zeros(m, nb);
            let fill = |b0: usize, out: &mut [C64]| {
                for (lb, o) in out.chunks_exact_mut(m).enumerate() {
                    let bi = b0 + lb;
                    let l = cache.get(bi, |b| &b.l, m * m);
                    let sc = sc_of(&group.bins[bi]);
                    for (i, o) in o.iter_mut().enumerate() {
                        let mut v = ZERO;
                        for k in 0..=i {
                            let ro = row(bi, m, k);
                            v += l[i + k * m] * C64::new(rv[ro], rv[ro + 1]);
                        }
                        *o = v / sc;
                    }
                }
            };
            if split {
                let bins = part / (2 * m);
                out.as_mut_slice()
                    .par_chunks_mut(bins * m)
                    .enumerate()
                    .for_each(|(c, o)| fill(c * bins, o));
            } else {
                fill(0, out.as_mut_slice());
            }
            out
        };
        // Per hit, the projection and then (if kept) the unwhitened residuals, in one
        // parallel pass over the hits.
        let projected: Vec<(f64, Vec<f64>, Option<DMatrix<C64>>)> = rs
            .par_chunks_mut(rows)
            .map(|rv| {
                let mut xtv = vec![0.0; s];
                let mut sol = vec![0.0; s];
                let mut correction = vec![0.0; s];
                xt_mul(rv, &mut xtv);
                inv_mul(&xtx_inv, &xtv, &mut sol);
                sub_x(rv, &sol);
                // One step of iterative refinement: the normal equations square the
                // condition number, and the gradient J^T r is exact only for r orthogonal
                // to X.
                xt_mul(rv, &mut xtv);
                inv_mul(&xtx_inv, &xtv, &mut correction);
                sub_x(rv, &correction);
                for (a, c) in sol.iter_mut().zip(&correction) {
                    *a += c;
                }
                let hit_cost = rv.iter().map(|v| v * v).sum::<f64>();
                (hit_cost, sol, keep.then(|| unwhiten(rv)))
            })
            .collect();
        for ((hit_cost, sol, unwhitened), &h) in projected.into_iter().zip(&group.hits) {
            cost += hit_cost;
            xi[h] = DVector::from_vec(sol);
            if let (Some(res), Some(out)) = (residuals.as_mut(), unwhitened) {
                res[h] = out;
            }
        }
        if !cost.is_finite() {
            return Err(Singular);
        }
        #[cfg(test)]
        for (slot, &h) in group.hits.iter().enumerate() {
            let x = DMatrix::from_column_slice(rows, s, &xreal);
            matrices[h] = HitMatrices {
                r0: DVector::from_column_slice(&r0s[slot * rows..(slot + 1) * rows]),
                x,
                xi: xi[h].clone(),
                j: None,
            };
        }

        // Pass 2: Jacobian with respect to the parameters at fixed transients, reduced on
        // the fly to `J^T J` (all hits), `J^T X` and `J^T r` (per hit).
        let (Some(weight_derivative), Some(der)) = (jac, derivs) else {
            continue;
        };
        // The model's derivatives are real; they are laid out with the parameter index
        // innermost, so that the per-bin products below run over contiguous parameters.
        let by_param = |rows: usize, cols: usize, get: &dyn Fn(usize, usize, usize) -> f64| {
            let mut out = vec![0.0; rows * cols * npp];
            for a in 0..rows {
                for b in 0..cols {
                    for p in 0..np {
                        out[(a * cols + b) * npp + p] = get(p, a, b);
                    }
                }
            }
            out
        };
        // `dC` and `dA_d` for the resolvent form (the eigenbasis has its own).
        let (dc, dad) = if eigen.is_some() {
            (Vec::new(), Vec::new())
        } else {
            (
                by_param(m, s, &|p, i, q| der.c[p][(i, q)].re),
                by_param(s, s, &|p, t, q| der.ad[p][(t, q)].re),
            )
        };
        let (dd, dbd, basis) = match model.intersample {
            Intersample::Zoh => (
                by_param(m, r, &|p, i, l| der.d[p][(i, l)].re),
                by_param(s, r, &|p, q, l| der.bd[p][(q, l)].re),
                Vec::new(),
            ),
            Intersample::Bandlimited => (
                Vec::new(),
                Vec::new(),
                by_param(n, n, &|p, j, k| params[p].basis[(j, k)]),
            ),
        };
        let mut jtx = vec![0.0; hits_here * np * s];
        // The hits' transients one after another (`s` each), in slot order.
        let xis: Vec<f64> = group
            .hits
            .iter()
            .flat_map(|&h| xi[h].iter().copied())
            .collect();
        let mut jtr = vec![0.0; hits_here * np];
        // With few hits per group (a long record), the transient terms enter each hit's rows
        // as `s` complex terms, `-sc L^-1 (dC + C R dA_d)` with the coefficients `R z xi`
        // (`s^2` per hit), instead of real ones with the coefficients `xi`, whose weights are
        // `s` times as many products per bin: the same rows, summed in another order.
        // In the eigenbasis the real terms' weights are cheap: used for every hit count.
        let few = eigen.is_none() && hits_here <= tunable!(FEW_HITS_LIMIT, FEW_HITS);
        let tc = if few { s } else { 0 };
        // Complex terms of row `i`: the transient terms (few hits), the `r` inputs and, with
        // the weight derivative, the whitened residuals `0..=i`; real terms: the `s`
        // transient components (more hits).
        let nc = tc + r + if weight_derivative { m } else { 0 };
        // Per term, the real parts of the parameters' weights followed by the imaginary
        // parts (`2 npp` values).
        let np2 = 2 * npp;
        // `sw` and `ww` are laid out for `hit_rows`: per output `i` and chunk `c` of
        // `LANES` parameters, the terms one after another, each as `LANES` real parts then
        // `LANES` imaginary parts.
        let chunks = npp / LANES;
        let ww_at = |i: usize, t: usize, p: usize| {
            ((i * chunks + p / LANES) * nc + t) * 2 * LANES + p % LANES
        };
        // Jacobian rows of a block of bins, column-major (one column per parameter, rows
        // ordered by hit, bin, output, real and imaginary part), reduced by dot products
        // over whole columns at the end of the block.
        let cap = hits_here * 2 * m * BLOCK_BINS.min(nb);
        let mut jtx2 = vec![0.0; if second { hits_here * np * s } else { 0 }];
        /// Working memory of the Jacobian pass over one block (every value read is
        /// written first in the same block).
        struct Scratch<'a> {
            work: BinWork<'a>,
            ma_re: Vec<f64>,
            ma_im: Vec<f64>,
            dg: Vec<C64>,
            eg: Vec<C64>,
            factor: Vec<C64>,
            bw: Vec<C64>,
            aw: Vec<C64>,
            coefs: Vec<C64>,
            ww: Vec<f64>,
            sw: Vec<f64>,
            jblk: Vec<f64>,
            jblk2: Vec<f64>,
            rz: Vec<C64>,
            acc_re: Vec<f64>,
            acc_im: Vec<f64>,
        }
        // Per bin, `[(a * cols + b) * npp + p]`: `dC + C (z I - A_d)^-1 dA_d` (m x s, real and
        // imaginary parts), `dG` (m x r) and, band-limited, `E_p G` (n x r).
        let scratch = || Scratch {
            work: BinWork::new(model, eigen),
            ma_re: vec![0.0; if eigen.is_some() { 0 } else { m * s * npp }],
            ma_im: vec![0.0; if eigen.is_some() { 0 } else { m * s * npp }],
            dg: vec![ZERO; m * r * npp],
            eg: vec![ZERO; n * r * npp],
            factor: vec![ZERO; npp],
            bw: vec![ZERO; m * r],
            aw: vec![ZERO; m * r],
            coefs: vec![ZERO; hits_here * nc],
            ww: vec![0.0; m * nc * np2],
            sw: vec![0.0; m * s * np2],
            jblk: vec![0.0; np * cap],
            jblk2: vec![0.0; if second { np * cap } else { 0 }],
            rz: vec![ZERO; if eigen.is_some() { 0 } else { s * s }],
            acc_re: vec![0.0; npp],
            acc_im: vec![0.0; npp],
        };
        /// One block's `J^T J` (upper triangle, row-major), and per hit `J^T X` and
        /// `J^T r` (and the same without the weight derivative).
        struct BlockSums {
            jtj: Vec<f64>,
            jtx: Vec<f64>,
            jtr: Vec<f64>,
            jtj2: Vec<f64>,
            jtx2: Vec<f64>,
            /// Jacobian rows: hit slot, row, real parts then imaginary parts.
            #[cfg(test)]
            rows: Vec<(usize, usize, Vec<f64>)>,
        }
        // Pass 2 over one block of bins starting at `b0`; blocks run in parallel and their
        // sums are added in block order (the same numbers for any thread count).
        let pass2 = |scratch: &mut Scratch, b0: usize| -> Result<BlockSums, Singular> {
            let Scratch {
                work,
                ma_re,
                ma_im,
                dg,
                eg,
                factor,
                bw,
                aw,
                coefs,
                ww,
                sw,
                jblk,
                jblk2,
                rz,
                acc_re,
                acc_im,
            } = scratch;
            let nbb = BLOCK_BINS.min(nb - b0);
            let seg = 2 * m * nbb;
            let mut sums = BlockSums {
                jtj: vec![0.0; np * np],
                jtx: vec![0.0; hits_here * np * s],
                jtr: vec![0.0; hits_here * np],
                jtj2: vec![0.0; if second { np * np } else { 0 }],
                jtx2: vec![0.0; if second { hits_here * np * s } else { 0 }],
                #[cfg(test)]
                rows: Vec::new(),
            };
            for (lb, bin) in group.bins[b0..b0 + nbb].iter().enumerate() {
                let bi = b0 + lb;
                let (res, cr, rb, qi) = if cache.full {
                    (
                        cache.get(bi, |b| &b.model.res, work.res.len()),
                        cache.get(bi, |b| &b.model.cr, m * s),
                        cache.get(bi, |b| &b.model.rb, s * r),
                        cache.get(bi, |b| &b.model.qi, n * n),
                    )
                } else {
                    // Succeeds: it did for this bin in pass 1. The weights `L` are those
                    // pass 1 kept (below), not computed again.
                    work.compute_model(model, bin)?;
                    (&work.res[..], &work.cr[..], &work.rb[..], &work.qi[..])
                };
                let g = cache.get(bi, |b| &b.model.g, m * r);
                let l = cache.get(bi, |b| &b.l, m * m);
                let sc = sc_of(bin);
                // dT/dtheta_p (z I - A_d)^-1 with T = C (z I - A_d)^-1 z: `dC + C R dA_d`.
                // Per output `i`, the `s npp` values of `(q, p)` are contiguous in `dC`,
                // `dA_d` (row `t`) and the result: axpys over whole rows, summed over `t` in
                // order. In the eigenbasis: `-sc d(T W)/dtheta_p` at fixed `xi'` itself, laid out
                // for `hit_rows` and whitened there (below).
                let row_len = s * npp;
                if let (Some(eigen), Some(ed)) = (eigen, eigen_derivatives.as_ref()) {
                    eigen.derivative_terms(ed, bin.z, -sc, sw);
                }
                for i in (0..m).filter(|_| eigen.is_none()) {
                    let (are, aim) = (
                        &mut ma_re[i * row_len..(i + 1) * row_len],
                        &mut ma_im[i * row_len..(i + 1) * row_len],
                    );
                    are.copy_from_slice(&dc[i * row_len..(i + 1) * row_len]);
                    aim.fill(0.0);
                    for t in 0..s {
                        let c = cr[i + t * m];
                        let d = &dad[t * row_len..(t + 1) * row_len];
                        for ((re, im), &d) in are.iter_mut().zip(aim.iter_mut()).zip(d) {
                            *re += c.re * d;
                            *im += c.im * d;
                        }
                    }
                }
                match model.intersample {
                    Intersample::Zoh => {
                        // dG = dD + (dC + C R dA_d) R B_d + C R dB_d.
                        for i in 0..m {
                            for li in 0..r {
                                let o = (i * r + li) * npp;
                                let out = &mut dg[o..o + npp];
                                for (v, &d) in out.iter_mut().zip(&dd[o..o + npp]) {
                                    *v = C64::new(d, 0.0);
                                }
                                for q in 0..s {
                                    let b = rb[q + li * s];
                                    let c = cr[i + q * m];
                                    let a = (i * s + q) * npp;
                                    let (are, aim) = (&ma_re[a..a + npp], &ma_im[a..a + npp]);
                                    let e = &dbd[(q * r + li) * npp..(q * r + li + 1) * npp];
                                    for p in 0..npp {
                                        out[p] += C64::new(are[p], aim[p]) * b + c * e[p];
                                    }
                                }
                            }
                        }
                    }
                    Intersample::Bandlimited => {
                        // dG = -s^2 Q^-1 dQ Q^-1 B2 = -f Q^-1 E G, dQ = f E.
                        let w = bin.omega;
                        for (f, p) in factor.iter_mut().zip(params) {
                            *f = -match p.matrix {
                                MatrixKind::Mass => C64::new(-w * w, 0.0),
                                MatrixKind::Damping => C64::new(0.0, w),
                                MatrixKind::Stiffness => C64::new(1.0, 0.0),
                            };
                        }
                        for j in 0..n {
                            for li in 0..r {
                                let out = &mut eg[(j * r + li) * npp..(j * r + li + 1) * npp];
                                out.fill(ZERO);
                                for k in 0..n {
                                    let gk = g[k + li * m];
                                    let e = &basis[(j * n + k) * npp..(j * n + k + 1) * npp];
                                    for p in 0..npp {
                                        out[p] += gk * e[p];
                                    }
                                }
                            }
                        }
                        for i in 0..n {
                            for li in 0..r {
                                let o = (i * r + li) * npp;
                                let out = &mut dg[o..o + npp];
                                out.fill(ZERO);
                                for j in 0..n {
                                    let qij = qi[i + j * n];
                                    let e = &eg[(j * r + li) * npp..(j * r + li + 1) * npp];
                                    for p in 0..npp {
                                        out[p] += qij * e[p];
                                    }
                                }
                                for (v, f) in out.iter_mut().zip(factor.iter()) {
                                    *v *= f;
                                }
                            }
                        }
                    }
                }
                // Whitened once per bin, shared by the hits: forward substitution with `L`
                // (real diagonal) on the output index.
                let resolvent = eigen.is_none();
                for i in 0..m {
                    for k in 0..i {
                        let lik = l[i + k * m];
                        for q in (0..s).filter(|_| resolvent) {
                            let (oi, ok) = ((i * s + q) * npp, (k * s + q) * npp);
                            for p in 0..npp {
                                let (kr, ki) = (ma_re[ok + p], ma_im[ok + p]);
                                ma_re[oi + p] -= lik.re * kr - lik.im * ki;
                                ma_im[oi + p] -= lik.re * ki + lik.im * kr;
                            }
                        }
                        for li in 0..r {
                            let (oi, ok) = ((i * r + li) * npp, (k * r + li) * npp);
                            for p in 0..npp {
                                let v = dg[ok + p];
                                dg[oi + p] -= lik * v;
                            }
                        }
                    }
                    let d = l[i + i * m].re;
                    if resolvent {
                        for v in &mut ma_re[i * s * npp..(i + 1) * s * npp] {
                            *v /= d;
                        }
                        for v in &mut ma_im[i * s * npp..(i + 1) * s * npp] {
                            *v /= d;
                        }
                    }
                    for v in &mut dg[i * r * npp..(i + 1) * r * npp] {
                        *v /= d;
                    }
                }
                // Transient terms: `-sc L^-1 (dC + C R dA_d) R z`, the derivative of the
                // whitened transient regressor, whose coefficients are the real `xi`.
                // Laid out for `hit_rows`: per output and chunk of parameters, the `s` terms.
                // In the eigenbasis `-sc L^-1 d(T W)`, with the coefficients `xi'`.
                if eigen.is_some() {
                    // Per output, the `chunks s` blocks of `LANES` real and `LANES` imaginary
                    // parts, the same `(chunk, term)` in every output's row.
                    let len = chunks * s * 2 * LANES;
                    for i in 0..m {
                        let (done, rest) = sw.split_at_mut(i * len);
                        let row = &mut rest[..len];
                        for k in 0..i {
                            let lik = l[i + k * m];
                            for (a, b) in row
                                .chunks_exact_mut(2 * LANES)
                                .zip(done[k * len..(k + 1) * len].chunks_exact(2 * LANES))
                            {
                                let (are, aim) = a.split_at_mut(LANES);
                                let (bre, bim) = b.split_at(LANES);
                                for t in 0..LANES {
                                    are[t] -= lik.re * bre[t] - lik.im * bim[t];
                                    aim[t] -= lik.re * bim[t] + lik.im * bre[t];
                                }
                            }
                        }
                        let d = l[i + i * m].re;
                        for v in row.iter_mut() {
                            *v /= d;
                        }
                    }
                }
                for (v, r) in rz.iter_mut().zip(res) {
                    *v = r * bin.z;
                }
                for i in (0..m).filter(|_| few) {
                    for q in 0..s {
                        for p in 0..npp {
                            let a = (i * s + q) * npp + p;
                            let at = ww_at(i, q, p);
                            ww[at] = ma_re[a] * -sc;
                            ww[at + LANES] = ma_im[a] * -sc;
                        }
                    }
                }
                for i in (0..m).filter(|_| !few && eigen.is_none()) {
                    let (mre, mim) = (
                        &ma_re[i * row_len..(i + 1) * row_len],
                        &ma_im[i * row_len..(i + 1) * row_len],
                    );
                    for q2 in 0..s {
                        acc_re.fill(0.0);
                        acc_im.fill(0.0);
                        for q in 0..s {
                            let w = rz[q + q2 * s];
                            let (a_re, a_im) =
                                (&mre[q * npp..(q + 1) * npp], &mim[q * npp..(q + 1) * npp]);
                            for (((or, oi), &ar), &ai) in
                                acc_re.iter_mut().zip(acc_im.iter_mut()).zip(a_re).zip(a_im)
                            {
                                *or += ar * w.re - ai * w.im;
                                *oi += ar * w.im + ai * w.re;
                            }
                        }
                        for (c, (cre, cim)) in acc_re
                            .chunks_exact(LANES)
                            .zip(acc_im.chunks_exact(LANES))
                            .enumerate()
                        {
                            let o = ((i * chunks + c) * s + q2) * 2 * LANES;
                            let dst = &mut sw[o..o + 2 * LANES];
                            for k in 0..LANES {
                                dst[k] = cre[k] * -sc;
                                dst[LANES + k] = cim[k] * -sc;
                            }
                        }
                    }
                }
                // Complex terms: the input DFTs (`dG`) and, with the weight derivative, the
                // whitened residuals (`Phi`): L^-1 dC L^-H = a b^H + b a^H with
                // b = L^-1 G Su^1/2, a = L^-1 dG Su^1/2; d(L^-1) e = -Phi(L^-1 dC L^-H) L^-1 e
                // (Cholesky derivative).
                for i in 0..m {
                    for t in 0..r {
                        let o = (i * r + t) * npp;
                        for p in 0..npp {
                            let w = dg[o + p] * -sc;
                            let at = ww_at(i, tc + t, p);
                            ww[at] = w.re;
                            ww[at + LANES] = w.im;
                        }
                    }
                }
                if weight_derivative {
                    for li in 0..r {
                        for i in 0..m {
                            bw[i + li * m] = g[i + li * m] * noise.inputs[li];
                        }
                    }
                    dense::forward_solve(l, m, bw, r);
                    for p in 0..np {
                        for li in 0..r {
                            for i in 0..m {
                                aw[i + li * m] = dg[(i * r + li) * npp + p] * noise.inputs[li];
                            }
                        }
                        for j in 0..m {
                            for i in j..m {
                                let mut sij = ZERO;
                                for li in 0..r {
                                    sij += aw[i + li * m] * bw[j + li * m].conj()
                                        + bw[i + li * m] * aw[j + li * m].conj();
                                }
                                let w = if i == j { sij * 0.5 } else { sij } * -sc;
                                let at = ww_at(i, tc + r + j, p);
                                ww[at] = w.re;
                                ww[at + LANES] = w.im;
                            }
                        }
                    }
                }
                let complex_terms = |i: usize| tc + r + if weight_derivative { i + 1 } else { 0 };
                // Rows of this bin in the block: hit `slot`, output `i`, real and imaginary.
                for (slot, &h) in group.hits.iter().enumerate() {
                    let u = &spectra.u[h].as_slice()[bi * r..(bi + 1) * r];
                    let rv = &rs[slot * rows + 2 * bi * m..slot * rows + 2 * (bi + 1) * m];
                    let coef = &mut coefs[slot * nc..(slot + 1) * nc];
                    if few {
                        // `R z xi`, the transient terms' coefficients.
                        let xi = &xis[slot * s..(slot + 1) * s];
                        for (q, c) in coef[..s].iter_mut().enumerate() {
                            let mut v = ZERO;
                            for (q2, &x) in xi.iter().enumerate() {
                                v += rz[q + q2 * s] * x;
                            }
                            *c = v;
                        }
                    }
                    coef[tc..tc + r].copy_from_slice(u);
                    if weight_derivative {
                        for i in 0..m {
                            coef[tc + r + i] = C64::new(rv[2 * i], rv[2 * i + 1]) / sc;
                        }
                    }
                }
                for i in 0..m {
                    // Transient terms (real coefficients) first, then the complex ones.
                    let sw_i = &sw[i * chunks * s * 2 * LANES..(i + 1) * chunks * s * 2 * LANES];
                    let ww_i = &ww[i * chunks * nc * 2 * LANES..(i + 1) * chunks * nc * 2 * LANES];
                    let ro = (bi - b0) * 2 * m + 2 * i;
                    // Without the weight derivative (`second`): the same sums stopped before
                    // its terms.
                    hit_rows(
                        (sw_i, s - tc),
                        (ww_i, nc, complex_terms(i)),
                        &xis,
                        coefs,
                        (jblk, cap, seg, ro),
                        second.then_some((&mut jblk2[..], tc + r)),
                        np,
                    );
                    #[cfg(test)]
                    for slot in 0..hits_here {
                        let mut values = vec![0.0; np2];
                        for p in 0..np {
                            values[p] = jblk[p * cap + slot * seg + ro];
                            values[npp + p] = jblk[p * cap + slot * seg + ro + 1];
                        }
                        sums.rows.push((slot, row(bi, m, i), values));
                    }
                }
            }
            // Block full: per hit, `J^T J` (added over the hits), `J^T X` and `J^T r`.
            let first = 2 * m * b0;
            let xcols: Vec<&[f64]> = (0..s)
                .map(|q| &xreal[q * rows + first..q * rows + first + seg])
                .collect();
            let cols = |jb, slot| hit_columns(jb, np, cap, slot, seg);
            let mut out = Vec::new();
            for slot in 0..hits_here {
                let r_seg = &rs[slot * rows + first..slot * rows + first + seg];
                reduce_hit(
                    &cols(jblk, slot),
                    &xcols,
                    Some((r_seg, &mut sums.jtr[slot * np..(slot + 1) * np])),
                    &mut out,
                    &mut sums.jtj,
                    &mut sums.jtx[slot * np * s..(slot + 1) * np * s],
                );
                if second {
                    reduce_hit(
                        &cols(jblk2, slot),
                        &xcols,
                        None,
                        &mut out,
                        &mut sums.jtj2,
                        &mut sums.jtx2[slot * np * s..(slot + 1) * np * s],
                    );
                }
            }
            Ok(sums)
        };
        let blocks: Vec<Result<BlockSums, Singular>> = (0..nb)
            .step_by(BLOCK_BINS)
            .collect::<Vec<_>>()
            .into_par_iter()
            // A few jobs per thread, each with one scratch (the split changes no number).
            .with_min_len(
                nb.div_ceil(BLOCK_BINS * 2 * rayon::current_num_threads())
                    .max(1),
            )
            .map_init(scratch, pass2)
            .collect();
        #[cfg(test)]
        let mut jts: Vec<DMatrix<f64>> = group
            .hits
            .iter()
            .map(|_| DMatrix::zeros(rows, np))
            .collect();
        for block in blocks {
            let block = block?;
            for p in 0..np {
                for q in p..np {
                    jtj[p * np + q] += block.jtj[p * np + q];
                }
            }
            for (a, b) in jtx.iter_mut().zip(&block.jtx) {
                *a += b;
            }
            for (a, b) in jtr.iter_mut().zip(&block.jtr) {
                *a += b;
            }
            if second {
                for p in 0..np {
                    for q in p..np {
                        jtj2[p * np + q] += block.jtj2[p * np + q];
                    }
                }
                for (a, b) in jtx2.iter_mut().zip(&block.jtx2) {
                    *a += b;
                }
            }
            #[cfg(test)]
            for (slot, ro, values) in block.rows {
                for p in 0..np {
                    jts[slot][(ro, p)] = values[p];
                    jts[slot][(ro + 1, p)] = values[npp + p];
                }
            }
        }
        // `J^T J - J^T X (X^T X)^-1 X^T J` per hit (upper triangle), `J^T r`.
        let mut t = vec![0.0; np * s];
        for slot in 0..hits_here {
            let jtx_h = &jtx[slot * np * s..(slot + 1) * np * s];
            subtract_nuisance(jtx_h, &xtx_inv, &mut t, &mut jtj);
            for p in 0..np {
                gradient[p] += jtr[slot * np + p];
            }
            if second {
                let jtx_h = &jtx2[slot * np * s..(slot + 1) * np * s];
                subtract_nuisance(jtx_h, &xtx_inv, &mut t, &mut jtj2);
            }
        }
        #[cfg(test)]
        for (slot, &h) in group.hits.iter().enumerate() {
            matrices[h].j = Some(jts[slot].clone());
        }
    }
    for p in 0..np {
        for q in p..np {
            fisher[(p, q)] = jtj[p * np + q];
            fisher[(q, p)] = jtj[p * np + q];
        }
    }
    let expected_fisher = (want == Want::JacobianAndFisher).then(|| {
        if second {
            DMatrix::from_fn(np, np, |p, q| jtj2[p.min(q) * np + p.max(q)])
        } else {
            fisher.clone()
        }
    });
    // The transients in the state's coordinates: `xi = W xi'`.
    if let Some(eigen) = eigen {
        for x in xi.iter_mut() {
            *x = &eigen.w * &*x;
        }
    }
    let has_jac = jac.is_some();
    Ok(Evaluation {
        cost,
        xi,
        expected_fisher,
        fisher: has_jac.then_some(fisher),
        gradient: has_jac.then_some(gradient),
        residuals,
        gains,
        models: models_out,
        #[cfg(test)]
        matrices,
    })
}

/// Real observations (real and imaginary parts) over all hits and channels.
pub(crate) fn observations(spectra: &Spectra, m: usize) -> usize {
    spectra
        .groups
        .iter()
        .map(|g| {
            let per_hit: usize = g
                .bins
                .iter()
                .map(|b| if b.weight > 1.5 { 2 * m } else { m })
                .sum();
            per_hit * g.hits.len()
        })
        .sum()
}

/// Noise levels for the first run, from the residuals of the initial guess (mostly model
/// error): per output the median of `|e_ik|^2 / N` over the bins, and for the force the
/// median of `|e_ik|^2 / (N sum_l |G_il|^2)`, so that the force term dominates wherever
/// `|G|` is above its typical size. That is a relative-error fit near the resonances, whose
/// cost is far smoother in the parameters than an absolute fit of sharp peaks placed at
/// slightly wrong frequencies: it widens the basin of attraction of the first run (which
/// uses these levels whatever the noise model). Force levels below the resolution are set
/// to zero as usual.
pub(crate) fn initial_noise(spectra: &Spectra, ev: &Evaluation, fit: &NoiseFit) -> Noise {
    let residuals = ev.residuals.as_ref().expect("residuals kept");
    let gains = ev.gains.as_ref().expect("gains kept");
    let (m, r) = (fit.m, fit.r);
    let median = |mut v: Vec<f64>| -> f64 {
        if v.is_empty() {
            return 0.0;
        }
        let mid = v.len() / 2;
        *v.select_nth_unstable_by(mid, f64::total_cmp).1
    };
    let mut per_output = vec![Vec::new(); m];
    let mut ratios = Vec::new();
    for (gi, group) in spectra.groups.iter().enumerate() {
        for &h in &group.hits {
            for bi in 0..group.bins.len() {
                for i in 0..m {
                    let q = residuals[h][(i, bi)].norm_sqr() / group.len as f64;
                    per_output[i].push(q);
                    let g2: f64 = (0..r).map(|l| gains[gi][(i + l * m, bi)]).sum();
                    if g2 > 0.0 {
                        ratios.push(q / g2);
                    }
                }
            }
        }
    }
    let outputs = per_output
        .into_iter()
        .enumerate()
        .map(|(i, v)| median(v).sqrt().max(fit.output_floor(i)))
        .collect();
    let su = median(ratios).sqrt();
    Noise {
        outputs,
        inputs: (0..r).map(|l| fit.input_level(l, su)).collect(),
    }
}

/// What the noise fit needs besides the residuals.
#[derive(Debug, Clone)]
pub(crate) struct NoiseFit {
    /// Outputs.
    pub m: usize,
    /// Inputs.
    pub r: usize,
    /// Whether the input (force) noise is estimated (else 0).
    pub estimate_inputs: bool,
    /// Observations over observations minus unknowns.
    pub dof_factor: f64,
    /// RMS of each output channel over all records.
    pub output_rms: Vec<f64>,
    /// RMS of each input channel over all records.
    pub input_rms: Vec<f64>,
}

/// Noise levels below this fraction of a channel's RMS (200 dB, beyond any acquisition
/// chain) are round-off of noise-free data, not noise: output levels are raised to it and
/// force levels below it set to zero, so that the weights do not reflect round-off.
pub(crate) const NOISE_RESOLUTION: f64 = 1e-10;

impl NoiseFit {
    fn output_floor(&self, i: usize) -> f64 {
        NOISE_RESOLUTION * self.output_rms[i]
    }

    fn input_level(&self, l: usize, level: f64) -> f64 {
        if level >= NOISE_RESOLUTION * self.input_rms[l] {
            level
        } else {
            0.0
        }
    }
}

/// Noise variances from the residuals of `ev` (evaluated with residuals kept):
/// `E |e_ik|^2 / N = sy_i^2 + sum_l |G_il|^2 su_l^2`, fitted by maximum likelihood for
/// exponentially distributed `|e|^2` (iteratively reweighted least squares with weights
/// `1 / V^2`), variances kept non-negative, then corrected for the degrees of freedom used
/// by the fit. Returns standard deviations.
pub(crate) fn estimate_noise(spectra: &Spectra, ev: &Evaluation, fit: &NoiseFit) -> Noise {
    let residuals = ev.residuals.as_ref().expect("residuals kept");
    let gains = ev.gains.as_ref().expect("gains kept");
    let NoiseFit {
        m,
        r,
        estimate_inputs,
        dof_factor,
        ..
    } = *fit;
    // Observations `q = |e_ik|^2 / N`. The regressor and the IRLS weight of an observation
    // depend only on its (channel, group, bin), not on the hit: the hits' `q` are summed
    // per cell once, so each iteration costs one pass over the cells instead of over every
    // observation (the same normal equations, summed in another order).
    struct Cell {
        channel: usize,
        group: usize,
        bin: usize,
        count: f64,
        q_sum: f64,
    }
    let mut cells: Vec<Cell> = Vec::new();
    for (gi, group) in spectra.groups.iter().enumerate() {
        let nb = group.bins.len();
        let first = cells.len();
        for bi in 0..nb {
            for i in 0..m {
                cells.push(Cell {
                    channel: i,
                    group: gi,
                    bin: bi,
                    count: group.hits.len() as f64,
                    q_sum: 0.0,
                });
            }
        }
        for &h in &group.hits {
            // Column-major m x nb: bin `bi`, channel `i` at `i + bi m`, the cells' order.
            let res = residuals[h].as_slice();
            for (cell, e) in cells[first..].iter_mut().zip(res) {
                cell.q_sum += e.norm_sqr() / group.len as f64;
            }
        }
    }
    let unknowns = m + if estimate_inputs { r } else { 0 };
    // Each cell's regressor, `unknowns` values: its channel's unit entry and, with the
    // force noise, the gains `|G_il|^2`.
    let mut regressors = vec![0.0; cells.len() * unknowns];
    for (cell, x) in cells.iter().zip(regressors.chunks_exact_mut(unknowns)) {
        x[cell.channel] = 1.0;
        if estimate_inputs {
            for l in 0..r {
                x[m + l] = gains[cell.group][(cell.channel + l * m, cell.bin)];
            }
        }
    }
    // Start: output noise only, channel means.
    let mut theta = vec![0.0; unknowns];
    let mut counts = vec![0.0; m];
    for cell in &cells {
        theta[cell.channel] += cell.q_sum;
        counts[cell.channel] += cell.count;
    }
    for i in 0..m {
        theta[i] /= counts[i].max(1.0);
    }
    let mut active = vec![true; unknowns];
    // One part's normal equations (row-major `ata`, then `atb`), summed over its cells in
    // order.
    let part_sums = |cells: &[Cell], regressors: &[f64], theta: &[f64], active: &[bool]| {
        let mut sums = vec![0.0; unknowns * (unknowns + 1)];
        let (ata, atb) = sums.split_at_mut(unknowns * unknowns);
        for (cell, x) in cells.iter().zip(regressors.chunks_exact(unknowns)) {
            let v: f64 = x.iter().zip(theta).map(|(a, b)| a * b).sum();
            let w = 1.0 / (v * v).max(f64::MIN_POSITIVE);
            let (wq, wn) = (w * cell.q_sum, w * cell.count);
            for a in 0..unknowns {
                if !active[a] || x[a] == 0.0 {
                    continue;
                }
                atb[a] += wq * x[a];
                let row = &mut ata[a * unknowns..(a + 1) * unknowns];
                for b in 0..unknowns {
                    if active[b] {
                        row[b] += wn * x[a] * x[b];
                    }
                }
            }
        }
        sums
    };
    let part = tunable!(NOISE_PART_LIMIT, NOISE_PART_CELLS).clamp(1, cells.len().max(1));
    for _ in 0..30 {
        // Normal equations summed over parts of the cells in parallel and the parts' sums
        // added in order (the same numbers for any thread count). A campaign of one part
        // (a 10-hit paper campaign has 1638 cells) sums its cells in order, as before parts.
        let sums = if cells.len() <= part {
            part_sums(&cells, &regressors, &theta, &active)
        } else {
            let parts: Vec<Vec<f64>> = cells
                .par_chunks(part)
                .zip(regressors.par_chunks(part * unknowns))
                .map(|(c, x)| part_sums(c, x, &theta, &active))
                .collect();
            let mut sums = vec![0.0; unknowns * (unknowns + 1)];
            for p in &parts {
                for (a, b) in sums.iter_mut().zip(p) {
                    *a += b;
                }
            }
            sums
        };
        let (ata_sums, atb) = sums.split_at(unknowns * unknowns);
        let mut atb = DVector::from_column_slice(atb);
        let mut ata = DMatrix::from_row_slice(unknowns, unknowns, ata_sums);
        for a in 0..unknowns {
            if !active[a] {
                ata[(a, a)] = 1.0;
                atb[a] = 0.0;
            }
        }
        let Some(sol) = ata.clone().cholesky().map(|c| c.solve(&atb)) else {
            break;
        };
        let mut changed = 0.0f64;
        let mut any_negative = false;
        for a in 0..unknowns {
            let new = sol[a];
            if active[a] && new < 0.0 {
                any_negative = true;
                active[a] = a < m; // output variances stay, clamped below
            }
            let new = new.max(0.0);
            if theta[a] > 0.0 {
                changed = changed.max(((new - theta[a]) / theta[a]).abs());
            } else if new > 0.0 {
                changed = 1.0;
            }
            theta[a] = new;
        }
        for i in 0..m {
            theta[i] = theta[i].max(fit.output_floor(i).powi(2));
        }
        if changed < 1e-8 && !any_negative {
            break;
        }
    }
    Noise {
        outputs: (0..m)
            .map(|i| (theta[i] * dof_factor).sqrt().max(fit.output_floor(i)))
            .collect(),
        inputs: (0..r)
            .map(|l| {
                let level = if estimate_inputs {
                    (theta[m + l] * dof_factor).sqrt()
                } else {
                    0.0
                };
                fit.input_level(l, level)
            })
            .collect(),
    }
}
