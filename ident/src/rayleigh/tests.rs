use super::*;
use rand::rngs::ChaCha8Rng;
use rand::{RngExt, SeedableRng};

#[test]
fn two_modes_are_fitted_exactly_and_more_in_least_squares() {
    let (alpha, beta) = (0.1755, 3.2283e-5);
    let truth = Rayleigh { alpha, beta };
    let f = [2.7, 9.2, 15.0];
    let xi: Vec<f64> = f.iter().map(|&f| truth.damping_ratio(f)).collect();
    let fit = Rayleigh::fit(&f[..2], &xi[..2]).unwrap();
    // Two equations, two unknowns: round-off only.
    assert!((fit.alpha - alpha).abs() < 1e-12 * alpha);
    assert!((fit.beta - beta).abs() < 1e-10 * beta);
    let fit = Rayleigh::fit(&f, &xi).unwrap();
    assert!((fit.alpha - alpha).abs() < 1e-12 * alpha);
    let m = DMatrix::identity(2, 2);
    let k = DMatrix::from_element(2, 2, 1.0);
    assert_eq!(fit.damping(&m, &k)[(0, 1)], fit.beta);
}

#[test]
fn errors_are_typed() {
    assert_eq!(
        Rayleigh::fit(&[3.0], &[0.01]),
        Err(RayleighError::TooFewModes { modes: 1 })
    );
    assert_eq!(
        Rayleigh::fit(&[3.0, 3.0], &[0.01, 0.02]),
        Err(RayleighError::Degenerate)
    );
    assert!(matches!(
        Rayleigh::fit(&[3.0, f64::NAN], &[0.01, 0.02]),
        Err(RayleighError::InvalidMode { mode: 1, .. })
    ));
}

/// `omega = 2 pi f`, written out here rather than taken from the module.
fn omega(f_hz: f64) -> f64 {
    2.0 * std::f64::consts::PI * f_hz
}

#[test]
fn two_modes_match_the_closed_form_over_frequency_ratios() {
    // xi_i = alpha / (2 w_i) + beta w_i / 2 at two modes solves to
    //   alpha = 2 w1 w2 (xi1 w2 - xi2 w1) / (w2^2 - w1^2),
    //   beta  = 2 (xi2 w2 - xi1 w1) / (w2^2 - w1^2),
    // with w = 2 pi f (f in Hz). Errors are measured against the natural
    // scales of the coefficients, 2 w1 w2 |xi|max / (w2 - w1) and
    // 2 |xi|max / (w2 - w1) (a coefficient can itself be near zero), for
    // damping ratios of either sign and zero.
    let mut rng = ChaCha8Rng::seed_from_u64(16);
    let mut worst: f64 = 0.0;
    for &ratio in &[1.0 + 1e-6, 1.001, 1.1, 2.0, 10.0, 1e2, 1e4, 1e8] {
        for trial in 0..50 {
            let f1 = 0.1 + 20.0 * rng.random::<f64>();
            let f2 = f1 * ratio;
            let mut xi = [
                -0.02 + 0.12 * rng.random::<f64>(),
                -0.02 + 0.12 * rng.random::<f64>(),
            ];
            if trial == 0 {
                xi[0] = 0.0;
            }
            let (w1, w2) = (omega(f1), omega(f2));
            let den = (w2 - w1) * (w2 + w1);
            let alpha = 2.0 * w1 * w2 * (xi[0] * w2 - xi[1] * w1) / den;
            let beta = 2.0 * (xi[1] * w2 - xi[0] * w1) / den;
            let xmax = xi[0].abs().max(xi[1].abs());
            // Either order of the modes.
            for (f, x) in [([f1, f2], xi), ([f2, f1], [xi[1], xi[0]])] {
                let fit = Rayleigh::fit(&f, &x).unwrap();
                // Rounding w = 2 pi f perturbs w2 - w1 by eps w: the
                // errors scale with kappa = (w1 + w2) / (w2 - w1).
                let kappa = (w1 + w2) / (w2 - w1);
                let ea = (fit.alpha - alpha).abs() / (2.0 * w1 * w2 * xmax / (w2 - w1));
                let eb = (fit.beta - beta).abs() / (2.0 * xmax / (w2 - w1));
                worst = worst.max(ea / kappa).max(eb / kappa);
            }
        }
    }
    // Round-off of a 2 x 2 solve over its conditioning kappa: measured
    // 1.2e-15 at worst (kappa from 2e6 at the ratio 1 + 1e-6 down to 1).
    assert!(worst < 1e-13, "closed-form error {worst:e}");
}

#[test]
fn more_modes_are_an_unweighted_least_squares_fit() {
    // The module states an ordinary least-squares fit of the damping ratios
    // (no weighting): with r_i = xi_i - alpha / (2 w_i) - beta w_i / 2, the
    // normal equations sum r_i / w_i = 0 and sum r_i w_i = 0 hold, and the
    // coefficients are those of the 2 x 2 normal equations by Cramer's rule.
    // Data consistent with some alpha, beta are reproduced (alpha and beta
    // themselves only to the conditioning of three decades of frequency).
    let mut rng = ChaCha8Rng::seed_from_u64(17);
    let (mut worst_normal, mut worst_cramer, mut worst_exact) = (0.0f64, 0.0f64, 0.0f64);
    for trial in 0..200 {
        let n = 3 + trial % 4;
        let spread: f64 = [1.5, 10.0, 1e3][trial % 3];
        let f: Vec<f64> = (0..n)
            .map(|_| 0.5 * spread.powf(rng.random::<f64>()))
            .collect();
        let xi: Vec<f64> = (0..n).map(|_| 0.005 + 0.05 * rng.random::<f64>()).collect();
        let Ok(fit) = Rayleigh::fit(&f, &xi) else {
            panic!("trial {trial}: {f:?}");
        };
        let w: Vec<f64> = f.iter().map(|&f| omega(f)).collect();
        let r: Vec<f64> = (0..n)
            .map(|i| xi[i] - fit.alpha / (2.0 * w[i]) - fit.beta * w[i] / 2.0)
            .collect();
        // Each normal equation against the size of its terms.
        let g1: f64 =
            (0..n).map(|i| r[i] / w[i]).sum::<f64>() / (0..n).map(|i| xi[i] / w[i]).sum::<f64>();
        let g2: f64 =
            (0..n).map(|i| r[i] * w[i]).sum::<f64>() / (0..n).map(|i| xi[i] * w[i]).sum::<f64>();
        worst_normal = worst_normal.max(g1.abs()).max(g2.abs());
        // Cramer on the normal equations (fine at these conditionings).
        let s = |p: i32| (0..n).map(|i| w[i].powi(p)).sum::<f64>() / 4.0;
        let (a11, a12, a22) = (s(-2), s(0), s(2));
        let b1: f64 = (0..n).map(|i| xi[i] / (2.0 * w[i])).sum();
        let b2: f64 = (0..n).map(|i| xi[i] * w[i] / 2.0).sum();
        let det = a11 * a22 - a12 * a12;
        let alpha = (b1 * a22 - a12 * b2) / det;
        let beta = (a11 * b2 - a12 * b1) / det;
        worst_cramer = worst_cramer
            .max((fit.alpha - alpha).abs() / alpha.abs())
            .max((fit.beta - beta).abs() / beta.abs());
        // Consistent data.
        let truth = Rayleigh {
            alpha: 0.05 + rng.random::<f64>(),
            beta: 1e-4 * rng.random::<f64>(),
        };
        let xi: Vec<f64> = w
            .iter()
            .map(|&w| truth.alpha / (2.0 * w) + truth.beta * w / 2.0)
            .collect();
        let fit = Rayleigh::fit(&f, &xi).unwrap();
        for (&f, &xi) in f.iter().zip(&xi) {
            worst_exact = worst_exact.max((fit.damping_ratio(f) / xi - 1.0).abs());
        }
    }
    // Measured: normal equations 9.4e-15, Cramer 1.9e-12 (its own
    // round-off: the normal equations square the conditioning of frequencies
    // spread over three decades), consistent data reproduced to 4.9e-15.
    assert!(worst_normal < 1e-12, "normal equations {worst_normal:e}");
    assert!(worst_cramer < 1e-9, "against Cramer {worst_cramer:e}");
    assert!(worst_exact < 1e-12, "consistent data {worst_exact:e}");
}

#[test]
fn degenerate_and_odd_inputs_are_typed() {
    // Two or three equal frequencies, or equal to 1e-12: nothing separates
    // alpha from beta.
    for (f, xi) in [
        (vec![3.0, 3.0, 3.0], vec![0.01, 0.02, 0.03]),
        (vec![3.0, 3.0 * (1.0 + 1e-12)], vec![0.01, 0.02]),
    ] {
        assert_eq!(Rayleigh::fit(&f, &xi), Err(RayleighError::Degenerate));
    }
    // 1e-9 apart with damping ratios of 1e300: the exact coefficients
    // overflow, which is refused rather than returned as infinite.
    assert_eq!(
        Rayleigh::fit(&[1.0, 1.0 + 1e-9], &[1e300, -1e300]),
        Err(RayleighError::Degenerate)
    );
    // Two of three equal is fine: alpha and beta from the two frequencies.
    assert!(Rayleigh::fit(&[3.0, 3.0, 9.0], &[0.01, 0.02, 0.03]).is_ok());
    // No damping: exactly none. Negative damping ratios are fitted (the
    // identification warns on negative coefficients).
    let zero = Rayleigh::fit(&[2.0, 7.0], &[0.0, 0.0]).unwrap();
    assert_eq!((zero.alpha, zero.beta), (0.0, 0.0));
    let negative = Rayleigh::fit(&[2.0, 7.0], &[-0.01, -0.02]).unwrap();
    assert!(negative.alpha < 0.0 && negative.beta < 0.0, "{negative:?}");
    // Invalid modes name their position.
    for (f, xi, mode) in [
        ([2.0, 0.0], [0.01, 0.02], 1),
        ([-2.0, 5.0], [0.01, 0.02], 0),
        ([2.0, f64::INFINITY], [0.01, 0.02], 1),
        ([2.0, 5.0], [f64::NAN, 0.02], 0),
        ([2.0, 5.0], [0.01, f64::NEG_INFINITY], 1),
    ] {
        assert!(
            matches!(
                Rayleigh::fit(&f, &xi),
                Err(RayleighError::InvalidMode { mode: m, .. }) if m == mode
            ),
            "{f:?} {xi:?}"
        );
    }
    assert_eq!(
        Rayleigh::fit(&[], &[]),
        Err(RayleighError::TooFewModes { modes: 0 })
    );
}

#[test]
fn damping_ratio_is_in_hz_and_the_matrix_is_alpha_m_plus_beta_k() {
    // alpha = 0.2 1/s, beta = 1e-3 s at 1 Hz: xi = 0.2 / (4 pi) + 1e-3 pi.
    let r = Rayleigh {
        alpha: 0.2,
        beta: 1e-3,
    };
    let want = 0.2 / (4.0 * std::f64::consts::PI) + 1e-3 * std::f64::consts::PI;
    // One rounding of each term and of the sum.
    assert!((r.damping_ratio(1.0) - want).abs() < 4.0 * f64::EPSILON * want);
    let m = DMatrix::from_row_slice(2, 2, &[2.0, 0.0, 0.0, 1.0]);
    let k = DMatrix::from_row_slice(2, 2, &[300.0, -100.0, -100.0, 100.0]);
    let c = r.damping(&m, &k);
    let want = DMatrix::from_row_slice(2, 2, &[0.7, -0.1, -0.1, 0.3]);
    // A product and a sum per entry.
    assert!((c - &want).amax() < 4.0 * f64::EPSILON, "{want}");
}
