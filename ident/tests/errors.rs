//! Every way the data or the parameters can be unusable gives a typed error.

mod common;

use common::*;
use ident::era::EraError;
use ident::mkr::MatrixKind;
use ident::{
    Channel, DataError, Error, Identifier, Intersample, MkrError, ModelOrder, ObserverOrder,
    RayleighError, Record, StructuralRule,
};
use nalgebra::DMatrix;
use rand::SeedableRng;
use rand::rngs::ChaCha8Rng;

fn records(count: usize) -> Vec<Record> {
    let mut rng = ChaCha8Rng::seed_from_u64(501);
    let hits: Vec<Hit> = (0..count).map(|_| Hit::random(&mut rng, 6)).collect();
    held_records(&frame2(), &hits)
}

fn zoh() -> Identifier {
    Identifier::default().intersample(Intersample::Zoh)
}

#[test]
fn record_problems() {
    let good = records(2);
    assert_eq!(
        zoh().identify(&[], DT_S).unwrap_err(),
        Error::Data(DataError::NoRecords)
    );
    assert_eq!(
        zoh().identify(&good, 0.0).unwrap_err(),
        Error::Data(DataError::InvalidSampleInterval { dt_s: 0.0 })
    );

    let mut no_inputs = good.clone();
    no_inputs[1].inputs = DMatrix::zeros(0, SAMPLES);
    assert_eq!(
        zoh().identify(&no_inputs, DT_S).unwrap_err(),
        Error::Data(DataError::NoChannels {
            record: 1,
            inputs: 0,
            outputs: 2
        })
    );

    let mut mismatch = good.clone();
    mismatch[0].inputs = mismatch[0].inputs.columns(0, 100).into_owned();
    assert_eq!(
        zoh().identify(&mismatch, DT_S).unwrap_err(),
        Error::Data(DataError::LengthMismatch {
            record: 0,
            input_samples: 100,
            output_samples: SAMPLES
        })
    );

    let mut channels = good.clone();
    channels[1].outputs = channels[1].outputs.rows(0, 1).into_owned();
    assert!(matches!(
        zoh().identify(&channels, DT_S).unwrap_err(),
        Error::Data(DataError::ChannelCountMismatch {
            record: 1,
            outputs: 1,
            expected_outputs: 2,
            ..
        })
    ));

    let mut nan = good.clone();
    nan[1].inputs[(0, 17)] = f64::INFINITY;
    assert!(matches!(
        zoh().identify(&nan, DT_S).unwrap_err(),
        Error::Data(DataError::NonFinite {
            record: 1,
            channel: Channel::Input(0),
            sample: 17,
            ..
        })
    ));

    let mut silent = good.clone();
    silent[1].inputs.fill(0.0);
    assert_eq!(
        zoh().identify(&silent, DT_S).unwrap_err(),
        Error::Data(DataError::NoExcitation { record: 1 })
    );

    let mut dead = good.clone();
    for rec in &mut dead {
        rec.outputs.row_mut(1).fill(0.0);
    }
    assert_eq!(
        zoh().identify(&dead, DT_S).unwrap_err(),
        Error::Data(DataError::DeadChannel {
            channel: Channel::Output(1)
        })
    );
}

#[test]
fn records_too_short() {
    // Too short for the Hankel matrices: named by the longest record. The default Hankel
    // matrix needs 40 block rows, at least 21 block columns and 5 correlation lags: 66
    // Markov parameters.
    let mut short = records(2);
    short[0] = Record::new(
        short[0].inputs.columns(0, 40).into_owned(),
        short[0].outputs.columns(0, 40).into_owned(),
    );
    short[1] = Record::new(
        short[1].inputs.columns(0, 50).into_owned(),
        short[1].outputs.columns(0, 50).into_owned(),
    );
    match zoh().identify(&short, DT_S).unwrap_err() {
        Error::Data(DataError::TooShort {
            record,
            samples,
            required,
            ..
        }) => {
            assert_eq!((record, samples, required), (1, 50, 66));
        }
        other => panic!("{other}"),
    }
    // Too short for the observer order: named by the offending record.
    let mut tiny = records(3);
    tiny[2] = Record::new(
        tiny[2].inputs.columns(0, 20).into_owned(),
        tiny[2].outputs.columns(0, 20).into_owned(),
    );
    let err = zoh()
        .observer_order(ObserverOrder::Fixed(25))
        .identify(&tiny, DT_S)
        .unwrap_err();
    assert!(
        matches!(
            err,
            Error::Data(DataError::TooShort {
                record: 2,
                samples: 20,
                required: 26,
                ..
            })
        ),
        "{err}"
    );
    assert!(
        err.to_string()
            .contains("record 2 has 20 samples, 26 are required")
    );
}

#[test]
fn configuration_problems() {
    let good = records(2);
    assert_eq!(
        zoh().dofs(3).identify(&good, DT_S).unwrap_err(),
        Error::OutputsFewerThanDofs {
            outputs: 2,
            dofs: 3
        }
    );
    assert!(matches!(
        zoh().dofs(1).identify(&good, DT_S).unwrap_err(),
        Error::InvalidParams { .. }
    ));
    assert_eq!(
        zoh().collocated(2, 0).identify(&good, DT_S).unwrap_err(),
        Error::Mkr(MkrError::CollocatedOutOfRange {
            output: 2,
            input: 0,
            outputs: 2,
            inputs: 1
        })
    );
    assert!(matches!(
        zoh().collocated(0, 1).identify(&good, DT_S).unwrap_err(),
        Error::Mkr(MkrError::CollocatedOutOfRange { input: 1, .. })
    ));
    assert!(matches!(
        zoh().rcond(2.0).check(),
        Err(Error::InvalidParams { .. })
    ));
    assert!(matches!(
        zoh().order(ModelOrder::Fixed(0)).check(),
        Err(Error::Era(EraError::InvalidParams { .. }))
    ));
    assert!(matches!(
        zoh()
            .order(ModelOrder::Fixed(500))
            .identify(&good, DT_S)
            .unwrap_err(),
        // An observer of order 20 with 2 outputs has at most 40 states.
        Error::Era(EraError::OrderTooLarge {
            order: 500,
            max: 40
        })
    ));
}

#[test]
fn order_not_identifiable() {
    // Order 2 holds one mode of a 2-DOF frame.
    let err = zoh()
        .order(ModelOrder::Fixed(2))
        .identify(&records(2), DT_S)
        .unwrap_err();
    assert_eq!(
        err,
        Error::OrderNotIdentifiable {
            structural: 1,
            required: 2,
            order: 2
        }
    );
    // A realization with one mode for two outputs.
    let a = DMatrix::from_row_slice(2, 2, &[0.9, -0.3, 0.3, 0.9]);
    let b = DMatrix::from_column_slice(2, 1, &[1.0, 0.5]);
    let c = DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.5, 0.0]);
    let d = DMatrix::from_column_slice(2, 1, &[1.0, 0.1]);
    assert_eq!(
        zoh().from_realization(DT_S, a, b, c, d).unwrap_err(),
        Error::OrderNotIdentifiable {
            structural: 1,
            required: 2,
            order: 2
        }
    );
}

/// The paper's case 1 realization, edited into physically impossible ones.
fn case1() -> (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>, DMatrix<f64>) {
    (
        DMatrix::from_row_slice(
            4,
            4,
            &[
                0.6220, -0.7789, -0.0003, -0.0021, 0.7839, 0.6191, 0.0031, -0.0012, -0.0036,
                0.0061, 0.9623, 0.2616, 0.0041, 0.0044, -0.2676, 0.9634,
            ],
        ),
        DMatrix::from_column_slice(4, 1, &[0.0541, -0.0268, 0.0412, 0.0363]),
        DMatrix::from_row_slice(
            2,
            4,
            &[
                -37.8710, -5.0124, -5.8513, 1.8479, 26.5700, 3.2700, -7.2966, 2.2001,
            ],
        ),
        DMatrix::from_column_slice(2, 1, &[3.6387, 0.0739]),
    )
}

#[test]
fn physically_impossible_realizations() {
    // States 0-1 carry the 9 Hz mode and states 2-3 the 2.7 Hz one (A is nearly block
    // diagonal): negating B for states 0-1 inverts one mode's driving-point residue only.
    let (a, mut b, c, d) = case1();
    b[0] = -b[0];
    b[1] = -b[1];
    assert!(matches!(
        zoh().from_realization(DT_S, a, b, c, d).unwrap_err(),
        Error::Mkr(MkrError::InconsistentPolarity { ref imaginary_parts }) if imaginary_parts.len() == 2
    ));
    // Turning output 1's view of the 9 Hz mode by 90 degrees (C[1, 0..2] -> (-C[1,1],
    // C[1,0])) and scaling it makes that mode's contribution to M^-1 change sign at DOF 1.
    // Its shape is then far from monophase, which the default rule rejects as a noise
    // mode (order not identifiable); a rule accepting every mode lets MKR see it.
    let (a, b, mut c, d) = case1();
    let (c10, c11) = (c[(1, 0)], c[(1, 1)]);
    c[(1, 0)] = -3.0 * c11;
    c[(1, 1)] = 3.0 * c10;
    assert!(matches!(
        zoh()
            .from_realization(DT_S, a.clone(), b.clone(), c.clone(), d.clone())
            .unwrap_err(),
        Error::OrderNotIdentifiable { structural: 1, .. }
    ));
    let accept_all = StructuralRule {
        min_cmi: 0.0,
        ..StructuralRule::default()
    };
    match zoh()
        .rule(accept_all)
        .from_realization(DT_S, a, b, c, d)
        .unwrap_err()
    {
        Error::Mkr(MkrError::NotPositiveDefinite {
            matrix,
            pivot,
            value,
        }) => {
            assert_eq!(pivot, 1, "{matrix}");
            assert!(value <= 0.0);
            assert!(matches!(matrix, MatrixKind::Mass | MatrixKind::Stiffness));
        }
        other => panic!("expected NotPositiveDefinite, got {other}"),
    }
}

#[test]
fn one_dof_needs_two_modes_for_rayleigh() {
    // A single-DOF oscillator (0.5 kg, 200 N/m, 0.1 N s/m): MKR has its one mode, the
    // two-parameter Rayleigh fit does not.
    let (m, k, r): (f64, f64, f64) = (0.5, 200.0, 0.1);
    let (wn, zeta) = ((k / m).sqrt(), r / (2.0 * (k * m).sqrt()));
    let lc = nalgebra::Complex::new(-zeta * wn, wn * (1.0 - zeta * zeta).sqrt());
    let l = (lc * DT_S).exp();
    let a = DMatrix::from_row_slice(2, 2, &[l.re, -l.im, l.im, l.re]);
    let b = DMatrix::from_column_slice(2, 1, &[0.0, -1.0]);
    let c = DMatrix::from_row_slice(1, 2, &[1.0, 0.0]);
    let d = DMatrix::from_element(1, 1, 1.0 / m);
    assert_eq!(
        zoh().from_realization(DT_S, a, b, c, d).unwrap_err(),
        Error::Rayleigh(RayleighError::TooFewModes { modes: 1 })
    );
}
