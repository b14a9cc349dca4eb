//! Allocation-free kernels on small complex matrices stored column-major in slices, for the
//! per-bin loops (sizes up to twice the number of DOFs). Everything else uses nalgebra.

use crate::linalg::C64;

const ZERO: C64 = C64::new(0.0, 0.0);

/// `out = a b` with `a` r x k and `b` k x c.
pub(crate) fn mul(a: &[C64], r: usize, k: usize, b: &[C64], c: usize, out: &mut [C64]) {
    debug_assert!(a.len() >= r * k && b.len() >= k * c && out.len() >= r * c);
    for j in 0..c {
        let col = &mut out[j * r..(j + 1) * r];
        col.fill(ZERO);
        for l in 0..k {
            let blj = b[l + j * k];
            if blj == ZERO {
                continue;
            }
            let acol = &a[l * r..(l + 1) * r];
            for i in 0..r {
                col[i] += acol[i] * blj;
            }
        }
    }
}

/// `out += a b` with `a` r x k and `b` k x c.
pub(crate) fn mul_add(a: &[C64], r: usize, k: usize, b: &[C64], c: usize, out: &mut [C64]) {
    debug_assert!(a.len() >= r * k && b.len() >= k * c && out.len() >= r * c);
    for j in 0..c {
        let col = &mut out[j * r..(j + 1) * r];
        for l in 0..k {
            let blj = b[l + j * k];
            if blj == ZERO {
                continue;
            }
            let acol = &a[l * r..(l + 1) * r];
            for i in 0..r {
                col[i] += acol[i] * blj;
            }
        }
    }
}

/// Row of the largest magnitude in column `col` of the n x n matrix `a`, from the
/// diagonal down (partial pivoting); `None` if it is zero or not finite.
fn pivot(a: &[C64], n: usize, col: usize) -> Option<usize> {
    let mut piv = col;
    let mut best = a[col + col * n].norm_sqr();
    for row in col + 1..n {
        let v = a[row + col * n].norm_sqr();
        if v > best {
            best = v;
            piv = row;
        }
    }
    (best > 0.0 && best.is_finite()).then_some(piv)
}

/// Inverse of the n x n matrix `a` (destroyed) into `inv`, by Gauss-Jordan elimination
/// with partial pivoting. Returns false if a pivot is zero or not finite.
pub(crate) fn invert(a: &mut [C64], n: usize, inv: &mut [C64]) -> bool {
    debug_assert!(a.len() >= n * n && inv.len() >= n * n);
    inv[..n * n].fill(ZERO);
    for i in 0..n {
        inv[i + i * n] = C64::new(1.0, 0.0);
    }
    for col in 0..n {
        let Some(piv) = pivot(a, n, col) else {
            return false;
        };
        if piv != col {
            for j in 0..n {
                a.swap(col + j * n, piv + j * n);
                inv.swap(col + j * n, piv + j * n);
            }
        }
        let d = C64::new(1.0, 0.0) / a[col + col * n];
        for j in 0..n {
            a[col + j * n] *= d;
            inv[col + j * n] *= d;
        }
        for row in 0..n {
            if row == col {
                continue;
            }
            let f = a[row + col * n];
            if f == ZERO {
                continue;
            }
            for j in 0..n {
                let (ac, ic) = (a[col + j * n], inv[col + j * n]);
                a[row + j * n] -= f * ac;
                inv[row + j * n] -= f * ic;
            }
        }
    }
    true
}

/// Solves `a x = b` in place for the n x n matrix `a` (destroyed) and `c` right-hand sides
/// stored column-major in `b` (n x c), by Gaussian elimination with partial pivoting.
/// Returns false if a pivot is zero or not finite.
#[inline]
pub(crate) fn solve(a: &mut [C64], n: usize, b: &mut [C64], c: usize) -> bool {
    debug_assert!(a.len() >= n * n && b.len() >= n * c);
    for col in 0..n {
        let Some(piv) = pivot(a, n, col) else {
            return false;
        };
        if piv != col {
            for j in col..n {
                a.swap(col + j * n, piv + j * n);
            }
            for j in 0..c {
                b.swap(col + j * n, piv + j * n);
            }
        }
        let d = C64::new(1.0, 0.0) / a[col + col * n];
        for row in col + 1..n {
            let f = a[row + col * n] * d;
            if f == ZERO {
                continue;
            }
            for j in col + 1..n {
                let v = a[col + j * n];
                a[row + j * n] -= f * v;
            }
            for j in 0..c {
                let v = b[col + j * n];
                b[row + j * n] -= f * v;
            }
        }
    }
    for j in 0..c {
        let x = &mut b[j * n..(j + 1) * n];
        for row in (0..n).rev() {
            let mut v = x[row];
            for k in row + 1..n {
                v -= a[row + k * n] * x[k];
            }
            x[row] = v / a[row + row * n];
        }
    }
    true
}

/// Lower Cholesky factor `l` of the Hermitian positive definite m x m matrix `a` (only its
/// lower triangle is read). Returns false if a pivot is not positive.
pub(crate) fn cholesky(a: &[C64], m: usize, l: &mut [C64]) -> bool {
    l[..m * m].fill(ZERO);
    for j in 0..m {
        let mut d = a[j + j * m].re;
        for k in 0..j {
            d -= l[j + k * m].norm_sqr();
        }
        if !(d > 0.0 && d.is_finite()) {
            return false;
        }
        let djj = d.sqrt();
        l[j + j * m] = C64::new(djj, 0.0);
        for i in j + 1..m {
            let mut s = a[i + j * m];
            for k in 0..j {
                s -= l[i + k * m] * l[j + k * m].conj();
            }
            l[i + j * m] = s / djj;
        }
    }
    true
}

/// Solves `l x = b` in place for lower triangular `l` (m x m) and `c` right-hand sides
/// stored column-major in `x` (m x c). A diagonal with zero imaginary parts (every
/// Cholesky factor of [`cholesky`]) is divided as real numbers.
pub(crate) fn forward_solve(l: &[C64], m: usize, x: &mut [C64], c: usize) {
    let real_diagonal = (0..m).all(|i| l[i + i * m].im == 0.0);
    for col in 0..c {
        let x = &mut x[col * m..(col + 1) * m];
        for i in 0..m {
            let mut s = x[i];
            for k in 0..i {
                s -= l[i + k * m] * x[k];
            }
            x[i] = if real_diagonal {
                s / l[i + i * m].re
            } else {
                s / l[i + i * m]
            };
        }
    }
}
