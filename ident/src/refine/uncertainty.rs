//! Covariance of the parameters from the Fisher information and the delta method for the
//! matrix entries and the modal parameters.

use super::model::Model;
use super::param::Parameter;
use super::{ModalEstimate, RefineError, Uncertainty};
use crate::linalg::{self, C64};
use crate::mkr::MatrixKind;
use crate::modal;
use nalgebra::{DMatrix, DVector, SymmetricEigen};
use std::f64::consts::PI;

/// Smallest eigenvalue of the Jacobi-scaled Fisher matrix, relative to the largest, for the
/// parameters to count as identifiable.
pub const IDENTIFIABILITY_THRESHOLD: f64 = 1e-13;

/// Inverse of the Fisher information, or `NotIdentifiable`.
fn covariance(fisher: &DMatrix<f64>) -> Result<DMatrix<f64>, RefineError> {
    let p = fisher.nrows();
    let d: Vec<f64> = (0..p)
        .map(|i| {
            let v = fisher[(i, i)];
            if v > 0.0 { 1.0 / v.sqrt() } else { 0.0 }
        })
        .collect();
    if let Some(i) = d.iter().position(|&x| x == 0.0) {
        return Err(RefineError::NotIdentifiable {
            rank: p - 1,
            parameters: p,
            weakest: i,
        });
    }
    let scaled = DMatrix::from_fn(p, p, |i, j| fisher[(i, j)] * d[i] * d[j]);
    let eig = SymmetricEigen::new(scaled);
    let top = eig.eigenvalues.iter().cloned().fold(0.0, f64::max);
    let rank = eig
        .eigenvalues
        .iter()
        .filter(|&&l| l > IDENTIFIABILITY_THRESHOLD * top)
        .count();
    if rank < p {
        // The parameter with the largest component in the weakest eigenvector.
        let (imin, _) =
            eig.eigenvalues
                .iter()
                .enumerate()
                .fold(
                    (0, f64::INFINITY),
                    |a, (i, &l)| if l < a.1 { (i, l) } else { a },
                );
        let v = eig.eigenvectors.column(imin);
        let weakest = v.iamax();
        return Err(RefineError::NotIdentifiable {
            rank,
            parameters: p,
            weakest,
        });
    }
    let mut inv = DMatrix::zeros(p, p);
    for (k, &l) in eig.eigenvalues.iter().enumerate() {
        let v = eig.eigenvectors.column(k);
        inv += (v * v.transpose()) / l;
    }
    let cov = DMatrix::from_fn(p, p, |i, j| inv[(i, j)] * d[i] * d[j]);
    Ok((&cov + cov.transpose()) * 0.5)
}

fn quadratic(cov: &DMatrix<f64>, g: &DVector<f64>) -> f64 {
    g.dot(&(cov * g)).max(0.0).sqrt()
}

/// Standard deviations of the entries of one matrix.
fn matrix_std(
    params: &[Parameter],
    cov: &DMatrix<f64>,
    kind: MatrixKind,
    n: usize,
) -> DMatrix<f64> {
    DMatrix::from_fn(n, n, |i, j| {
        let g = DVector::from_fn(params.len(), |p, _| {
            if params[p].matrix == kind {
                params[p].basis[(i, j)]
            } else {
                0.0
            }
        });
        quadratic(cov, &g)
    })
}

/// Modal parameters of `model` (built with derivatives) and their standard deviations.
pub(crate) fn modal_estimates(
    model: &Model,
    cov: &DMatrix<f64>,
) -> Result<Vec<ModalEstimate>, RefineError> {
    let der = model
        .derivatives
        .as_ref()
        .expect("modal estimates need the model derivatives");
    let np = der.a.len();
    let eig = linalg::eig(&model.a).map_err(|_| RefineError::ModalAnalysis)?;
    let v = &eig.vectors;
    let vinv =
        linalg::inverse_complex(v, "eigenvector matrix").map_err(|_| RefineError::ModalAnalysis)?;
    let s = v.nrows();
    let m = model.n;
    let tilde: Vec<DMatrix<C64>> = der
        .a
        .iter()
        .map(|da| &vinv * da.map(|x| C64::new(x, 0.0)) * v)
        .collect();
    let scale = model.a.norm().max(1.0);
    let mut order: Vec<usize> = (0..s)
        .filter(|&j| eig.values[j].im > 1e-10 * scale)
        .collect();
    order.sort_by(|&a, &b| eig.values[a].norm().total_cmp(&eig.values[b].norm()));
    let mut out = Vec::with_capacity(order.len());
    for &j in &order {
        let lambda = eig.values[j];
        let mag = lambda.norm();
        let vj = v.column(j).into_owned();
        let c = &model.c * &vj;
        let shape = modal::normalize_shape(&c);
        let pivot = (0..m)
            .max_by(|&a, &b| c[a].norm().total_cmp(&c[b].norm()))
            .unwrap_or(0);
        let mut g_f = DVector::zeros(np);
        let mut g_xi = DVector::zeros(np);
        let mut g_re = DMatrix::zeros(m, np);
        let mut g_im = DMatrix::zeros(m, np);
        for p in 0..np {
            let dl = tilde[p][(j, j)];
            let dmag = (lambda.conj() * dl).re / mag;
            g_f[p] = dmag / (2.0 * PI);
            g_xi[p] = -dl.re / mag + lambda.re * dmag / (mag * mag);
            // dv_j = sum_{l != j} v_l (V^-1 dA V)_lj / (lambda_j - lambda_l); the v_j
            // component does not change the normalized shape.
            let mut dv = DVector::<C64>::zeros(s);
            for l in 0..s {
                if l != j {
                    let coef = tilde[p][(l, j)] / (lambda - eig.values[l]);
                    dv += v.column(l) * coef;
                }
            }
            let dc = &der.c[p] * &vj + &model.c * dv;
            let ds = (&dc - &shape * dc[pivot]) / c[pivot];
            for i in 0..m {
                g_re[(i, p)] = ds[i].re;
                g_im[(i, p)] = ds[i].im;
            }
        }
        out.push(ModalEstimate {
            frequency_hz: mag / (2.0 * PI),
            frequency_std_hz: quadratic(cov, &g_f),
            damping_ratio: -lambda.re / mag,
            damping_ratio_std: quadratic(cov, &g_xi),
            pole: lambda,
            shape,
            shape_std_re: DVector::from_fn(m, |i, _| quadratic(cov, &g_re.row(i).transpose())),
            shape_std_im: DVector::from_fn(m, |i, _| quadratic(cov, &g_im.row(i).transpose())),
        });
    }
    Ok(out)
}

/// Covariance, standard deviations and modal parameters from the Fisher information at
/// `model`.
pub(crate) fn uncertainty(
    params: &[Parameter],
    model: &Model,
    fisher: DMatrix<f64>,
) -> Result<Uncertainty, RefineError> {
    let cov = covariance(&fisher)?;
    let n = model.n;
    let parameter_std = DVector::from_fn(params.len(), |p, _| cov[(p, p)].max(0.0).sqrt());
    Ok(Uncertainty {
        labels: params.iter().map(|p| p.label.clone()).collect(),
        mass_std: matrix_std(params, &cov, MatrixKind::Mass, n),
        stiffness_std: matrix_std(params, &cov, MatrixKind::Stiffness, n),
        damping_std: matrix_std(params, &cov, MatrixKind::Damping, n),
        modes: modal_estimates(model, &cov)?,
        parameter_std,
        fisher,
        covariance: cov,
    })
}
