use super::*;
use crate::testutil::{max_relative_difference, normal, random_stable_system, white_noise_records};
use rand::SeedableRng;
use rand::rngs::ChaCha8Rng;

/// Noise-free white-noise records from a random stable system, identified with a fixed
/// observer order: the system Markov parameters must match C A^(k-1) B term by term.
#[test]
fn system_markov_parameters_match_known_systems() {
    // (states n, outputs m, inputs r, observer order p, leads q)
    let cases = [
        (4, 2, 1, 2, 0),
        (4, 2, 1, 4, 0),
        (6, 3, 2, 2, 0),
        (5, 1, 1, 6, 0),
        (3, 1, 2, 4, 0),
        (4, 2, 1, 3, 3),
        (6, 2, 2, 4, 2),
    ];
    let mut rng = ChaCha8Rng::seed_from_u64(21);
    for (case, &(n, m, r, p, q)) in cases.iter().enumerate() {
        let sys = random_stable_system(&mut rng, n, m, r, 0.95);
        let records = white_noise_records(&mut rng, &sys, &[300, 517, 250]);
        let okid = OkidParams::zoh()
            .order(ObserverOrder::Fixed(p))
            .leads(q)
            .rcond(1e-10)
            .markov_count(80)
            .fit(&records)
            .unwrap();
        let want = sys.markov(80);
        let err = max_relative_difference(&okid.markov, &want);
        // Exact data and an exact observer model: only round-off of a well-conditioned
        // least-squares problem remains (measured ~1e-13); 1e-9 leaves room for the
        // recursion's growth over 80 terms at spectral radius up to 0.95.
        assert!(err < 1e-9, "case {case}: Markov error {err:e}");
        assert!(okid.rcond_raises.is_empty(), "case {case}");
        for (j, g) in okid.lead_markov.iter().enumerate() {
            // The data are causal: every lead term must vanish (same round-off budget).
            assert!(
                g.amax() < 1e-9 * want[1].amax(),
                "case {case}: lead {} = {g}",
                j + 1
            );
        }
        assert!(okid.relative_residual < 1e-10, "case {case}");
    }
}

/// The recursion from observer to system Markov parameters, checked term by term without
/// any least squares: observer coefficients built from a known system and observer gain.
#[test]
fn recursion_reproduces_markov_parameters_including_the_bd_term() {
    let mut rng = ChaCha8Rng::seed_from_u64(22);
    // Two to four outputs take the recursion's unrolled products, five the general ones.
    // The observer below needs a spectral radius of at most 0.8: the later systems' own
    // radius (0.75) is below it, so that halving the gain always gets there.
    for (n, m, r, radius) in [
        (5, 2, 2, 0.9),
        (6, 3, 1, 0.75),
        (8, 4, 1, 0.75),
        (6, 5, 2, 0.75),
    ] {
        recursion_case(&mut rng, n, m, r, radius);
    }
}

fn recursion_case(rng: &mut ChaCha8Rng, n: usize, m: usize, r: usize, radius: f64) {
    let sys = random_stable_system(rng, n, m, r, radius);
    // A small random gain keeps A + G C stable; p = 160 makes its tail negligible.
    let mut g = DMatrix::from_fn(n, m, |_, _| 0.05 * normal(rng));
    let mut abar = &sys.a + &g * &sys.c;
    while linalg::spectral_radius(&abar).unwrap() > 0.8 {
        g *= 0.5;
        abar = &sys.a + &g * &sys.c;
    }
    let p = 160;
    let mut a = vec![sys.d.clone()];
    let mut b = Vec::new();
    let mut power = DMatrix::<f64>::identity(n, n);
    let bbar = &sys.b + &g * &sys.d;
    for _ in 1..=p {
        a.push(&sys.c * &power * &bbar);
        b.push(-(&sys.c * &power * &g));
        power = &abar * power;
    }
    let (leads, markov) = system_markov(&a, &b, 0, 60);
    assert!(leads.is_empty());
    let want = sys.markov(60);
    for (k, (got, w)) in markov.iter().zip(&want).enumerate() {
        // Each term is a finite sum of products of O(1) matrices: round-off only.
        assert!(
            (got - w).amax() < 1e-12 * want[1].amax().max(1.0),
            "Y_{k}: {got} vs {w}"
        );
    }
    // Dropping the b_k D term (as some packaged code does) changes Y_1 by b_1 D.
    let missing = &a[1];
    assert!((missing - &want[1]).amax() > 1e-3 * want[1].amax());

    let h = observer_gain_markov(&b, 40);
    let mut ak = DMatrix::<f64>::identity(n, n);
    for (k, hk) in h.iter().enumerate() {
        let w = &sys.c * &ak * &g;
        assert!((hk - &w).amax() < 1e-12, "h_{}: {hk} vs {w}", k + 1);
        ak = &sys.a * ak;
    }

    // With leads the recursion starts at -q: a lone lead term propagates through b.
    let q = 2;
    let mut a_lead = vec![DMatrix::from_element(m, r, 1.0), DMatrix::zeros(m, r)];
    a_lead.extend(a.iter().cloned());
    let (lead, markov_lead) = system_markov(&a_lead, &b, q, 5);
    assert_eq!(lead.len(), 2);
    // g[-2] = a_{-2}; g[-1] = a_{-1} + b_1 g[-2]; g[0] = a_0 + b_1 g[-1] + b_2 g[-2].
    let g2 = &a_lead[0];
    let g1 = &a_lead[1] + &b[0] * g2;
    let g0 = &a_lead[2] + &b[0] * &g1 + &b[1] * g2;
    assert!((&lead[1] - g2).amax() < 1e-15);
    assert!((&lead[0] - &g1).amax() < 1e-15);
    assert!((&markov_lead[0] - &g0).amax() < 1e-14);
}

/// With p m = n the observer is unique (deadbeat): the identified observer-gain Markov
/// parameters are those of a gain G with (A + G C)^p = 0.
#[test]
fn observer_gain_markov_parameters_define_a_deadbeat_observer() {
    let mut rng = ChaCha8Rng::seed_from_u64(23);
    for &(n, m, r) in &[(4usize, 2usize, 1usize), (6, 3, 2), (3, 1, 1), (6, 2, 1)] {
        let p = n / m;
        let sys = random_stable_system(&mut rng, n, m, r, 0.95);
        let records = white_noise_records(&mut rng, &sys, &[400, 300]);
        let okid = OkidParams::zoh()
            .order(ObserverOrder::Fixed(p))
            .rcond(1e-12)
            .markov_count(41)
            .fit(&records)
            .unwrap();
        // G from the first p terms: [h_1; ...; h_p] = O_p G.
        let mut obs = DMatrix::zeros(p * m, n);
        let mut hs = DMatrix::zeros(p * m, m);
        let mut ak = DMatrix::<f64>::identity(n, n);
        for k in 0..p {
            obs.view_mut((k * m, 0), (m, n)).copy_from(&(&sys.c * &ak));
            hs.view_mut((k * m, 0), (m, m))
                .copy_from(&okid.observer_gain_markov[k]);
            ak = &sys.a * ak;
        }
        let g = obs.lu().solve(&hs).unwrap();
        let abar = &sys.a + &g * &sys.c;
        let mut power = DMatrix::<f64>::identity(n, n);
        for _ in 0..p {
            power = &abar * power;
        }
        // Deadbeat to round-off (entries of A are O(1)).
        assert!(power.amax() < 1e-8, "n={n} m={m}: (A+GC)^p = {power}");
        let mut ak = DMatrix::<f64>::identity(n, n);
        for (k, hk) in okid.observer_gain_markov.iter().enumerate() {
            let w = &sys.c * &ak * &g;
            assert!(
                (hk - &w).amax() < 1e-8 * w.amax().max(1.0),
                "n={n} m={m}: h_{} differs",
                k + 1
            );
            ak = &sys.a * ak;
        }
    }
}

#[test]
fn automatic_order_stops_at_the_first_exact_fit() {
    let mut rng = ChaCha8Rng::seed_from_u64(24);
    for &(n, m, want) in &[(4usize, 2usize, 2usize), (6, 2, 3), (3, 1, 3)] {
        let sys = random_stable_system(&mut rng, n, m, 1, 0.9);
        let records = white_noise_records(&mut rng, &sys, &[500, 400]);
        let okid = OkidParams::zoh()
            .order(ObserverOrder::Auto { max: 12 })
            .fit(&records)
            .unwrap();
        assert_eq!(okid.observer_order, want, "n={n} m={m}: bic {:?}", okid.bic);
        assert_eq!(okid.bic.len(), 12);
    }
}

#[test]
fn data_errors_are_typed() {
    let mut rng = ChaCha8Rng::seed_from_u64(26);
    let sys = random_stable_system(&mut rng, 4, 2, 1, 0.9);
    let good = white_noise_records(&mut rng, &sys, &[100, 100]);
    let params = OkidParams::zoh().order(ObserverOrder::Fixed(10)).leads(2);

    let mut short = good.clone();
    short[1] = white_noise_records(&mut rng, &sys, &[12]).remove(0);
    assert_eq!(
        params.fit(&short),
        Err(OkidError::Data(DataError::TooShort {
            record: 1,
            samples: 12,
            required: 13,
            reason: "observer order plus leads plus one",
        }))
    );

    let mut silent = good.clone();
    silent[0].inputs.fill(0.0);
    assert_eq!(
        params.fit(&silent),
        Err(OkidError::Data(DataError::NoExcitation { record: 0 }))
    );

    let mut nan = good.clone();
    nan[1].outputs[(1, 37)] = f64::NAN;
    assert!(matches!(
        params.fit(&nan),
        Err(OkidError::Data(DataError::NonFinite {
            record: 1,
            channel: crate::record::Channel::Output(1),
            sample: 37,
            ..
        }))
    ));

    let few = white_noise_records(&mut rng, &sys, &[20]);
    assert!(matches!(
        OkidParams::zoh().order(ObserverOrder::Fixed(10)).fit(&few),
        Err(OkidError::Underdetermined { .. })
    ));

    assert!(matches!(
        OkidParams::zoh().rcond(0.0).check(),
        Err(OkidError::InvalidParams { .. })
    ));
    assert!(matches!(
        OkidParams::zoh().order(ObserverOrder::Fixed(0)).check(),
        Err(OkidError::InvalidParams { .. })
    ));
    assert_eq!(
        OkidParams::zoh().fit(&[]),
        Err(OkidError::Data(DataError::NoRecords))
    );
}

/// The stacked regression `[X | Y]` written out row by row (the definition in the module
/// docs), in raw units: the naive oracle of the lagged products.
fn regression_matrix(records: &[Record], layout: &Layout) -> DMatrix<f64> {
    let (r, m, q, p) = (layout.r, layout.m, layout.q, layout.p);
    let ncols = layout.columns(p);
    let rows: usize = records.iter().map(|rec| rec.len() - q - layout.skip).sum();
    let mut z = DMatrix::zeros(rows, ncols + m);
    let mut row = 0;
    for rec in records {
        let u = |ch: usize, k: isize| {
            if k < 0 {
                0.0
            } else {
                rec.inputs[(ch, k as usize)]
            }
        };
        let y = |ch: usize, k: isize| {
            if k < 0 {
                0.0
            } else {
                rec.outputs[(ch, k as usize)]
            }
        };
        for n in layout.skip as isize..(rec.len() - q) as isize {
            for t in 0..q {
                for ch in 0..r {
                    z[(row, t * r + ch)] = u(ch, n + (q - t) as isize);
                }
            }
            for ch in 0..r {
                z[(row, q * r + ch)] = u(ch, n);
            }
            for i in 1..=p {
                let base = (q + 1) * r + (i - 1) * (r + m);
                for ch in 0..r {
                    z[(row, base + ch)] = u(ch, n - i as isize);
                }
                for ch in 0..m {
                    z[(row, base + r + ch)] = y(ch, n - i as isize);
                }
            }
            for ch in 0..m {
                z[(row, ncols + ch)] = y(ch, n);
            }
            row += 1;
        }
    }
    z
}

#[test]
fn lagged_products_equal_the_gram_matrix_of_the_regression() {
    let mut rng = ChaCha8Rng::seed_from_u64(31);
    // (outputs, inputs, order, leads); records of 40 to 4200 samples, each within one
    // correlation block (the block boundaries are crossed in
    // `lagged_products_at_every_block_boundary_equal_the_gram_matrix`).
    // Skipping the first equations of each record (unknown initial state) as well.
    for &(m, r, p, q, skip) in &[
        (2usize, 1usize, 5usize, 0usize, 0usize),
        (3, 1, 4, 3, 0),
        (2, 2, 3, 2, 0),
        (2, 1, 5, 0, 5),
        (3, 1, 4, 3, 4),
        (2, 2, 3, 2, 7),
    ] {
        let sys = random_stable_system(&mut rng, 4, m, r, 0.9);
        let records = white_noise_records(&mut rng, &sys, &[40, 4200, 4096 + 7]);
        let layout = Layout { r, m, q, p, skip };
        let refs: Vec<&Record> = records.iter().collect();
        let got = Moments::of_records(&refs, &layout);
        let z = regression_matrix(&records, &layout);
        let want = z.transpose() * &z;
        let scale = want.amax();
        // Same products summed in another order: round-off of sums of ~8000 terms.
        assert!(
            (&got.gram - &want).amax() < 1e-12 * scale,
            "m={m} r={r} p={p} q={q}: {:e}",
            (&got.gram - &want).amax() / scale
        );
        assert_eq!(got.equations, z.nrows());
        // Leaving a record out is the Gram matrix of the others.
        let without = got.without(&Moments::of_record(&records[1], &layout));
        let z = regression_matrix(&[records[0].clone(), records[2].clone()], &layout);
        let want = z.transpose() * &z;
        // Cancellation against the left-out record's share: round-off of the full sums.
        assert!((&without.gram - &want).amax() < 1e-12 * scale);
        assert_eq!(without.equations, z.nrows());
    }
}

/// On noisy records (the case the normal equations serve) both routes give the same
/// observer, the same order and the same Markov parameters.
#[test]
fn normal_equations_agree_with_qr_on_noisy_records() {
    let mut rng = ChaCha8Rng::seed_from_u64(32);
    for &(m, r, q) in &[(2usize, 1usize, 0usize), (3, 1, 4)] {
        let sys = random_stable_system(&mut rng, 6, m, r, 0.95);
        let mut records = white_noise_records(&mut rng, &sys, &[600, 800, 500]);
        for rec in &mut records {
            let level = 0.01 * rec.outputs.norm() / (rec.outputs.len() as f64).sqrt();
            rec.outputs.apply(|v| *v += level * normal(&mut rng));
        }
        let params = OkidParams::zoh()
            .order(ObserverOrder::Auto { max: 8 })
            .leads(q)
            .rcond(1e-6)
            .markov_count(60);
        let refs: Vec<&Record> = records.iter().collect();
        let layout = params.layout(r, m);
        let moments = Moments::of_records(&refs, &layout);
        let normal_fit = params
            .fit_normal(&moments, &layout)
            .unwrap()
            .expect("noisy records take the normal equations");
        let qr = params.fit_qr(&refs, &layout, moments.equations).unwrap();
        assert_eq!(normal_fit.observer_order, qr.observer_order);
        assert_eq!(normal_fit.rank, qr.rank);
        let err = max_relative_difference(&normal_fit.markov, &qr.markov);
        // Condition number of the scaled regression ~1e2 here: the normal equations
        // lose about 1e-16 * 1e4 = 1e-12; 1e-9 leaves room for the recursion over 60 terms.
        assert!(err < 1e-9, "m={m} q={q}: {err:e}");
        assert!((normal_fit.relative_residual / qr.relative_residual - 1.0).abs() < 1e-9);
        for (a, b) in normal_fit.bic.iter().zip(&qr.bic) {
            assert!((a - b).abs() < 1e-9 * b.abs(), "{a} {b}");
        }
    }
}

/// Records cut out of longer ones (the system already moving at their first sample):
/// with an unknown initial state the first `p` equations are not formed and the Markov
/// parameters come out exact; from rest, the zeros read before each record bias them.
#[test]
fn unknown_initial_state_discards_the_first_equations() {
    let mut rng = ChaCha8Rng::seed_from_u64(33);
    let (n, m, r, p) = (4, 2, 1, 4);
    let sys = random_stable_system(&mut rng, n, m, r, 0.95);
    let long = white_noise_records(&mut rng, &sys, &[700, 900, 650]);
    let cut: Vec<Record> = long
        .iter()
        .map(|rec| {
            let len = rec.len() - 200;
            Record::new(
                rec.inputs.columns(200, len).into_owned(),
                rec.outputs.columns(200, len).into_owned(),
            )
        })
        .collect();
    let params = OkidParams::zoh()
        .order(ObserverOrder::Fixed(p))
        .rcond(1e-10)
        .markov_count(60);
    let want = sys.markov(60);
    let unknown = params
        .initial_state(InitialState::Unknown)
        .fit(&cut)
        .unwrap();
    let err = max_relative_difference(&unknown.markov, &want);
    // An observer of order p = 4 >= n / m = 2 can be deadbeat, so the model is exact
    // from sample p on: round-off only (measured 1.1e-15; the budget of the at-rest
    // test above).
    assert!(err < 1e-9, "unknown initial state: {err:e}");
    assert_eq!(
        unknown.equations,
        cut.iter().map(|c| c.len() - p).sum::<usize>()
    );
    let at_rest = params.fit(&cut).unwrap();
    let err = max_relative_difference(&at_rest.markov, &want);
    // The first p equations of each record read zeros for a past that moved: an error
    // of the size of the response in 12 of 1650 equations (measured 1.5e-3, twelve
    // orders above the round-off of the exact fit).
    assert!(err > 1e-4, "at rest assumed: {err:e}");
    // Records too short for the skipped equations are refused by length.
    let short = vec![Record::new(
        cut[0].inputs.columns(0, p + 1).into_owned(),
        cut[0].outputs.columns(0, p + 1).into_owned(),
    )];
    assert!(matches!(
        params.initial_state(InitialState::Unknown).fit(&short),
        Err(OkidError::Data(DataError::TooShort { .. }))
    ));
}

/// The matrix whose spectral radius gates the observer is the block companion matrix
/// transposed and permuted (entry for entry), and its radius is the companion's.
#[test]
fn permuted_companion_is_a_similarity_of_the_companion() {
    let mut rng = ChaCha8Rng::seed_from_u64(37);
    for &(m, p) in &[(1, 1), (1, 5), (2, 1), (2, 7), (3, 20), (4, 3)] {
        let b: Vec<DMatrix<f64>> = (0..p)
            .map(|_| DMatrix::from_fn(m, m, |_, _| 0.4 * normal(&mut rng)))
            .collect();
        let plain = companion(&b, m);
        let permuted = companion_for_radius(&b, m);
        let pos = |k: usize| (k % m) * p + p - 1 - k / m;
        for a in 0..m * p {
            for c in 0..m * p {
                assert_eq!(permuted[(pos(a), pos(c))], plain[(c, a)], "m {m} p {p}");
            }
        }
        // Nothing below the subdiagonal outside the coefficients' columns: the reduction
        // to Hessenberg form has nothing to do before column p - 1.
        for c in 0..m * p {
            if c % p != p - 1 {
                for row in c + 2..m * p {
                    assert_eq!(permuted[(row, c)], 0.0, "m {m} p {p} column {c}");
                }
            }
        }
        let want = linalg::spectral_radius(&plain).unwrap();
        let got = linalg::spectral_radius(&permuted).unwrap();
        // Two backward-stable eigenvalue computations of the same spectrum (different
        // reductions): round-off, scaled by the conditioning of the largest root
        // (measured at most 4.5e-15 relative here); 1e-10 relative still fails any wrong entry.
        assert!(
            (got - want).abs() <= 1e-10 * want.max(1e-300),
            "m {m} p {p}: {got} against {want}"
        );
    }
}

/// Both recursions against the naive sums over nalgebra products, for every shape and
/// length relation: `m != r` both ways, leads 0 to 3, outputs 1 to 5 (the unrolled 2, 3, 4
/// and the generic path), fewer input coefficients than terms asked (`a_k` zero past them)
/// and more, fewer output coefficients than lags (the sums stop at `p`) and more than the
/// terms (the lags never reached).
#[test]
fn markov_recursions_match_the_naive_sums_for_every_shape() {
    let mut rng = ChaCha8Rng::seed_from_u64(61);
    let mut worst = 0.0f64;
    for &(m, r) in &[(1usize, 1usize), (2, 3), (3, 1), (4, 2), (5, 7), (3, 3)] {
        for leads in 0..=3 {
            for &(inputs, outputs, count) in &[(4usize, 3usize, 9usize), (12, 2, 5), (3, 12, 6)] {
                let inputs = inputs + leads;
                // Coefficients of norm about 0.3 per entry: terms stay of order one.
                let a: Vec<DMatrix<f64>> = (0..inputs)
                    .map(|_| DMatrix::from_fn(m, r, |_, _| normal(&mut rng)))
                    .collect();
                let b: Vec<DMatrix<f64>> = (0..outputs)
                    .map(|_| DMatrix::from_fn(m, m, |_, _| 0.3 * normal(&mut rng) / m as f64))
                    .collect();
                // g[k] = a_k + sum_{i >= 1} b_i g[k - i], k = -leads .., zero before -leads.
                let total = leads + count;
                let mut g: Vec<DMatrix<f64>> = Vec::with_capacity(total);
                for idx in 0..total {
                    let mut v = a.get(idx).cloned().unwrap_or_else(|| DMatrix::zeros(m, r));
                    for (i, bi) in b.iter().enumerate() {
                        if idx > i {
                            v += bi * &g[idx - i - 1];
                        }
                    }
                    g.push(v);
                }
                let (lead, markov) = system_markov(&a, &b, leads, count);
                assert_eq!((lead.len(), markov.len()), (leads, count));
                let scale = g.iter().map(|x| x.amax()).fold(1.0, f64::max);
                for (j, got) in lead.iter().enumerate() {
                    let e = (got - &g[leads - 1 - j]).amax() / scale;
                    worst = worst.max(e);
                    assert!(
                        e < 1e-13,
                        "m {m} r {r} leads {leads}: g[-{}] off by {e:e}",
                        j + 1
                    );
                }
                for (k, got) in markov.iter().enumerate() {
                    assert_eq!(got.shape(), (m, r));
                    let e = (got - &g[leads + k]).amax() / scale;
                    worst = worst.max(e);
                    // The same sums through nalgebra's products: round-off of a few terms of
                    // order one at most (measured: equal bit for bit, the same order); a
                    // missing, extra or misplaced lag gives order 0.1.
                    assert!(e < 1e-13, "m {m} r {r} leads {leads}: Y_{k} off by {e:e}");
                }
                // h_k = -b_k + sum_{i = 1 .. k-1} b_i h_{k-i}, b_k zero past p.
                let mut h: Vec<DMatrix<f64>> = Vec::with_capacity(count);
                for k in 1..=count {
                    let mut v = b
                        .get(k - 1)
                        .map(|x| -x)
                        .unwrap_or_else(|| DMatrix::zeros(m, m));
                    for i in 1..k {
                        if let Some(bi) = b.get(i - 1) {
                            v += bi * &h[k - i - 1];
                        }
                    }
                    h.push(v);
                }
                let got = observer_gain_markov(&b, count);
                assert_eq!(got.len(), count);
                let scale = h.iter().map(|x| x.amax()).fold(f64::MIN_POSITIVE, f64::max);
                for (k, (x, y)) in got.iter().zip(&h).enumerate() {
                    let e = (x - y).amax() / scale;
                    worst = worst.max(e);
                    assert!(e < 1e-13, "m {m} p {outputs}: h_{} off by {e:e}", k + 1);
                }
            }
        }
    }
    eprintln!("worst relative difference: {worst:e}");
}

/// Random records (no system behind them: the Gram matrix does not care), channels with
/// different means and scales so that no two columns of the regression are alike.
fn random_records(rng: &mut ChaCha8Rng, r: usize, m: usize, lengths: &[usize]) -> Vec<Record> {
    lengths
        .iter()
        .map(|&len| {
            let inputs = DMatrix::from_fn(r, len, |ch, _| (ch as f64 + 1.0) * normal(rng) + 0.3);
            let outputs = DMatrix::from_fn(m, len, |ch, _| {
                normal(rng) / (ch as f64 + 1.0) - 0.2 * ch as f64
            });
            Record::new(inputs, outputs)
        })
        .collect()
}

/// Largest entry difference of the Gram matrices, relative to the oracle's largest entry.
fn gram_error(got: &Moments, records: &[Record], layout: &Layout) -> f64 {
    let z = regression_matrix(records, layout);
    let want = z.transpose() * &z;
    assert_eq!(got.equations, z.nrows());
    (&got.gram - &want).amax() / want.amax()
}

/// The FFT correlations at every boundary of their blocks: records whose length plus the
/// largest lag difference `dmax = p + q` is one below, at and one above the one-block
/// limit (8192), lengths at, one below and one above the 8192 mark itself, one sample
/// past one and two blocks of `8192 - dmax` (a last block of one sample, whose extension
/// is empty), a last block exactly `dmax` long, records just long enough for the order,
/// the leads and the skipped equations, and tiny transforms of odd length (3 and 9),
/// with several inputs and outputs either way round, leads, and the unknown-initial-state
/// layout. Oracle: the Gram matrix of the regression written out row by row.
#[test]
fn lagged_products_at_every_block_boundary_equal_the_gram_matrix() {
    let mut rng = ChaCha8Rng::seed_from_u64(71);
    let mut worst = 0.0f64;
    // (outputs, inputs, order, leads, skipped equations)
    for &(m, r, p, q, skip) in &[
        (1usize, 1usize, 1usize, 0usize, 0usize),
        (2, 3, 3, 2, 0),
        (3, 1, 2, 1, 2),
        (1, 2, 4, 3, 4),
        (2, 2, 1, 0, 1),
    ] {
        let layout = Layout { r, m, q, p, skip };
        let dmax = p + q;
        let block = 8192 - dmax;
        let shortest = p + q + skip + 1;
        let mut lengths = vec![
            shortest,
            shortest + 1,
            // Transforms of 3 and 9 points when they fit (`fft_len` of 2^a 3^b).
            3usize.saturating_sub(dmax).max(shortest),
            9usize.saturating_sub(dmax).max(shortest),
            8191 - dmax,
            8192 - dmax,
            8193 - dmax,
            8191,
            8192,
            8193,
            block + 1,
            block + dmax,
            2 * block,
            2 * block + 1,
            16384 + 1,
        ];
        lengths.sort_unstable();
        for &len in &lengths {
            let records = random_records(&mut rng, r, m, &[len]);
            let got = Moments::of_record(&records[0], &layout);
            let e = gram_error(&got, &records, &layout);
            worst = worst.max(e);
            // The FFT's round-off, eps log2(n) of sqrt(sum x_a^2 sum x_b^2) (module docs),
            // against sums of up to 16385 products: measured at most 4.4e-15 of the
            // largest entry (one input, one output); a single product left in or out is
            // 6e-5 of it or more.
            assert!(
                e < 1e-12,
                "m={m} r={r} p={p} q={q} skip={skip} len={len}: {e:e}"
            );
        }
        // All of them together (records of different lengths summed in order).
        let records = random_records(&mut rng, r, m, &lengths);
        let refs: Vec<&Record> = records.iter().collect();
        let got = Moments::of_records(&refs, &layout);
        let e = gram_error(&got, &records, &layout);
        worst = worst.max(e);
        // Same budget: sums of ~75000 products (measured at most 1.6e-14).
        assert!(e < 1e-12, "m={m} r={r} p={p} q={q} skip={skip} all: {e:e}");
    }
    eprintln!("worst relative difference: {worst:e}");
}

/// A resample's moments as the total minus some records' equal the moments accumulated
/// from the other records directly, for every subset of four records (of lengths on
/// both sides of the block limit), and removing the records one at a time in any order
/// gives the same; the channel sums of squares, samples and equations follow.
#[test]
fn moments_without_any_subset_equal_those_of_the_rest() {
    let mut rng = ChaCha8Rng::seed_from_u64(72);
    let (m, r, p, q, skip) = (2, 2, 3, 1, 3);
    let layout = Layout { r, m, q, p, skip };
    let records = random_records(&mut rng, r, m, &[9, 700, 8190, 9000]);
    let each: Vec<Moments> = records
        .iter()
        .map(|rec| Moments::of_record(rec, &layout))
        .collect();
    let refs: Vec<&Record> = records.iter().collect();
    let total = Moments::of_records(&refs, &layout);
    let scale = total.gram.amax();
    let mut worst = 0.0f64;
    for mask in 0u32..16 {
        let (out, kept): (Vec<usize>, Vec<usize>) = (0..4).partition(|&i| mask & (1 << i) != 0);
        let mut removed = Moments::zeros(&layout);
        for &i in out.iter().rev() {
            removed.add(&each[i]);
        }
        let got = total.without(&removed);
        let kept_refs: Vec<&Record> = kept.iter().map(|&i| &records[i]).collect();
        let want = Moments::of_records(&kept_refs, &layout);
        // One at a time, in the opposite order.
        let mut stepwise = total.clone();
        for &i in &out {
            stepwise = stepwise.without(&each[i]);
        }
        for (name, g) in [("at once", &got), ("one by one", &stepwise)] {
            let e = (&g.gram - &want.gram).amax() / scale;
            worst = worst.max(e);
            // Cancellation against the removed records' share: round-off of the total's
            // entries (measured at most 2.0e-16 of the largest entry); relative to the
            // total's scale, since an all-removed resample is zero up to that round-off.
            assert!(e < 1e-13, "mask {mask:04b} {name}: {e:e}");
            assert_eq!(g.equations, want.equations);
            // The channels' RMS (sums of squares over samples, both subtracted): the
            // same cancellation, relative to the total's sums of squares; 1 for an empty
            // resample either way.
            let (gs, ws, ts) = (g.scales(), want.scales(), total.scales());
            for ((a, b), t) in
                gs.u.iter()
                    .chain(&gs.y)
                    .zip(ws.u.iter().chain(&ws.y))
                    .zip(ts.u.iter().chain(&ts.y))
            {
                assert!(
                    (a * a - b * b).abs() <= 1e-12 * t * t,
                    "mask {mask:04b}: rms {a} {b}"
                );
            }
        }
        if !kept.is_empty() {
            let kept_records: Vec<Record> = kept.iter().map(|&i| records[i].clone()).collect();
            let e = gram_error(&got, &kept_records, &layout) * want.gram.amax() / scale;
            assert!(e < 1e-13, "mask {mask:04b} against the regression: {e:e}");
        }
    }
    eprintln!("worst relative difference: {worst:e}");
}

/// The Gram matrix of every lower order cut out of the moments and scaled equals that of
/// the lower-order regression (same leads and skipped equations) with its channels
/// scaled, and the nested residual sums of squares from the elimination equal the least
/// squares residuals of each order (nalgebra's SVD solve of the scaled regression).
#[test]
fn scaled_gram_and_nested_rss_match_the_regression_of_every_order() {
    let mut rng = ChaCha8Rng::seed_from_u64(73);
    let mut worst = 0.0f64;
    for &(m, r, p, q, skip) in &[(2usize, 1usize, 4usize, 2usize, 4usize), (1, 3, 3, 0, 0)] {
        let layout = Layout { r, m, q, p, skip };
        let records = random_records(&mut rng, r, m, &[300, 8200, 57]);
        let refs: Vec<&Record> = records.iter().collect();
        let moments = Moments::of_records(&refs, &layout);
        let s = moments.scales();
        // Scales against the channels' RMS over all samples.
        for ch in 0..r + m {
            let (mut ss, mut n) = (0.0, 0);
            for rec in &records {
                for k in 0..rec.len() {
                    let v = if ch < r {
                        rec.inputs[(ch, k)]
                    } else {
                        rec.outputs[(ch - r, k)]
                    };
                    ss += v * v;
                    n += 1;
                }
            }
            let want = (ss / n as f64).sqrt();
            let got = if ch < r { s.u[ch] } else { s.y[ch - r] };
            // Square root of an FFT lag-0 sum: round-off of the FFT (eps log2 n).
            assert!((got / want - 1.0).abs() < 1e-13, "channel {ch}");
        }
        let rss = nested_rss(&moments.scaled_gram(&layout, &s), &layout).unwrap();
        for order in 1..=p {
            let lower = Layout { p: order, ..layout };
            let got = moments.scaled_gram(&lower, &s);
            let mut z = regression_matrix(&records, &lower);
            let ncols = lower.columns(order);
            for j in 0..ncols + m {
                // Channel of column j: leads and lag 0 inputs, then lags of all
                // channels, then the targets (the module docs' layout).
                let ch = if j < (q + 1) * r {
                    j % r
                } else if j < ncols {
                    (j - (q + 1) * r) % (r + m)
                } else {
                    r + j - ncols
                };
                let sc = if ch < r { s.u[ch] } else { s.y[ch - r] };
                z.column_mut(j).scale_mut(1.0 / sc);
            }
            let want = z.transpose() * &z;
            let e = (&got - &want).amax() / want.amax();
            // As in the block-boundary test: FFT round-off (measured 1e-15).
            assert!(e < 1e-12, "order {order}: {e:e}");
            let x = z.columns(0, ncols).into_owned();
            let y = z.columns(ncols, m).into_owned();
            let theta = x.clone().svd(true, true).solve(&y, 1e-14).unwrap();
            let want_rss = (&y - &x * theta).norm_squared();
            let e = (rss[order - 1] - want_rss).abs() / want_rss;
            worst = worst.max(e);
            // Random regressors: the scaled regression's condition is ~10, so the normal
            // equations lose eps * 1e2 at most (measured 6.4e-16); 1e-10 still fails the
            // residual of any neighbouring order (they differ by 1.7e-4 to 7.8e-3
            // relative here, measured).
            assert!(
                e < 1e-10,
                "order {order}: rss {} against {want_rss}",
                rss[order - 1]
            );
        }
    }
    eprintln!("worst relative rss difference: {worst:e}");
}
