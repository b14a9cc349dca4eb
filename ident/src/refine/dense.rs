//! Allocation-free kernels on small complex matrices stored column-major in slices, for the
//! per-bin loops (sizes up to twice the number of DOFs). Everything else uses nalgebra.

use crate::linalg::C64;

const ZERO: C64 = C64::new(0.0, 0.0);

/// `out = a b` with `a` r x k and `b` k x c.
pub(crate) fn mul(a: &[C64], r: usize, k: usize, b: &[C64], c: usize, out: &mut [C64]) {
    // The likelihood's per-line products of the common frames with constant sizes, so that
    // the loops unroll: `C (z I - A_d)^-1` (2 x 4 x 4, 3 x 6 x 6) and `Q^-1 B2` (2 x 2 x 1,
    // 3 x 3 x 1); the same operations in the same order.
    match (r, k, c) {
        (2, 4, 4) => mul_sizes(a, 2, 4, b, 4, out),
        (3, 6, 6) => mul_sizes(a, 3, 6, b, 6, out),
        (2, 2, 1) => mul_sizes(a, 2, 2, b, 1, out),
        (3, 3, 1) => mul_sizes(a, 3, 3, b, 1, out),
        _ => mul_sizes(a, r, k, b, c, out),
    }
}

/// [`mul`] itself, inlined into each of its calls so that constant sizes unroll it.
#[inline(always)]
fn mul_sizes(a: &[C64], r: usize, k: usize, b: &[C64], c: usize, out: &mut [C64]) {
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

/// Largest order [`invert`] takes (it records its row interchanges on the stack).
const MAX_ORDER: usize = 64;

/// Inverse of the n x n matrix `a` into `inv` (`a` is not changed), by in-place Gauss-Jordan
/// elimination with partial pivoting (n^3 complex multiply-adds: the inverse overwrites the
/// matrix column by column, and the row interchanges are undone as column interchanges at
/// the end). Returns false if a pivot is zero or not finite, or if the inverse is not (a
/// non-finite entry that met no pivot). Panics above [`MAX_ORDER`].
pub(crate) fn invert(a: &mut [C64], n: usize, inv: &mut [C64]) -> bool {
    assert!(n <= MAX_ORDER, "dense::invert: order {n} above {MAX_ORDER}");
    // The orders of the common frames (two to four storeys: states 4 to 8, DOFs 2 to 4) as
    // constants, so that the loops unroll: the same operations in the same order.
    match n {
        2 => invert_order(a, 2, inv),
        3 => invert_order(a, 3, inv),
        4 => invert_order(a, 4, inv),
        6 => invert_order(a, 6, inv),
        8 => invert_order(a, 8, inv),
        _ => invert_order(a, n, inv),
    }
}

/// [`invert`] itself, inlined into each of its calls so that a constant `n` unrolls it.
#[inline(always)]
fn invert_order(a: &mut [C64], n: usize, inv: &mut [C64]) -> bool {
    let w = &mut inv[..n * n];
    w.copy_from_slice(&a[..n * n]);
    let mut swaps = [0u8; MAX_ORDER];
    for k in 0..n {
        let Some(piv) = pivot(w, n, k) else {
            return false;
        };
        swaps[k] = piv as u8;
        if piv != k {
            for j in 0..n {
                w.swap(k + j * n, piv + j * n);
            }
        }
        let d = C64::new(1.0, 0.0) / w[k + k * n];
        w[k + k * n] = C64::new(1.0, 0.0);
        for j in 0..n {
            w[k + j * n] *= d;
        }
        for i in 0..n {
            if i == k {
                continue;
            }
            let f = w[i + k * n];
            if f == ZERO {
                continue;
            }
            w[i + k * n] = ZERO;
            for j in 0..n {
                let v = w[k + j * n];
                w[i + j * n] -= f * v;
            }
        }
    }
    for k in (0..n).rev() {
        let piv = usize::from(swaps[k]);
        if piv != k {
            for i in 0..n {
                w.swap(i + k * n, i + piv * n);
            }
        }
    }
    // A non-finite entry off the pivots' paths (above the diagonal of a triangular matrix,
    // say) reaches no pivot but spreads over its row of the inverse.
    finite(w)
}

/// Whether every entry is finite.
#[inline]
fn finite(v: &[C64]) -> bool {
    v.iter().all(|x| x.re.is_finite() && x.im.is_finite())
}

/// Solves `a x = b` in place for the n x n matrix `a` (destroyed) and `c` right-hand sides
/// stored column-major in `b` (n x c), by Gaussian elimination with partial pivoting.
/// Returns false if a pivot is zero or not finite, or if the solution is not.
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
    // As in `invert`: a non-finite entry that met no pivot (or one of `b`).
    finite(&b[..n * c])
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
    // The output counts of the common frames (two to four storeys) as constants, so that the
    // loops unroll (the likelihood solves one right-hand side per hit and line): the same
    // operations in the same order.
    match m {
        2 => forward_solve_order(l, 2, x, c),
        3 => forward_solve_order(l, 3, x, c),
        4 => forward_solve_order(l, 4, x, c),
        _ => forward_solve_order(l, m, x, c),
    }
}

/// [`forward_solve`] itself, inlined into each of its calls so that a constant `m` unrolls it.
#[inline(always)]
fn forward_solve_order(l: &[C64], m: usize, x: &mut [C64], c: usize) {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testutil::normal;
    use nalgebra::DMatrix;
    use rand::rngs::ChaCha8Rng;
    use rand::{RngExt, SeedableRng};

    /// [`invert`] on the augmented matrix `[a | I]` (2 n^3 operations): the test oracle.
    #[cfg(test)]
    fn invert_augmented(a: &mut [C64], n: usize, inv: &mut [C64]) -> bool {
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

    /// The in-place elimination against the augmented one and `A A^-1` against the identity, on
    /// random complex matrices of the orders the likelihood uses (2 to 8), some with
    /// permuted rows so that every pivoting path runs.
    #[test]
    fn inverse_matches_the_augmented_elimination() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for trial in 0..200 {
            let n = 2 + trial % 7;
            let mut a: Vec<C64> = (0..n * n)
                .map(|_| C64::new(normal(&mut rng), normal(&mut rng)))
                .collect();
            if trial % 3 == 0 {
                // A small leading entry forces an interchange.
                a[0] *= 1e-6;
            }
            let (mut a1, mut a2) = (a.clone(), a.clone());
            let (mut fast, mut slow) = (vec![ZERO; n * n], vec![ZERO; n * n]);
            assert!(invert(&mut a1, n, &mut fast));
            assert!(invert_augmented(&mut a2, n, &mut slow));
            let mut product = vec![ZERO; n * n];
            mul(&a, n, n, &fast, n, &mut product);
            // The in-place elimination does the augmented one's arithmetic on the entries
            // that are not known zeros or ones, in the same order: equal bit for bit.
            assert_eq!(fast, slow, "order {n}");
            let norm = |v: &[C64]| v.iter().map(|x| x.norm_sqr()).sum::<f64>().sqrt();
            let scale = norm(&fast);
            for i in 0..n {
                for j in 0..n {
                    let want = if i == j { 1.0 } else { 0.0 };
                    let e = (product[i + j * n] - C64::new(want, 0.0)).norm();
                    // Backward stable: round-off times the condition number. Measured at
                    // most 4.8e-16 of the inverse's norm over these 200 matrices; 1e-10
                    // leaves room for a condition number up to about 1e5.
                    assert!(e <= 1e-10 * scale, "order {n}: A A^-1 off by {e}");
                }
            }
        }
    }

    /// The product with constant sizes (the common frames' shapes) is the naive sum over the
    /// inner index in order, bit for bit, as is any other shape; zeros of `b` are skipped.
    #[test]
    fn product_matches_the_naive_sums_for_every_shape() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        for (r, k, c) in [
            (2, 4, 4),
            (3, 6, 6),
            (2, 2, 1),
            (3, 3, 1),
            (2, 3, 5),
            (4, 8, 8),
        ] {
            let a: Vec<C64> = (0..r * k)
                .map(|_| C64::new(normal(&mut rng), normal(&mut rng)))
                .collect();
            let mut b: Vec<C64> = (0..k * c)
                .map(|_| C64::new(normal(&mut rng), normal(&mut rng)))
                .collect();
            b[0] = ZERO;
            let mut out = vec![C64::new(f64::NAN, 0.0); r * c];
            mul(&a, r, k, &b, c, &mut out);
            for i in 0..r {
                for j in 0..c {
                    let want = (0..k)
                        .filter(|&l| b[l + j * k] != ZERO)
                        .fold(ZERO, |s, l| s + a[i + l * r] * b[l + j * k]);
                    assert_eq!(out[i + j * r], want, "{r} x {k} x {c}, entry ({i}, {j})");
                }
            }
        }
    }

    /// Forward substitution against its residual: `l x` gives back the right-hand sides, for
    /// the unrolled orders and others, one and several columns, real and complex diagonals.
    #[test]
    fn forward_solve_residual_is_rounding() {
        let mut rng = ChaCha8Rng::seed_from_u64(6);
        for m in 1..=6 {
            for c in [1, 4] {
                for real_diagonal in [true, false] {
                    let mut l = vec![ZERO; m * m];
                    for j in 0..m {
                        for i in j..m {
                            l[i + j * m] = C64::new(normal(&mut rng), normal(&mut rng));
                        }
                        // Well away from zero: the residual then bounds the error.
                        let d = 2.0 + normal(&mut rng).abs();
                        l[j + j * m] = if real_diagonal {
                            C64::new(d, 0.0)
                        } else {
                            C64::new(d, normal(&mut rng))
                        };
                    }
                    let b: Vec<C64> = (0..m * c)
                        .map(|_| C64::new(normal(&mut rng), normal(&mut rng)))
                        .collect();
                    let mut x = b.clone();
                    forward_solve(&l, m, &mut x, c);
                    let mut back = vec![ZERO; m * c];
                    mul(&l, m, m, &x, c, &mut back);
                    let worst = back
                        .iter()
                        .zip(&b)
                        .map(|(a, b)| (a - b).norm())
                        .fold(0.0, f64::max);
                    // Rounding of m terms of order one: a few 1e-16; 1e-13 leaves room. A
                    // wrong or skipped term gives order one.
                    assert!(
                        worst < 1e-13,
                        "m {m}, c {c}, real {real_diagonal}: {worst:e}"
                    );
                }
            }
        }
    }

    /// A zero column has no pivot: both report it instead of dividing by zero.
    #[test]
    fn singular_matrix_is_reported() {
        let n = 3;
        let mut a = vec![C64::new(1.0, 0.5); n * n];
        for i in 0..n {
            a[i + n] = ZERO;
        }
        let mut inv = vec![ZERO; n * n];
        assert!(!invert(&mut a.clone(), n, &mut inv));
        assert!(!invert_augmented(&mut a, n, &mut inv));
    }

    fn random_c(rng: &mut ChaCha8Rng) -> C64 {
        C64::new(normal(rng), normal(rng))
    }

    /// A uniformly random permutation of `0..n` (Fisher-Yates).
    fn permutation(rng: &mut ChaCha8Rng, n: usize) -> Vec<usize> {
        let mut p: Vec<usize> = (0..n).collect();
        for i in (1..n).rev() {
            let j = (rng.random::<u64>() % (i as u64 + 1)) as usize;
            p.swap(i, j);
        }
        p
    }

    fn frobenius(v: &[C64]) -> f64 {
        v.iter().map(|x| x.norm_sqr()).sum::<f64>().sqrt()
    }

    /// Matrices whose elimination needs row interchanges at (almost) every step, or skips
    /// exact zeros (`f == ZERO`), or both, for every order 1 to 8 (the unrolled 2, 3, 4, 6
    /// and 8 and the generic path): a row-permuted upper triangular matrix (exact zeros
    /// below the pivots everywhere), the same plus small dense noise (pivots still far
    /// from the diagonal), a sparse matrix with half its entries exactly zero, and a dense
    /// one with a leading column a million times smaller than the rest. The inverse and the
    /// solution of three right-hand sides against nalgebra's complex LU (an independent
    /// elimination).
    #[test]
    fn inverse_and_solve_match_nalgebra_with_interchanges_and_zeros() {
        let mut rng = ChaCha8Rng::seed_from_u64(17);
        let mut worst = 0.0f64;
        for n in 1..=8 {
            for trial in 0..24 {
                let kind = trial % 4;
                let p = permutation(&mut rng, n);
                let mut a = vec![ZERO; n * n];
                match kind {
                    0 | 1 => {
                        // Row p[i] of `a` is row i of an upper triangular matrix.
                        for j in 0..n {
                            for i in 0..=j {
                                let v = if i == j {
                                    // Away from zero: a condition number of order n.
                                    C64::from_polar(1.0 + rng.random::<f64>(), normal(&mut rng))
                                } else {
                                    random_c(&mut rng) * 0.5
                                };
                                a[p[i] + j * n] = v;
                            }
                        }
                        if kind == 1 {
                            for v in &mut a {
                                *v += random_c(&mut rng) * 1e-3;
                            }
                        }
                    }
                    2 => {
                        // A permuted complex diagonal plus half of the other entries.
                        for j in 0..n {
                            a[p[j] + j * n] = C64::from_polar(2.0, normal(&mut rng));
                        }
                        for v in &mut a {
                            if *v == ZERO && rng.random::<f64>() < 0.5 {
                                *v = random_c(&mut rng) * 0.3;
                            }
                        }
                    }
                    _ => {
                        for v in &mut a {
                            *v = random_c(&mut rng);
                        }
                        for i in 0..n {
                            a[i] *= 1e-6;
                        }
                    }
                }
                let c = 3;
                let b: Vec<C64> = (0..n * c).map(|_| random_c(&mut rng)).collect();
                let am = DMatrix::from_column_slice(n, n, &a);
                let bm = DMatrix::from_column_slice(n, c, &b);
                let lu = am.clone().lu();
                let want_inv = lu.try_inverse().expect("nonsingular");
                let want_x = lu.solve(&bm).expect("nonsingular");
                let cond = am.norm() * want_inv.norm();

                let mut inv = vec![ZERO; n * n];
                let mut a1 = a.clone();
                assert!(invert(&mut a1, n, &mut inv), "order {n} kind {kind}");
                assert_eq!(a1, a, "invert changed its input");
                let mut a2 = a.clone();
                let mut x = b.clone();
                assert!(solve(&mut a2, n, &mut x, c), "order {n} kind {kind}");

                let e_inv = frobenius(
                    &inv.iter()
                        .zip(want_inv.as_slice())
                        .map(|(x, y)| x - y)
                        .collect::<Vec<_>>(),
                ) / want_inv.norm();
                let e_x = frobenius(
                    &x.iter()
                        .zip(want_x.as_slice())
                        .map(|(x, y)| x - y)
                        .collect::<Vec<_>>(),
                ) / want_x.norm();
                worst = worst.max(e_inv / cond).max(e_x / cond);
                // Two backward-stable eliminations differ by round-off times the condition
                // number (Frobenius): measured at most 1.3e-16 cond, cond up to 3.2e7 (the
                // column scaled by 1e-6); 1e-13 cond leaves a factor of about 1000, while a
                // wrong interchange, a skipped term or a misplaced column gives an error
                // of order one (at most 3e-6 allowed).
                assert!(
                    e_inv <= 1e-13 * cond && e_x <= 1e-13 * cond,
                    "order {n} kind {kind}: inverse off by {e_inv:e}, solution by {e_x:e} \
                     (cond {cond:e})"
                );
            }
        }
        eprintln!("worst error over cond: {worst:e}");
    }

    /// A permuted complex diagonal `A = P D` (`A[p[j], j] = d_j`) has the inverse
    /// `D^-1 P^T` (`X[j, p[j]] = 1 / d_j`), and Gauss-Jordan finds it exactly: every step
    /// interchanges rows to reach the one nonzero of its column, scales that row by the
    /// reciprocal and skips every other row (`f == ZERO`); the interchanges are then undone
    /// as column interchanges in reverse order, which a cycle of length three or more tells
    /// from the forward order. Bit for bit, every order 1 to 8, 40 permutations each.
    #[test]
    fn permuted_diagonal_inverts_exactly() {
        let mut rng = ChaCha8Rng::seed_from_u64(19);
        let one = C64::new(1.0, 0.0);
        for n in 1..=8 {
            for _ in 0..40 {
                let p = permutation(&mut rng, n);
                let d: Vec<C64> = (0..n).map(|_| random_c(&mut rng)).collect();
                let mut a = vec![ZERO; n * n];
                let mut want = vec![ZERO; n * n];
                for j in 0..n {
                    a[p[j] + j * n] = d[j];
                    want[j + p[j] * n] = one / d[j];
                }
                let mut inv = vec![C64::new(f64::NAN, 0.0); n * n];
                assert!(invert(&mut a.clone(), n, &mut inv));
                assert_eq!(inv, want, "order {n}, permutation {p:?}");
                // The solve of the identity's columns is the same inverse.
                let mut x = vec![ZERO; n * n];
                for i in 0..n {
                    x[i + i * n] = one;
                }
                assert!(solve(&mut a, n, &mut x, n));
                assert_eq!(x, want, "solve, order {n}, permutation {p:?}");
            }
        }
    }

    /// Singular matrices whose zero pivot appears only at step `k` (1 to n - 1), after
    /// interchanges: the first `k + 1` columns are nonzero only in `k` rows (scattered by a
    /// random row permutation), so they have rank at most `k`. The other rows are never
    /// touched by the elimination of those columns (their multipliers are exact zeros), so
    /// column `k` is exactly zero from the diagonal down at step `k`: both kernels report it
    /// (no rounding can hide it). Also a matrix with one exactly zero row, at every position.
    #[test]
    fn singular_matrices_with_a_late_zero_pivot_are_reported() {
        let mut rng = ChaCha8Rng::seed_from_u64(23);
        for n in 2..=8 {
            for k in 1..n {
                let p = permutation(&mut rng, n);
                let mut a: Vec<C64> = (0..n * n).map(|_| random_c(&mut rng)).collect();
                for j in 0..=k {
                    for i in k..n {
                        a[p[i] + j * n] = ZERO;
                    }
                }
                let mut inv = vec![ZERO; n * n];
                assert!(!invert(&mut a.clone(), n, &mut inv), "order {n}, step {k}");
                let mut b: Vec<C64> = (0..n).map(|_| random_c(&mut rng)).collect();
                assert!(!solve(&mut a, n, &mut b, 1), "order {n}, step {k}");
            }
            for row in 0..n {
                let mut a: Vec<C64> = (0..n * n).map(|_| random_c(&mut rng)).collect();
                for j in 0..n {
                    a[row + j * n] = ZERO;
                }
                let mut inv = vec![ZERO; n * n];
                assert!(!invert(&mut a.clone(), n, &mut inv), "order {n}, row {row}");
                let mut b: Vec<C64> = (0..n).map(|_| random_c(&mut rng)).collect();
                assert!(!solve(&mut a, n, &mut b, 1), "order {n}, row {row}");
            }
        }
    }

    /// A NaN or an infinity anywhere in the matrix (and, for `solve`, in the right-hand
    /// side) must be reported, never returned as a "successful" inverse or solution holding
    /// NaNs: every position, every order 1 to 8, on well-conditioned random matrices.
    #[test]
    fn non_finite_entries_are_reported() {
        let mut rng = ChaCha8Rng::seed_from_u64(29);
        let bad = [
            C64::new(f64::NAN, 0.0),
            C64::new(0.0, f64::INFINITY),
            C64::new(f64::NEG_INFINITY, 1.0),
        ];
        for n in 1..=8 {
            let mut base: Vec<C64> = (0..n * n).map(|_| random_c(&mut rng)).collect();
            for i in 0..n {
                base[i + i * n] += C64::new(3.0 * n as f64, 0.0);
            }
            for pos in 0..n * n {
                for &x in &bad {
                    let mut a = base.clone();
                    a[pos] = x;
                    let mut inv = vec![ZERO; n * n];
                    let ok = invert(&mut a.clone(), n, &mut inv);
                    let finite = inv.iter().all(|v| v.re.is_finite() && v.im.is_finite());
                    assert!(
                        !ok,
                        "order {n}, entry ({}, {}) = {x}: invert returned true (finite \
                         output: {finite})",
                        pos % n,
                        pos / n
                    );
                    let mut b: Vec<C64> = (0..n).map(|_| random_c(&mut rng)).collect();
                    assert!(!solve(&mut a, n, &mut b, 1), "order {n}, entry {pos} = {x}");
                }
            }
            // Upper triangular: the multipliers below the diagonal are exact zeros, so a
            // NaN above the diagonal meets no pivot on its way (before the final check,
            // `[[1, NaN], [0, 1]]` came back as a "successful" inverse full of NaNs).
            let mut upper = base.clone();
            for j in 0..n {
                for i in j + 1..n {
                    upper[i + j * n] = ZERO;
                }
            }
            for j in 0..n {
                for i in 0..j {
                    for &x in &bad {
                        let mut a = upper.clone();
                        a[i + j * n] = x;
                        let mut inv = vec![ZERO; n * n];
                        assert!(
                            !invert(&mut a.clone(), n, &mut inv),
                            "upper, order {n}, ({i}, {j}) = {x}"
                        );
                        let mut b: Vec<C64> = (0..n).map(|_| random_c(&mut rng)).collect();
                        assert!(
                            !solve(&mut a, n, &mut b, 1),
                            "upper solve, order {n}, ({i}, {j}) = {x}"
                        );
                    }
                }
            }
            for row in 0..n {
                for &x in &bad {
                    let mut b: Vec<C64> = (0..n).map(|_| random_c(&mut rng)).collect();
                    b[row] = x;
                    assert!(
                        !solve(&mut upper.clone(), n, &mut b, 1),
                        "order {n}, b[{row}]"
                    );
                }
            }
        }
    }

    /// `mul_add` adds the naive sums to what `out` held, for the unrolled shapes of `mul`
    /// and others, with exact zeros in `b` (skipped) and in `a`.
    #[test]
    fn product_accumulation_matches_the_naive_sums() {
        let mut rng = ChaCha8Rng::seed_from_u64(31);
        for (r, k, c) in [
            (2, 4, 4),
            (3, 6, 6),
            (2, 2, 1),
            (3, 3, 1),
            (1, 1, 1),
            (5, 2, 3),
        ] {
            let mut a: Vec<C64> = (0..r * k).map(|_| random_c(&mut rng)).collect();
            let mut b: Vec<C64> = (0..k * c).map(|_| random_c(&mut rng)).collect();
            b[k * c - 1] = ZERO;
            a[0] = ZERO;
            let start: Vec<C64> = (0..r * c).map(|_| random_c(&mut rng)).collect();
            let mut out = start.clone();
            mul_add(&a, r, k, &b, c, &mut out);
            for i in 0..r {
                for j in 0..c {
                    let want = (0..k)
                        .filter(|&l| b[l + j * k] != ZERO)
                        .fold(start[i + j * r], |s, l| s + a[i + l * r] * b[l + j * k]);
                    assert_eq!(out[i + j * r], want, "{r} x {k} x {c}, entry ({i}, {j})");
                }
            }
        }
    }

    /// The complex Cholesky factor against nalgebra's (unique: positive real diagonal) on
    /// random Hermitian positive definite matrices of orders 1 to 6, with the strict upper
    /// triangle filled with garbage (only the lower one is read); a positive semidefinite
    /// matrix of rank `m - 1` (a zero Schur complement, or round-off of either sign), an
    /// indefinite one and a NaN below the diagonal are reported.
    #[test]
    fn cholesky_matches_nalgebra_and_reports_failures() {
        let mut rng = ChaCha8Rng::seed_from_u64(37);
        for m in 1..=6 {
            let g = DMatrix::from_fn(m, m, |_, _| random_c(&mut rng));
            let h = &g * g.adjoint() + DMatrix::identity(m, m) * C64::new(0.1, 0.0);
            let mut a: Vec<C64> = h.as_slice().to_vec();
            for j in 0..m {
                for i in 0..j {
                    a[i + j * m] = C64::new(f64::NAN, 7.0);
                }
            }
            let mut l = vec![C64::new(f64::NAN, 0.0); m * m];
            assert!(cholesky(&a, m, &mut l));
            let want = h.clone().cholesky().expect("positive definite").l();
            let e = frobenius(
                &l.iter()
                    .zip(want.as_slice())
                    .map(|(x, y)| x - y)
                    .collect::<Vec<_>>(),
            ) / want.norm();
            // Both factors are backward stable, the condition numbers here at most 190
            // (the 0.1 shift): measured at most 2.8e-16 relative; 1e-13 leaves a factor of
            // 300, while a wrong conjugate or term gives an error of order one.
            assert!(e < 1e-13, "order {m}: {e:e}");
            // Rank m - 1: exactly singular Gram matrix (one column of g repeated).
            if m >= 2 {
                let mut g2 = g.clone();
                let c0 = g2.column(0).into_owned();
                g2.set_column(m - 1, &c0);
                let h2 = g2.adjoint().adjoint() * g2.adjoint();
                let a2: Vec<C64> = h2.as_slice().to_vec();
                let ok = cholesky(&a2, m, &mut l);
                // Round-off may leave a tiny positive pivot: then the last diagonal entry
                // of the factor is at round-off level (at most 1e-6 of the largest).
                if ok {
                    let top = (0..m).map(|i| l[i + i * m].re).fold(0.0, f64::max);
                    let last = l[m - 1 + (m - 1) * m].re;
                    assert!(last < 1e-6 * top, "order {m}: pivot {last:e} of {top:e}");
                }
                let mut a3 = h.as_slice().to_vec();
                a3[m - 1 + (m - 1) * m] = C64::new(-1.0, 0.0);
                assert!(!cholesky(&a3, m, &mut l), "order {m}: indefinite");
                let mut a4 = h.as_slice().to_vec();
                a4[m - 1] = C64::new(f64::NAN, 0.0);
                assert!(!cholesky(&a4, m, &mut l), "order {m}: NaN");
            }
        }
    }
}
