//! Dense linear algebra helpers that nalgebra 0.35 does not provide directly.
//!
//! * [`eig`] / [`eig_complex`]: general eigendecomposition of a non-symmetric square matrix
//!   (complex Schur form, then eigenvectors of the triangular factor by back-substitution).
//! * [`thin_svd`]: thin SVD with singular values in descending order.
//! * [`cholesky`]: Cholesky factor that reports the failing pivot.
//! * [`lstsq_truncated`]: least squares through an SVD with a relative truncation.

use nalgebra::{DMatrix, DVector, SVD, Schur};
use num_complex::Complex;

/// Complex scalar used throughout the crate.
pub type C64 = Complex<f64>;

/// Numerical failures of the helpers in this module.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum LinalgError {
    /// An iterative decomposition did not converge within its iteration budget.
    #[error("{algorithm} did not converge for a {rows} x {cols} matrix")]
    NoConvergence {
        /// The decomposition that stopped (e.g. `"complex Schur decomposition"`).
        algorithm: &'static str,
        /// Rows of the matrix being decomposed.
        rows: usize,
        /// Columns of the matrix being decomposed.
        cols: usize,
    },
    /// The matrix contains NaN or infinite entries.
    #[error("{what} has a non-finite entry at ({row}, {col})")]
    NonFinite {
        /// The role of the matrix in the caller (e.g. `"matrix"`, `"Hankel matrix"`).
        what: &'static str,
        /// Row of the first non-finite entry (0-based, column-major scan).
        row: usize,
        /// Column of the first non-finite entry (0-based).
        col: usize,
    },
    /// A square matrix that must be inverted is singular to working precision.
    #[error("{what} is singular to working precision")]
    Singular {
        /// The role of the matrix in the caller.
        what: &'static str,
    },
}

/// Eigenvalues and right eigenvectors: `A V = V diag(values)`.
#[derive(Debug, Clone)]
pub struct Eigen {
    /// Eigenvalues, in no particular order.
    pub values: DVector<C64>,
    /// Eigenvectors by columns, each of unit 2-norm.
    pub vectors: DMatrix<C64>,
}

/// Position of the first non-finite entry of `m`, if any.
pub fn first_non_finite(m: &DMatrix<f64>) -> Option<(usize, usize)> {
    for j in 0..m.ncols() {
        for i in 0..m.nrows() {
            if !m[(i, j)].is_finite() {
                return Some((i, j));
            }
        }
    }
    None
}

fn ensure_finite(m: &DMatrix<f64>, what: &'static str) -> Result<(), LinalgError> {
    match first_non_finite(m) {
        Some((row, col)) => Err(LinalgError::NonFinite { what, row, col }),
        None => Ok(()),
    }
}

/// Iteration budget for the QR iterations of Schur and SVD (total, not per eigenvalue).
fn iteration_budget(n: usize) -> usize {
    200 * n.max(4)
}

/// Eigendecomposition of a real square matrix.
///
/// The matrix is balanced (Parlett-Reinsch), reduced to complex Schur form `Q T Q^H`, the
/// eigenvectors of the upper triangular `T` are found by back-substitution and mapped back.
/// Complex-conjugate eigenvalues are returned as separate entries.
pub fn eig(a: &DMatrix<f64>) -> Result<Eigen, LinalgError> {
    assert!(a.is_square(), "eig: matrix must be square");
    ensure_finite(a, "matrix")?;
    let mut balanced = a.clone();
    let scale = if a.nrows() > 0 {
        nalgebra::linalg::balancing::balance_parlett_reinsch(&mut balanced)
    } else {
        DVector::zeros(0)
    };
    let mut e = eig_complex(&balanced.map(|x| C64::new(x, 0.0)))?;
    for j in 0..e.vectors.ncols() {
        let mut col = e.vectors.column_mut(j);
        for i in 0..col.nrows() {
            col[i] *= scale[i];
        }
        let norm = col.norm();
        if norm > 0.0 {
            col.unscale_mut(norm);
        }
    }
    Ok(e)
}

/// Eigendecomposition of a complex square matrix (complex Schur + back-substitution).
pub fn eig_complex(a: &DMatrix<C64>) -> Result<Eigen, LinalgError> {
    assert!(a.is_square(), "eig_complex: matrix must be square");
    let n = a.nrows();
    if n == 0 {
        return Ok(Eigen {
            values: DVector::zeros(0),
            vectors: DMatrix::zeros(0, 0),
        });
    }
    for j in 0..n {
        for i in 0..n {
            if !(a[(i, j)].re.is_finite() && a[(i, j)].im.is_finite()) {
                return Err(LinalgError::NonFinite {
                    what: "matrix",
                    row: i,
                    col: j,
                });
            }
        }
    }
    let schur = Schur::try_new(a.clone(), f64::EPSILON, iteration_budget(n)).ok_or(
        LinalgError::NoConvergence {
            algorithm: "complex Schur decomposition",
            rows: n,
            cols: n,
        },
    )?;
    let (mut q, mut t) = schur.unpack();
    // nalgebra returns a triangular factor for complex input; this only guards against a
    // 2x2 block left behind.
    triangularize_leftover_blocks(&mut t, &mut q);
    let values = DVector::from_fn(n, |i, _| t[(i, i)]);
    let x = triangular_eigenvectors(&t);
    let mut vectors = &q * &x;
    for j in 0..n {
        let mut col = vectors.column_mut(j);
        let norm = col.norm();
        if norm > 0.0 {
            col.unscale_mut(norm);
        }
    }
    Ok(Eigen { values, vectors })
}

/// Removes any nonzero subdiagonal entry of a complex Schur factor with a unitary 2x2
/// rotation (eigenvector of the 2x2 block), updating `q` so that `A = Q T Q^H` still holds.
fn triangularize_leftover_blocks(t: &mut DMatrix<C64>, q: &mut DMatrix<C64>) {
    let n = t.nrows();
    for i in 0..n.saturating_sub(1) {
        if t[(i + 1, i)] == C64::new(0.0, 0.0) {
            continue;
        }
        let (a, b, c, d) = (t[(i, i)], t[(i, i + 1)], t[(i + 1, i)], t[(i + 1, i + 1)]);
        // Eigenvalue of the block and an eigenvector (x, y).
        let half_tr = (a + d) * 0.5;
        let disc = ((a - d) * 0.5).powi(2) + b * c;
        let lambda = half_tr + disc.sqrt();
        let (x, y) = if (lambda - a).norm() > (lambda - d).norm() {
            (b, lambda - a)
        } else {
            (lambda - d, c)
        };
        let norm = (x.norm_sqr() + y.norm_sqr()).sqrt();
        if norm == 0.0 {
            t[(i + 1, i)] = C64::new(0.0, 0.0);
            continue;
        }
        let (x, y) = (x / norm, y / norm);
        // G = [x, -conj(y); y, conj(x)] is unitary with first column the eigenvector.
        // T <- G^H T G, Q <- Q G.
        for col in 0..n {
            let (t0, t1) = (t[(i, col)], t[(i + 1, col)]);
            t[(i, col)] = x.conj() * t0 + y.conj() * t1;
            t[(i + 1, col)] = -y * t0 + x * t1;
        }
        for row in 0..n {
            let (t0, t1) = (t[(row, i)], t[(row, i + 1)]);
            t[(row, i)] = t0 * x + t1 * y;
            t[(row, i + 1)] = -t0 * y.conj() + t1 * x.conj();
        }
        for row in 0..q.nrows() {
            let (q0, q1) = (q[(row, i)], q[(row, i + 1)]);
            q[(row, i)] = q0 * x + q1 * y;
            q[(row, i + 1)] = -q0 * y.conj() + q1 * x.conj();
        }
        t[(i + 1, i)] = C64::new(0.0, 0.0);
    }
}

/// Eigenvectors of an upper triangular matrix by back-substitution, one column per
/// diagonal entry (unnormalized). Near-equal diagonal entries are separated by a
/// perturbation of size `eps * ||T||`, as LAPACK's `ztrevc` does.
fn triangular_eigenvectors(t: &DMatrix<C64>) -> DMatrix<C64> {
    let n = t.nrows();
    let smin = (f64::EPSILON * t.norm()).max(f64::MIN_POSITIVE);
    let mut x = DMatrix::<C64>::zeros(n, n);
    for k in 0..n {
        let tkk = t[(k, k)];
        x[(k, k)] = C64::new(1.0, 0.0);
        for i in (0..k).rev() {
            let mut s = C64::new(0.0, 0.0);
            for j in i + 1..=k {
                s += t[(i, j)] * x[(j, k)];
            }
            let mut d = t[(i, i)] - tkk;
            if d.norm() < smin {
                d = C64::new(smin, 0.0);
            }
            x[(i, k)] = -s / d;
            // Rescale the partial vector to avoid overflow.
            let big = x[(i, k)].norm();
            if big > 1e100 {
                for r in i..=k {
                    x[(r, k)] /= big;
                }
            }
        }
    }
    x
}

/// Eigenvalues of a real square matrix (real Schur form), cheaper than [`eig`].
pub fn eigenvalues(a: &DMatrix<f64>) -> Result<DVector<C64>, LinalgError> {
    assert!(a.is_square(), "eigenvalues: matrix must be square");
    ensure_finite(a, "matrix")?;
    let n = a.nrows();
    if n == 0 {
        return Ok(DVector::zeros(0));
    }
    let mut balanced = a.clone();
    nalgebra::linalg::balancing::balance_parlett_reinsch(&mut balanced);
    let schur = Schur::try_new(balanced, f64::EPSILON, iteration_budget(n)).ok_or(
        LinalgError::NoConvergence {
            algorithm: "real Schur decomposition",
            rows: n,
            cols: n,
        },
    )?;
    Ok(schur.complex_eigenvalues())
}

/// Largest eigenvalue magnitude of a real square matrix (0 for an empty matrix).
///
/// Balanced, reduced to Hessenberg form, then the eigenvalues by the Francis double-shift
/// QR iteration applied to the unreduced active block only (no Schur vectors, none of the
/// rows and columns already deflated): a fraction of the work of [`eigenvalues`], with
/// eigenvalues equal to its to round-off (each within `eps` of the matrix norm times its
/// condition, as for any backward-stable method).
pub fn spectral_radius(a: &DMatrix<f64>) -> Result<f64, LinalgError> {
    assert!(a.is_square(), "spectral_radius: matrix must be square");
    ensure_finite(a, "matrix")?;
    let n = a.nrows();
    if n == 0 {
        return Ok(0.0);
    }
    let mut h = a.clone();
    nalgebra::linalg::balancing::balance_parlett_reinsch(&mut h);
    reduce_to_hessenberg(h.as_mut_slice(), n);
    let values =
        hessenberg_eigenvalues(&mut h, iteration_budget(n)).ok_or(LinalgError::NoConvergence {
            algorithm: "Hessenberg QR iteration",
            rows: n,
            cols: n,
        })?;
    Ok(values.iter().map(|l| l.norm()).fold(0.0, f64::max))
}

/// `col -= beta (v . col) v`: the Householder reflection `I - beta v v^T` applied to a
/// column (`v` and `col` of one length), as every reduction and product of this module
/// applies it.
#[inline]
fn reflect(v: &[f64], beta: f64, col: &mut [f64]) {
    let w = beta * dot(v, col);
    for (c, x) in col.iter_mut().zip(v) {
        *c -= w * x;
    }
}

/// Norms of reflected columns below this (`2^-500`) may have lost their squares to
/// underflow (a column of entries below `1e-162` has a computed norm of zero, and `2 / |v|^2`
/// is then infinite), and above [`REFLECT_HUGE`] they may overflow.
const REFLECT_TINY: f64 = f64::from_bits((1023 - 500) << 52);
/// `2^500`: see [`REFLECT_TINY`].
const REFLECT_HUGE: f64 = f64::from_bits((1023 + 500) << 52);

/// The power of two by which to scale a column `x` of computed norm `norm` before forming
/// its Householder reflection: 1 for an ordinary norm (or a zero or non-finite column);
/// below [`REFLECT_TINY`] or above [`REFLECT_HUGE`], the one that brings its largest
/// magnitude into `[1, 2)` (within `2^+-1000`). The reflection `I - beta v v^T` is the same
/// for any multiple of `v`, and a power of two scales exactly; with `v` of order one,
/// `beta (v . y)` does not underflow where `y` does not.
fn reflector_scale(norm: f64, x: &[f64]) -> f64 {
    if norm.is_nan() || (REFLECT_TINY..=REFLECT_HUGE).contains(&norm) {
        return 1.0;
    }
    let amax = x.iter().fold(0.0, |m: f64, &e| m.max(e.abs()));
    if amax == 0.0 || !amax.is_finite() {
        return 1.0;
    }
    let e = (amax.log2().floor() as i64).clamp(-1000, 1000);
    f64::from_bits(((1023 - e) as u64) << 52)
}

/// `v` (a column of computed norm `norm`) scaled in place by [`reflector_scale`], with that
/// scale and the norm of the scaled `v` (`norm` itself when the scale is 1): what both
/// Householder reductions form their reflection from.
fn scale_reflector(norm: f64, v: &mut [f64]) -> (f64, f64) {
    let scale = reflector_scale(norm, v);
    if scale == 1.0 {
        return (1.0, norm);
    }
    v.iter_mut().for_each(|e| *e *= scale);
    (scale, dot(v, v).sqrt())
}

/// Reduces the `n x n` column-major matrix `d` to upper Hessenberg form `Q^T A Q` in place
/// by Householder reflections (entries below the subdiagonal set to zero, `Q` not kept), as
/// [`nalgebra::linalg::Hessenberg`] does, but on contiguous column slices: each reflection
/// is applied from the left column by column (a dot product and an update over the
/// column's rows `k + 1..`) and from the right as `w = A v` (a sum of whole columns) and
/// a rank-one update of the columns `k + 1..`.
fn reduce_to_hessenberg(d: &mut [f64], n: usize) {
    assert_eq!(d.len(), n * n, "reduce_to_hessenberg: matrix must be n x n");
    let mut v = vec![0.0; n];
    let mut w = vec![0.0; n];
    for k in 0..n.saturating_sub(2) {
        let len = n - k - 1;
        let x = &mut d[k * n + k + 1..(k + 1) * n];
        if x[1..].iter().all(|&e| e == 0.0) {
            // Already zero below the subdiagonal: no reflection.
            continue;
        }
        let norm = dot(x, x).sqrt();
        let v = &mut v[..len];
        v.copy_from_slice(x);
        // The reflection from `v` scaled into the range where its squares are exact (the
        // same reflection); `x[0]` becomes the column's norm, unscaled.
        let (scale, norm) = scale_reflector(norm, v);
        let alpha = v[0];
        let s = if alpha >= 0.0 { -norm } else { norm };
        v[0] = alpha - s;
        let beta = 2.0 / dot(v, v);
        x[0] = s / scale;
        x[1..].fill(0.0);
        // From the left: rows k + 1.. of columns k + 1...
        for col in d[(k + 1) * n..].chunks_exact_mut(n) {
            reflect(v, beta, &mut col[k + 1..]);
        }
        // From the right: every row of columns k + 1...
        w.fill(0.0);
        for (col, &e) in d[(k + 1) * n..].chunks_exact(n).zip(v.iter()) {
            for (o, &c) in w.iter_mut().zip(col) {
                *o += c * e;
            }
        }
        for (col, &e) in d[(k + 1) * n..].chunks_exact_mut(n).zip(v.iter()) {
            let t = beta * e;
            for (c, &o) in col.iter_mut().zip(&w) {
                *c -= t * o;
            }
        }
    }
}

/// Eigenvalues of the upper Hessenberg matrix `h` (overwritten; entries below the
/// subdiagonal are ignored) by the implicit double-shift (Francis) QR iteration.
///
/// The active block `lo ..= hi` is the trailing unreduced one: a subdiagonal entry at most
/// `eps` times its two diagonal neighbours splits it; one or two eigenvalues are taken
/// off its end when it has size 1 or 2. Each step chases a 3-row bulge started from the
/// two eigenvalues of the trailing 2x2 block (ad hoc shifts after 10 and 20 steps without
/// a deflation; they shift the whole unreduced matrix, whose eigenvalues all get the sum
/// of the shifts back), updating the active block only. `None` after `budget` steps.
fn hessenberg_eigenvalues(h: &mut DMatrix<f64>, budget: usize) -> Option<Vec<C64>> {
    let n = h.nrows();
    let d = h.as_mut_slice();
    // Column-major: entry (i, j) at `i + j n`.
    let at = |i: usize, j: usize| i + j * n;
    let mut values = vec![C64::new(0.0, 0.0); n];
    // Shifts already subtracted from the diagonal (ad hoc steps).
    let mut shift_sum = 0.0;
    let mut steps = 0;
    let mut hi = n - 1;
    let mut since_deflation = 0;
    loop {
        // Start of the active block: after the last negligible subdiagonal entry.
        let mut lo = hi;
        while lo > 0 {
            let mut s = d[at(lo - 1, lo - 1)].abs() + d[at(lo, lo)].abs();
            if s == 0.0 {
                s = dot(d, d).sqrt();
            }
            if d[at(lo, lo - 1)].abs() <= f64::EPSILON * s {
                d[at(lo, lo - 1)] = 0.0;
                break;
            }
            lo -= 1;
        }
        let x = d[at(hi, hi)];
        if lo == hi {
            values[hi] = C64::new(x + shift_sum, 0.0);
            since_deflation = 0;
            if hi == 0 {
                break;
            }
            hi -= 1;
            continue;
        }
        let y = d[at(hi - 1, hi - 1)];
        let w = d[at(hi, hi - 1)] * d[at(hi - 1, hi)];
        if lo + 1 == hi {
            // The 2x2 block's eigenvalues: x + p +- sqrt(p^2 + w), p = (y - x) / 2.
            let p = 0.5 * (y - x);
            let q = p * p + w;
            let z = q.abs().sqrt();
            let x = x + shift_sum;
            if q >= 0.0 {
                let z = p + z.copysign(p);
                values[hi - 1] = C64::new(x + z, 0.0);
                values[hi] = C64::new(if z != 0.0 { x - w / z } else { x + z }, 0.0);
            } else {
                values[hi - 1] = C64::new(x + p, -z);
                values[hi] = C64::new(x + p, z);
            }
            since_deflation = 0;
            if hi < 2 {
                break;
            }
            hi -= 2;
            continue;
        }
        if steps == budget {
            return None;
        }
        steps += 1;
        let (mut x, mut y, mut w) = (x, y, w);
        if since_deflation == 10 || since_deflation == 20 {
            // Ad hoc shift (a stalled iteration). Every eigenvalue found from now on gets
            // `shift_sum` added back, so the whole unreduced matrix is shifted, the rows
            // above the active block too (they hold the eigenvalues still to come).
            shift_sum += x;
            for i in 0..=hi {
                d[at(i, i)] -= x;
            }
            let s = d[at(hi, hi - 1)].abs() + d[at(hi - 1, hi - 2)].abs();
            x = 0.75 * s;
            y = x;
            w = -0.4375 * s * s;
        }
        since_deflation += 1;
        // First column of (H - s1)(H - s2) at row `m`, started as low as two small
        // consecutive subdiagonal entries allow.
        let mut m = hi - 2;
        let (mut p, mut q, mut r);
        loop {
            let z = d[at(m, m)];
            let (rr, ss) = (x - z, y - z);
            p = (rr * ss - w) / d[at(m + 1, m)] + d[at(m, m + 1)];
            q = d[at(m + 1, m + 1)] - z - rr - ss;
            r = d[at(m + 2, m + 1)];
            let scale = p.abs() + q.abs() + r.abs();
            p /= scale;
            q /= scale;
            r /= scale;
            if m == lo {
                break;
            }
            let u = d[at(m, m - 1)].abs() * (q.abs() + r.abs());
            let v = p.abs() * (d[at(m - 1, m - 1)].abs() + z.abs() + d[at(m + 1, m + 1)].abs());
            if u <= f64::EPSILON * v {
                break;
            }
            m -= 1;
        }
        for i in m + 2..=hi {
            d[at(i, i - 2)] = 0.0;
            if i != m + 2 {
                d[at(i, i - 3)] = 0.0;
            }
        }
        // Chase the bulge down with 3-row reflectors (2-row at the end).
        for k in m..hi {
            let last = k + 1 == hi;
            let mut scale = 1.0;
            if k != m {
                p = d[at(k, k - 1)];
                q = d[at(k + 1, k - 1)];
                r = if last { 0.0 } else { d[at(k + 2, k - 1)] };
                scale = p.abs() + q.abs() + r.abs();
                if scale != 0.0 {
                    p /= scale;
                    q /= scale;
                    r /= scale;
                }
            }
            let s = (p * p + q * q + r * r).sqrt().copysign(p);
            if s == 0.0 {
                continue;
            }
            if k == m {
                if lo != m {
                    d[at(k, k - 1)] = -d[at(k, k - 1)];
                }
            } else {
                d[at(k, k - 1)] = -s * scale;
            }
            p += s;
            let (vx, vy, vz) = (p / s, q / s, r / s);
            let (q, r) = (q / p, r / p);
            // Rows k..k+2 (contiguous in each column) of columns k..=hi, then columns
            // k..k+2 (each contiguous) of rows lo..=min(k+3, hi): the same operations as
            // indexing entry by entry, on slices (one bounds check a column).
            if last {
                for col in d[at(0, k)..at(0, hi + 1)].chunks_exact_mut(n) {
                    let [a, b] = &mut col[k..k + 2] else {
                        unreachable!()
                    };
                    let t = *a + q * *b;
                    *b -= t * vy;
                    *a -= t * vx;
                }
                let (left, right) = d[at(0, k)..at(0, k + 2)].split_at_mut(n);
                for (a, b) in left[lo..=hi].iter_mut().zip(&mut right[lo..=hi]) {
                    let t = vx * *a + vy * *b;
                    *b -= t * q;
                    *a -= t;
                }
            } else {
                for col in d[at(0, k)..at(0, hi + 1)].chunks_exact_mut(n) {
                    let [a, b, c] = &mut col[k..k + 3] else {
                        unreachable!()
                    };
                    let t = *a + q * *b + r * *c;
                    *c -= t * vz;
                    *b -= t * vy;
                    *a -= t * vx;
                }
                let rows = lo..=hi.min(k + 3);
                let (left, rest) = d[at(0, k)..at(0, k + 3)].split_at_mut(n);
                let (mid, right) = rest.split_at_mut(n);
                for ((a, b), c) in left[rows.clone()]
                    .iter_mut()
                    .zip(&mut mid[rows.clone()])
                    .zip(&mut right[rows])
                {
                    let t = vx * *a + vy * *b + vz * *c;
                    *c -= t * r;
                    *b -= t * q;
                    *a -= t;
                }
            }
        }
    }
    Some(values)
}

/// Thin singular value decomposition `M = U diag(s) V^T`, singular values descending.
#[derive(Debug, Clone)]
pub struct ThinSvd {
    /// Left singular vectors, rows x k.
    pub u: DMatrix<f64>,
    /// Singular values, descending, length k = min(rows, cols).
    pub s: DVector<f64>,
    /// Right singular vectors, cols x k.
    pub v: DMatrix<f64>,
}

impl ThinSvd {
    /// Number of singular values above `rcond * s[0]` (0 for a zero matrix).
    pub fn rank(&self, rcond: f64) -> usize {
        match self.s.iter().next() {
            Some(&s0) if s0 > 0.0 => self.s.iter().filter(|&&s| s > rcond * s0).count(),
            _ => 0,
        }
    }
}

/// A matrix at least this many times longer than wide (or wider than long) is reduced by
/// QR before its SVD: the SVD's rotations then run over vectors of the short side only.
/// The triangular factor has the same singular values (QR is backward stable, so they
/// keep their absolute accuracy of round-off times the largest) and its singular vectors
/// map back through `Q`. At the 1:3 shape of the ERA Hankel matrices this takes about a
/// third of the instructions of the direct SVD (measured with callgrind).
const QR_FIRST_RATIO: usize = 2;

/// Thin SVD with singular values in descending order: nalgebra's, checked for
/// `||M - U S V^T||_F` (nalgebra 0.35 returns wrong factors for some matrices with
/// near-zero singular values) and recomputed by one-sided Jacobi when it fails.
pub fn thin_svd(m: &DMatrix<f64>) -> Result<ThinSvd, LinalgError> {
    ensure_finite(m, "matrix")?;
    let (rows, cols) = m.shape();
    if rows == 0 || cols == 0 {
        let k = rows.min(cols);
        return Ok(ThinSvd {
            u: DMatrix::zeros(rows, k),
            s: DVector::zeros(k),
            v: DMatrix::zeros(cols, k),
        });
    }
    if rows >= QR_FIRST_RATIO * cols {
        // M = Q R, R = U S V^T: M = (Q U) S V^T.
        let (q, r) = thin_qr(m);
        let inner = square_svd(&r, rows, cols)?;
        return Ok(ThinSvd {
            u: q * inner.u,
            s: inner.s,
            v: inner.v,
        });
    }
    if cols >= QR_FIRST_RATIO * rows {
        // M^T = Q R, R^T = U S W^T: M = U S (Q W)^T.
        let (q, r) = thin_qr(&m.transpose());
        let inner = square_svd(&r.transpose(), rows, cols)?;
        return Ok(ThinSvd {
            u: inner.u,
            s: inner.s,
            v: q * inner.v,
        });
    }
    square_svd(m, rows, cols)
}

/// Thin QR factorization `M = Q R` of a matrix with at least as many rows as columns: `Q`
/// rows x cols with orthonormal columns, `R` cols x cols upper triangular. Householder
/// reflections on contiguous column slices (nalgebra's `QR::q` forms `Q` through generic
/// strided reflections, several times slower at the sizes of the ERA matrices); matrices
/// wider than long go to nalgebra.
pub fn thin_qr(m: &DMatrix<f64>) -> (DMatrix<f64>, DMatrix<f64>) {
    let (rows, cols) = m.shape();
    if rows < cols {
        let qr = m.clone().qr();
        return (qr.q(), qr.r());
    }
    let h = Householder::new(m.clone());
    let mut r = DMatrix::zeros(cols, cols);
    for j in 0..cols {
        for i in 0..j {
            r[(i, j)] = h.a[(i, j)];
        }
        r[(j, j)] = h.diag[j];
    }
    // Q = H_0 ... H_(cols-1) [I; 0], accumulated backwards: H_k acts on rows k.. and only
    // columns k.. of the partial product are nonzero there.
    let mut q = DMatrix::zeros(rows, cols);
    for j in 0..cols {
        q[(j, j)] = 1.0;
    }
    let vs = h.a.as_slice();
    let qd = q.as_mut_slice();
    for k in (0..cols).rev() {
        let beta = h.betas[k];
        if beta == 0.0 {
            continue;
        }
        let v = &vs[k * rows + k..(k + 1) * rows];
        for j in k..cols {
            reflect(v, beta, &mut qd[j * rows + k..(j + 1) * rows]);
        }
    }
    (q, r)
}

/// Householder reduction of a matrix with at least as many rows as columns, in place:
/// below the diagonal of `a` the reflector vectors, above it `R`.
#[derive(Debug, Clone)]
struct Householder {
    /// Reflector vectors (column `k` from row `k` on) and the strict upper part of `R`.
    a: DMatrix<f64>,
    /// `2 / |v_k|^2` of every reflector (0: no reflection).
    betas: Vec<f64>,
    /// Diagonal of `R`.
    diag: Vec<f64>,
}

impl Householder {
    fn new(a: DMatrix<f64>) -> Self {
        Self::reduce(a, None)
    }

    /// With `stop_below = Some(t)`: stops before step `k` once every remaining column
    /// (rows `k..`) has a norm of at most `t`; then only `k` reflectors are formed
    /// ([`Householder::steps`]) and the unreduced block, whose norm is at most
    /// `sqrt(cols - k) t`, is dropped.
    fn reduce(mut a: DMatrix<f64>, stop_below: Option<f64>) -> Self {
        let (rows, cols) = a.shape();
        debug_assert!(rows >= cols);
        let mut betas = vec![0.0; cols];
        let mut diag = vec![0.0; cols];
        let mut steps = cols;
        let data = a.as_mut_slice();
        for k in 0..cols {
            let (head, tail) = data.split_at_mut((k + 1) * rows);
            let v = &mut head[k * rows + k..];
            let norm = dot(v, v).sqrt();
            if let Some(t) = stop_below
                && norm <= t
                && (k + 1..cols).all(|j| {
                    let col = &tail[(j - k - 1) * rows + k..(j - k) * rows];
                    dot(col, col).sqrt() <= t
                })
            {
                steps = k;
                break;
            }
            // As in `reduce_to_hessenberg`: the reflector scaled by a power of two (it is
            // stored so: `beta` goes with it), the diagonal of `R` unscaled.
            let (scale, norm) = scale_reflector(norm, v);
            let alpha = v[0];
            let s = if alpha >= 0.0 { -norm } else { norm };
            diag[k] = s / scale;
            let v0 = alpha - s;
            let vnorm2 = v0 * v0 + (norm * norm - alpha * alpha).max(0.0);
            if norm == 0.0 || vnorm2 == 0.0 {
                betas[k] = 0.0;
                diag[k] = alpha / scale;
                continue;
            }
            v[0] = v0;
            let beta = 2.0 / dot(v, v);
            betas[k] = beta;
            for j in k + 1..cols {
                reflect(v, beta, &mut tail[(j - k - 1) * rows + k..(j - k) * rows]);
            }
        }
        betas.truncate(steps);
        diag.truncate(steps);
        Self { a, betas, diag }
    }

    /// Reflectors formed (rows of `R` kept).
    fn steps(&self) -> usize {
        self.betas.len()
    }

    /// `R^T` (cols x steps, lower trapezoidal).
    fn r_transpose(&self) -> DMatrix<f64> {
        let cols = self.a.ncols();
        DMatrix::from_fn(cols, self.steps(), |i, j| match i.cmp(&j) {
            std::cmp::Ordering::Greater => self.a[(j, i)],
            std::cmp::Ordering::Equal => self.diag[i],
            std::cmp::Ordering::Less => 0.0,
        })
    }

    /// `Q [x; 0]` for `x` with [`Householder::steps`] rows (rows x x.ncols()).
    fn q_times(&self, x: &DMatrix<f64>) -> DMatrix<f64> {
        let rows = self.a.nrows();
        let (steps, k) = x.shape();
        debug_assert_eq!(steps, self.steps());
        let mut out = DMatrix::zeros(rows, k);
        out.view_mut((0, 0), (steps, k)).copy_from(x);
        let vs = self.a.as_slice();
        let od = out.as_mut_slice();
        for c in (0..steps).rev() {
            let beta = self.betas[c];
            if beta == 0.0 {
                continue;
            }
            let v = &vs[c * rows + c..(c + 1) * rows];
            for j in 0..k {
                reflect(v, beta, &mut od[j * rows + c..(j + 1) * rows]);
            }
        }
        out
    }
}

/// Singular values and right singular vectors of a matrix, the right singular vectors
/// formed only as far as asked for ([`RightSvd::v_columns`]): for ERA/DC, which needs all
/// the Hankel singular values but only the leading right singular vectors.
#[derive(Debug, Clone)]
pub struct RightSvd {
    /// Singular values, descending, length min(rows, cols).
    pub s: DVector<f64>,
    /// Rows and columns of the matrix.
    shape: (usize, usize),
    /// For a wide matrix `M^T = Q R`, `R^T = U S W^T`: the reflectors of `Q` and `W`;
    /// otherwise the thin SVD's `V`.
    form: RightForm,
}

#[derive(Debug, Clone)]
enum RightForm {
    Reflected { q: Householder, w: DMatrix<f64> },
    Direct(DMatrix<f64>),
}

impl RightSvd {
    /// Rows and columns of the factored matrix.
    pub fn shape(&self) -> (usize, usize) {
        self.shape
    }

    /// Number of singular values above `rcond * s[0]` (0 for a zero matrix).
    pub fn rank(&self, rcond: f64) -> usize {
        match self.s.iter().next() {
            Some(&s0) if s0 > 0.0 => self.s.iter().filter(|&&s| s > rcond * s0).count(),
            _ => 0,
        }
    }

    /// The first `k` right singular vectors (cols x k).
    pub fn v_columns(&self, k: usize) -> DMatrix<f64> {
        match &self.form {
            RightForm::Reflected { q, w } => q.q_times(&w.columns(0, k).into_owned()),
            RightForm::Direct(v) => v.columns(0, k).into_owned(),
        }
    }
}

/// Singular values (descending) and, on demand, right singular vectors of `m`. For a
/// matrix at least twice as wide as long (`QR_FIRST_RATIO`), `M^T = Q R` by Householder,
/// then the SVD of `R^T` without its left vectors, and `V = Q W` formed only for the
/// columns asked for: the same singular values as [`thin_svd`] (the same factorizations),
/// at a fraction of its work.
pub fn right_svd(m: &DMatrix<f64>) -> Result<RightSvd, LinalgError> {
    right_svd_with(m, true)
}

/// The singular values of [`right_svd`] without its right singular vectors: for a wide
/// matrix the SVD of `R^T` runs without accumulating `W` (nalgebra then bidiagonalizes it
/// otherwise: the values agree with [`right_svd`]'s to round-off, not bit for bit).
pub fn right_singular_values(m: &DMatrix<f64>) -> Result<DVector<f64>, LinalgError> {
    Ok(right_svd_with(m, false)?.s)
}

/// [`right_svd`], with the right vectors of a wide matrix only when `vectors` (without
/// them its `RightSvd` holds the values only: not for [`RightSvd::v_columns`]).
fn right_svd_with(m: &DMatrix<f64>, vectors: bool) -> Result<RightSvd, LinalgError> {
    ensure_finite(m, "matrix")?;
    let (rows, cols) = m.shape();
    if rows == 0 || cols < QR_FIRST_RATIO * rows {
        let svd = thin_svd(m)?;
        return Ok(RightSvd {
            s: svd.s,
            shape: (rows, cols),
            form: RightForm::Direct(svd.v),
        });
    }
    // A norm whose squares underflow or overflow would set the threshold below to zero or
    // infinity (and the columns' norms underflow with it): every column would then pass as
    // round-off and all values come out zero. Those matrices are scaled by a power of two
    // (exactly), and their values scaled back.
    let norm = m.norm();
    let scale = reflector_scale(norm, m.as_slice());
    if scale != 1.0 {
        let mut svd = right_svd_with(&(m * scale), vectors)?;
        svd.s.unscale_mut(scale);
        return Ok(svd);
    }
    // Columns of M^T left below eps ||M||_F after the reflections so far are round-off
    // (the rank of a Hankel matrix of a finite-order system is its order): the block
    // dropped has a norm of at most eps sqrt(rows) ||M||_F <= eps rows s_1, below the
    // rank tolerance eps max(rows, cols) s_1 of its users; the singular values kept move
    // by its square over themselves, and those dropped are reported as zero. (ERA/DC of
    // paper case 1: the 80 x 240 H(0) stops after 40 = p m reflectors; the full SVD put
    // the 40 values dropped at 2e-15 and below, of a largest 92.)
    let q = Householder::reduce(m.transpose(), Some(f64::EPSILON * norm));
    if q.steps() == 0 {
        return Ok(RightSvd {
            s: DVector::zeros(rows),
            shape: (rows, cols),
            form: RightForm::Reflected {
                q,
                w: DMatrix::zeros(0, 0),
            },
        });
    }
    let rt = q.r_transpose();
    let svd = SVD::try_new(
        rt,
        false,
        vectors,
        f64::EPSILON,
        iteration_budget(rows.max(cols)) * 10,
    )
    .ok_or(LinalgError::NoConvergence {
        algorithm: "singular value decomposition",
        rows,
        cols,
    })?;
    let w = match svd.v_t {
        Some(v_t) => v_t.transpose(),
        None => DMatrix::zeros(0, 0),
    };
    let mut values = DVector::zeros(rows);
    values
        .rows_mut(0, svd.singular_values.len())
        .copy_from(&svd.singular_values);
    Ok(RightSvd {
        s: values,
        shape: (rows, cols),
        form: RightForm::Reflected { q, w },
    })
}

/// `a . b` over the shorter of the two, with four partial sums in two pairs of adjacent
/// lanes: a fixed order (the result does not depend on threads), kept in two-lane vector
/// registers. The sum is `(s0 + s2) + (s1 + s3) + tail`, `sk` over elements `k mod 4`.
#[inline]
pub(crate) fn dot(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut lo = [0.0; 2];
    let mut hi = [0.0; 2];
    let (ac, bc) = (a.chunks_exact(4), b.chunks_exact(4));
    let (ar, br) = (ac.remainder(), bc.remainder());
    for (x, y) in ac.zip(bc) {
        let ((x0, x1), (y0, y1)) = (x.split_at(2), y.split_at(2));
        for k in 0..2 {
            lo[k] += x0[k] * y0[k];
        }
        for k in 0..2 {
            hi[k] += x1[k] * y1[k];
        }
    }
    let mut tail = 0.0;
    for (x, y) in ar.iter().zip(br) {
        tail += x * y;
    }
    (lo[0] + hi[0]) + (lo[1] + hi[1]) + tail
}

/// Rows of a column pass of [`cross_products`]: the `P x Q` two-lane partial sums of a tile
/// stay in registers (`2 P Q + 2 (P + Q)` values: 14 of the 16 SSE registers for 2 x 4).
const TILE_ROWS: usize = 2;

/// `out[p * b.len() + q] = a[p] . b[q]` for column slices of one length: the products of `P`
/// columns of `a` with up to four of `b` are summed together in one pass over the rows (each
/// loaded value serves several products), two lanes per product (elements `l mod 2`), the sum
/// `s0 + s1 + tail`: a fixed order whatever the threads. Panics if the columns' lengths differ.
pub(crate) fn cross_products(a: &[&[f64]], b: &[&[f64]], out: &mut [f64]) {
    let len = a.first().or(b.first()).map_or(0, |c| c.len());
    assert!(
        a.iter().chain(b).all(|c| c.len() == len),
        "cross_products: columns of different lengths"
    );
    assert_eq!(out.len(), a.len() * b.len(), "cross_products: output size");
    let nb = b.len();
    let mut p = 0;
    while p < a.len() {
        let pa = (a.len() - p).min(2);
        let mut q = 0;
        while q < nb {
            let qb = (nb - q).min(4);
            let (at, bt) = (&a[p..p + pa], &b[q..q + qb]);
            let mut put = |i: usize, j: usize, v: f64| out[(p + i) * nb + q + j] = v;
            match (pa, qb) {
                (2, 4) => tile::<2, 4>(at, bt, &mut put),
                (2, 3) => tile::<2, 3>(at, bt, &mut put),
                (2, 2) => tile::<2, 2>(at, bt, &mut put),
                (2, _) => tile::<2, 1>(at, bt, &mut put),
                (_, 4) => tile::<1, 4>(at, bt, &mut put),
                (_, 3) => tile::<1, 3>(at, bt, &mut put),
                (_, 2) => tile::<1, 2>(at, bt, &mut put),
                _ => tile::<1, 1>(at, bt, &mut put),
            }
            q += qb;
        }
        p += pa;
    }
}

/// One tile of [`cross_products`]: `P` columns of `a` against `Q` of `b`.
#[inline(always)]
fn tile<const P: usize, const Q: usize>(
    a: &[&[f64]],
    b: &[&[f64]],
    put: &mut impl FnMut(usize, usize, f64),
) {
    let len = a[0].len();
    let whole = len - len % TILE_ROWS;
    // Whole row groups of every column, each exactly `groups` long.
    let groups = len / TILE_ROWS;
    let ag: [&[[f64; TILE_ROWS]]; P] =
        std::array::from_fn(|i| &a[i].as_chunks::<TILE_ROWS>().0[..groups]);
    let bg: [&[[f64; TILE_ROWS]]; Q] =
        std::array::from_fn(|j| &b[j].as_chunks::<TILE_ROWS>().0[..groups]);
    let acc = tile_sums(&ag, &bg);
    for i in 0..P {
        for j in 0..Q {
            let mut tail = 0.0;
            for l in whole..len {
                tail += a[i][l] * b[j][l];
            }
            put(i, j, acc[i][j][0] + acc[i][j][1] + tail);
        }
    }
}

/// The lanes' sums of a tile: `acc[i][j][k] = sum_g a[i][g][k] * b[j][g][k]`, in `g` order.
/// On x86-64 with SSE2 vectors (part of its baseline): the compiler's own vectorization pairs
/// products of different columns here and shuffles, slower than plain dot products.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn tile_sums<const P: usize, const Q: usize>(
    a: &[&[[f64; TILE_ROWS]]; P],
    b: &[&[[f64; TILE_ROWS]]; Q],
) -> [[[f64; TILE_ROWS]; Q]; P] {
    #[cfg(target_feature = "avx")]
    if Q.is_multiple_of(2) {
        // SAFETY: AVX is enabled for this build (`target_feature = "avx"`).
        return unsafe { tile_sums_avx(a, b) };
    }
    // SAFETY: SSE2 is enabled on every x86-64 target (it is in the architecture's baseline).
    unsafe { tile_sums_sse2(a, b) }
}

/// [`tile_sums_sse2`] with two columns of `b` per 256-bit vector: the same lanes (`[b_j even,
/// b_j odd, b_j+1 even, b_j+1 odd]`), the same products and sums, half the instructions.
#[cfg(all(target_arch = "x86_64", target_feature = "avx"))]
#[target_feature(enable = "avx")]
fn tile_sums_avx<const P: usize, const Q: usize>(
    a: &[&[[f64; TILE_ROWS]]; P],
    b: &[&[[f64; TILE_ROWS]]; Q],
) -> [[[f64; TILE_ROWS]; Q]; P] {
    use std::arch::x86_64::{
        __m256d, _mm256_add_pd, _mm256_mul_pd, _mm256_setr_pd, _mm256_setzero_pd, _mm256_storeu_pd,
    };
    let groups = a.first().map_or(0, |c| c.len());
    let mut acc: [[__m256d; Q]; P] = [[_mm256_setzero_pd(); Q]; P];
    for g in 0..groups {
        let x: [__m256d; P] = std::array::from_fn(|i| {
            let (x0, x1) = (a[i][g][0], a[i][g][1]);
            _mm256_setr_pd(x0, x1, x0, x1)
        });
        for jj in 0..Q / 2 {
            let (y0, y1) = (b[2 * jj][g], b[2 * jj + 1][g]);
            let y = _mm256_setr_pd(y0[0], y0[1], y1[0], y1[1]);
            for i in 0..P {
                acc[i][jj] = _mm256_add_pd(acc[i][jj], _mm256_mul_pd(x[i], y));
            }
        }
    }
    let mut out = [[[0.0; TILE_ROWS]; Q]; P];
    for i in 0..P {
        for jj in 0..Q / 2 {
            let mut v = [0.0; 4];
            // SAFETY: `v` holds four doubles.
            unsafe { _mm256_storeu_pd(v.as_mut_ptr(), acc[i][jj]) };
            out[i][2 * jj] = [v[0], v[1]];
            out[i][2 * jj + 1] = [v[2], v[3]];
        }
    }
    out
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "sse2")]
fn tile_sums_sse2<const P: usize, const Q: usize>(
    a: &[&[[f64; TILE_ROWS]]; P],
    b: &[&[[f64; TILE_ROWS]]; Q],
) -> [[[f64; TILE_ROWS]; Q]; P] {
    use std::arch::x86_64::{
        __m128d, _mm_add_pd, _mm_cvtsd_f64, _mm_mul_pd, _mm_set_pd, _mm_setzero_pd, _mm_unpackhi_pd,
    };
    let groups = a.first().map_or(0, |c| c.len());
    let mut acc: [[__m128d; Q]; P] = [[_mm_setzero_pd(); Q]; P];
    for g in 0..groups {
        let x: [__m128d; P] = std::array::from_fn(|i| _mm_set_pd(a[i][g][1], a[i][g][0]));
        for j in 0..Q {
            let y = _mm_set_pd(b[j][g][1], b[j][g][0]);
            for i in 0..P {
                acc[i][j] = _mm_add_pd(acc[i][j], _mm_mul_pd(x[i], y));
            }
        }
    }
    // The two lanes out of each vector (the low one, then the high one moved down).
    acc.map(|row| row.map(|v| [_mm_cvtsd_f64(v), _mm_cvtsd_f64(_mm_unpackhi_pd(v, v))]))
}

/// The lanes' sums of a tile (see the x86-64 version): the same sums in the same order.
#[cfg(not(target_arch = "x86_64"))]
#[inline(always)]
fn tile_sums<const P: usize, const Q: usize>(
    a: &[&[[f64; TILE_ROWS]]; P],
    b: &[&[[f64; TILE_ROWS]]; Q],
) -> [[[f64; TILE_ROWS]; Q]; P] {
    let groups = a.first().map_or(0, |c| c.len());
    let mut acc = [[[0.0; TILE_ROWS]; Q]; P];
    for g in 0..groups {
        for i in 0..P {
            for j in 0..Q {
                for k in 0..TILE_ROWS {
                    acc[i][j][k] += a[i][g][k] * b[j][g][k];
                }
            }
        }
    }
    acc
}

/// Thin SVD by nalgebra, checked (`rows` x `cols` is the shape reported on failure).
///
/// nalgebra 0.35's implicit-shift bidiagonal QR returns wrong factors for some matrices
/// with (near-)zero singular values: `U` and `V` orthonormal, but a singular value off by
/// up to its own size (a 4 x 4 real embedding of an exactly rank-one 2 x 2 complex
/// residue: 67.301 for 67.240, `||M - U S V^T|| / ||M||` = 3e-2; of random 4 x 4 matrices
/// of rank 1, one in five). So the factorization is checked, `||M - U S V^T||_F` against
/// [`svd_residual_bound`], and one-sided Jacobi ([`jacobi_svd`]) replaces a failed one.
fn square_svd(m: &DMatrix<f64>, rows: usize, cols: usize) -> Result<ThinSvd, LinalgError> {
    let svd = SVD::try_new(
        m.clone(),
        true,
        true,
        f64::EPSILON,
        iteration_budget(rows.max(cols)) * 10,
    )
    .ok_or(LinalgError::NoConvergence {
        algorithm: "singular value decomposition",
        rows,
        cols,
    })?;
    let u = svd.u.expect("U requested");
    let v = svd.v_t.expect("V requested").transpose();
    let svd = ThinSvd {
        u,
        s: svd.singular_values,
        v,
    };
    let mut residual = m.clone();
    for (j, &s) in svd.s.iter().enumerate() {
        residual.ger(-s, &svd.u.column(j), &svd.v.column(j), 1.0);
    }
    if residual.norm() <= svd_residual_bound(m) {
        Ok(svd)
    } else {
        jacobi_svd(m, rows, cols)
    }
}

/// Largest `||M - U S V^T||_F` accepted from nalgebra's SVD: `16 eps sqrt(max(rows, cols))
/// ||M||_F`. Its correct factorizations of random matrices (4 x 4 to 200 x 200, 80 x 40)
/// were measured at 3.7 times `eps sqrt(max(rows, cols)) ||M||_F` at worst; the failures
/// range from 700 times that (one random full-rank 4 x 4 matrix in 2000) to `||M||_F`.
fn svd_residual_bound(m: &DMatrix<f64>) -> f64 {
    let (rows, cols) = m.shape();
    16.0 * f64::EPSILON * (rows.max(cols) as f64).sqrt() * m.norm()
}

/// Thin SVD by one-sided (Hestenes) Jacobi rotations, singular values descending: slower
/// than nalgebra's bidiagonal QR but free of its failures on rank-deficient matrices (the
/// columns are rotated until every pair is orthogonal to working precision; their norms
/// are the singular values). `rows` x `cols` is the shape reported on failure.
fn jacobi_svd(m: &DMatrix<f64>, rows: usize, cols: usize) -> Result<ThinSvd, LinalgError> {
    if m.nrows() < m.ncols() {
        // M^T = U S V^T: M = V S U^T.
        let t = jacobi_svd(&m.transpose(), rows, cols)?;
        return Ok(ThinSvd {
            u: t.v,
            s: t.s,
            v: t.u,
        });
    }
    let n = m.ncols();
    let mut a = m.clone();
    let mut v = DMatrix::<f64>::identity(n, n);
    let mut converged = false;
    for _ in 0..JACOBI_MAX_SWEEPS {
        let mut rotated = false;
        for p in 0..n {
            for q in p + 1..n {
                let alpha = a.column(p).norm_squared();
                let beta = a.column(q).norm_squared();
                let gamma = a.column(p).dot(&a.column(q));
                if gamma == 0.0 || gamma.abs() <= f64::EPSILON * alpha.sqrt() * beta.sqrt() {
                    continue;
                }
                rotated = true;
                // The rotation that zeroes the (p, q) entry of the 2 x 2 Gram matrix.
                let zeta = (beta - alpha) / (2.0 * gamma);
                let t = zeta.signum() / (zeta.abs() + zeta.hypot(1.0));
                let c = 1.0 / t.hypot(1.0);
                let s = c * t;
                for mat in [&mut a, &mut v] {
                    for i in 0..mat.nrows() {
                        let (x, y) = (mat[(i, p)], mat[(i, q)]);
                        mat[(i, p)] = c * x - s * y;
                        mat[(i, q)] = s * x + c * y;
                    }
                }
            }
        }
        if !rotated {
            converged = true;
            break;
        }
    }
    if !converged {
        return Err(LinalgError::NoConvergence {
            algorithm: "singular value decomposition (Jacobi)",
            rows,
            cols,
        });
    }
    let norms: Vec<f64> = (0..n).map(|j| a.column(j).norm()).collect();
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&i, &j| norms[j].total_cmp(&norms[i]));
    let s = DVector::from_iterator(n, order.iter().map(|&j| norms[j]));
    let v = DMatrix::from_fn(n, n, |i, k| v[(i, order[k])]);
    let mut u = DMatrix::from_fn(m.nrows(), n, |i, k| a[(i, order[k])]);
    for k in 0..n {
        if s[k] > 0.0 {
            u.column_mut(k).unscale_mut(s[k]);
            continue;
        }
        // A zero singular value: any unit vector orthogonal to the columns before it
        // (Gram-Schmidt, twice, of the coordinate vector least inside their span).
        let mut best = DVector::zeros(m.nrows());
        for e in 0..m.nrows() {
            let mut x = DVector::zeros(m.nrows());
            x[e] = 1.0;
            for _ in 0..2 {
                for c in 0..k {
                    let d = u.column(c).dot(&x);
                    x.axpy(-d, &u.column(c), 1.0);
                }
            }
            if x.norm() > best.norm() {
                best = x;
            }
        }
        let norm = best.norm();
        u.set_column(k, &(best / norm));
    }
    Ok(ThinSvd { u, s, v })
}

/// Sweeps of [`jacobi_svd`] before it gives up (it converges quadratically: a handful).
const JACOBI_MAX_SWEEPS: usize = 60;

/// Singular values of `m`, descending (no singular vectors: a fraction of the cost of
/// [`thin_svd`]).
pub fn singular_values(m: &DMatrix<f64>) -> Result<DVector<f64>, LinalgError> {
    ensure_finite(m, "matrix")?;
    let (rows, cols) = m.shape();
    if rows == 0 || cols == 0 {
        return Ok(DVector::zeros(rows.min(cols)));
    }
    let svd = SVD::try_new(
        m.clone(),
        false,
        false,
        f64::EPSILON,
        iteration_budget(rows.max(cols)) * 10,
    )
    .ok_or(LinalgError::NoConvergence {
        algorithm: "singular value decomposition",
        rows,
        cols,
    })?;
    Ok(svd.singular_values)
}

/// Columns added to the leading `k` in [`leading_svd`]'s block: the subspace then converges
/// at the rate `(s_(k+p+1) / s_k)^2` per iteration rather than `(s_(k+1) / s_k)^2`, which
/// matters when the `k`-th value is a weak mode just above the noise.
const LEADING_OVERSAMPLE: usize = 8;

/// Most block iterations of [`leading_svd`] before it gives up (the caller then takes the
/// full SVD). The three-storey campaign's jackknife resamples converge after one (callgrind
/// counted three QR factorizations per call: the values', the start's and one iteration's).
const LEADING_MAX_ITERATIONS: usize = 30;

/// All singular values of `m` (descending) with only the leading `k` singular vectors, by
/// block subspace iteration with Rayleigh-Ritz: a fraction of [`thin_svd`]'s cost when `k`
/// is small beside `min(rows, cols)`.
///
/// The values come from the values-only SVD (of the triangular factor for an elongated
/// matrix, as in [`thin_svd`]: they agree with [`singular_values`] to round-off). The
/// block of `k + 8` columns starts from the `k + 8` rows of `m` of largest norm; each
/// iteration multiplies by `m` and `m^T` and takes the SVD of the small projected matrix.
/// It stops when every leading pair has `|m v_i - s_i u_i| <= 64 eps sqrt(max(rows, cols))
/// s_1` (the residual of a full SVD is of that order) and its Ritz value agrees with the
/// values-only SVD to the same bound; vectors are then accurate to that residual over the
/// gap to the nearest other value. `Ok(None)` when that takes more than 30 iterations, when
/// `k + 8` is more than half of `min(rows, cols)` (the full SVD is then about as cheap) or
/// for a zero matrix: the caller takes [`thin_svd`]. Singular vectors are determined up to
/// sign (and within a cluster of equal values up to rotation), as [`thin_svd`]'s are.
pub fn leading_svd(m: &DMatrix<f64>, k: usize) -> Result<Option<ThinSvd>, LinalgError> {
    ensure_finite(m, "matrix")?;
    if !leading_block_fits(m, k) {
        return Ok(None);
    }
    let (rows, cols) = m.shape();
    // The values of an elongated matrix from its square triangular factor, as `thin_svd`
    // does (the bidiagonalization then runs over the short side only).
    let values = if rows >= QR_FIRST_RATIO * cols {
        singular_values(&thin_qr(m).1)?
    } else if cols >= QR_FIRST_RATIO * rows {
        singular_values(&thin_qr(&m.transpose()).1)?
    } else {
        singular_values(m)?
    };
    let s0 = values.get(0).copied().unwrap_or(0.0);
    let tol = leading_tolerance(m, s0);
    let converged = |small: &ThinSvd, residual: &DMatrix<f64>| {
        (0..k).all(|i| residual.column(i).norm() <= tol && (small.s[i] - values[i]).abs() <= tol)
    };
    Ok(subspace_iteration(m, k, s0, &converged)?.map(|svd| ThinSvd { s: values, ..svd }))
}

/// Whether [`leading_svd`]'s block of `k + 8` columns is at most half of `min(rows, cols)`
/// (and `k > 0`); otherwise the full SVD is about as cheap. Panics if `k` exceeds
/// `min(rows, cols)`.
fn leading_block_fits(m: &DMatrix<f64>, k: usize) -> bool {
    let (rows, cols) = m.shape();
    let full = rows.min(cols);
    assert!(
        k <= full,
        "leading_svd: {k} vectors of a {rows} x {cols} matrix"
    );
    k > 0 && 2 * (k + LEADING_OVERSAMPLE) <= full
}

/// The residual bound of [`leading_svd`] and [`leading_svd_certified`]:
/// `64 eps sqrt(max(rows, cols)) s_1`, of the order of a full SVD's residual.
fn leading_tolerance(m: &DMatrix<f64>, s1: f64) -> f64 {
    let (rows, cols) = m.shape();
    64.0 * f64::EPSILON * (rows.max(cols) as f64).sqrt() * s1
}

/// [`leading_svd`] without the values-only SVD: the leading `k` singular triplets of `m`,
/// certified from the block iteration itself, and `k + 8` values (the first `k` those
/// singular values, the rest the block's Ritz values, lower bounds of the next ones).
///
/// The certificate: every leading Ritz pair has `|m v_i - s_i u_i| <= tol` (and
/// `m^T u_i = s_i v_i` by construction), so `k` singular values of `m` lie within
/// `sqrt(k) tol` of the Ritz values `s_1 >= ... >= s_k` (Kahan's residual bound for the
/// symmetric matrix `[0 m; m^T 0]`); and `s_(k+1)(m) <= |m - U_k U_k^T m|_F =
/// sqrt(|m|_F^2 - sum_i s_i^2)`, the energy left outside the Ritz vectors. When that energy
/// is below `s_k - sqrt(k) tol`, the `k` singular values found are the `k` largest, each
/// within `sqrt(k) tol` of its Ritz value. Otherwise (a weak `k`-th direction under a heavy
/// tail) it falls back to [`leading_svd`], and it returns `Ok(None)` where that does.
/// For ERA/DC's correlation Hankel matrices (a few structural directions over a noise tail
/// thousands of times weaker) the certificate holds after the first iteration.
pub fn leading_svd_certified(m: &DMatrix<f64>, k: usize) -> Result<Option<ThinSvd>, LinalgError> {
    ensure_finite(m, "matrix")?;
    let fro2 = m.norm_squared();
    // An estimate of `s_1` for the tolerance (the largest column norm is within a factor
    // `sqrt(cols)` of it; the certificate below uses the Ritz value, a lower bound).
    let col_max = m.column_iter().map(|c| c.norm()).fold(0.0, f64::max);
    let tol = |ritz: &DVector<f64>| leading_tolerance(m, ritz[0].max(col_max));
    if !leading_block_fits(m, k) || fro2 <= 0.0 {
        // What `leading_svd` returns, without its values-only SVD.
        return Ok(None);
    }
    let converged = |small: &ThinSvd, residual: &DMatrix<f64>| {
        let tol = tol(&small.s);
        (0..k).all(|i| residual.column(i).norm() <= tol)
    };
    let Some(svd) = subspace_iteration(m, k, fro2.sqrt(), &converged)? else {
        return leading_svd(m, k);
    };
    let captured: f64 = svd.s.iter().take(k).map(|s| s * s).sum();
    // `|m|_F^2 - sum s_i^2` loses about `eps |m|_F^2` to round-off (each term once):
    // a margin of 4 k eps |m|_F^2 covers it.
    let energy = ((fro2 - captured).max(0.0) + 4.0 * (k + 1) as f64 * f64::EPSILON * fro2).sqrt();
    if energy < svd.s[k - 1] - (k as f64).sqrt() * tol(&svd.s) {
        Ok(Some(svd))
    } else {
        // No certificate: the values-only SVD decides.
        leading_svd(m, k)
    }
}

/// The block subspace iteration of [`leading_svd`] and [`leading_svd_certified`]: the
/// leading `k` left and right Ritz vectors (`u`, `v`) and the block's `k + 8` Ritz values
/// (`s`) once `converged(small, residual)` says so (`residual` holds `m v_i - s_i u_i`,
/// `i < k`). The block must fit ([`leading_block_fits`]). `None` when `scale` (a norm of
/// `m`) is 0, or after [`LEADING_MAX_ITERATIONS`].
fn subspace_iteration(
    m: &DMatrix<f64>,
    k: usize,
    scale: f64,
    converged: &dyn Fn(&ThinSvd, &DMatrix<f64>) -> bool,
) -> Result<Option<ThinSvd>, LinalgError> {
    let (rows, cols) = m.shape();
    debug_assert!(leading_block_fits(m, k));
    let block = k + LEADING_OVERSAMPLE;
    if scale <= 0.0 {
        return Ok(None);
    }
    // Start: the directions of the rows of largest norm (ties by index: deterministic).
    let mut norms: Vec<(usize, f64)> = (0..rows).map(|i| (i, m.row(i).norm_squared())).collect();
    norms.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
    let mut start = DMatrix::zeros(cols, block);
    for (j, &(i, _)) in norms.iter().take(block).enumerate() {
        start.set_column(j, &m.row(i).transpose());
    }
    let mut q = thin_qr(&start).0;
    for _ in 0..LEADING_MAX_ITERATIONS {
        let (p, _) = thin_qr(&(m * &q));
        // m ~ p z^T with z = m^T p; z = U S W^T gives m ~ (p W) S U^T.
        let z = m.tr_mul(&p);
        let small = thin_svd(&z)?;
        let u = &p * small.v.columns(0, k);
        let v = small.u.columns(0, k).into_owned();
        let residual = m * &v - &u * DMatrix::from_diagonal(&small.s.rows(0, k));
        if converged(&small, &residual) {
            return Ok(Some(ThinSvd { u, s: small.s, v }));
        }
        q = small.u;
    }
    Ok(None)
}

/// Solution of `min ||A X - B||_F` keeping the singular values of `A` above `rcond * s_max`.
/// Returns the solution and the number of singular values kept.
pub fn lstsq_truncated(svd: &ThinSvd, b: &DMatrix<f64>, rcond: f64) -> (DMatrix<f64>, usize) {
    assert_eq!(svd.u.nrows(), b.nrows(), "lstsq_truncated: row mismatch");
    let k = svd.rank(rcond);
    let u = svd.u.columns(0, k);
    let v = svd.v.columns(0, k);
    // Dot products of the columns (`U_k^T` on the left of a product is short and wide).
    let mut coeff = u.tr_mul(b);
    for i in 0..k {
        let inv = 1.0 / svd.s[i];
        coeff.row_mut(i).scale_mut(inv);
    }
    (v * coeff, k)
}

/// Cholesky factor `L` (lower) of a symmetric matrix. On failure returns the index of the
/// first non-positive pivot and its value (the Schur complement diagonal entry).
pub fn cholesky(a: &DMatrix<f64>) -> Result<DMatrix<f64>, (usize, f64)> {
    assert!(a.is_square(), "cholesky: matrix must be square");
    let n = a.nrows();
    let mut l = DMatrix::<f64>::zeros(n, n);
    for j in 0..n {
        let mut d = a[(j, j)];
        for k in 0..j {
            d -= l[(j, k)] * l[(j, k)];
        }
        if d.is_nan() || d <= 0.0 {
            return Err((j, d));
        }
        let djj = d.sqrt();
        l[(j, j)] = djj;
        for i in j + 1..n {
            let mut s = a[(i, j)];
            for k in 0..j {
                s -= l[(i, k)] * l[(j, k)];
            }
            l[(i, j)] = s / djj;
        }
    }
    Ok(l)
}

/// Inverse of a real square matrix by LU with partial pivoting.
pub fn inverse(a: &DMatrix<f64>, what: &'static str) -> Result<DMatrix<f64>, LinalgError> {
    assert!(a.is_square(), "inverse: matrix must be square");
    ensure_finite(a, what)?;
    let inv = a
        .clone()
        .lu()
        .try_inverse()
        .ok_or(LinalgError::Singular { what })?;
    if first_non_finite(&inv).is_some() {
        return Err(LinalgError::Singular { what });
    }
    Ok(inv)
}

/// Inverse of a complex square matrix by LU with partial pivoting.
pub fn inverse_complex(a: &DMatrix<C64>, what: &'static str) -> Result<DMatrix<C64>, LinalgError> {
    assert!(a.is_square(), "inverse_complex: matrix must be square");
    let inv = a
        .clone()
        .lu()
        .try_inverse()
        .ok_or(LinalgError::Singular { what })?;
    if inv.iter().any(|z| !(z.re.is_finite() && z.im.is_finite())) {
        return Err(LinalgError::Singular { what });
    }
    Ok(inv)
}

/// Relative Frobenius distance `||a - b|| / ||b||`.
pub fn relative_error(a: &DMatrix<f64>, b: &DMatrix<f64>) -> f64 {
    assert_eq!(a.shape(), b.shape(), "relative_error: shape mismatch");
    (a - b).norm() / b.norm()
}

#[cfg(test)]
mod tests;
