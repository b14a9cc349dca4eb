//! The per-hit transient in the model's eigenbasis: a cheaper form of the likelihood's
//! transient regressors and their derivatives for band-limited models.
//!
//! The transient of bin `k` is `T_k xi` with `T_k = z_k C (z_k I - A_d)^-1` and a real
//! `xi` per hit. The projected cost, its Gauss-Newton matrix (the Schur complement) and its
//! gradient do not change under a real, invertible, smooth reparametrization of the
//! nuisance, `xi = W(theta) xi'`: `X W` spans what `X` spans, and the Jacobian at fixed `xi'`,
//! `J + X (dW xi')`, differs from `J` by columns in that span, which vanish from the Schur
//! complement and from `J^T r` (`X^T r = 0`). With `W` the real and imaginary parts of the
//! eigenvectors of `A` (those of `A_d = expm(A dt)`, eigenvalues `mu = exp(lambda dt)`), the
//! columns of `T_k W` are, per mode `(lambda, v)` (and its conjugate),
//! `(e + f) / 2` and `(e - f) / (2i)` with `e = z C v / (z - mu)` and
//! `f = z C conj(v) / (z - conj(mu))`, and their derivatives at fixed `xi'`
//! `de = z [d(Cv) / (z - mu) + C v dmu / (z - mu)^2]`, `d(Cv) = dC v + C dv`: the
//! parameter-dependent parts are the same at every bin and computed once per evaluation,
//! leaving a few products per bin, output, mode and parameter and no `s x s` inverse.
//!
//! Used only where the decomposition is well conditioned ([`Eigenbasis::new`]): every
//! eigenvalue in a complex pair, all of them well apart, and `W` well conditioned. Other
//! models (held inputs, overdamped or repeated modes) keep the resolvent form.

use super::likelihood::LANES;
use super::model::Model;
use crate::linalg::{self, C64};
use crate::modal::Intersample;
use nalgebra::{DMatrix, DVector};

/// Smallest distance between two eigenvalues of `A` (a mode and its conjugate included),
/// relative to the larger magnitude, for the eigenbasis to be used: `dv` divides by these
/// differences.
const SEPARATION: f64 = 1e-6;

/// Largest condition number (2-norm) of `W` for the eigenbasis to be used.
const CONDITION: f64 = 1e8;

/// The eigenbasis of a band-limited model: modes `j < n` with `Im lambda_j > 0`, ordered by
/// `Im lambda` (then by the eigensolver's order), each eigenvector scaled so that its largest
/// component (the first of equal ones) is exactly 1. Any normalization gives the same
/// evaluation; this one is smooth in the parameters while the largest component stays the
/// same, so that the Jacobian at fixed `xi'` (its `dv` keeps that component at 1) is also the
/// derivative of the residual at fixed `xi'` across evaluations (tests difference it).
#[derive(Debug, Clone)]
pub(crate) struct Eigenbasis {
    /// Modes (pairs of eigenvalues), the model's `n`.
    n: usize,
    /// Outputs.
    m: usize,
    /// Eigenvalues of `A`: the modes' then their conjugates (`s`).
    lambda: Vec<C64>,
    /// Eigenvectors by columns, in `lambda`'s order (`s x s`, the last `n` the conjugates of
    /// the first).
    v: DMatrix<C64>,
    /// `V^-1`.
    vinv: DMatrix<C64>,
    /// Per mode, the component of its eigenvector fixed at 1.
    pivot: Vec<usize>,
    /// `mu_j = exp(lambda_j dt)`, per mode.
    mu: Vec<C64>,
    /// `C v_j`, `m x n` column-major.
    cv: Vec<C64>,
    /// `W`: column `2 j` is `Re v_j`, column `2 j + 1` is `Im v_j` (`s x s`).
    pub w: DMatrix<f64>,
    /// `dt`.
    dt: f64,
}

/// The parameters' derivatives of the eigenbasis' transient, the same at every bin: per
/// output `i`, mode `j` and parameter `p` at `(i * n + j) * npp + p` (parameters padded with
/// zeros to `npp`), `a = d(C v_j)/dtheta_p` and `b = C v_j dmu_j/dtheta_p`, real and
/// imaginary parts apart.
#[derive(Debug, Clone)]
pub(crate) struct EigenDerivatives {
    npp: usize,
    a_re: Vec<f64>,
    a_im: Vec<f64>,
    b_re: Vec<f64>,
    b_im: Vec<f64>,
}

impl Eigenbasis {
    /// The eigenbasis of `model`, or `None` where the resolvent form is kept: held inputs,
    /// an eigenvalue without a complex partner well apart from it, two eigenvalues closer than
    /// [`SEPARATION`], `W` with a condition number above [`CONDITION`], or a failed
    /// decomposition.
    pub(crate) fn new(model: &Model) -> Option<Self> {
        if model.intersample != Intersample::Bandlimited {
            return None;
        }
        let (n, m) = (model.n, model.n);
        let s = 2 * n;
        let eig = linalg::eig(&model.a).ok()?;
        let mut up: Vec<usize> = (0..s).filter(|&j| eig.values[j].im > 0.0).collect();
        if up.len() != n {
            return None;
        }
        up.sort_by(|&a, &b| {
            eig.values[a]
                .im
                .total_cmp(&eig.values[b].im)
                .then(a.cmp(&b))
        });
        let lambda: Vec<C64> = up
            .iter()
            .map(|&j| eig.values[j])
            .chain(up.iter().map(|&j| eig.values[j].conj()))
            .collect();
        for j in 0..s {
            for k in 0..j {
                let gap = (lambda[j] - lambda[k]).norm();
                let least = SEPARATION * lambda[j].norm().max(lambda[k].norm());
                if gap.is_nan() || gap <= least {
                    return None;
                }
            }
        }
        let mut v = DMatrix::<C64>::zeros(s, s);
        let mut pivot = Vec::with_capacity(n);
        for (j, &col) in up.iter().enumerate() {
            let x = eig.vectors.column(col);
            let mut big = 0;
            for k in 1..s {
                if x[k].norm() > x[big].norm() {
                    big = k;
                }
            }
            let scale = x[big];
            if scale.norm() == 0.0 {
                return None;
            }
            for k in 0..s {
                v[(k, j)] = if k == big {
                    C64::new(1.0, 0.0)
                } else {
                    x[k] / scale
                };
                v[(k, j + n)] = v[(k, j)].conj();
            }
            pivot.push(big);
        }
        let w = DMatrix::from_fn(s, s, |k, q| {
            let x = v[(k, q / 2)];
            if q % 2 == 0 { x.re } else { x.im }
        });
        let sv = linalg::singular_values(&w).ok()?;
        let (top, low) = sv
            .iter()
            .fold((0.0f64, f64::INFINITY), |(t, l), &x| (t.max(x), l.min(x)));
        if top.is_nan() || low.is_nan() || top >= CONDITION * low {
            return None;
        }
        let vinv = linalg::inverse_complex(&v, "eigenvector matrix").ok()?;
        let mu: Vec<C64> = lambda[..n].iter().map(|l| (l * model.dt).exp()).collect();
        if mu.iter().any(|z| !(z.re.is_finite() && z.im.is_finite())) {
            return None;
        }
        let mut cv = vec![C64::new(0.0, 0.0); m * n];
        for j in 0..n {
            for i in 0..m {
                let mut acc = C64::new(0.0, 0.0);
                for k in 0..s {
                    acc += v[(k, j)] * model.c[(i, k)].re;
                }
                cv[i + j * m] = acc;
            }
        }
        Some(Self {
            n,
            m,
            lambda,
            v,
            vinv,
            pivot,
            mu,
            cv,
            w,
            dt: model.dt,
        })
    }

    /// `C (z I - A_d)^-1 W` (`m x s`, column-major) into `out`; false if not finite (`z` at
    /// a pole).
    pub(crate) fn resolvent_product(&self, z: C64, out: &mut [C64]) -> bool {
        let (n, m) = (self.n, self.m);
        for j in 0..n {
            // Halved: the columns are (e + f) / 2 and (e - f) / (2i).
            let d = reciprocal(z - self.mu[j]) * 0.5;
            let dc = reciprocal(z - self.mu[j].conj()) * 0.5;
            if !(d.re.is_finite() && d.im.is_finite() && dc.re.is_finite() && dc.im.is_finite()) {
                return false;
            }
            for i in 0..m {
                let e = self.cv[i + j * m] * d;
                let f = self.cv[i + j * m].conj() * dc;
                let diff = e - f;
                out[i + 2 * j * m] = e + f;
                out[i + (2 * j + 1) * m] = C64::new(diff.im, -diff.re);
            }
        }
        true
    }

    /// The bin-independent parts of the transient's derivatives (`model` built with
    /// derivatives; parameters padded to `npp`).
    pub(crate) fn derivatives(&self, model: &Model, npp: usize) -> EigenDerivatives {
        let der = model
            .derivatives
            .as_ref()
            .expect("eigenbasis derivatives need the model derivatives");
        let (n, m) = (self.n, self.m);
        let s = 2 * n;
        let mut out = EigenDerivatives {
            npp,
            a_re: vec![0.0; m * n * npp],
            a_im: vec![0.0; m * n * npp],
            b_re: vec![0.0; m * n * npp],
            b_im: vec![0.0; m * n * npp],
        };
        for (p, (da, dc)) in der.a.iter().zip(&der.c).enumerate() {
            let da = da.map(|x| C64::new(x, 0.0));
            for j in 0..n {
                let vj = self.v.column(j);
                // Column j of Q = V^-1 dA V: dlambda_j = Q_jj, and
                // dv_j = sum_{k != j} v_k Q_kj / (lambda_j - lambda_k) + c v_j with c such
                // that the pivot component stays 1.
                let q = &self.vinv * (&da * vj);
                let mut dv = DVector::<C64>::zeros(s);
                for k in (0..s).filter(|&k| k != j) {
                    dv += self.v.column(k) * (q[k] / (self.lambda[j] - self.lambda[k]));
                }
                let fix = dv[self.pivot[j]];
                dv -= vj * fix;
                let dmu = self.mu[j] * q[j] * self.dt;
                for i in 0..m {
                    let mut dcv = C64::new(0.0, 0.0);
                    for k in 0..s {
                        dcv += vj[k] * dc[(i, k)].re + dv[k] * model.c[(i, k)].re;
                    }
                    let b = self.cv[i + j * m] * dmu;
                    let at = (i * n + j) * npp + p;
                    out.a_re[at] = dcv.re;
                    out.a_im[at] = dcv.im;
                    out.b_re[at] = b.re;
                    out.b_im[at] = b.im;
                }
            }
        }
        out
    }

    /// `scale d(T W)/dtheta_p` at `z` (`T = z C (z I - A_d)^-1`) into `out`, laid out as the
    /// likelihood's real transient terms: per output `i`, chunk `c` of [`LANES`] parameters
    /// and column `q` of `W`, at `((i * chunks + c) * s + q) * 2 LANES`, the chunk's real
    /// parts and then its imaginary parts.
    pub(crate) fn derivative_terms(
        &self,
        der: &EigenDerivatives,
        z: C64,
        scale: f64,
        out: &mut [f64],
    ) {
        let (n, m, npp) = (self.n, self.m, der.npp);
        let (s, chunks) = (2 * n, npp / LANES);
        for j in 0..n {
            // de = zd a + zd2 b, df = zdc conj(a) + zdc2 conj(b), halved and scaled.
            let d = reciprocal(z - self.mu[j]);
            let dc = reciprocal(z - self.mu[j].conj());
            let zd = z * d * (0.5 * scale);
            let zd2 = zd * d;
            let zdc = z * dc * (0.5 * scale);
            let zdc2 = zdc * dc;
            // Columns 2j = de + df and 2j + 1 = -i (de - df) in sums and differences.
            let (sr, dr) = (zd.re + zdc.re, zd.re - zdc.re);
            let (si, di) = (zd.im + zdc.im, zd.im - zdc.im);
            let (s2r, d2r) = (zd2.re + zdc2.re, zd2.re - zdc2.re);
            let (s2i, d2i) = (zd2.im + zdc2.im, zd2.im - zdc2.im);
            for i in 0..m {
                for c in 0..chunks {
                    let src = (i * n + j) * npp + c * LANES;
                    let lanes = |v: &[f64]| -> [f64; LANES] {
                        v[src..src + LANES].try_into().expect("LANES values")
                    };
                    let (ar, ai) = (lanes(&der.a_re), lanes(&der.a_im));
                    let (br, bi) = (lanes(&der.b_re), lanes(&der.b_im));
                    let at = ((i * chunks + c) * s + 2 * j) * 2 * LANES;
                    let block = &mut out[at..at + 4 * LANES];
                    let (re0, rest) = block.split_at_mut(LANES);
                    let (im0, rest) = rest.split_at_mut(LANES);
                    let (re1, im1) = rest.split_at_mut(LANES);
                    for k in 0..LANES {
                        re0[k] = ar[k] * sr - ai[k] * di + br[k] * s2r - bi[k] * d2i;
                        im0[k] = ar[k] * si + ai[k] * dr + br[k] * s2i + bi[k] * d2r;
                        re1[k] = ar[k] * di + ai[k] * sr + br[k] * d2i + bi[k] * s2r;
                        im1[k] = ai[k] * si - ar[k] * dr + bi[k] * s2i - br[k] * d2r;
                    }
                }
            }
        }
    }
}

/// `1 / w` (not finite for `w` 0).
fn reciprocal(w: C64) -> C64 {
    let scale = 1.0 / w.norm_sqr();
    C64::new(w.re * scale, -w.im * scale)
}
