//! The paper's two published realizations (Guida, Nilvetti, Pappalardo, COMPDYN 2011).

use ident::{Error, Identification, Identifier, Intersample, MkrError, PolarityPolicy, Warning};
use nalgebra::DMatrix;
use rand::rngs::ChaCha8Rng;
use rand::{RngExt, SeedableRng};

const DT_S: f64 = 1.0 / 64.0;

struct Published {
    a: DMatrix<f64>,
    b: DMatrix<f64>,
    c: DMatrix<f64>,
    d: DMatrix<f64>,
}

/// Case 1, eq. 31-34.
fn case1() -> Published {
    Published {
        a: DMatrix::from_row_slice(
            4,
            4,
            &[
                0.6220, -0.7789, -0.0003, -0.0021, //
                0.7839, 0.6191, 0.0031, -0.0012, //
                -0.0036, 0.0061, 0.9623, 0.2616, //
                0.0041, 0.0044, -0.2676, 0.9634,
            ],
        ),
        b: DMatrix::from_column_slice(4, 1, &[0.0541, -0.0268, 0.0412, 0.0363]),
        c: DMatrix::from_row_slice(
            2,
            4,
            &[
                -37.8710, -5.0124, -5.8513, 1.8479, //
                26.5700, 3.2700, -7.2966, 2.2001,
            ],
        ),
        d: DMatrix::from_column_slice(2, 1, &[3.6387, 0.0739]),
    }
}

/// Case 2 (added mass on floor 1), eq. 48-51.
fn case2() -> Published {
    Published {
        a: DMatrix::from_row_slice(
            4,
            4,
            &[
                0.7776, -0.6220, 0.0041, -0.0044, //
                0.6205, 0.7848, 0.0014, -0.0011, //
                -0.0116, 0.0064, 0.9799, 0.1867, //
                0.0072, -0.0023, -0.1848, 0.9824,
            ],
        ),
        b: DMatrix::from_column_slice(4, 1, &[-0.0524, -0.0317, -0.0561, 0.0124]),
        c: DMatrix::from_row_slice(
            2,
            4,
            &[
                -5.4178, -3.7972, -1.9582, 1.7973, //
                12.0353, 8.4148, -1.8316, 1.9635,
            ],
        ),
        d: DMatrix::from_column_slice(2, 1, &[-2.7906, -0.0621]),
    }
}

fn identify(p: &Published, intersample: Intersample) -> Identification {
    Identifier::default()
        .intersample(intersample)
        .from_realization(DT_S, p.a.clone(), p.b.clone(), p.c.clone(), p.d.clone())
        .unwrap()
}

/// Perturbs every printed entry by a uniform amount within +-0.5 of its last printed digit.
fn perturbed(p: &Published, rng: &mut ChaCha8Rng) -> Published {
    let mut jitter = |m: &DMatrix<f64>, half_ulp: f64| {
        m.map(|x| x + half_ulp * (2.0 * rng.random::<f64>() - 1.0))
    };
    Published {
        a: jitter(&p.a, 0.5e-4),
        b: jitter(&p.b, 0.5e-4),
        c: jitter(&p.c, 0.5e-4),
        d: jitter(&p.d, 0.5e-4),
    }
}

/// Quantities compared with the paper, in a fixed order.
const NAMES: [&str; 15] = [
    "f1", "f2", "xi1", "xi2", "M11", "M12", "M22", "K11", "K12", "K22", "R11", "R12", "R22",
    "alpha", "beta",
];

fn quantities(r: &Identification) -> [f64; 15] {
    [
        r.frequencies_hz[0],
        r.frequencies_hz[1],
        r.damping_ratios[0],
        r.damping_ratios[1],
        r.mass[(0, 0)],
        r.mass[(0, 1)],
        r.mass[(1, 1)],
        r.stiffness[(0, 0)],
        r.stiffness[(0, 1)],
        r.stiffness[(1, 1)],
        r.damping_mkr[(0, 0)],
        r.damping_mkr[(0, 1)],
        r.damping_mkr[(1, 1)],
        r.rayleigh.alpha,
        r.rayleigh.beta,
    ]
}

/// Envelope (min, max) of every quantity over `samples` realizations whose printed entries
/// are perturbed within their rounding (+-0.5 of the last printed digit, 1e-4).
fn rounding_envelope(case: &Published, samples: usize, seed: u64) -> Vec<(f64, f64)> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut env = vec![(f64::INFINITY, f64::NEG_INFINITY); NAMES.len()];
    for _ in 0..samples {
        let q = quantities(&identify(&perturbed(case, &mut rng), Intersample::Zoh));
        for (e, v) in env.iter_mut().zip(q) {
            *e = (e.0.min(v), e.1.max(v));
        }
    }
    env
}

/// Each printed value must lie inside the rounding envelope of the published realization,
/// widened by half a unit of its own last printed digit (`printed_half_ulp`).
fn assert_published(case: &Published, printed: &[(usize, f64, f64)], seed: u64) {
    let env = rounding_envelope(case, 1000, seed);
    for &(i, value, printed_half_ulp) in printed {
        let (lo, hi) = env[i];
        assert!(
            value >= lo - printed_half_ulp && value <= hi + printed_half_ulp,
            "{}: printed {value} outside the rounding envelope [{lo}, {hi}] +- {printed_half_ulp}",
            NAMES[i]
        );
    }
}

/// Case 1 with the paper's ZOH assumption. The published A, B, C, D carry 4 decimals; a
/// seeded Monte Carlo over +-0.5e-4 perturbations of every entry gives the spread each
/// output inherits from that rounding (measured half-widths: f 2e-4 / 6e-5, xi 4 % / 3 %,
/// M11 0.12 %, M12 2.5 %, M22 0.16 %, K 0.16-0.20 %, MKR damping 0.3-0.5 %, alpha 4.6 %,
/// beta 12 %). Every printed number lies inside that envelope.
#[test]
fn case1_matches_the_published_results() {
    let r = identify(&case1(), Intersample::Zoh);
    assert!(r.warnings.is_empty(), "{:?}", r.warnings);
    assert!(!r.polarity_flipped);
    assert_eq!(r.model_order, 4);
    assert!(r.modes.iter().all(|m| m.structural));
    // Printed: eq. 37-42 and 44-46, with half a unit of each printed last digit.
    let printed = [
        (0, 2.7314, 0.5e-4),
        (1, 9.1638, 0.5e-4),
        (2, 0.0054, 0.5e-4),
        (3, 0.0025, 0.5e-4),
        (4, 0.2913, 0.5e-4),
        (5, 0.0153, 0.5e-4),
        (6, 0.3387, 0.5e-4),
        (7, 630.44, 0.5e-2),
        (8, -425.83, 0.5e-2),
        (9, 439.01, 0.5e-2),
        (10, 6.9208, 0.5e-4),
        (11, -3.6833, 0.5e-4),
        (12, 5.6759, 0.5e-4),
        (13, 0.1755, 0.5e-4),
        (14, 3.2283e-5, 0.5e-9),
    ];
    assert_published(&case1(), &printed, 101);
    // Regression values of this implementation on the unperturbed realization (an
    // independent prototype gave the same to all digits shown; 1e-5 relative covers the
    // last one).
    let want: [f64; 13] = [
        2.731548, 9.163611, 0.00543075, 0.00242087, 0.291408, 0.0151735, 0.338722, 630.679,
        -426.112, 439.301, 6.92049, -3.68555, 5.68010,
    ];
    let got = quantities(&r);
    for (i, w) in want.iter().enumerate() {
        // Six significant digits shown: 1e-5 relative.
        assert!(
            (got[i] - w).abs() <= 1e-5 * w.abs(),
            "{}: {} vs {w}",
            NAMES[i],
            got[i]
        );
    }
    // Rayleigh damping (eq. 47) within a few percent: it inherits alpha and beta.
    let eq47 = DMatrix::from_row_slice(2, 2, &[0.0715, -0.0111, -0.0111, 0.0736]);
    let rel = (&r.damping_rayleigh - &eq47).norm() / eq47.norm();
    // Measured 1.1 %; the rounding envelope of its entries is 3 % (diagonal) to 16 %
    // (off-diagonal), so 5 % on the Frobenius norm.
    assert!(rel < 0.05, "Rayleigh damping off by {rel}");
    // MKR damping two orders of magnitude above Rayleigh's: the paper's finding.
    assert!(r.damping_mkr.norm() > 50.0 * r.damping_rayleigh.norm());
}

/// Case 2: the published realization has D11 < 0 (inverted polarity). It is flagged and
/// flipped; the results then match eq. 54-59, 61 and 63. The printed K (eq. 62) repeats
/// case 1 and is a misprint: K is checked against what eq. 64 implies with eq. 58, 59, 61.
#[test]
fn case2_polarity_is_flipped_and_results_match() {
    let r = identify(&case2(), Intersample::Zoh);
    assert!(r.polarity_flipped);
    assert!(matches!(
        r.warnings.as_slice(),
        [Warning::PolarityFlipped { driving_point }] if *driving_point == -2.7906
    ));
    assert!(
        r.realization.d[(0, 0)] > 0.0,
        "the realization is returned corrected"
    );
    // Printed eq. 54-59, 61 (M11, M22) and 63. Measured rounding half-widths: f 3e-4 /
    // 9e-5, xi 4 %, M11 0.2 %, M12 15 %, M22 0.25 %, MKR damping 0.5-0.7 %. The printed
    // M12 = 0.0119 is 7 % from the 0.01273 this realization gives, inside its 15 % envelope:
    // it is the difference of two nearly equal numbers.
    let printed = [
        (0, 1.9056, 0.5e-4),
        (1, 6.8439, 0.5e-4),
        (2, 0.0075, 0.5e-4),
        (3, 0.0028, 0.5e-4),
        (4, 1.3771, 0.5e-4),
        (5, 0.0119, 0.5e-4),
        (6, 0.5566, 0.5e-4),
        (10, 59.9062, 0.5e-4),
        (11, -34.1418, 0.5e-4),
        (12, 38.4897, 0.5e-4),
        (13, 0.1752, 0.5e-4),
        (14, 3.4355e-5, 0.5e-9),
    ];
    assert_published(&case2(), &printed, 102);
    let want = [1.3757, 0.01273, 0.55603];
    let got = [r.mass[(0, 0)], r.mass[(0, 1)], r.mass[(1, 1)]];
    for (g, w) in got.iter().zip(want) {
        // Regression to the digits shown.
        assert!((g - w).abs() < 0.6e-4 * w.abs().max(1.0), "M: {g} vs {w}");
    }

    // K implied by eq. 64 = alpha M + beta K with eq. 58, 59, 61: ~[[949.8, -709.8], 744.7].
    // Its own rounding (R to 1e-4, M to 1e-4, alpha, beta to their digits) is propagated by
    // a Monte Carlo; the identified K must fall inside the sum of both envelopes.
    let implied = |rr: [f64; 3], m: [f64; 3], alpha: f64, beta: f64| -> [f64; 3] {
        [0, 1, 2].map(|i| (rr[i] - alpha * m[i]) / beta)
    };
    let center = implied(
        [0.2739, -0.0223, 0.1231],
        [1.3771, 0.0119, 0.5566],
        0.1752,
        3.4355e-5,
    );
    let mut rng = ChaCha8Rng::seed_from_u64(103);
    let mut implied_half = [0.0f64; 3];
    for _ in 0..1000 {
        let mut j = |x: f64, h: f64| x + h * (2.0 * rng.random::<f64>() - 1.0);
        let k = implied(
            [j(0.2739, 0.5e-4), j(-0.0223, 0.5e-4), j(0.1231, 0.5e-4)],
            [j(1.3771, 0.5e-4), j(0.0119, 0.5e-4), j(0.5566, 0.5e-4)],
            j(0.1752, 0.5e-4),
            j(3.4355e-5, 0.5e-9),
        );
        for i in 0..3 {
            implied_half[i] = implied_half[i].max((k[i] - center[i]).abs());
        }
    }
    let env = rounding_envelope(&case2(), 1000, 104);
    for (i, idx) in [7usize, 8, 9].into_iter().enumerate() {
        let (lo, hi) = env[idx];
        assert!(
            center[i] >= lo - implied_half[i] && center[i] <= hi + implied_half[i],
            "{}: implied {} outside [{lo}, {hi}] +- {}",
            NAMES[idx],
            center[i],
            implied_half[i]
        );
    }
    let k = &r.stiffness;
    for (got, want) in [
        (k[(0, 0)], 946.65),
        (k[(0, 1)], -706.55),
        (k[(1, 1)], 744.42),
    ] {
        assert!((got - want).abs() < 0.01, "K: {got} vs {want}");
    }
    // And not eq. 62 (case 1's K).
    assert!((k[(0, 0)] - 630.44).abs() > 300.0);
    // Rayleigh damping (eq. 64): measured 0.1 % off (entries 0.07 %, 0.5 %, 0.15 %);
    // alpha and beta carry 4-19 % rounding spread but their combination with this M and K
    // is far better determined; 2 % on the Frobenius norm.
    let eq64 = DMatrix::from_row_slice(2, 2, &[0.2739, -0.0223, -0.0223, 0.1231]);
    let rel = (&r.damping_rayleigh - &eq64).norm() / eq64.norm();
    assert!(rel < 0.02, "Rayleigh damping off by {rel}");
}

#[test]
fn case2_with_refusal_is_a_typed_error() {
    let p = case2();
    let err = Identifier::default()
        .intersample(Intersample::Zoh)
        .polarity(PolarityPolicy::Refuse)
        .from_realization(DT_S, p.a, p.b, p.c, p.d)
        .unwrap_err();
    assert_eq!(
        err,
        Error::Mkr(MkrError::PolarityInverted {
            driving_point: -2.7906
        })
    );
}

/// The band-limited assumption on the same realizations: same poles, different residues,
/// hence different M, K and (mostly) damping. Reported, not a paper number.
#[test]
fn bandlimited_assumption_on_the_published_realizations() {
    for (case, name) in [(case1(), "case 1"), (case2(), "case 2")] {
        let zoh = identify(&case, Intersample::Zoh);
        let bl = identify(&case, Intersample::Bandlimited);
        for (a, b) in zoh.frequencies_hz.iter().zip(&bl.frequencies_hz) {
            assert_eq!(a, b);
        }
        let dm = (&bl.mass - &zoh.mass).norm() / zoh.mass.norm();
        let dk = (&bl.stiffness - &zoh.stiffness).norm() / zoh.stiffness.norm();
        let dr = (&bl.damping_mkr - &zoh.damping_mkr).norm() / zoh.damping_mkr.norm();
        println!(
            "{name}: band-limited vs ZOH: M {dm:.3}, K {dk:.3}, MKR damping {dr:.3} (relative); \
             MKR damping ZOH {} band-limited {}; consistency ZOH {:.4} band-limited {:.4}",
            zoh.damping_mkr, bl.damping_mkr, zoh.consistency, bl.consistency
        );
        // Several percent on M and K (NOTES: ~10 % modal scale at 9 Hz).
        assert!(dm > 0.02 && dk > 0.02, "{name}: {dm} {dk}");
    }
}
