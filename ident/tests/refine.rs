//! Refinement of M, K and damping: noise-free round trips, typed errors, the bound for the
//! paper's case 1 and timing.

mod common;

use common::*;
use ident::mkr::MatrixKind;
use ident::refine::{
    Dashpot, Node, NoiseLevels, NoiseModel, Parametrization, RefineError, Refiner, SecondOrder,
    StopReason,
};
use ident::{Channel, DataError, Intersample, Record};
use nalgebra::DMatrix;
use rand::rngs::ChaCha8Rng;
use rand::{RngExt, SeedableRng};

fn hits(rng: &mut ChaCha8Rng, count: usize, pre: usize) -> Vec<Hit> {
    (0..count).map(|_| Hit::random(rng, pre)).collect()
}

#[test]
fn noise_free_records_give_the_true_matrices() {
    let mut rng = ChaCha8Rng::seed_from_u64(900);
    let cases = [
        ("2 DOF full", frame2(), Parametrization::Full),
        ("3 DOF full", frame3(), Parametrization::Full),
        ("3 DOF shear", frame3(), shear3()),
    ];
    for (name, base, parametrization) in cases {
        for (damping_kind, frame) in [
            ("proportional", base.clone()),
            (
                "extra dashpot",
                base.clone().storey_dashpot(base.dofs(), 0.2),
            ),
        ] {
            for intersample in [Intersample::Zoh, Intersample::Bandlimited] {
                let hit_list = hits(&mut rng, 3, 64);
                let records = match intersample {
                    Intersample::Zoh => held_records(&frame, &hit_list),
                    Intersample::Bandlimited => bandlimited_records(&frame, &hit_list),
                };
                let start = perturbed(&frame, &mut rng);
                let t0 = std::time::Instant::now();
                let r = Refiner::default()
                    .intersample(intersample)
                    .parametrization(parametrization.clone())
                    .refine(&records, DT_S, &start)
                    .unwrap();
                let (em, ek, ec) = (
                    rel(&r.mass, &frame.mass),
                    rel(&r.stiffness, &frame.stiffness),
                    rel(&r.damping, &frame.damping),
                );
                println!(
                    "{name}, {damping_kind}, {intersample:?}: M {em:.1e} K {ek:.1e} damping {ec:.1e} (start damping {:.1e}); {} iterations, {} noise updates, {}, cost {:.3e}, {:?}",
                    rel(&start.damping, &frame.damping),
                    r.iterations,
                    r.noise_updates,
                    r.stop,
                    r.cost,
                    t0.elapsed()
                );
                assert!(r.stop.converged(), "{:?}", r.stop);
                assert!(em < 1e-4 && ek < 1e-4 && ec < 1e-4, "{em:e} {ek:e} {ec:e}");
            }
        }
    }
}

/// Noise of `fraction` times each channel's RMS over the whole campaign (a sensor noise
/// floor, the same for every hit).
fn campaign_levels(records: &[Record], fraction: f64, force: bool) -> NoiseLevels {
    let rms = |rows: &dyn Fn(&Record) -> DMatrix<f64>, ch: usize| {
        let (s, c) = records.iter().fold((0.0, 0usize), |(s, c), r| {
            (s + rows(r).row(ch).norm_squared(), c + r.len())
        });
        (s / c as f64).sqrt()
    };
    let m = records[0].outputs.nrows();
    let r = records[0].inputs.nrows();
    NoiseLevels {
        outputs: (0..m)
            .map(|i| fraction * rms(&|rec: &Record| rec.outputs.clone(), i))
            .collect(),
        inputs: (0..r)
            .map(|l| {
                if force {
                    fraction * rms(&|rec: &Record| rec.inputs.clone(), l)
                } else {
                    0.0
                }
            })
            .collect(),
    }
}

/// The bound for the paper's case 1 (eq. 44-45, damping 0.1755 M + 3.2283e-5 K), ten
/// band-limited hits, 1 % noise of each output channel's RMS; with and without 1 % noise on
/// the force.
#[test]
fn paper_case1_bound() {
    let frame = testkit::paper_case1();
    let truth = truth(&frame);
    let mut rng = ChaCha8Rng::seed_from_u64(1000);
    let records = bandlimited_records(&frame, &hits(&mut rng, 10, 64));
    let inputs: Vec<DMatrix<f64>> = records.iter().map(|r| r.inputs.clone()).collect();
    let refiner = Refiner::default().intersample(Intersample::Bandlimited);
    for force in [false, true] {
        let levels = campaign_levels(&records, 0.01, force);
        let t0 = std::time::Instant::now();
        let b = refiner.cramer_rao(&truth, DT_S, &inputs, &levels).unwrap();
        let elapsed = t0.elapsed();
        println!(
            "case 1, 1 % output noise, force noise {force} (bound computed in {elapsed:.1?}):"
        );
        let pct = |std: &DMatrix<f64>, v: &DMatrix<f64>, i: usize, j: usize| {
            100.0 * std[(i, j)] / v[(i, j)].abs()
        };
        for (name, v, std) in [
            ("M", &truth.mass, &b.mass_std),
            ("K", &truth.stiffness, &b.stiffness_std),
            ("R", &truth.damping, &b.damping_std),
        ] {
            println!(
                "  {name}: [0,0] {:.4} %  [0,1] {:.4} %  [1,1] {:.4} %",
                pct(std, v, 0, 0),
                pct(std, v, 0, 1),
                pct(std, v, 1, 1)
            );
        }
        for md in &b.modes {
            println!(
                "  f {:.4} Hz +- {:.2e} %, xi {:.5} +- {:.3} %",
                md.frequency_hz,
                100.0 * md.frequency_std_hz / md.frequency_hz,
                md.damping_ratio,
                100.0 * md.damping_ratio_std / md.damping_ratio
            );
        }
        // The claim to verify: "about 0.03 % for M and K and about 1 % for the damping
        // matrix". The diagonal entries of M and K are within 0.01-0.1 % and those of the
        // damping matrix within 0.5-2 % (measured without force noise: M 0.021/0.045 %,
        // K 0.030/0.053 %, damping 1.05/1.15 %; the small off-diagonal mass 0.0153 kg is
        // known to 0.47 %, the off-diagonal damping to 2.2 %; force noise adds 5-30 %).
        for i in 0..2 {
            for (v, std, lo, hi) in [
                (&truth.mass, &b.mass_std, 0.01, 0.1),
                (&truth.stiffness, &b.stiffness_std, 0.01, 0.1),
                (&truth.damping, &b.damping_std, 0.5, 2.0),
            ] {
                let p = pct(std, v, i, i);
                assert!(p > lo && p < hi, "{p} % not in ({lo}, {hi})");
            }
        }
    }
}

/// One refinement of a 10-hit, 2-DOF, 2048-sample band-limited campaign at 1 % noise (from
/// MKR-like errors) and one bound. In release both take well under a second (reported);
/// the limit here is for the test profile on a loaded machine.
#[test]
fn timing_of_one_refinement_and_one_bound() {
    let frame = frame2();
    let mut rng = ChaCha8Rng::seed_from_u64(1100);
    let clean = bandlimited_records(&frame, &hits(&mut rng, 10, 64));
    let levels = campaign_levels(&clean, 0.01, true);
    let mut records = clean.clone();
    for rec in records.iter_mut() {
        for (i, s) in levels.outputs.iter().enumerate() {
            for k in 0..rec.len() {
                rec.outputs[(i, k)] += s * rng.sample::<f64, _>(rand_distr::StandardNormal);
            }
        }
        for k in 0..rec.len() {
            rec.inputs[(0, k)] +=
                levels.inputs[0] * rng.sample::<f64, _>(rand_distr::StandardNormal);
        }
    }
    let start = perturbed(&frame, &mut rng);
    let refiner = Refiner::default();
    let t0 = std::time::Instant::now();
    let r = refiner.refine(&records, DT_S, &start).unwrap();
    let refine_time = t0.elapsed();
    let inputs: Vec<DMatrix<f64>> = clean.iter().map(|r| r.inputs.clone()).collect();
    let t0 = std::time::Instant::now();
    refiner
        .cramer_rao(&truth(&frame), DT_S, &inputs, &levels)
        .unwrap();
    let bound_time = t0.elapsed();
    println!(
        "one refinement: {refine_time:.1?} ({} steps, {} noise updates, {}); one bound: {bound_time:.1?}",
        r.iterations, r.noise_updates, r.stop
    );
    assert!(r.stop.converged());
    assert!(refine_time.as_secs_f64() < 5.0 && bound_time.as_secs_f64() < 5.0);
}

fn held_campaign() -> (ShearFrame, Vec<Record>) {
    let frame = frame2();
    let mut rng = ChaCha8Rng::seed_from_u64(950);
    let records = held_records(&frame, &hits(&mut rng, 2, 8));
    (frame, records)
}

fn truth(frame: &ShearFrame) -> SecondOrder {
    SecondOrder::new(
        frame.mass.clone(),
        frame.stiffness.clone(),
        frame.damping.clone(),
    )
}

#[test]
fn typed_errors() {
    let (frame, records) = held_campaign();
    let zoh = Refiner::default().intersample(Intersample::Zoh);
    let good = truth(&frame);

    // Initial M or K not positive definite.
    let mut bad = good.clone();
    bad.mass[(1, 1)] = -0.1;
    assert!(matches!(
        zoh.refine(&records, DT_S, &bad).unwrap_err(),
        RefineError::NotPositiveDefinite {
            matrix: MatrixKind::Mass,
            pivot: 1,
            ..
        }
    ));
    let mut bad = good.clone();
    bad.stiffness[(0, 1)] = 1000.0;
    bad.stiffness[(1, 0)] = 1000.0;
    assert!(matches!(
        zoh.refine(&records, DT_S, &bad).unwrap_err(),
        RefineError::NotPositiveDefinite {
            matrix: MatrixKind::Stiffness,
            ..
        }
    ));
    // Non-finite initial model.
    let mut bad = good.clone();
    bad.damping[(0, 0)] = f64::NAN;
    assert_eq!(
        zoh.refine(&records, DT_S, &bad).unwrap_err(),
        RefineError::NonFiniteModel
    );

    // Non-finite data.
    let mut nan = records.clone();
    nan[1].outputs[(0, 33)] = f64::NAN;
    assert!(matches!(
        zoh.refine(&nan, DT_S, &good).unwrap_err(),
        RefineError::Data(DataError::NonFinite {
            record: 1,
            channel: Channel::Output(0),
            sample: 33,
            ..
        })
    ));
    assert!(matches!(
        zoh.refine(&records, 0.0, &good).unwrap_err(),
        RefineError::Data(DataError::InvalidSampleInterval { .. })
    ));

    // Too few bins: two 6-sample records give 4 bins each, 12 real values per record for 2
    // outputs (DC and Nyquist are real), 24 in all, against 4 transient values per record
    // plus 9 parameters (17 unknowns) -- enough; 4-sample records give 8 each, 16 < 17.
    let short: Vec<Record> = (0..2)
        .map(|h| {
            Record::new(
                DMatrix::from_row_slice(1, 4, &[1.0, 0.5, 0.0, 0.0]),
                DMatrix::from_fn(2, 4, |i, k| ((h + i + k) as f64).sin() + 0.1),
            )
        })
        .collect();
    assert!(matches!(
        zoh.refine(&short, DT_S, &good).unwrap_err(),
        RefineError::TooFewBins { hit: None, .. }
    ));
    // A band edge so low that a record's bins cannot even carry its transient (DC only:
    // 2 real values for 4 transient values).
    let err = Refiner::default()
        .band_edge(0.0005)
        .refine(&records, DT_S, &good)
        .unwrap_err();
    assert_eq!(
        err,
        RefineError::TooFewBins {
            hit: Some(0),
            observations: 2,
            unknowns: 4
        }
    );
    // Three bins below the first mode (0.06 Hz) cannot tell M, K and damping apart.
    let err = Refiner::default()
        .band_edge(0.002)
        .refine(&records, DT_S, &good)
        .unwrap_err();
    assert!(
        matches!(err, RefineError::NotIdentifiable { parameters: 9, .. }),
        "{err}"
    );

    // Invalid parameters.
    for refiner in [
        Refiner::default().band_edge(0.0),
        Refiner::default().band_edge(1.5),
        Refiner::default().input_dofs(vec![]),
        Refiner::default().input_dofs(vec![0, 0]),
        Refiner::default().noise(NoiseModel::Known(NoiseLevels {
            outputs: vec![0.1, 0.0],
            inputs: vec![0.0],
        })),
        Refiner::default().parametrization(Parametrization::ShearFrame {
            dashpots: vec![Dashpot::between(Node::Dof(0), Node::Dof(0))],
        }),
        Refiner::default().parametrization(Parametrization::ShearFrame {
            dashpots: vec![Dashpot::between(Node::Ground, Node::Dof(5))],
        }),
        // Duplicates storey 1.
        Refiner::default().parametrization(Parametrization::ShearFrame {
            dashpots: vec![Dashpot::between(Node::Dof(1), Node::Dof(0))],
        }),
    ] {
        let err = refiner.refine(&records, DT_S, &good).unwrap_err();
        assert!(matches!(err, RefineError::InvalidParams { .. }), "{err}");
    }

    // The bound needs a model the parametrization can represent (frame2's M is not
    // diagonal).
    let inputs: Vec<DMatrix<f64>> = records.iter().map(|r| r.inputs.clone()).collect();
    let levels = NoiseLevels {
        outputs: vec![0.1, 0.1],
        inputs: vec![0.0],
    };
    assert!(matches!(
        zoh.clone()
            .parametrization(Parametrization::shear_frame())
            .cramer_rao(&good, DT_S, &inputs, &levels)
            .unwrap_err(),
        RefineError::NotRepresentable {
            matrix: MatrixKind::Mass,
            ..
        }
    ));
}

/// Shapes that code passes inconsistently are programming errors.
#[test]
#[should_panic(expected = "outputs")]
fn outputs_must_match_the_dofs() {
    let (_, records) = held_campaign();
    let f3 = frame3();
    let _ = Refiner::default().refine(&records, DT_S, &truth(&f3));
}

#[test]
#[should_panic(expected = "inputs")]
fn inputs_must_match_the_input_dofs() {
    let (frame, records) = held_campaign();
    let _ = Refiner::default()
        .input_dofs(vec![0, 1])
        .refine(&records, DT_S, &truth(&frame));
}

#[test]
#[should_panic(expected = "must be 2 x 2")]
fn matrices_must_have_one_size() {
    let _ = SecondOrder::new(
        DMatrix::identity(2, 2),
        DMatrix::identity(3, 3),
        DMatrix::identity(2, 2),
    );
}

/// The bound and the refinement share one likelihood: on noise-free band-limited records
/// (the generator's, not the bound's own simulation) with the same noise levels, the
/// Fisher information the refinement reports at its estimate equals the bound's.
#[test]
fn refinement_and_bound_share_the_likelihood() {
    let mut rng = ChaCha8Rng::seed_from_u64(960);
    for (frame, parametrization) in [
        (frame2().storey_dashpot(2, 0.2), Parametrization::Full),
        (frame3(), shear3()),
    ] {
        let records = bandlimited_records(&frame, &hits(&mut rng, 3, 64));
        let levels = campaign_levels(&records, 0.01, true);
        let refiner = Refiner::default()
            .parametrization(parametrization)
            .noise(NoiseModel::Known(levels.clone()));
        let truth = truth(&frame);
        let refined = refiner.refine(&records, DT_S, &truth).unwrap();
        let inputs: Vec<DMatrix<f64>> = records.iter().map(|r| r.inputs.clone()).collect();
        let bound = refiner.cramer_rao(&truth, DT_S, &inputs, &levels).unwrap();
        let diff = (&refined.uncertainty.fisher - &bound.fisher).norm() / bound.fisher.norm();
        let worst_std = refined
            .uncertainty
            .parameter_std
            .iter()
            .zip(bound.parameter_std.iter())
            .map(|(a, b)| ((a - b) / b).abs())
            .fold(0.0, f64::max);
        println!(
            "{} DOF: Fisher relative difference {diff:.1e}, worst parameter std {worst_std:.1e}",
            frame.dofs()
        );
        // What differs: the estimate (1e-9 from the truth), and the responses (the
        // generator's analytic hammer spectrum vs the bound's FFT product of the sampled
        // force, which differ by the filter precursor cut at the record start). Measured
        // 1e-6 to 3e-6.
        assert!(diff < 1e-4 && worst_std < 1e-4, "{diff:e} {worst_std:e}");
    }
}

/// Stop reasons are data: an iteration limit is reported, not raised.
#[test]
fn iteration_limit_is_a_stop_reason() {
    let mut rng = ChaCha8Rng::seed_from_u64(1200);
    let frame = frame2();
    let records = bandlimited_records(&frame, &hits(&mut rng, 2, 64));
    let start = perturbed(&frame, &mut rng);
    let r = Refiner::default()
        .max_iterations(1)
        .refine(&records, DT_S, &start)
        .unwrap();
    assert_eq!(r.stop, StopReason::MaxIterations);
    assert!(!r.stop.converged());
    assert!(r.cost < r.initial_cost);
}
