//! Collating FRF files into one FRF matrix: the two Cristallo measurements
//! (force at floors 2 and 3), conversions between quantities, and the
//! refusals that name files and pairs.

use std::path::{Path, PathBuf};

use ident::linalg::C64;
use ident::{CollocatedPair, FrfQuantity};
use records::frf::FrfSetProblem;
use records::{
    AssembleOptions, FrfFile, FrfFormat, FrfPair, FrfPoint, FrfReadOptions, RecordError, read_frf,
};

fn cristallo(name: &str, force_floor: i64) -> FrfFile {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/realdata/cristallo")
        .join(name);
    assert!(
        path.is_file(),
        "{} is missing: the shared real data is required",
        path.display()
    );
    let opts = FrfReadOptions {
        quantity: Some(FrfQuantity::Accelerance),
        reference: Some(FrfPoint::named_at(
            format!("force{force_floor}"),
            force_floor,
            1,
        )),
        responses: Some(
            (1..=3)
                .map(|k| FrfPoint::named_at(format!("floor{k}"), k, 1))
                .collect(),
        ),
        ..FrfReadOptions::default()
    };
    read_frf(&path, &opts).unwrap()
}

fn problem(r: Result<records::FrfSet, RecordError>) -> (FrfSetProblem, String) {
    match r {
        Err(e) => {
            let msg = e.to_string();
            match e {
                RecordError::FrfSet { problem } => (*problem, msg),
                other => panic!("expected an assembly error, got {other}"),
            }
        }
        Ok(_) => panic!("expected an assembly error"),
    }
}

#[test]
fn cristallo_columns_make_a_three_by_two_matrix() {
    let files = [cristallo("test_2.csv", 2), cristallo("test_3.csv", 3)];
    let set = records::frf::assemble(&files, &AssembleOptions::default()).unwrap();
    assert_eq!(set.frf.outputs, ["floor1", "floor2", "floor3"]);
    assert_eq!(set.frf.references, ["force2", "force3"]);
    assert_eq!(set.frf.lines(), 4096);
    assert_eq!(set.frf.quantity, FrfQuantity::Accelerance);
    assert_eq!(set.frf.coherence, None);
    // Driving points from nodes and directions: floor 2 under force 2,
    // floor 3 under force 3.
    assert_eq!(
        set.collocated,
        [
            CollocatedPair {
                output: 1,
                input: 0
            },
            CollocatedPair {
                output: 2,
                input: 1
            }
        ]
    );
    for k in [0, 99, 4095] {
        for i in 0..3 {
            assert_eq!(set.frf.values[k][(i, 0)], files[0].pairs[i].values[k]);
            assert_eq!(set.frf.values[k][(i, 1)], files[1].pairs[i].values[k]);
        }
    }
    // Given instead of detected.
    let opts = AssembleOptions {
        collocated: vec![("floor3".into(), "force2".into())],
        ..AssembleOptions::default()
    };
    let set = records::frf::assemble(&files, &opts).unwrap();
    assert_eq!(
        set.collocated,
        [CollocatedPair {
            output: 2,
            input: 0
        }]
    );
    let opts = AssembleOptions {
        collocated: vec![("floor4".into(), "force2".into())],
        ..AssembleOptions::default()
    };
    let (_, msg) = problem(records::frf::assemble(&files, &opts));
    assert!(
        msg.contains("no response of that name; responses: floor1, floor2, floor3"),
        "{msg}"
    );
}

fn pair(response: FrfPoint, reference: FrfPoint, quantity: FrfQuantity, f: &[f64]) -> FrfPair {
    // A single-DOF receptance 1 / (k - w^2 m + i w c), in `quantity`.
    let values = f
        .iter()
        .map(|&f| {
            let w = 2.0 * std::f64::consts::PI * f;
            let h = C64::new(1.0, 0.0) / C64::new(1e4 - w * w, 2.0 * w);
            h * C64::new(0.0, w).powi(quantity.derivative_order())
        })
        .collect();
    FrfPair {
        response,
        reference,
        quantity,
        values,
        coherence: None,
        averages: None,
        source: "dataset 1".into(),
        exponential_tau_s: None,
    }
}

fn file(name: &str, f: &[f64], pairs: Vec<FrfPair>) -> FrfFile {
    FrfFile {
        path: PathBuf::from(name),
        format: FrfFormat::Uff58Binary,
        frequency_hz: f.to_vec(),
        pairs,
    }
}

#[test]
fn quantities_convert_or_are_refused() {
    let f: Vec<f64> = (0..20).map(|k| k as f64 * 2.5).collect();
    let files = [
        file(
            "a.uff",
            &f,
            vec![pair(
                FrfPoint::at(1, 1),
                FrfPoint::at(1, 1),
                FrfQuantity::Receptance,
                &f,
            )],
        ),
        file(
            "b.uff",
            &f,
            vec![pair(
                FrfPoint::at(2, 1),
                FrfPoint::at(1, 1),
                FrfQuantity::Accelerance,
                &f,
            )],
        ),
    ];
    let (p, msg) = problem(records::frf::assemble(&files, &AssembleOptions::default()));
    assert!(matches!(p, FrfSetProblem::MixedQuantity { .. }));
    assert!(
        msg.contains("a.uff (dataset 1) is receptance but b.uff (dataset 1) is accelerance"),
        "{msg}"
    );
    let opts = AssembleOptions {
        quantity: Some(FrfQuantity::Accelerance),
        ..AssembleOptions::default()
    };
    let set = records::frf::assemble(&files, &opts).unwrap();
    let want = pair(
        FrfPoint::at(1, 1),
        FrfPoint::at(1, 1),
        FrfQuantity::Accelerance,
        &f,
    );
    for k in 0..f.len() {
        // (i w)^2 applied to the same receptance in two orders of
        // multiplication: a few ulps.
        let (got, w) = (set.frf.values[k][(0, 0)], want.values[k]);
        assert!((got - w).norm() <= 1e-14 * w.norm(), "line {k}");
        assert_eq!(set.frf.values[k][(1, 0)], files[1].pairs[0].values[k]);
    }
    assert_eq!(
        set.collocated,
        [CollocatedPair {
            output: 0,
            input: 0
        }]
    );
}

#[test]
fn refusals_name_files_and_pairs() {
    let f: Vec<f64> = (1..10).map(|k| k as f64).collect();
    let acc = FrfQuantity::Accelerance;
    let (r1, r2) = (FrfPoint::at(1, 1), FrfPoint::at(2, 1));
    let (s1, s2) = (FrfPoint::at(1, 1), FrfPoint::at(2, 1));
    // Missing pair: 2 responses x 2 references, one absent.
    let files = [
        file(
            "hit1.uff",
            &f,
            vec![
                pair(r1.clone(), s1.clone(), acc, &f),
                pair(r2.clone(), s1.clone(), acc, &f),
            ],
        ),
        file("hit2.uff", &f, vec![pair(r1.clone(), s2.clone(), acc, &f)]),
    ];
    let (p, msg) = problem(records::frf::assemble(&files, &AssembleOptions::default()));
    assert!(matches!(p, FrfSetProblem::MissingPair { .. }));
    assert!(
        msg.contains("no FRF of response 2:+X over reference 2:+X in hit1.uff, hit2.uff"),
        "{msg}"
    );
    // Duplicate pair.
    let files = [
        file("hit1.uff", &f, vec![pair(r1.clone(), s1.clone(), acc, &f)]),
        file("hit2.uff", &f, vec![pair(r1.clone(), s1.clone(), acc, &f)]),
    ];
    let (_, msg) = problem(records::frf::assemble(&files, &AssembleOptions::default()));
    assert!(
        msg.contains("response 1:+X over reference 1:+X is given twice: hit1.uff (dataset 1) and hit2.uff (dataset 1)"),
        "{msg}"
    );
    // Different grids.
    let g: Vec<f64> = f.iter().map(|x| x * 1.001).collect();
    let files = [
        file("hit1.uff", &f, vec![pair(r1.clone(), s1.clone(), acc, &f)]),
        file("hit2.uff", &g, vec![pair(r1.clone(), s2.clone(), acc, &g)]),
    ];
    let (_, msg) = problem(records::frf::assemble(&files, &AssembleOptions::default()));
    assert!(
        msg.contains("hit1.uff and hit2.uff have different frequency grids: line 1 is 1.001 Hz in one, 1 Hz in the other"),
        "{msg}"
    );
    // Different averages.
    let mut a = pair(r1.clone(), s1.clone(), acc, &f);
    a.averages = Some(5);
    let mut b = pair(r1.clone(), s2.clone(), acc, &f);
    b.averages = Some(8);
    let files = [file("hit1.uff", &f, vec![a]), file("hit2.uff", &f, vec![b])];
    let (_, msg) = problem(records::frf::assemble(&files, &AssembleOptions::default()));
    assert!(
        msg.contains("hit1.uff (dataset 1) has 5 averages but hit2.uff (dataset 1) has 8"),
        "{msg}"
    );
    // One name for two places.
    let files = [file(
        "hit1.uff",
        &f,
        vec![
            pair(FrfPoint::named_at("acc", 1, 1), s1.clone(), acc, &f),
            pair(FrfPoint::named_at("acc", 2, 1), s1.clone(), acc, &f),
        ],
    )];
    let (_, msg) = problem(records::frf::assemble(&files, &AssembleOptions::default()));
    assert!(
        msg.contains(
            "two different response points are named 'acc': acc (node 1 +X) and acc (node 2 +X)"
        ),
        "{msg}"
    );
    let (p, _) = problem(records::frf::assemble(&[], &AssembleOptions::default()));
    assert_eq!(p, FrfSetProblem::Empty);
}
