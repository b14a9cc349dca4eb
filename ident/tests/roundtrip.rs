//! Round trips: records generated inside the test suite from known M, K and Rayleigh
//! damping (2 and 3 DOF, 2-10 Hz, ~0.5 % damping), identified back.

mod common;

use common::*;
use ident::okid::OkidError;
use ident::{Error, Identification, Identifier, Intersample, StructuralRule, Warning};
use rand::SeedableRng;
use rand::rngs::ChaCha8Rng;

/// Errors of one identification against the frame it came from.
#[derive(Debug)]
struct Errors {
    /// Largest relative frequency error.
    frequency: f64,
    /// Largest relative damping-ratio error.
    damping_ratio: f64,
    /// Relative Frobenius errors.
    mass: f64,
    stiffness: f64,
    damping_mkr: f64,
    damping_rayleigh: f64,
}

fn errors(frame: &ShearFrame, r: &Identification) -> Errors {
    let truth = frame.modes();
    assert_eq!(r.frequencies_hz.len(), truth.len(), "one MKR mode per DOF");
    let mut frequency = 0.0f64;
    let mut damping_ratio = 0.0f64;
    for ((f, xi), (f0, xi0)) in r.frequencies_hz.iter().zip(&r.damping_ratios).zip(&truth) {
        frequency = frequency.max(((f - f0) / f0).abs());
        damping_ratio = damping_ratio.max(((xi - xi0) / xi0).abs());
    }
    Errors {
        frequency,
        damping_ratio,
        mass: rel(&r.mass, &frame.mass),
        stiffness: rel(&r.stiffness, &frame.stiffness),
        damping_mkr: rel(&r.damping_mkr, &frame.damping),
        damping_rayleigh: rel(&r.damping_rayleigh, &frame.damping),
    }
}

fn hits(rng: &mut ChaCha8Rng, count: usize, pre: usize) -> Vec<Hit> {
    (0..count).map(|_| Hit::random(rng, pre)).collect()
}

/// (a) Held records (force averaged and held per sample, exact ZOH discretization), three
/// hits with 4-8 zero pre-trigger samples: the discrete model is exact, so `Zoh` recovers
/// everything to round-off.
#[test]
fn held_records_with_zoh() {
    let mut rng = ChaCha8Rng::seed_from_u64(201);
    for frame in [frame2(), frame3()] {
        let records: Vec<_> = (0..3)
            .flat_map(|i| held_records(&frame, &hits(&mut rng, 1, 4 + 2 * i)))
            .collect();
        let r = Identifier::default()
            .intersample(Intersample::Zoh)
            .identify(&records, DT_S)
            .unwrap();
        let e = errors(&frame, &r);
        println!("held/zoh {} DOF: {e:?}", frame.dofs());
        assert!(r.warnings.is_empty(), "{:?}", r.warnings);
        assert_eq!(r.model_order, 2 * frame.dofs());
        // Specification: f 0.01 %, xi 1 %, M and K 0.1 %. The data are exact for this
        // model, so the chain is round-off limited (measured: f 2e-13, xi 3e-12, M and K
        // 4e-14, MKR damping 8e-13); 1e-8 keeps a wide margin yet catches any modelling
        // error.
        assert!(e.frequency < 1e-8, "{e:?}");
        assert!(e.damping_ratio < 1e-8, "{e:?}");
        assert!(e.mass < 1e-8 && e.stiffness < 1e-8, "{e:?}");
        assert!(e.damping_mkr < 1e-6 && e.damping_rayleigh < 1e-6, "{e:?}");
        assert!(r.consistency < 1e-10);
    }
}

/// (b) Band-limited records generated in the frequency domain (a 25 Hz zero-phase
/// low-pass with a smooth stop at 32 Hz applied to the hammer pulse, response by
/// `H(j omega)`), three hits with a one-second pre-trigger. `Bandlimited` (8 leads,
/// rcond 1e-4, Markov offset 10, impulse-invariant residues) recovers the frame.
#[test]
fn bandlimited_records_with_bandlimited() {
    let mut rng = ChaCha8Rng::seed_from_u64(202);
    for frame in [frame2(), frame3()] {
        let records = bandlimited_records(&frame, &hits(&mut rng, 3, 64));
        let r = Identifier::default()
            .intersample(Intersample::Bandlimited)
            .identify(&records, DT_S)
            .unwrap();
        let e = errors(&frame, &r);
        println!("band-limited/bandlimited {} DOF: {e:?}", frame.dofs());
        assert!(r.warnings.is_empty(), "{:?}", r.warnings);
        // Specification: f 0.01 %, xi 1 %, M and K 0.1 %. Measured: f 2e-8, xi 2e-6, M and
        // K 3e-6 to 6e-6 (what remains is the band-limited relation's infinite order and
        // the filter precursor cut at the record start). The specification holds with a
        // margin of over 100.
        assert!(e.frequency < 1e-4, "{e:?}");
        assert!(e.damping_ratio < 1e-2, "{e:?}");
        assert!(e.mass < 1e-3 && e.stiffness < 1e-3, "{e:?}");
        // MKR damping is hypersensitive (paper's finding) but still within 1 % here
        // (measured 8e-4); Rayleigh damping inherits xi (measured 6e-6).
        assert!(e.damping_mkr < 1e-2, "{e:?}");
        assert!(e.damping_rayleigh < 1e-3, "{e:?}");
    }
}

/// Band-limited records need quiet before the hit: the filtered force and response start
/// before it. A short pre-trigger is reported and costs accuracy (measured with one of
/// three hits 8 samples in: M 3.4e-3, K 1.7e-3, against 5e-6 with all 64 samples in).
#[test]
fn short_pretrigger_on_bandlimited_records_is_reported() {
    let frame = frame2();
    let mut rng = ChaCha8Rng::seed_from_u64(204);
    let mut hit_list = hits(&mut rng, 3, 64);
    hit_list[1] = Hit::random(&mut rng, 8);
    let records = bandlimited_records(&frame, &hit_list);
    let r = Identifier::default().identify(&records, DT_S).unwrap();
    let e = errors(&frame, &r);
    println!("band-limited, one 8-sample pre-trigger: {e:?}");
    assert!(
        matches!(
            r.warnings.as_slice(),
            [Warning::ShortPretrigger {
                record: 1,
                peak_sample: 8 | 9,
                recommended: 16
            }]
        ),
        "{:?}",
        r.warnings
    );
    // Held records have no precursor: no warning whatever the pre-trigger.
    let held = held_records(&frame, &[Hit::random(&mut rng, 2)]);
    let r = Identifier::default()
        .intersample(Intersample::Zoh)
        .identify(&held, DT_S)
        .unwrap();
    assert!(r.warnings.is_empty());
}

/// ZOH on band-limited records is biased (NOTES): by several percent on M and K through
/// the residue conversion alone, and the MKR damping is off by far more.
#[test]
fn zoh_on_bandlimited_records_is_biased() {
    let mut rng = ChaCha8Rng::seed_from_u64(203);
    for frame in [frame2(), frame3()] {
        let records = bandlimited_records(&frame, &hits(&mut rng, 3, 64));
        // Same OKID/ERA settings as `Bandlimited`, only the residue conversion differs.
        let conversion_only = Identifier::default()
            .intersample(Intersample::Zoh)
            .leads(8)
            .rcond(1e-4)
            .markov_offset(10)
            .identify(&records, DT_S)
            .unwrap();
        let e = errors(&frame, &conversion_only);
        println!("band-limited/zoh conversion {} DOF: {e:?}", frame.dofs());
        // The poles do not depend on the conversion (measured f 2e-8).
        assert!(e.frequency < 1e-4, "{e:?}");
        // Measured 2 DOF: M 5 %, K 7 %; 3 DOF: M 5 %, K 6 %. "Several percent".
        assert!(e.mass > 0.02 && e.stiffness > 0.02, "{e:?}");
        assert!(e.damping_mkr > 1.0, "{e:?}");

        // Plain ZOH defaults (no leads, offset 0, rcond 1e-8): the observer's AR part is
        // unstable on band-limited data until rcond is raised to 1e-4 (safeguard), and the
        // result is biased as well.
        let defaults = Identifier::default()
            .intersample(Intersample::Zoh)
            .identify(&records, DT_S)
            .unwrap();
        let e = errors(&frame, &defaults);
        println!("band-limited/zoh defaults {} DOF: {e:?}", frame.dofs());
        assert!(e.mass > 0.02 && e.stiffness > 0.02, "{e:?}");
        let raises: Vec<_> = defaults
            .warnings
            .iter()
            .filter(|w| matches!(w, Warning::RcondRaised { .. }))
            .collect();
        assert!(!raises.is_empty(), "{:?}", defaults.warnings);
        assert_eq!(defaults.observer.unwrap().rcond_raises, raises.len());
        for w in &raises {
            assert!(w.to_string().contains("rcond raised"));
        }
        // Without raises allowed the instability is a typed error.
        let err = Identifier::default()
            .intersample(Intersample::Zoh)
            .max_rcond_raises(0)
            .identify(&records, DT_S)
            .unwrap_err();
        assert!(
            matches!(err, Error::Okid(OkidError::UnstableObserver { spectral_radius, .. }) if spectral_radius > 1.0),
            "{err}"
        );
    }
}

/// (c) 1 % Gaussian output noise (of each channel's RMS), ten hits, automatic observer
/// and model orders, for both kinds of records and three seeds each.
#[test]
fn noisy_records() {
    for (kind, intersample) in [
        ("held", Intersample::Zoh),
        ("band-limited", Intersample::Bandlimited),
    ] {
        for frame in [frame2(), frame3()] {
            for seed in 0..3u64 {
                let mut rng = ChaCha8Rng::seed_from_u64(300 + seed);
                let hit_list = hits(&mut rng, 10, if kind == "held" { 6 } else { 64 });
                let mut records = match intersample {
                    Intersample::Zoh => held_records(&frame, &hit_list),
                    Intersample::Bandlimited => bandlimited_records(&frame, &hit_list),
                };
                add_output_noise(&mut records, 0.01, &mut rng);
                let r = Identifier::default()
                    .intersample(intersample)
                    .identify(&records, DT_S)
                    .unwrap();
                let e = errors(&frame, &r);
                println!("noisy {kind} {} DOF seed {seed}: {e:?}", frame.dofs());
                // The automatic orders find every structural mode, and only those.
                assert_eq!(r.mkr_modes.len(), frame.dofs());
                assert_eq!(r.model_order, 2 * frame.dofs(), "{:?}", r.warnings);
                // Specification: f 0.05 %, M and K 1 %, Rayleigh damping 10 %. Measured
                // worst over the twelve runs: f 4e-5, xi 1 %, M 2.5e-3, K 6e-4, Rayleigh
                // damping 2.2e-3 (MKR damping 2-9 %, not specified).
                assert!(e.frequency < 5e-4, "{e:?}");
                assert!(e.mass < 1e-2 && e.stiffness < 1e-2, "{e:?}");
                assert!(e.damping_rayleigh < 0.1, "{e:?}");
            }
        }
    }
}

/// The test-data generators themselves: the FFT against a direct DFT, and the band-limited
/// force against its analytic impulse (sum of samples times dt = integral of the pulse).
#[test]
fn generators_are_consistent() {
    let n = 64;
    let x: Vec<C64> = (0..n)
        .map(|k| C64::new((k as f64 * 0.37).sin(), (k as f64 * 0.11).cos()))
        .collect();
    let mut y = x.clone();
    fft_in_place(&mut y);
    for (k, yk) in y.iter().enumerate() {
        let direct: C64 = x
            .iter()
            .enumerate()
            .map(|(j, xj)| {
                xj * C64::from_polar(1.0, -2.0 * std::f64::consts::PI * (j * k) as f64 / n as f64)
            })
            .sum();
        // O(n log n) vs O(n^2) summation of O(1) terms: round-off only.
        assert!((yk - direct).norm() < 1e-11, "bin {k}");
    }
    let hit = Hit {
        amplitude_n: 100.0,
        duration_s: 0.003,
        onset_s: 64.0 * DT_S,
    };
    let records = bandlimited_records(&frame2(), &[hit]);
    let impulse: f64 = records[0].inputs.iter().sum::<f64>() * DT_S;
    let analytic = 2.0 * hit.amplitude_n * hit.duration_s / std::f64::consts::PI;
    // The filter passes DC; only the precursor before the record start and the record's
    // tail are missing (below 1e-5 of the peak here).
    assert!(
        (impulse - analytic).abs() < 1e-5 * analytic,
        "{impulse} vs {analytic}"
    );
    let held = held_records(&frame2(), &[hit]);
    let held_impulse: f64 = held[0].inputs.iter().sum::<f64>() * DT_S;
    assert!((held_impulse - analytic).abs() < 1e-12 * analytic);
    // Precursor: the zero-phase band-limited force is not zero before the hit; 56-64
    // samples ahead of it (the record start) it has decayed to a few 1e-6 of the peak,
    // which is what the zero-initial-condition assumption neglects.
    let before = records[0].inputs.columns(0, 8).amax() / records[0].inputs.amax();
    assert!(before < 2e-5, "precursor {before}");
}

/// Timing of one ten-hit identification (2 DOF, 2048 samples). Run with
/// `cargo test --release -p ident --test roundtrip -- --ignored --nocapture`.
#[test]
#[ignore]
fn timing_of_a_ten_hit_identification() {
    let mut rng = ChaCha8Rng::seed_from_u64(400);
    let frame = frame2();
    for (kind, intersample) in [
        ("held", Intersample::Zoh),
        ("band-limited", Intersample::Bandlimited),
    ] {
        let hit_list = hits(&mut rng, 10, 64);
        let mut records = match intersample {
            Intersample::Zoh => held_records(&frame, &hit_list),
            Intersample::Bandlimited => bandlimited_records(&frame, &hit_list),
        };
        add_output_noise(&mut records, 0.01, &mut rng);
        let id = Identifier::default().intersample(intersample);
        let runs = 20;
        let start = std::time::Instant::now();
        for _ in 0..runs {
            std::hint::black_box(id.identify(&records, DT_S).unwrap());
        }
        println!("{kind}: {:?} per identification", start.elapsed() / runs);
    }
}

/// An over-specified model order (20 states for 2 or 3 DOF) on noisy band-limited records:
/// the extra modes are flagged as noise (their input EMAC, hence CMI, is ~0, against ~1 for
/// the structural modes), MKR uses the structural ones. With a rule that accepts everything,
/// the selection by `cmi * msv_relative` still keeps the right modes and says so.
#[test]
fn overspecified_order_separates_noise_modes() {
    for frame in [frame2(), frame3()] {
        let mut rng = ChaCha8Rng::seed_from_u64(700);
        let mut records = bandlimited_records(&frame, &hits(&mut rng, 10, 64));
        add_output_noise(&mut records, 0.01, &mut rng);
        let id = Identifier::default().order(ident::ModelOrder::Fixed(20));
        let r = id.identify(&records, DT_S).unwrap();
        let e = errors(&frame, &r);
        println!("over-specified {} DOF: {e:?}", frame.dofs());
        assert_eq!(r.model_order, 20);
        assert!(r.modes.len() > frame.dofs());
        let structural: Vec<_> = r.modes.iter().filter(|m| m.structural).collect();
        assert_eq!(structural.len(), frame.dofs());
        for m in &r.modes {
            // Measured: structural CMI > 0.999, noise CMI < 0.01.
            if m.structural {
                assert!(m.indicators.cmi > 0.9, "{m:?}");
            } else {
                assert!(m.indicators.cmi < 0.5, "{m:?}");
            }
        }
        // Same specification as the noisy round trips (measured M 1.4e-3, K 8e-4).
        assert!(
            e.frequency < 5e-4 && e.mass < 1e-2 && e.stiffness < 1e-2,
            "{e:?}"
        );

        let accept_all = StructuralRule {
            min_cmi: 0.0,
            min_msv_relative: 0.0,
            max_damping_ratio: 1.0,
            max_nyquist_fraction: 1.0,
            band_hz: None,
        };
        let all = id
            .clone()
            .rule(accept_all)
            .identify(&records, DT_S)
            .unwrap();
        assert_eq!(all.frequencies_hz, r.frequencies_hz);
        assert!(
            all.warnings
                .iter()
                .any(|w| matches!(w, Warning::ExtraStructuralModes { kept_hz, .. } if kept_hz.len() == frame.dofs())),
            "{:?}",
            all.warnings
        );
    }
}
