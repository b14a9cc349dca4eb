//! The structural model at one parameter vector: continuous state space, its discretization
//! and the exact derivatives of both with respect to every parameter.
//!
//! State `[x; x']`, force inputs at the DOFs of `B2` (unit columns), accelerations out:
//! `A = [[0, I], [-M^-1 K, -M^-1 R]]`, `B = [0; M^-1 B2]`, `C = [-M^-1 K, -M^-1 R]`,
//! `D = M^-1 B2`. `A_d = expm(A dt)`; for held inputs also `B_d = int_0^dt expm(A s) ds B`,
//! both read from `expm([[A, B], [0, 0]] dt)`. Their derivatives are Frechet derivatives of
//! the exponential, read from the block-triangular exponential
//! `expm([[X, E], [0, X]]) = [[expm(X), L(X, E)], [0, expm(X)]]`.

use super::param::Parameter;
use crate::linalg::{self, C64};
use crate::mkr::MatrixKind;
use crate::modal::Intersample;
use nalgebra::DMatrix;

/// Why a parameter vector has no model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum ModelError {
    /// M or K is not positive definite (first failing Cholesky pivot and its value).
    NotPositiveDefinite {
        matrix: MatrixKind,
        pivot: usize,
        value: f64,
    },
    /// Something is not finite.
    NonFinite,
}

/// Derivatives of the model with respect to parameter `p`, one entry per parameter.
#[derive(Debug, Clone)]
pub(crate) struct Derivatives {
    /// Continuous `dA/dtheta_p` (real).
    pub a: Vec<DMatrix<f64>>,
    /// `dA_d/dtheta_p`.
    pub ad: Vec<DMatrix<C64>>,
    /// `dB_d/dtheta_p` (held inputs only; empty otherwise).
    pub bd: Vec<DMatrix<C64>>,
    /// `dC/dtheta_p`.
    pub c: Vec<DMatrix<C64>>,
    /// `dD/dtheta_p`.
    pub d: Vec<DMatrix<C64>>,
}

/// The model at one parameter vector.
#[derive(Debug, Clone)]
pub(crate) struct Model {
    pub n: usize,
    pub r: usize,
    pub intersample: Intersample,
    pub dt: f64,
    pub mass: DMatrix<f64>,
    pub stiffness: DMatrix<f64>,
    pub damping: DMatrix<f64>,
    /// Continuous state matrix (real).
    pub a: DMatrix<f64>,
    /// `expm(A dt)`.
    pub ad: DMatrix<C64>,
    /// `B_d` for held inputs (empty otherwise).
    pub bd: DMatrix<C64>,
    /// Output matrix (n x 2n).
    pub c: DMatrix<C64>,
    /// Feedthrough `M^-1 B2` (n x r).
    pub d: DMatrix<C64>,
    /// Input DOF matrix `B2` (n x r).
    pub b2: DMatrix<C64>,
    /// Derivatives, if requested.
    pub derivatives: Option<Derivatives>,
}

fn complex(m: &DMatrix<f64>) -> DMatrix<C64> {
    m.map(|x| C64::new(x, 0.0))
}

/// Frechet derivative `L(x, e)` of the matrix exponential at `x` in direction `e`, with
/// `expm(x)`, from the exponential of `[[x, e], [0, x]]`. The direction is scaled to the
/// norm of `x` first (the result is linear in `e`), so that the scaling-and-squaring
/// choice is driven by `x`.
pub(crate) fn expm_frechet(x: &DMatrix<f64>, e: &DMatrix<f64>) -> (DMatrix<f64>, DMatrix<f64>) {
    let k = x.nrows();
    let (xn, en) = (x.norm(), e.norm());
    let scale = if en > 0.0 && xn > 0.0 { xn / en } else { 1.0 };
    let mut big = DMatrix::zeros(2 * k, 2 * k);
    big.view_mut((0, 0), (k, k)).copy_from(x);
    big.view_mut((k, k), (k, k)).copy_from(x);
    big.view_mut((0, k), (k, k)).copy_from(&(e * scale));
    let ex = big.exp();
    (
        ex.view((0, 0), (k, k)).into_owned(),
        ex.view((0, k), (k, k)).into_owned() / scale,
    )
}

impl Model {
    /// Builds the model of `mass`, `stiffness`, `damping`; with `params`, also the
    /// derivatives with respect to each parameter.
    pub(crate) fn new(
        mass: &DMatrix<f64>,
        stiffness: &DMatrix<f64>,
        damping: &DMatrix<f64>,
        b2: &DMatrix<f64>,
        dt: f64,
        intersample: Intersample,
        params: Option<&[Parameter]>,
    ) -> Result<Self, ModelError> {
        let n = mass.nrows();
        let r = b2.ncols();
        for m in [mass, stiffness, damping] {
            if linalg::first_non_finite(m).is_some() {
                return Err(ModelError::NonFinite);
            }
        }
        for (matrix, value) in [(MatrixKind::Mass, mass), (MatrixKind::Stiffness, stiffness)] {
            if let Err((pivot, v)) = linalg::cholesky(value) {
                return Err(ModelError::NotPositiveDefinite {
                    matrix,
                    pivot,
                    value: v,
                });
            }
        }
        let minv = linalg::inverse(mass, "mass").map_err(|_| ModelError::NonFinite)?;
        let minv = (&minv + minv.transpose()) * 0.5;
        let s = 2 * n;
        let mut a = DMatrix::zeros(s, s);
        a.view_mut((0, n), (n, n)).fill_with_identity();
        a.view_mut((n, 0), (n, n)).copy_from(&-(&minv * stiffness));
        a.view_mut((n, n), (n, n)).copy_from(&-(&minv * damping));
        let d = &minv * b2;
        let mut b = DMatrix::zeros(s, r);
        b.view_mut((n, 0), (n, r)).copy_from(&d);
        let c = a.rows(n, n).into_owned();

        // Exponentials: the augmented one for held inputs, A alone otherwise.
        let (x, k) = match intersample {
            Intersample::Zoh => {
                let mut x = DMatrix::zeros(s + r, s + r);
                x.view_mut((0, 0), (s, s)).copy_from(&a);
                x.view_mut((0, s), (s, r)).copy_from(&b);
                (x * dt, s + r)
            }
            Intersample::Bandlimited => (&a * dt, s),
        };
        let ex = x.exp();
        if linalg::first_non_finite(&ex).is_some() {
            return Err(ModelError::NonFinite);
        }
        let ad = complex(&ex.view((0, 0), (s, s)).into_owned());
        let bd = match intersample {
            Intersample::Zoh => complex(&ex.view((0, s), (s, r)).into_owned()),
            Intersample::Bandlimited => DMatrix::zeros(0, 0),
        };

        let derivatives = params.map(|params| {
            let mut out = Derivatives {
                a: Vec::with_capacity(params.len()),
                ad: Vec::with_capacity(params.len()),
                bd: Vec::with_capacity(params.len()),
                c: Vec::with_capacity(params.len()),
                d: Vec::with_capacity(params.len()),
            };
            for p in params {
                let e = &p.basis;
                let mut da = DMatrix::zeros(s, s);
                let mut dd = DMatrix::zeros(n, r);
                match p.matrix {
                    MatrixKind::Mass => {
                        // d(M^-1) = -M^-1 E M^-1
                        let dminv = -(&minv * e * &minv);
                        da.view_mut((n, 0), (n, n))
                            .copy_from(&-(&dminv * stiffness));
                        da.view_mut((n, n), (n, n)).copy_from(&-(&dminv * damping));
                        dd = &dminv * b2;
                    }
                    MatrixKind::Stiffness => {
                        da.view_mut((n, 0), (n, n)).copy_from(&-(&minv * e));
                    }
                    MatrixKind::Damping => {
                        da.view_mut((n, n), (n, n)).copy_from(&-(&minv * e));
                    }
                }
                let mut dx = DMatrix::zeros(k, k);
                dx.view_mut((0, 0), (s, s)).copy_from(&da);
                if intersample == Intersample::Zoh {
                    dx.view_mut((n, s), (n, r)).copy_from(&dd);
                }
                let (_, l) = expm_frechet(&x, &(dx * dt));
                out.ad.push(complex(&l.view((0, 0), (s, s)).into_owned()));
                if intersample == Intersample::Zoh {
                    out.bd.push(complex(&l.view((0, s), (s, r)).into_owned()));
                }
                out.c.push(complex(&da.rows(n, n).into_owned()));
                out.d.push(complex(&dd));
                out.a.push(da);
            }
            out
        });
        Ok(Self {
            n,
            r,
            intersample,
            dt,
            mass: mass.clone(),
            stiffness: stiffness.clone(),
            damping: damping.clone(),
            a,
            ad,
            bd,
            c: complex(&c),
            d: complex(&d),
            b2: complex(b2),
            derivatives,
        })
    }
}
