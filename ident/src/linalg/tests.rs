use super::*;
use rand::rngs::ChaCha8Rng;
use rand::{RngExt, SeedableRng};

fn random_real(rng: &mut ChaCha8Rng, n: usize) -> DMatrix<f64> {
    DMatrix::from_fn(n, n, |_, _| rng.random::<f64>() * 2.0 - 1.0)
}

fn residual(a: &DMatrix<C64>, e: &Eigen) -> f64 {
    let av = a * &e.vectors;
    let vl = &e.vectors * DMatrix::from_diagonal(&e.values);
    (av - vl).norm() / (a.norm() * e.vectors.norm())
}

#[test]
fn eig_residual_on_random_real_matrices() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    for &n in &[1usize, 2, 3, 5, 8, 20, 60] {
        for _ in 0..3 {
            let a = random_real(&mut rng, n);
            let e = eig(&a).unwrap();
            // Backward-stable Schur + back-substitution: residual is a small multiple of
            // machine epsilon times the matrix norm (measured <= 1e-14 up to n = 60).
            let r = residual(&a.map(|x| C64::new(x, 0.0)), &e);
            assert!(r < 1e-13, "n = {n}: relative residual {r:e}");
            // Eigenvalues of a real matrix come in conjugate pairs.
            let sum_im: f64 = e.values.iter().map(|l| l.im).sum();
            assert!(sum_im.abs() < 1e-12 * (n as f64) * a.norm());
        }
    }
}

#[test]
fn eig_residual_on_random_complex_and_badly_scaled_matrices() {
    let mut rng = ChaCha8Rng::seed_from_u64(12);
    for &n in &[2usize, 4, 7, 30] {
        let a = DMatrix::from_fn(n, n, |_, _| {
            C64::new(rng.random::<f64>() - 0.5, rng.random::<f64>() - 0.5)
        });
        let e = eig_complex(&a).unwrap();
        let r = residual(&a, &e);
        assert!(r < 1e-13, "complex n = {n}: relative residual {r:e}");
    }
    // Entries spanning eight orders of magnitude: balancing keeps the residual small
    // relative to the balanced matrix, so check it column by column against |lambda|.
    let n = 6;
    let d = DVector::from_fn(n, |i, _| 10f64.powi(i as i32 - 3));
    let a0 = random_real(&mut rng, n);
    let a = DMatrix::from_diagonal(&d) * a0 * DMatrix::from_diagonal(&d.map(|x| 1.0 / x));
    let e = eig(&a).unwrap();
    let ac = a.map(|x| C64::new(x, 0.0));
    let mut want = eigenvalues(&a)
        .unwrap()
        .iter()
        .map(|l| l.norm())
        .collect::<Vec<_>>();
    let mut got = e.values.iter().map(|l| l.norm()).collect::<Vec<_>>();
    want.sort_by(f64::total_cmp);
    got.sort_by(f64::total_cmp);
    for (g, w) in got.iter().zip(&want) {
        // Same eigenvalues from real and complex Schur: both backward stable.
        assert!((g - w).abs() < 1e-10 * w.max(1.0), "{g} vs {w}");
    }
    for j in 0..n {
        let v = e.vectors.column(j);
        let r = (&ac * v - v * e.values[j]).norm();
        // Balanced problem: the residual is eps times the balanced norm (~1), not ||A||.
        assert!(r < 1e-10, "column {j}: residual {r:e}");
    }
}

#[test]
fn eig_of_matrix_with_repeated_eigenvalue_and_known_vectors() {
    // diag(2, 2, 3) in a rotated basis: repeated eigenvalue, non-defective.
    let s = DMatrix::from_row_slice(3, 3, &[1.0, 2.0, 0.0, 0.0, 1.0, 1.0, 1.0, 0.0, 1.0]);
    let si = s.clone().try_inverse().unwrap();
    let a = &s * DMatrix::from_diagonal(&DVector::from_vec(vec![2.0, 2.0, 3.0])) * si;
    let e = eig(&a).unwrap();
    let r = residual(&a.map(|x| C64::new(x, 0.0)), &e);
    assert!(r < 1e-13, "residual {r:e}");
    let mut re: Vec<f64> = e.values.iter().map(|l| l.re).collect();
    re.sort_by(f64::total_cmp);
    for (g, w) in re.iter().zip([2.0, 2.0, 3.0]) {
        assert!((g - w).abs() < 1e-7, "{g} vs {w}");
    }
}

#[test]
fn leftover_two_by_two_block_is_triangularized() {
    let mut t = DMatrix::from_row_slice(
        3,
        3,
        &[
            C64::new(1.0, 0.5),
            C64::new(2.0, 0.0),
            C64::new(0.3, 0.1),
            C64::new(-1.5, 0.2),
            C64::new(0.5, -1.0),
            C64::new(0.0, 1.0),
            C64::new(0.0, 0.0),
            C64::new(0.0, 0.0),
            C64::new(4.0, 0.0),
        ],
    );
    let a = t.clone();
    let mut q = DMatrix::<C64>::identity(3, 3);
    triangularize_leftover_blocks(&mut t, &mut q);
    assert_eq!(t[(1, 0)], C64::new(0.0, 0.0));
    let recon = &q * &t * q.adjoint();
    assert!((recon - a).norm() < 1e-14 * t.norm());
}

#[test]
fn thin_svd_is_sorted_and_reconstructs() {
    let mut rng = ChaCha8Rng::seed_from_u64(13);
    for &(r, c) in &[(7usize, 3usize), (3, 7), (40, 40)] {
        let m = DMatrix::from_fn(r, c, |_, _| rng.random::<f64>() - 0.5);
        let svd = thin_svd(&m).unwrap();
        assert!(svd.s.as_slice().windows(2).all(|w| w[0] >= w[1]));
        let recon = &svd.u * DMatrix::from_diagonal(&svd.s) * svd.v.transpose();
        assert!((recon - &m).norm() < 1e-13 * m.norm());
    }
}

#[test]
fn thin_svd_of_exactly_rank_deficient_matrices_reconstructs() {
    // nalgebra 0.35's SVD alone failed on 423 of 2000 random 4 x 4 matrices of rank 1
    // (recomposition errors up to 2.4), 96 of rank 2 and 14 of 10 x 10 of rank 5; the
    // first matrix below is the real embedding of an exactly rank-one complex residue
    // (a random 2-DOF system, two references) on which it returned 67.301 for a double
    // singular value 67.240, so the FRF route's mode shapes and M, K were 4 % wrong.
    let embedded = DMatrix::from_row_slice(
        4,
        4,
        &[
            -1.7846245960713785,
            1.1262358172720224,
            -45.220893363064334,
            31.52187618003585,
            1.1262358172720186,
            -0.7029829557039018,
            31.52187618003585,
            -21.97247240317331,
            45.220893363064334,
            -31.52187618003585,
            -1.7846245960713785,
            1.1262358172720224,
            -31.52187618003585,
            21.97247240317331,
            1.1262358172720186,
            -0.7029829557039018,
        ],
    );
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let mut cases = vec![embedded];
    for &(rows, cols, rank) in &[(4, 4, 1), (4, 4, 2), (6, 4, 2), (4, 6, 2), (10, 10, 5)] {
        for _ in 0..200 {
            let a = DMatrix::from_fn(rows, rank, |_, _| rng.random::<f64>() - 0.5);
            let b = DMatrix::from_fn(rank, cols, |_, _| rng.random::<f64>() - 0.5);
            cases.push(a * b);
        }
    }
    let mut worst = (0.0f64, 0.0f64);
    for m in &cases {
        for svd in [
            thin_svd(m).unwrap(),
            jacobi_svd(m, m.nrows(), m.ncols()).unwrap(),
        ] {
            let k = m.nrows().min(m.ncols());
            assert!(svd.s.as_slice().windows(2).all(|w| w[0] >= w[1]));
            let recon = &svd.u * DMatrix::from_diagonal(&svd.s) * svd.v.transpose();
            let ortho = (svd.u.transpose() * &svd.u - DMatrix::identity(k, k))
                .norm()
                .max((svd.v.transpose() * &svd.v - DMatrix::identity(k, k)).norm());
            let err = (recon - m).norm() / m.norm();
            worst = (worst.0.max(err), worst.1.max(ortho));
        }
    }
    // Backward-stable factorizations: measured 7.9e-15 recomposition error (a 4 x 6
    // matrix nalgebra factored within the acceptance bound, 8.7e-15 there) and 5.4e-15
    // departure from orthonormality at worst; the failures were 1e-3 to 1.8.
    assert!(
        worst.0 < 2e-14 && worst.1 < 2e-14,
        "recomposition {:e}, orthonormality {:e}",
        worst.0,
        worst.1
    );
}

#[test]
fn truncated_least_squares_drops_null_directions() {
    // Two identical columns: the minimum-norm solution splits the weight equally.
    let a = DMatrix::from_row_slice(3, 2, &[1.0, 1.0, 2.0, 2.0, 3.0, 3.0]);
    let b = DMatrix::from_row_slice(3, 1, &[2.0, 4.0, 6.0]);
    let (x, k) = lstsq_truncated(&thin_svd(&a).unwrap(), &b, 1e-10);
    assert_eq!(k, 1);
    assert!((x[0] - 1.0).abs() < 1e-12 && (x[1] - 1.0).abs() < 1e-12);
}

#[test]
fn cholesky_reports_failing_pivot() {
    let spd = DMatrix::from_row_slice(2, 2, &[4.0, 2.0, 2.0, 3.0]);
    let l = cholesky(&spd).unwrap();
    assert!((&l * l.transpose() - &spd).norm() < 1e-14);
    let indefinite = DMatrix::from_row_slice(3, 3, &[4.0, 2.0, 0.0, 2.0, 1.0, 0.0, 0.0, 0.0, 1.0]);
    let (pivot, value) = cholesky(&indefinite).unwrap_err();
    assert_eq!(pivot, 1);
    assert!(value <= 0.0);
}

#[test]
fn non_finite_input_is_an_error() {
    let a = DMatrix::from_row_slice(2, 2, &[1.0, f64::NAN, 0.0, 1.0]);
    assert!(matches!(
        eig(&a),
        Err(LinalgError::NonFinite { row: 0, col: 1, .. })
    ));
    assert!(thin_svd(&a).is_err());
}

/// `thin_qr` reproduces the matrix with orthonormal `Q` and upper triangular `R`, also for
/// rank-deficient and zero columns.
#[test]
fn thin_qr_factors_tall_matrices() {
    let mut a = DMatrix::from_fn(37, 9, |i, j| {
        ((i * 7 + j * 13) % 11) as f64 - 5.0 + 0.1 * j as f64
    });
    // A repeated column and a zero column.
    let c = a.column(2).into_owned();
    a.set_column(5, &c);
    a.column_mut(7).fill(0.0);
    for m in [
        a.clone(),
        DMatrix::from_fn(6, 6, |i, j| 1.0 / (i + j + 1) as f64),
    ] {
        let (q, r) = thin_qr(&m);
        assert_eq!(
            (q.shape(), r.shape()),
            ((m.nrows(), m.ncols()), (m.ncols(), m.ncols()))
        );
        let scale = m.norm().max(1.0);
        // Round-off of Householder QR: a few eps times the norm (measured below 1e-14).
        assert!((&q * &r - &m).norm() <= 1e-13 * scale);
        let qtq = q.transpose() * &q;
        assert!((qtq - DMatrix::identity(m.ncols(), m.ncols())).norm() <= 1e-13);
        for j in 0..r.ncols() {
            for i in j + 1..r.nrows() {
                assert_eq!(r[(i, j)], 0.0);
            }
        }
    }
}

#[test]
fn spectral_radius_agrees_with_the_schur_eigenvalues() {
    let mut rng = ChaCha8Rng::seed_from_u64(21);
    for &n in &[1usize, 2, 3, 4, 5, 8, 20, 40, 60] {
        for _ in 0..4 {
            let a = random_real(&mut rng, n);
            let want = eigenvalues(&a)
                .unwrap()
                .iter()
                .map(|l| l.norm())
                .fold(0.0, f64::max);
            let got = spectral_radius(&a).unwrap();
            // Two backward-stable eigenvalue computations of the same balanced matrix
            // (nalgebra's Hessenberg reduction and Schur form against this module's):
            // they differ by round-off times the eigenvalue's condition (measured at most
            // 3.4e-14 relative for these sizes, at n = 60; 2e-15 when both reductions were
            // nalgebra's).
            assert!(
                (got - want).abs() <= 1e-12 * want,
                "n = {n}: {got} against {want}"
            );
        }
    }
    assert_eq!(spectral_radius(&DMatrix::zeros(0, 0)).unwrap(), 0.0);
    assert_eq!(spectral_radius(&DMatrix::zeros(5, 5)).unwrap(), 0.0);
}

/// The oracle of `reduce_to_hessenberg`: nalgebra's Householder reduction. Both start the
/// orthogonal factor with `e1`, so by the implicit Q theorem the two Hessenberg forms of a
/// matrix with nonzero subdiagonal agree up to the signs `D H D` (`D` diagonal, entries +-1):
/// their entries agree in magnitude.
#[test]
fn hessenberg_reduction_matches_nalgebra_up_to_signs() {
    let mut rng = ChaCha8Rng::seed_from_u64(23);
    // Random matrices, and a block companion matrix with its structural zeros (columns
    // already reduced take no reflection).
    let mut cases: Vec<DMatrix<f64>> = [1usize, 2, 3, 4, 7, 20, 60]
        .iter()
        .map(|&n| random_real(&mut rng, n))
        .collect();
    let (m, p) = (3, 20);
    let mut c = DMatrix::zeros(m * p, m * p);
    for j in 0..m * p {
        for i in 0..m {
            c[(i, j)] = rng.random::<f64>() - 0.5;
        }
    }
    for i in m..m * p {
        c[(i, i - m)] = 1.0;
    }
    cases.push(c);
    for a in cases {
        let n = a.nrows();
        let mut got = a.clone();
        reduce_to_hessenberg(got.as_mut_slice(), n);
        let want = if n > 2 {
            nalgebra::linalg::Hessenberg::new(a.clone()).unpack_h()
        } else {
            a.clone()
        };
        for j in 0..n {
            for i in j + 2..n {
                assert_eq!(
                    got[(i, j)],
                    0.0,
                    "n = {n}: ({i}, {j}) below the subdiagonal"
                );
            }
        }
        // Two backward-stable reductions: entries agree to round-off of the matrix norm
        // (a few hundred eps for n = 60: each entry is the sum of about n^2 rounded
        // products; measured at most 7.3e-15 relative to the norm, at n = 60).
        let scale = a.norm();
        for j in 0..n {
            for i in 0..n.min(j + 2) {
                let (g, w) = (got[(i, j)], want[(i, j)]);
                assert!(
                    (g.abs() - w.abs()).abs() <= 1e-12 * scale,
                    "n = {n}: ({i}, {j}) is {g}, nalgebra's {w}"
                );
            }
        }
    }
}

#[test]
fn spectral_radius_of_block_companion_matrices_with_known_roots() {
    // y[n] = sum_i b_i y[n-i] with scalar (diagonal 2 x 2) b_i: the roots of each channel's
    // polynomial are the eigenvalues. Channel 1: 0.99 e^(+-0.3 j), 0.5, -0.2;
    // channel 2: 0.95 e^(+-1.2 j), 0.7 e^(+-2.5 j).
    let poly = |roots: &[C64]| -> Vec<f64> {
        let mut c = vec![C64::new(1.0, 0.0)];
        for &z in roots {
            let mut next = vec![C64::new(0.0, 0.0); c.len() + 1];
            for (i, &v) in c.iter().enumerate() {
                next[i] += v;
                next[i + 1] -= v * z;
            }
            c = next;
        }
        c.iter().map(|v| v.re).collect()
    };
    let one = poly(&[
        C64::from_polar(0.99, 0.3),
        C64::from_polar(0.99, -0.3),
        C64::new(0.5, 0.0),
        C64::new(-0.2, 0.0),
    ]);
    let two = poly(&[
        C64::from_polar(0.95, 1.2),
        C64::from_polar(0.95, -1.2),
        C64::from_polar(0.7, 2.5),
        C64::from_polar(0.7, -2.5),
    ]);
    let p = 4;
    let m = 2;
    let mut c = DMatrix::zeros(m * p, m * p);
    for i in 0..p {
        c[(0, i * m)] = -one[i + 1];
        c[(1, i * m + 1)] = -two[i + 1];
    }
    for i in 1..p {
        for j in 0..m {
            c[(i * m + j, (i - 1) * m + j)] = 1.0;
        }
    }
    let got = spectral_radius(&c).unwrap();
    // Well-separated roots of a degree-4 polynomial: round-off of order 1e-15.
    assert!((got - 0.99).abs() < 1e-12, "{got}");
}

/// Random orthogonal factors, 90 x 90 and 84 x 84 (seed 5), of the ERA-like test matrices.
fn era_like_factors() -> (DMatrix<f64>, DMatrix<f64>) {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let mut orth = |n: usize| {
        let g = DMatrix::from_fn(n, n, |_, _| rng.random::<f64>() - 0.5);
        thin_qr(&g).0
    };
    let u = orth(90);
    (u, orth(84))
}

/// Singular values as ERA's Hankel matrices have them: three close pairs (structural modes,
/// 1e0 to 1e-2 of the largest) over a noise floor falling from 1e-4 of it; `n` in all.
fn era_like_values(n: usize) -> Vec<f64> {
    let mut s = vec![100.0, 99.99, 10.0, 9.999, 1.0, 0.9999];
    s.extend((0..n - 6).map(|i| 1e-2 * 0.95f64.powi(i as i32)));
    s
}

/// `u diag(s) v^T` with the first `s.len()` columns of `u`.
fn with_values(u: &DMatrix<f64>, v: &DMatrix<f64>, s: &[f64]) -> DMatrix<f64> {
    u.columns(0, s.len()) * DMatrix::from_diagonal(&DVector::from_row_slice(s)) * v.transpose()
}

#[test]
fn leading_svd_matches_the_full_svd_on_an_era_like_spectrum() {
    // Known singular values as ERA's Hankel matrices have them (`era_like_values`),
    // random orthogonal factors. The leading vectors must
    // agree with the full SVD's up to sign: within the pair's conditioning,
    // residual 1e-13 s_1 over the 1e-4 relative gap inside a pair gives 1e-9,
    // so 1e-8 is the tolerance (measured: 1.8e-11 for the weakest pair, 4e-13
    // for the strongest; values within 4e-16 of s_1).
    let (u, v) = era_like_factors();
    let (rows, cols) = (u.nrows(), v.nrows());
    let s = era_like_values(cols);
    let m = with_values(&u, &v, &s);
    let full = thin_svd(&m).unwrap();
    for k in [2, 4, 6] {
        let lead = leading_svd(&m, k)
            .unwrap()
            .expect("converges on a clear gap");
        assert_eq!(lead.s, singular_values(&m).unwrap());
        assert_eq!((lead.u.shape(), lead.v.shape()), ((rows, k), (cols, k)));
        for i in 0..k {
            // Values: to 1e-12 relative of s_1 (both from SVDs of m).
            assert!((lead.s[i] - s[i]).abs() < 1e-12 * s[0], "{k} {i}");
            let sign = lead.u.column(i).dot(&full.u.column(i)).signum();
            let du = (lead.u.column(i) * sign - full.u.column(i)).norm();
            let dv = (lead.v.column(i) * sign - full.v.column(i)).norm();
            assert!(du < 1e-8 && dv < 1e-8, "k {k} vector {i}: {du:e} {dv:e}");
        }
    }
    // An elongated matrix (values from its triangular factor): a 90 x 36 and a 36 x 90
    // block of `m`, values to 1e-13 of the largest, vectors up to sign to 1e-8.
    for tall in [m.columns(0, 36).into_owned(), m.columns(0, 36).transpose()] {
        let full = thin_svd(&tall).unwrap();
        let lead = leading_svd(&tall, 4).unwrap().expect("converges");
        assert!((&lead.s - &full.s).amax() < 1e-13 * full.s[0]);
        for i in 0..4 {
            let sign = lead.u.column(i).dot(&full.u.column(i)).signum();
            assert!((lead.u.column(i) * sign - full.u.column(i)).norm() < 1e-8);
            assert!((lead.v.column(i) * sign - full.v.column(i)).norm() < 1e-8);
        }
    }
    // Too many vectors for the shortcut, and a zero matrix: the caller's full SVD.
    assert!(leading_svd(&m, 40).unwrap().is_none());
    assert!(leading_svd(&DMatrix::zeros(30, 30), 2).unwrap().is_none());
}

#[test]
fn leading_svd_without_a_gap_gives_up() {
    // A slowly decaying spectrum (ratio 0.999 per value, no gap after the
    // second): the block of 10 converges at (s_11 / s_2)^2 = 0.999^18 per
    // iteration, so 30 iterations leave the residual near 0.58 of its start.
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let n = 60;
    let g = DMatrix::from_fn(n, n, |_, _| rng.random::<f64>() - 0.5);
    let q = thin_qr(&g).0;
    let s = DVector::from_fn(n, |i, _| 0.999f64.powi(i as i32));
    let m = &q * DMatrix::from_diagonal(&s) * q.transpose();
    assert!(leading_svd(&m, 2).unwrap().is_none());
}

#[test]
fn certified_leading_svd_matches_the_full_svd_without_the_values() {
    // The ERA-like spectrum of `leading_svd_matches_the_full_svd_on_an_era_like_spectrum`:
    // three close pairs over a noise floor. The certificate holds (the energy past the
    // k-th value is at most 0.15 of it: 14.2 against 99.99 for k = 2); values within
    // sqrt(k) tol = sqrt(6) 64 eps sqrt(90) 100 (4e-11) of the SVD's (measured: within
    // 1.0e-15 of s_1 = 100), vectors up to sign as in that test.
    let (u, v) = era_like_factors();
    let (rows, cols) = (u.nrows(), v.nrows());
    let s = era_like_values(cols);
    let m = with_values(&u, &v, &s);
    let full = thin_svd(&m).unwrap();
    for k in [2, 4, 6] {
        let lead = leading_svd_certified(&m, k).unwrap().expect("certified");
        // The block's values only (the full list would mean the fallback ran).
        assert_eq!(lead.s.len(), k + LEADING_OVERSAMPLE);
        let tol = (k as f64).sqrt() * 64.0 * f64::EPSILON * (rows as f64).sqrt() * s[0];
        for i in 0..k {
            assert!((lead.s[i] - full.s[i]).abs() <= tol, "{k} {i}");
            let sign = lead.u.column(i).dot(&full.u.column(i)).signum();
            let du = (lead.u.column(i) * sign - full.u.column(i)).norm();
            let dv = (lead.v.column(i) * sign - full.v.column(i)).norm();
            assert!(du < 1e-8 && dv < 1e-8, "k {k} vector {i}: {du:e} {dv:e}");
        }
        // Past `k`, Ritz values: lower bounds of the singular values (up to round-off).
        for i in k..lead.s.len() {
            assert!(lead.s[i] <= full.s[i] * (1.0 + 1e-12), "{k} {i}");
        }
    }
    // A heavy tail: two pairs (100, 10) over 80 values of 2.0. The gap after the fourth
    // value (a factor 5) lets the iteration converge, but the tail's energy (sqrt(80) 2 =
    // 17.9) exceeds the fourth value: no certificate, and the result is `leading_svd`'s,
    // all values included.
    let mut heavy = vec![100.0, 99.99, 10.0, 9.999];
    heavy.extend(std::iter::repeat_n(2.0, cols - 4));
    let m2 = with_values(&u, &v, &heavy);
    let a = leading_svd_certified(&m2, 4).unwrap().expect("converges");
    let b = leading_svd(&m2, 4).unwrap().expect("converges");
    assert_eq!(a.s.len(), cols);
    assert_eq!((a.s, a.u, a.v), (b.s, b.u, b.v));
}

#[test]
fn certified_leading_svd_does_not_accept_a_missed_direction() {
    // The start block (the rows of largest norm) spans exactly the right singular vectors
    // of values 0.5 .. 0.41 (one row each), and the largest singular value (1.0) lives on
    // 40 other rows of norm 1/sqrt(40) = 0.16 each, orthogonal to the block: the iteration
    // converges at once to accurate triplets that are not the leading ones. The energy
    // left outside (at least 1.0) exceeds the Ritz values, so the certificate refuses; the
    // fallback (`leading_svd`, whose Ritz values never meet the true values) gives up and
    // the caller would take the full SVD.
    let (rows, cols) = (60, 60);
    let mut m = DMatrix::zeros(rows, cols);
    for j in 0..10 {
        m[(j, j)] = 0.5 - 0.01 * j as f64;
    }
    for i in 10..50 {
        m[(i, 59)] = 1.0 / 40f64.sqrt();
    }
    for j in 10..19 {
        m[(j + 40, j)] = 0.01;
    }
    let top = thin_svd(&m).unwrap().s[0];
    assert!((top - 1.0).abs() < 1e-12);
    match leading_svd_certified(&m, 2).unwrap() {
        None => {}
        Some(svd) => assert!((svd.s[0] - top).abs() < 1e-10, "{}", svd.s[0]),
    }
}

/// The naive oracle of `cross_products`: each product summed alone over its lanes (elements
/// `l mod 2` up to the last whole pair), then the odd element, in the documented order.
fn cross_product_oracle(a: &[f64], b: &[f64]) -> f64 {
    let whole = a.len() - a.len() % 2;
    let lane = |k: usize| (k..whole).step_by(2).fold(0.0, |s, l| s + a[l] * b[l]);
    let tail = (whole..a.len()).fold(0.0, |s, l| s + a[l] * b[l]);
    lane(0) + lane(1) + tail
}

#[test]
fn cross_products_match_the_naive_sums_bit_for_bit_for_every_tile_shape() {
    let mut rng = ChaCha8Rng::seed_from_u64(41);
    // Widths 1 to 9 and 1 to 6 take every tile (2 x 4 down to 1 x 1) and their remainders;
    // lengths 0, 1 and odd ones take the empty pass and the tail.
    for len in [0, 1, 2, 7, 64, 257] {
        for na in 1..=9 {
            for nb in 1..=6 {
                let cols = |n: usize, rng: &mut ChaCha8Rng| -> Vec<Vec<f64>> {
                    (0..n)
                        .map(|_| (0..len).map(|_| rng.random_range(-1.0..1.0)).collect())
                        .collect()
                };
                let (a, b) = (cols(na, &mut rng), cols(nb, &mut rng));
                let ar: Vec<&[f64]> = a.iter().map(|c| c.as_slice()).collect();
                let br: Vec<&[f64]> = b.iter().map(|c| c.as_slice()).collect();
                let mut out = vec![f64::NAN; na * nb];
                cross_products(&ar, &br, &mut out);
                for p in 0..na {
                    for q in 0..nb {
                        // The same sums in the same order: equal bit for bit.
                        assert_eq!(
                            out[p * nb + q].to_bits(),
                            cross_product_oracle(&a[p], &b[q]).to_bits(),
                            "len {len}, {na} x {nb}, entry ({p}, {q})"
                        );
                    }
                }
            }
        }
    }
}

/// The AVX tile (two columns of `b` per vector) gives the SSE2 tile's sums bit for bit: the
/// same lanes, products and order. (The oracle test above checks whichever kernel the build
/// uses; this one checks the other against it in an AVX build.)
#[cfg(all(target_arch = "x86_64", target_feature = "avx"))]
#[test]
fn the_avx_tile_gives_the_sse2_tile_s_sums_bit_for_bit() {
    let mut rng = ChaCha8Rng::seed_from_u64(43);
    for groups in [0, 1, 5, 128] {
        let col = |rng: &mut ChaCha8Rng| -> Vec<[f64; TILE_ROWS]> {
            (0..groups)
                .map(|_| [rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0)])
                .collect()
        };
        let a: Vec<Vec<[f64; TILE_ROWS]>> = (0..2).map(|_| col(&mut rng)).collect();
        let b: Vec<Vec<[f64; TILE_ROWS]>> = (0..4).map(|_| col(&mut rng)).collect();
        let ar: [&[[f64; TILE_ROWS]]; 2] = std::array::from_fn(|i| a[i].as_slice());
        let br: [&[[f64; TILE_ROWS]]; 4] = std::array::from_fn(|j| b[j].as_slice());
        // SAFETY: this test is built only with AVX enabled; SSE2 is in the x86-64 baseline.
        let (avx, sse2) = unsafe { (tile_sums_avx(&ar, &br), tile_sums_sse2(&ar, &br)) };
        let bits = |t: [[[f64; TILE_ROWS]; 4]; 2]| t.map(|r| r.map(|l| l.map(f64::to_bits)));
        assert_eq!(bits(avx), bits(sse2), "{groups} row groups");
        let br2: [&[[f64; TILE_ROWS]]; 2] = [br[0], br[1]];
        // SAFETY: as above.
        let (avx, sse2) = unsafe { (tile_sums_avx(&ar, &br2), tile_sums_sse2(&ar, &br2)) };
        assert_eq!(
            avx.map(|r| r.map(|l| l.map(f64::to_bits))),
            sse2.map(|r| r.map(|l| l.map(f64::to_bits))),
            "{groups} row groups, two columns"
        );
    }
}

/// The values-only right SVD gives the singular values of [`right_svd`] and those of the
/// plain SVD to round-off: wide matrices (the reflected form), tall and square ones (the
/// direct form), full rank and of rank 3.
#[test]
fn right_singular_values_are_those_of_the_right_svd() {
    let mut rng = ChaCha8Rng::seed_from_u64(41);
    let low_rank = |rng: &mut ChaCha8Rng, rows: usize, cols: usize| {
        let a = DMatrix::from_fn(rows, 3, |_, _| rng.random::<f64>() - 0.5);
        let b = DMatrix::from_fn(3, cols, |_, _| rng.random::<f64>() - 0.5);
        a * b
    };
    let mut cases = Vec::new();
    for &(rows, cols) in &[(42, 126), (5, 40), (12, 12), (30, 8), (1, 9)] {
        cases.push(DMatrix::from_fn(rows, cols, |_, _| {
            rng.random::<f64>() - 0.5
        }));
        cases.push(low_rank(&mut rng, rows, cols));
    }
    for m in &cases {
        let want = right_svd(m).unwrap().s;
        let got = right_singular_values(m).unwrap();
        let plain = singular_values(m).unwrap();
        assert_eq!(got.len(), want.len(), "{:?}", m.shape());
        // Backward-stable SVDs of the same matrix: each value within a few eps of the
        // largest (measured at most 3.1e-15 relative to it); 1e-12 fails any wrong value.
        for ((a, b), c) in got.iter().zip(want.iter()).zip(plain.iter()) {
            assert!(
                (a - b).abs() <= 1e-12 * want[0],
                "{:?}: {a} against {b}",
                m.shape()
            );
            assert!(
                (a - c).abs() <= 1e-12 * want[0],
                "{:?}: {a} against {c}",
                m.shape()
            );
        }
    }
}

/// An ad hoc (exceptional) shift taken while the active block is split from the rows above
/// it must shift the whole unreduced matrix, as the shift's sum is added to every eigenvalue
/// found after it. Here a 3 x 3 upper triangular block (eigenvalues 5, 6, 7) sits above a
/// 4 x 4 cyclic permutation plus 0.5 (eigenvalues 0.5 + the fourth roots of unity), exactly
/// split from it: the trailing block stalls under the standard shifts (both at 0.5, where
/// it is orthogonal), so the iteration takes ad hoc shifts of 0.5 with the active block
/// starting at row 3. Shifting that block alone put the upper block's eigenvalues at 5.5,
/// 6.5 and 7.5 (spectral radius 7.5).
#[test]
fn ad_hoc_shifts_move_the_rows_above_the_active_block_too() {
    let n = 7;
    let mut h = DMatrix::<f64>::zeros(n, n);
    for (i, v) in [5.0, 6.0, 7.0].into_iter().enumerate() {
        h[(i, i)] = v;
    }
    h[(0, 1)] = 1.0;
    h[(0, 2)] = 2.0;
    h[(1, 2)] = 3.0;
    // Coupling above the split: the spectrum does not depend on it.
    for j in 3..n {
        h[(0, j)] = 0.25 * j as f64;
        h[(2, j)] = -0.5;
    }
    for i in 3..n {
        h[(i, i)] = 0.5;
    }
    for i in 4..n {
        h[(i, i - 1)] = 1.0;
    }
    h[(3, n - 1)] = 1.0;
    let mut values = {
        let mut work = h.clone();
        hessenberg_eigenvalues(&mut work, iteration_budget(n)).unwrap()
    };
    values.sort_by(|a, b| a.re.total_cmp(&b.re).then(a.im.total_cmp(&b.im)));
    let mut want = vec![
        C64::new(-0.5, 0.0),
        C64::new(0.5, -1.0),
        C64::new(0.5, 1.0),
        C64::new(1.5, 0.0),
        C64::new(5.0, 0.0),
        C64::new(6.0, 0.0),
        C64::new(7.0, 0.0),
    ];
    want.sort_by(|a, b| a.re.total_cmp(&b.re).then(a.im.total_cmp(&b.im)));
    for (got, want) in values.iter().zip(&want) {
        // Eigenvalues of a matrix with entries of order 1 to 7, well separated and
        // well conditioned: round-off of a few eps times the norm (1e-12 fails a shift of
        // 0.5 by far).
        assert!((got - want).norm() < 1e-12, "{values:?}");
    }
    assert!((spectral_radius(&h).unwrap() - 7.0).abs() < 1e-12);
}

/// Hessenberg matrices made of diagonal blocks exactly split from each other (zero
/// subdiagonal between blocks, random coupling above), with blocks that stall the standard
/// shifts (cyclic permutations plus a shift: orthogonal after the shift, eigenvalues on a
/// circle), random dense Hessenberg blocks and companion matrices of polynomials with known
/// roots. The eigenvalues are the blocks' own: in closed form for the first two kinds,
/// nalgebra's Schur form of the block alone for the random ones (nalgebra's Schur form of
/// the whole matrix does not converge on the stalling blocks, having no ad hoc shifts).
/// Every eigenvalue of `hessenberg_eigenvalues` must match one of them, one to one,
/// whatever the order in which blocks deflate and ad hoc shifts occur.
#[test]
fn hessenberg_eigenvalues_of_split_and_stalling_blocks_are_the_blocks_own() {
    let mut rng = ChaCha8Rng::seed_from_u64(43);
    let mut uniform = |lo: f64, hi: f64| lo + (hi - lo) * rng.random::<f64>();
    for case in 0..60 {
        let mut blocks: Vec<DMatrix<f64>> = Vec::new();
        let mut want: Vec<C64> = Vec::new();
        let count = 2 + case % 4;
        for b in 0..count {
            let kind = (case + b) % 3;
            let k = 2 + ((case * 7 + b * 3) % 5);
            let block =
                match kind {
                    0 => {
                        // Cyclic permutation plus a shift: eigenvalues c + the k-th roots of unity.
                        let c = uniform(-2.0, 2.0);
                        let mut m = DMatrix::from_element(k, k, 0.0);
                        for i in 0..k {
                            m[(i, i)] = c;
                        }
                        for i in 1..k {
                            m[(i, i - 1)] = 1.0;
                        }
                        m[(0, k - 1)] += 1.0;
                        want.extend((0..k).map(|j| {
                            C64::new(c, 0.0)
                                + C64::from_polar(
                                    1.0,
                                    2.0 * std::f64::consts::PI * j as f64 / k as f64,
                                )
                        }));
                        m
                    }
                    1 => {
                        let m = DMatrix::from_fn(k, k, |i, j| {
                            if i <= j + 1 { uniform(-1.0, 1.0) } else { 0.0 }
                        });
                        want.extend(eigenvalues(&m).unwrap().iter());
                        m
                    }
                    _ => {
                        // Companion (first row) of a real polynomial with roots on a circle.
                        let radius = uniform(0.3, 1.5);
                        let mut roots: Vec<C64> = Vec::new();
                        while roots.len() + 1 < k {
                            let theta = uniform(0.2, 2.9);
                            roots.push(C64::from_polar(radius, theta));
                            roots.push(C64::from_polar(radius, -theta));
                        }
                        if roots.len() < k {
                            roots.push(C64::new(uniform(-radius, radius), 0.0));
                        }
                        let mut poly = vec![C64::new(1.0, 0.0)];
                        for r in &roots {
                            let mut next = vec![C64::new(0.0, 0.0); poly.len() + 1];
                            for (i, &c) in poly.iter().enumerate() {
                                next[i] += c;
                                next[i + 1] -= c * r;
                            }
                            poly = next;
                        }
                        want.extend(roots.iter());
                        let mut m = DMatrix::from_element(k, k, 0.0);
                        for j in 0..k {
                            m[(0, j)] = -poly[j + 1].re;
                        }
                        for i in 1..k {
                            m[(i, i - 1)] = 1.0;
                        }
                        m
                    }
                };
            blocks.push(block);
        }
        let n: usize = blocks.iter().map(|b| b.nrows()).sum();
        let mut h = DMatrix::<f64>::zeros(n, n);
        let mut at = 0;
        for b in &blocks {
            let k = b.nrows();
            h.view_mut((at, at), (k, k)).copy_from(b);
            for i in 0..at {
                for j in at..at + k {
                    h[(i, j)] = uniform(-1.0, 1.0);
                }
            }
            at += k;
        }
        let got = hessenberg_eigenvalues(&mut h.clone(), iteration_budget(n)).unwrap();
        let scale = h.norm();
        let mut used = vec![false; n];
        for g in &got {
            let (best, dist) = (0..n)
                .filter(|&i| !used[i])
                .map(|i| (i, (want[i] - g).norm()))
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .unwrap();
            used[best] = true;
            // Backward-stable computations of well-separated, well-conditioned
            // eigenvalues (the companion blocks are small, of degree at most six):
            // round-off times the norm and the condition (measured at most 7.1e-14 of the
            // norm); an eigenvalue moved by a misapplied shift is far outside (0.32 of it
            // in case 1 before the fix of the ad hoc shifts).
            assert!(
                dist <= 1e-8 * scale,
                "case {case}: {g} is {dist:e} from the nearest block eigenvalue\n{got:?}\n{want:?}"
            );
        }
    }
}

/// Householder reflections of columns whose squares underflow (entries below `1e-162`) or
/// overflow (above `1e154`) are formed from the column scaled by a power of two. Before
/// that, `reduce_to_hessenberg` of a matrix with only `1e-170` below the subdiagonal of a
/// column computed a zero norm, `beta = 2 / 0` and a matrix of NaNs (`spectral_radius`
/// of the 3 x 3 case below reported `NoConvergence`; its radius is 0.5), and `thin_qr` /
/// `thin_svd` of a tall matrix scaled by `1e-160` failed the same way; `right_svd` of a wide
/// matrix scaled by `1e-170` or `1e160` (a Frobenius norm of 0 or infinity as its round-off
/// threshold) returned all singular values zero.
#[test]
fn reflections_of_columns_whose_squares_underflow_or_overflow() {
    // Row 0 has no off-diagonal entry (balancing cannot scale the column up): the
    // eigenvalues are 0.5 and those of [[0.2, 0.3], [-0.4, 0.1]], of modulus sqrt(0.14).
    for tiny in [1e-170, 1e-200, 5e-324] {
        let a = DMatrix::from_row_slice(3, 3, &[0.5, 0.0, 0.0, tiny, 0.2, 0.3, tiny, -0.4, 0.1]);
        let mut h = a.clone();
        reduce_to_hessenberg(h.as_mut_slice(), 3);
        assert!(first_non_finite(&h).is_none(), "{tiny:e}: {h}");
        let rho = spectral_radius(&a).unwrap();
        // Round-off of the QR iteration on a matrix of norm 0.8 (measured: exactly 0.5).
        assert!((rho - 0.5).abs() < 1e-14, "{tiny:e}: {rho}");
        // The reduced matrix keeps the eigenvalues (a similarity): its trailing block's
        // determinant is 0.14 and trace 0.3 (rounding only, measured within 1.2e-16).
        let det = h[(1, 1)] * h[(2, 2)] - h[(1, 2)] * h[(2, 1)];
        let trace = h[(1, 1)] + h[(2, 2)];
        assert!((det - 0.14).abs() < 1e-15 && (trace - 0.3).abs() < 1e-15);
    }
    let mut rng = ChaCha8Rng::seed_from_u64(47);
    let tall = DMatrix::from_fn(10, 3, |_, _| rng.random::<f64>() - 0.5);
    let want = singular_values(&tall).unwrap();
    let mut worst = 0.0f64;
    for scale in [1e-300, 1e-170, 1e-160, 1e160, 1e300] {
        // `scale` is decimal: the scaled matrix carries its own rounding, 1 ulp an entry.
        let m = &tall * scale;
        let (q, r) = thin_qr(&m);
        let qr = (&q * (&r / scale) - &tall).norm() / tall.norm();
        let orth = (q.transpose() * &q - DMatrix::identity(3, 3)).norm();
        let svd = thin_svd(&m).unwrap();
        let right = right_svd(&m.transpose()).unwrap();
        let values = right_singular_values(&m.transpose()).unwrap();
        let v = right.v_columns(3);
        let v_orth = (v.transpose() * &v - DMatrix::identity(3, 3)).norm();
        for (name, got) in [
            ("thin_svd", &svd.s),
            ("right_svd", &right.s),
            ("values", &values),
        ] {
            let e = (got / scale - &want).amax() / want[0];
            worst = worst.max(e);
            // Backward-stable SVDs of matrices one rounding apart: a few eps of the
            // largest value (measured at most 6.4e-16); a lost column gives order one.
            assert!(
                e < 1e-13,
                "{scale:e} {name}: {:?} against {want:?}",
                got / scale
            );
        }
        // Householder round-off (measured at most 1.3e-15).
        assert!(
            qr < 1e-14 && orth < 1e-14 && v_orth < 1e-14,
            "{scale:e}: qr {qr:e}, orth {orth:e}, v {v_orth:e}"
        );
    }
    eprintln!("worst relative value error: {worst:e}");
}

/// `right_svd` of wide matrices of exact rank `r` below their row count: the reduction of
/// `M^T` stops early (columns below `eps |M|_F`) or meets exactly zero columns (zero rows
/// of `M`), and `v_columns(rank)` must still be orthonormal, span the row space
/// (`M V V^T = M`), and be right singular vectors (`|M v_i| = s_i`); the values must be
/// the plain SVD's, the dropped ones zero.
#[test]
fn right_svd_vectors_of_exactly_low_rank_wide_matrices() {
    let mut rng = ChaCha8Rng::seed_from_u64(53);
    let mut cases: Vec<(DMatrix<f64>, usize)> = Vec::new();
    for &(rows, cols, r) in &[
        (12usize, 60usize, 3usize),
        (20, 40, 1),
        (8, 16, 4),
        (30, 90, 12),
    ] {
        let a = DMatrix::from_fn(rows, r, |_, _| rng.random::<f64>() - 0.5);
        let b = DMatrix::from_fn(r, cols, |_, _| rng.random::<f64>() - 0.5);
        let mut m = a * b;
        cases.push((m.clone(), r));
        // Exactly zero rows in the middle (zero columns of M^T between nonzero ones).
        for i in [1, rows / 2] {
            m.row_mut(i).fill(0.0);
        }
        cases.push((m.clone(), r));
        // Rows repeated exactly.
        let first = m.row(0).into_owned();
        m.set_row(rows - 1, &first);
        m.set_row(rows - 2, &first);
        cases.push((m, r));
    }
    // Exactly representable rank one (every row a multiple of one row by a power of two),
    // and the zero matrix.
    cases.push((
        DMatrix::from_fn(6, 18, |i, j| (j as f64 - 8.0) * 2f64.powi(i as i32 - 3)),
        1,
    ));
    cases.push((DMatrix::zeros(5, 20), 0));
    let mut worst = (0.0f64, 0.0f64, 0.0f64);
    for (m, r) in &cases {
        let (rows, cols) = m.shape();
        let svd = right_svd(m).unwrap();
        let plain = singular_values(m).unwrap();
        let norm = m.norm();
        let tol = f64::EPSILON * rows.max(cols) as f64;
        // The rank the ERA caller takes, and the early stop it relies on.
        assert_eq!(
            svd.rank(tol),
            *r,
            "{rows} x {cols}: values {:?}",
            svd.s.as_slice()
        );
        if let RightForm::Reflected { q, .. } = &svd.form {
            assert!(q.steps() < rows, "{rows} x {cols}, rank {r}: no early stop");
        }
        for (a, b) in svd.s.iter().zip(plain.iter()) {
            // A few eps of the largest (measured at most 2.3e-15 of it): round-off of
            // two backward-stable SVDs; the values dropped at the early stop are 0 and the
            // plain SVD's below eps |M|.
            let e = (a - b).abs() / plain[0].max(f64::MIN_POSITIVE);
            worst.0 = worst.0.max(e);
            assert!(e < 1e-13, "{rows} x {cols}: {a} against {b}");
        }
        let v = svd.v_columns(*r);
        assert_eq!(v.shape(), (cols, *r));
        let orth = (v.transpose() * &v - DMatrix::identity(*r, *r)).norm();
        let span = if *r == 0 {
            0.0
        } else {
            (m - m * &v * v.transpose()).norm() / norm
        };
        worst.1 = worst.1.max(orth);
        worst.2 = worst.2.max(span);
        // Householder and SVD round-off: measured at most 4.6e-15 (orthonormality) and
        // 1.4e-15 (row space, relative to |M|); a vector outside the row space or two
        // equal vectors give order one.
        assert!(orth < 1e-13, "{rows} x {cols}: V^T V - I = {orth:e}");
        assert!(
            span < 1e-13,
            "{rows} x {cols}: M - M V V^T = {span:e} of |M|"
        );
        for i in 0..*r {
            let mv = (m * v.column(i)).norm();
            assert!(
                (mv - svd.s[i]).abs() < 1e-13 * svd.s[0],
                "{rows} x {cols}: |M v_{i}| = {mv}, s_{i} = {}",
                svd.s[i]
            );
        }
    }
    eprintln!(
        "worst: values {:e}, orthonormality {:e}, span {:e}",
        worst.0, worst.1, worst.2
    );
}

/// Block upper triangular matrices `[[A11, A12], [0, A22]]` (a random row permutation of
/// neither: the structure itself): the Hessenberg reduction meets, at column `n1 - 1`, a
/// column already zero below the subdiagonal and takes no reflection there, with
/// reflections before and after it; the eigenvalues of the reduced matrix must be those of
/// the two blocks (nalgebra's Schur form of each block alone), one to one.
#[test]
fn hessenberg_reduction_across_an_exact_block_split() {
    let mut rng = ChaCha8Rng::seed_from_u64(59);
    let mut worst = 0.0f64;
    for &(n1, n2) in &[(3usize, 4usize), (5, 2), (2, 6), (6, 6), (1, 5), (4, 1)] {
        let n = n1 + n2;
        let mut a = random_real(&mut rng, n);
        for j in 0..n1 {
            for i in n1..n {
                a[(i, j)] = 0.0;
            }
        }
        let mut want: Vec<C64> = Vec::new();
        for (lo, len) in [(0, n1), (n1, n2)] {
            let block = a.view((lo, lo), (len, len)).into_owned();
            want.extend(Schur::new(block).complex_eigenvalues().iter().copied());
        }
        let mut h = a.clone();
        reduce_to_hessenberg(h.as_mut_slice(), n);
        if n1 >= 1 && n1 < n {
            // The split survives the reduction exactly.
            assert_eq!(h[(n1, n1 - 1)], 0.0, "{n1} + {n2}");
        }
        let got = hessenberg_eigenvalues(&mut h, iteration_budget(n)).expect("converges");
        let mut left = want.clone();
        for g in &got {
            let (idx, e) = left
                .iter()
                .enumerate()
                .map(|(i, w)| (i, (g - w).norm()))
                .min_by(|x, y| x.1.total_cmp(&y.1))
                .expect("one each");
            worst = worst.max(e / a.norm());
            // Eigenvalues of random blocks of norm about 2: round-off times a condition
            // number of order one (measured within 1.4e-15 of the norm); 1e-10 allows a
            // condition number near 1e5, a wrong block gives order one.
            assert!(e < 1e-10 * a.norm(), "{n1} + {n2}: {g} off by {e:e}");
            left.swap_remove(idx);
        }
    }
    eprintln!("worst eigenvalue error over the norm: {worst:e}");
}

/// `leading_svd` and `leading_svd_certified` with a cluster of equal leading values and the
/// gap exactly at `k` (`k` = 3: the whole cluster), or inside the cluster (`k` = 2 of 3
/// equal values: no gap at `k`, the vectors are any two of the cluster's span). Either
/// `None`, or triplets with small residuals, orthonormal vectors, the true values, and
/// vectors inside the true leading space (the cluster's span when `k` cuts it).
#[test]
fn leading_svd_with_a_cluster_at_the_top_is_right_or_absent() {
    let (u, v) = era_like_factors();
    let cols = v.nrows();
    let mut worst = 0.0f64;
    for (name, head) in [
        ("equal", vec![5.0, 5.0, 5.0]),
        ("close", vec![5.0, 5.0 * (1.0 - 1e-12), 5.0 * (1.0 - 2e-12)]),
    ] {
        let mut s = head.clone();
        s.extend((0..cols - 3).map(|i| 0.5 * 0.9f64.powi(i as i32)));
        let m = with_values(&u, &v, &s);
        for k in [1, 2, 3, 4] {
            for (which, result) in [
                ("leading_svd", leading_svd(&m, k).unwrap()),
                ("certified", leading_svd_certified(&m, k).unwrap()),
            ] {
                // Measured: all 16 calls return triplets. With the gap exactly at k = 3 (a
                // factor 10), the block of 11 converges at once: it must not give up.
                let Some(svd) = result else {
                    assert_ne!(k, 3, "{name} {which}: no triplets with the gap at k");
                    continue;
                };
                // The true leading space: the cluster's three vectors for k <= 3, plus the
                // fourth for k = 4.
                let space = k.max(3);
                let (us, vs) = (u.columns(0, space), v.columns(0, space));
                for i in 0..k {
                    let (ui, vi) = (svd.u.column(i), svd.v.column(i));
                    let res = (&m * vi - ui * svd.s[i]).norm();
                    let value = (svd.s[i] - s[i]).abs();
                    // Outside the true space: |x - P x| for unit x.
                    let out_u = (ui - us * us.tr_mul(&ui)).norm();
                    let out_v = (vi - vs * vs.tr_mul(&vi)).norm();
                    worst = worst.max(res / s[0]).max(value / s[0]);
                    // The residual bound of the iteration is 64 eps sqrt(90) s_1 (1.4e-13
                    // relative): measured residuals at most 7.4e-14 relative, values within
                    // 7.2e-16. A vector off the leading space by the gap (5 to 0.5, or 0.5
                    // to 0.45 for k = 4) would stand out by order one; measured 3.5e-13,
                    // allowed 1e-6.
                    assert!(
                        res < 1e-12 * s[0],
                        "{name} {which} k {k} {i}: residual {res:e}"
                    );
                    assert!(
                        value < 1e-12 * s[0],
                        "{name} {which} k {k} {i}: value off by {value:e}"
                    );
                    assert!(
                        out_u < 1e-6 && out_v < 1e-6,
                        "{name} {which} k {k} {i}: outside the leading space by {out_u:e} {out_v:e}"
                    );
                }
                let ortho = (svd.v.columns(0, k).tr_mul(&svd.v.columns(0, k))
                    - DMatrix::identity(k, k))
                .norm()
                .max(
                    (svd.u.columns(0, k).tr_mul(&svd.u.columns(0, k)) - DMatrix::identity(k, k))
                        .norm(),
                );
                assert!(
                    ortho < 1e-12,
                    "{name} {which} k {k}: orthonormality {ortho:e}"
                );
            }
        }
    }
    eprintln!("worst relative residual or value error: {worst:e}");
}
