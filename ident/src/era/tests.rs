use super::*;
use crate::linalg;
use crate::testutil::{max_relative_difference, random_stable_system};
use num_complex::Complex;
use rand::SeedableRng;
use rand::rngs::ChaCha8Rng;

/// Matches each wanted eigenvalue to the nearest one found; returns the largest distance.
fn pole_error(got: &[Complex<f64>], want: &[Complex<f64>]) -> f64 {
    assert_eq!(got.len(), want.len());
    want.iter()
        .map(|w| {
            got.iter()
                .map(|g| (g - w).norm())
                .fold(f64::INFINITY, f64::min)
        })
        .fold(0.0, f64::max)
}

#[test]
fn exact_markov_parameters_give_the_system_poles() {
    let mut rng = ChaCha8Rng::seed_from_u64(31);
    let correlations = [
        Correlation::None,
        Correlation::Dc { xi: 2, zeta: 2 },
        Correlation::Dc { xi: 0, zeta: 0 },
    ];
    for &(n, m, r) in &[(4usize, 2usize, 1usize), (6, 3, 1), (5, 1, 2), (8, 2, 2)] {
        let sys = random_stable_system(&mut rng, n, m, r, 0.95);
        let want: Vec<_> = linalg::eigenvalues(&sys.a)
            .unwrap()
            .iter()
            .copied()
            .collect();
        for &correlation in &correlations {
            for offset in [0usize, 5] {
                let params = EraParams {
                    block_rows: Some(20),
                    block_cols: Some(30),
                    correlation,
                    offset,
                    order: ModelOrder::Fixed(n),
                };
                let markov = sys.markov(params.shape(m, r, 1000).unwrap().markov_needed());
                let era = params.fit(&markov, 1.0).unwrap();
                let got: Vec<_> = linalg::eigenvalues(&era.realization.a)
                    .unwrap()
                    .iter()
                    .copied()
                    .collect();
                let err = pole_error(&got, &want);
                // Exact, well-conditioned data: poles to round-off (measured ~1e-14).
                assert!(
                    err < 1e-9,
                    "n={n} {correlation:?} offset {offset}: pole error {err:e}"
                );
                // The realization reproduces the Markov parameters, which checks B at the
                // offset (A^-k0 amplifies round-off by at most 2^5 here: 1e-8).
                let again = era.realization.markov(60);
                let diff = max_relative_difference(&again, &sys.markov(60));
                assert!(
                    diff < 1e-8,
                    "n={n} {correlation:?} offset {offset}: Markov error {diff:e}"
                );
            }
        }
    }
}

#[test]
fn automatic_order_finds_the_exact_order() {
    let mut rng = ChaCha8Rng::seed_from_u64(32);
    for &n in &[2usize, 4, 6] {
        let sys = random_stable_system(&mut rng, n, 2, 1, 0.95);
        let params = EraParams::default().order(ModelOrder::Auto { max: 12 });
        let markov = sys.markov(params.shape(2, 1, 1000).unwrap().markov_needed());
        let era = params.fit(&markov, 0.01).unwrap();
        assert_eq!(era.order, n);
        assert_eq!(era.realization.order(), n);
    }
}

#[test]
fn default_shape_follows_outputs_inputs_and_data_length() {
    let params = EraParams::default();
    let shape = params.shape(2, 1, 5000).unwrap();
    assert_eq!((shape.block_rows, shape.block_cols), (40, 240));
    assert_eq!(shape.markov_needed(), 40 + 240 + 2 + 2 + 1);
    // Short data: beta shrinks to fit.
    let shape = params.shape(2, 1, 150).unwrap();
    assert_eq!(shape.markov_needed(), 150);
    // Too short even for the smallest beta.
    assert!(matches!(
        params.shape(2, 1, 50),
        Err(EraError::TooFewMarkov { .. })
    ));
    let shape = params.shape(3, 2, 5000).unwrap();
    assert_eq!((shape.block_rows, shape.block_cols), (27, 122));
}

#[test]
fn errors_are_typed() {
    let mut rng = ChaCha8Rng::seed_from_u64(33);
    let sys = random_stable_system(&mut rng, 4, 2, 1, 0.9);
    let markov = sys.markov(200);
    let small = EraParams::default()
        .blocks(5, 5)
        .order(ModelOrder::Fixed(12));
    assert!(matches!(
        small.fit(&markov, 1.0),
        Err(EraError::OrderTooLarge { order: 12, .. })
    ));
    let deficient = EraParams::default()
        .blocks(10, 10)
        .order(ModelOrder::Fixed(6));
    assert!(matches!(
        deficient.fit(&markov, 1.0),
        Err(EraError::RankDeficient { order: 6, .. })
    ));
    assert!(matches!(
        EraParams::default().order(ModelOrder::Fixed(0)).check(),
        Err(EraError::InvalidParams { .. })
    ));
    assert!(matches!(
        EraParams::default().blocks(40, 100).fit(&markov[..50], 1.0),
        Err(EraError::TooFewMarkov { available: 50, .. })
    ));
}

/// The correlations from sums of Markov products equal `H(k) H(0)^T` formed directly.
#[test]
fn correlations_from_markov_sums_match_hankel_products() {
    let mut rng = ChaCha8Rng::seed_from_u64(41);
    let sys = random_stable_system(&mut rng, 6, 2, 2, 0.95);
    let markov = sys.markov(160);
    let params = EraParams::default().offset(3);
    let shape = params.shape(2, 2, markov.len()).unwrap();
    let (m, r) = (2, 2);
    let hankel = |k: usize| {
        DMatrix::from_fn(shape.block_rows * m, shape.block_cols * r, |i, j| {
            markov[shape.offset + 1 + k + i / m + j / r][(i % m, j % r)]
        })
    };
    let h0t = hankel(0).transpose();
    let corr = correlations(&markov, &shape);
    for (k, got) in corr.iter().enumerate() {
        let want = hankel(k) * &h0t;
        // Sums of the same products in another order (running updates along the
        // diagonals): round-off of sums of ~100 terms.
        assert!((got - &want).amax() < 1e-12 * want.amax(), "R({k})");
    }
}

/// The compressed SVD is used for Markov parameters of a finite-order system and gives
/// the same leading singular values and subspaces as factoring the whole matrix; for
/// parameters of no finite-order system it declines.
#[test]
fn compressed_svd_matches_the_full_svd_and_declines_full_rank_data() {
    let mut rng = ChaCha8Rng::seed_from_u64(42);
    let sys = random_stable_system(&mut rng, 8, 2, 1, 0.97);
    let markov = sys.markov(400);
    let params = EraParams::default().offset(2);
    let shape = params.shape(2, 1, markov.len()).unwrap();
    let (m, r) = (2, 1);
    let hankel = |k: usize| {
        DMatrix::from_fn(shape.block_rows * m, shape.block_cols * r, |i, j| {
            markov[shape.offset + 1 + k + i / m + j / r][(i % m, j % r)]
        })
    };
    let big = |corr: &[DMatrix<f64>]| {
        let s = corr[0].nrows();
        let mut out = DMatrix::zeros(3 * s, 3 * s);
        for i in 0..3 {
            for j in 0..3 {
                out.view_mut((i * s, j * s), (s, s)).copy_from(&corr[i + j]);
            }
        }
        out
    };
    let corr = correlations(&markov, &shape);
    let big0 = big(&corr);
    let h0 = hankel(0);
    let stacked = |v: &DMatrix<f64>| {
        let rows = h0.nrows();
        let mut out = DMatrix::zeros(3 * rows, v.ncols());
        for i in 0..3 {
            out.view_mut((i * rows, 0), (rows, v.ncols()))
                .copy_from(&(hankel(i) * v));
        }
        out
    };
    let h0_svd = linalg::thin_svd(&h0).unwrap();
    let got = compressed_svd(&corr, stacked, &h0_svd, 2, &big0)
        .unwrap()
        .expect("an 8-state system compresses");
    let want = linalg::thin_svd(&big0).unwrap();
    let n = 8;
    for i in 0..n {
        // Singular values of the same matrix by two exact factorizations: round-off
        // relative to the largest (the ratio s_8 / s_1 is ~1e-6 here).
        assert!(
            (got.s[i] - want.s[i]).abs() < 1e-12 * want.s[0],
            "s{i}: {} {}",
            got.s[i],
            want.s[i]
        );
    }
    assert!(got.s.iter().skip(n).all(|&x| x < 1e-12 * want.s[0]));
    // Same leading left subspace: the projector difference is at round-off over the gap.
    let pu = |u: &DMatrix<f64>| {
        let un = u.columns(0, n);
        un * un.transpose()
    };
    assert!((pu(&got.u) - pu(&want.u)).amax() < 1e-8);

    // Markov parameters of no finite-order system: the residual test refuses.
    let noise: Vec<DMatrix<f64>> = (0..400)
        .map(|_| DMatrix::from_fn(2, 1, |_, _| crate::testutil::normal(&mut rng)))
        .collect();
    let corr = correlations(&noise, &shape);
    let big0 = big(&corr);
    let hankel = |k: usize| {
        DMatrix::from_fn(shape.block_rows * m, shape.block_cols * r, |i, j| {
            noise[shape.offset + 1 + k + i / m + j / r][(i % m, j % r)]
        })
    };
    let h0 = hankel(0);
    let stacked = |v: &DMatrix<f64>| {
        let rows = h0.nrows();
        let mut out = DMatrix::zeros(3 * rows, v.ncols());
        for i in 0..3 {
            out.view_mut((i * rows, 0), (rows, v.ncols()))
                .copy_from(&(hankel(i) * v));
        }
        out
    };
    let h0_svd = linalg::thin_svd(&h0).unwrap();
    assert!(
        compressed_svd(&corr, stacked, &h0_svd, 2, &big0)
            .unwrap()
            .is_none()
    );
}

#[test]
fn a_decomposition_to_one_order_realizes_it_as_the_full_one_does() {
    // Noisy Markov parameters (1e-4 of the largest, so the factored matrix
    // has a full noise floor below the 6 structural values), both Hankel
    // forms: the realization of order 6 from the leading vectors only must
    // give the full decomposition's poles and Markov parameters. Measured:
    // poles within 5e-14 (ERA) and 1.9e-12 (ERA/DC), Markov parameters
    // within 1.1e-14 relative; 1e-9 leaves room for a closer pair of
    // structural values (vector error = residual / gap).
    let mut rng = ChaCha8Rng::seed_from_u64(77);
    let (n, m, r) = (6, 3, 1);
    let sys = random_stable_system(&mut rng, n, m, r, 0.97);
    for correlation in [Correlation::None, Correlation::Dc { xi: 2, zeta: 2 }] {
        let params = EraParams {
            block_rows: Some(30),
            block_cols: Some(60),
            correlation,
            offset: 0,
            order: ModelOrder::Fixed(n),
        };
        let mut markov = sys.markov(params.shape(m, r, 1000).unwrap().markov_needed());
        let scale = markov.iter().map(|y| y.amax()).fold(0.0, f64::max);
        for y in markov.iter_mut().skip(1) {
            for v in y.iter_mut() {
                *v += 1e-4 * scale * crate::testutil::normal(&mut rng);
            }
        }
        let full = params.decompose(&markov, 1.0).unwrap();
        let lead = params.decompose_to_order(&markov, 1.0, n).unwrap();
        // Singular values: without the vectors the SVD rounds differently (ERA
        // without correlation factors H(0) itself), 1e-13 of the largest.
        let s0 = full.hankel_singular_values[0];
        assert!((&full.hankel_singular_values - &lead.hankel_singular_values).amax() < 1e-13 * s0);
        let (a, b) = (full.realize(n).unwrap(), lead.realize(n).unwrap());
        let poles = |e: &Era| -> Vec<Complex<f64>> {
            linalg::eigenvalues(&e.realization.a)
                .unwrap()
                .iter()
                .copied()
                .collect()
        };
        let err = pole_error(&poles(&b), &poles(&a));
        assert!(err < 1e-9, "{correlation:?}: poles differ by {err:e}");
        let diff = max_relative_difference(&b.realization.markov(40), &a.realization.markov(40));
        assert!(
            diff < 1e-9,
            "{correlation:?}: Markov parameters differ by {diff:e}"
        );
        // Higher orders need vectors it did not compute.
        assert!(matches!(
            lead.realize(n + 2),
            Err(EraError::OrderTooLarge { order: 8, max: 6 })
        ));
    }
}

#[test]
fn an_observer_with_more_states_than_h0_rank_skips_only_a_failing_compression() {
    // ERA/DC of a 20-state system's exact Markov parameters with 5 block rows of 3
    // outputs: H(0) has rank 15 < 20, so the correlation Hankel matrix (rank 20) is not
    // in the compressed space and the compression fails; given the 20 states, the attempt
    // is skipped and the result is the same bit for bit. With 6 states (rank 6 = states)
    // the compression succeeds and is still tried: again the same bits.
    let mut rng = ChaCha8Rng::seed_from_u64(31);
    for (states, rows) in [(20, 5), (6, 30)] {
        let (m, r) = (3, 1);
        let sys = random_stable_system(&mut rng, states, m, r, 0.95);
        let params = EraParams {
            block_rows: Some(rows),
            block_cols: Some(60),
            correlation: Correlation::Dc { xi: 2, zeta: 2 },
            offset: 0,
            order: ModelOrder::Fixed(4),
        };
        let markov = sys.markov(params.shape(m, r, 1000).unwrap().markov_needed());
        let tried = params.decompose_to_order(&markov, 1.0, 4).unwrap();
        let given = params
            .decompose_observer_to_order(&markov, 1.0, 4, states)
            .unwrap();
        let (a, b) = (tried.realize(4).unwrap(), given.realize(4).unwrap());
        assert_eq!(a.realization, b.realization, "{states} states");
        assert_eq!(a.singular_values, b.singular_values, "{states} states");
    }
}

/// Block Hankel matrix `H(k)` of `markov` for `shape`, entry by entry (the module docs).
fn naive_hankel(markov: &[DMatrix<f64>], shape: &HankelShape, k: usize) -> DMatrix<f64> {
    let (m, r) = markov[0].shape();
    DMatrix::from_fn(shape.block_rows * m, shape.block_cols * r, |i, j| {
        markov[shape.offset + 1 + k + i / m + j / r][(i % m, j % r)]
    })
}

/// The correlations from the running diagonal sums against `H(k) H(0)^T` formed by
/// nalgebra's products, for shapes at the edges of the diagonal walk: one block row or
/// column (diagonals of one pair, no running update), more block rows than columns and
/// the reverse, one output and several inputs, several outputs and one input, offsets,
/// and ERA/DC with `xi` or `zeta` zero; Markov parameters of no system (random entries
/// with a mean, so that the sums do not cancel to nothing). The Hankel matrices the
/// decomposition factors (`H(0)`, and `H(1)` for ERA, the correlation Hankel matrix
/// `[R(1 + i + j)]` for ERA/DC), through the one-input fast path and the general one,
/// against the same naive matrices.
#[test]
fn correlations_and_hankel_matrices_match_naive_products_for_every_shape() {
    let mut rng = ChaCha8Rng::seed_from_u64(81);
    let mut worst = 0.0f64;
    // (outputs m, inputs r, alpha, beta, offset, xi, zeta)
    for &(m, r, alpha, beta, offset, xi, zeta) in &[
        (1usize, 1usize, 1usize, 1usize, 0usize, 0usize, 0usize),
        (1, 1, 5, 1, 0, 2, 2),
        (1, 1, 1, 7, 3, 0, 1),
        (2, 3, 4, 2, 1, 1, 0),
        (3, 1, 2, 9, 0, 2, 2),
        (3, 2, 6, 5, 5, 0, 3),
        (2, 2, 3, 3, 0, 0, 0),
        (1, 4, 7, 3, 2, 3, 1),
    ] {
        let shape = HankelShape {
            block_rows: alpha,
            block_cols: beta,
            xi,
            zeta,
            offset,
            correlated: true,
        };
        // Two spare terms past what is needed: they must not be read.
        let markov: Vec<DMatrix<f64>> = (0..shape.markov_needed() + 2)
            .map(|_| DMatrix::from_fn(m, r, |_, _| crate::testutil::normal(&mut rng) + 0.5))
            .collect();
        let h0t = naive_hankel(&markov, &shape, 0).transpose();
        let corr = correlations(&markov, &shape);
        assert_eq!(corr.len(), xi + zeta + 2);
        for (k, got) in corr.iter().enumerate() {
            let want = naive_hankel(&markov, &shape, k) * &h0t;
            let e = (got - &want).amax() / want.amax();
            worst = worst.max(e);
            // Sums of at most 9 r products of O(1) entries, updated along diagonals of
            // at most 7 blocks (two products per step): round-off of ~40 terms (measured
            // at most 3.7e-16 of the largest entry); a misplaced block or a missing
            // product is of order 0.1 of it.
            assert!(
                e < 1e-13,
                "m={m} r={r} alpha={alpha} beta={beta} R({k}): {e:e}"
            );
        }
        for correlation in [Correlation::None, Correlation::Dc { xi, zeta }] {
            let params = EraParams::default()
                .blocks(alpha, beta)
                .offset(offset)
                .correlation(correlation)
                .order(ModelOrder::Fixed(1));
            let dec = params.decompose(&markov, 1.0).unwrap();
            // Copies of the same numbers: equal bit for bit.
            assert_eq!(dec.h0, naive_hankel(&markov, &shape, 0), "m={m} r={r}");
            if correlation == Correlation::None {
                assert_eq!(dec.shifted, naive_hankel(&markov, &shape, 1), "m={m} r={r}");
            } else {
                let s = alpha * m;
                let want = DMatrix::from_fn((xi + 1) * s, (zeta + 1) * s, |i, j| {
                    let k = 1 + i / s + j / s;
                    (naive_hankel(&markov, &shape, k) * &h0t)[(i % s, j % s)]
                });
                let e = (&dec.shifted - &want).amax() / want.amax();
                // As for R(k) above.
                assert!(e < 1e-13, "m={m} r={r} Hc(1): {e:e}");
            }
        }
    }
    eprintln!("worst relative difference: {worst:e}");
}

/// The compression at its tolerance: Markov parameters of a 6-state system with
/// `alpha m = 6` (the rank of `H(0)` exactly the states, every direction of its row
/// space kept) plus noise of levels on both sides of the residual tolerance. Whichever
/// branch is taken, a compressed SVD returned must be that of the correlation Hankel
/// matrix to within its residual (Weyl: each singular value moves by at most the
/// spectral norm of what the compression drops, at most 1e-12 of the Frobenius norm),
/// and the noise levels must reach both branches.
#[test]
fn compression_at_its_tolerance_is_within_its_residual_of_the_full_svd() {
    let mut rng = ChaCha8Rng::seed_from_u64(82);
    let (n, m, r) = (6, 2, 1);
    let sys = random_stable_system(&mut rng, n, m, r, 0.9);
    let clean = sys.markov(60);
    let shape = HankelShape {
        block_rows: n / m,
        block_cols: 12,
        xi: 2,
        zeta: 2,
        offset: 1,
        correlated: true,
    };
    let noise: Vec<DMatrix<f64>> = clean
        .iter()
        .map(|y| DMatrix::from_fn(m, r, |_, _| crate::testutil::normal(&mut rng) * y.amax()))
        .collect();
    let (mut taken, mut declined) = (0, 0);
    let mut worst = 0.0f64;
    for level in (0..=18).map(|k| 10f64.powf(-17.0 + 0.5 * k as f64)) {
        let markov: Vec<DMatrix<f64>> = clean
            .iter()
            .zip(&noise)
            .map(|(y, e)| y + e * level)
            .collect();
        let corr = correlations(&markov, &shape);
        let s = corr[0].nrows();
        let big0 = DMatrix::from_fn(3 * s, 3 * s, |i, j| corr[i / s + j / s][(i % s, j % s)]);
        let h0 = naive_hankel(&markov, &shape, 0);
        let stacked = |v: &DMatrix<f64>| {
            let rows = h0.nrows();
            let mut out = DMatrix::zeros(3 * rows, v.ncols());
            for i in 0..3 {
                out.view_mut((i * rows, 0), (rows, v.ncols()))
                    .copy_from(&(naive_hankel(&markov, &shape, i) * v));
            }
            out
        };
        let h0_svd = linalg::thin_svd(&h0).unwrap();
        assert_eq!(h0_svd.rank(f64::EPSILON * 12.0), n);
        let want = linalg::thin_svd(&big0).unwrap();
        match compressed_svd(&corr, stacked, &h0_svd, 2, &big0).unwrap() {
            None => declined += 1,
            Some(got) => {
                taken += 1;
                let bound = COMPRESSION_TOLERANCE * big0.norm();
                for (i, (a, b)) in got.s.iter().zip(&want.s).enumerate() {
                    let e = (a - b).abs() / bound;
                    worst = worst.max(e);
                    // Weyl's bound, plus the two SVDs' round-off (1e-15 of s_1, a
                    // thousandth of the bound): measured at most 0.17 of the bound.
                    assert!(e < 1.0, "level {level:e}: s{i} {a} against {b}");
                }
                // The factorization reproduces the matrix to its residual.
                // (Values past the columns of its `U` are the zeros of the dropped part.)
                let kept = got.u.ncols();
                assert!(got.s.iter().skip(kept).all(|&x| x == 0.0));
                let rebuilt = &got.u
                    * DMatrix::from_diagonal(&got.s.rows(0, kept).into_owned())
                    * got.v.columns(0, kept).transpose();
                let e = (&rebuilt - &big0).norm() / big0.norm();
                assert!(
                    e < 2.0 * COMPRESSION_TOLERANCE,
                    "level {level:e}: rebuilt {e:e}"
                );
            }
        }
    }
    eprintln!("taken {taken}, declined {declined}, worst {worst:e} of the bound");
    assert!(taken > 0 && declined > 0);
}
