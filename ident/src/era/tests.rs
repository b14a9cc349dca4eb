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
