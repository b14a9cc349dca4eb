//! FRFs in UFF dataset 58 (function types 4 and 6): a hand-made file with
//! values worked out from a closed form, round trips through the writer,
//! and refusals that name the place.

use std::path::Path;

use ident::FrfQuantity;
use ident::linalg::C64;
use records::{
    ContentKind, FrfFile, FrfFormat, FrfPair, FrfPoint, FrfReadOptions, Problem, RecordError,
    content_kind, encode_frf, parse_frf, read_frf,
};

fn data(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

/// The single-DOF receptance of `make_frf_handmade.py`, in m/N.
fn receptance(f: f64) -> C64 {
    let (m, k, c) = (2.0, 8000.0, 4.0);
    let w = 2.0 * std::f64::consts::PI * f;
    C64::new(1.0, 0.0) / C64::new(k - w * w * m, w * c)
}

fn parse(bytes: &[u8]) -> Result<FrfFile, RecordError> {
    parse_frf(bytes, Path::new("frf.uff"), &FrfReadOptions::default())
}

fn problem(r: Result<FrfFile, RecordError>) -> (Problem, String) {
    match r {
        Err(e @ RecordError::Parse { .. }) => {
            let msg = e.to_string();
            let RecordError::Parse { problem, .. } = e else {
                unreachable!()
            };
            (problem, msg)
        }
        other => panic!("expected a parse error, got {other:?}"),
    }
}

#[test]
fn handmade_file_holds_the_closed_form() {
    let path = data("handmade_frf.uff");
    let bytes = std::fs::read(&path).unwrap();
    assert_eq!(content_kind(&bytes), ContentKind::Frf);
    let file = read_frf(&path, &FrfReadOptions::default()).unwrap();
    assert_eq!(file.format, FrfFormat::Uff58Ascii);
    assert_eq!(file.frequency_hz, [5.0, 10.0, 15.0, 20.0]);
    assert_eq!(file.pairs.len(), 2);

    let p = &file.pairs[0];
    assert_eq!(p.response, FrfPoint::at(1, 1));
    assert_eq!(p.reference, FrfPoint::at(1, 1));
    assert_eq!(p.quantity, FrfQuantity::Receptance);
    assert_eq!(p.source, "dataset 2");
    assert_eq!(p.coherence.as_deref(), Some(&[0.9, 0.95, 0.99, 1.0][..]));
    for (k, &f) in file.frequency_hz.iter().enumerate() {
        let want = receptance(f);
        // 6E13.5 in mm/N: each part carries 6 significant digits (5e-6
        // relative of the part, at most 5e-6 |H|); read as f32 first,
        // which adds 6e-8. 1e-5 |H| bounds both.
        assert!(
            (p.values[k] - want).norm() <= 1e-5 * want.norm(),
            "line {k}: {} vs {want}",
            p.values[k]
        );
    }

    let p = &file.pairs[1];
    assert_eq!(p.response, FrfPoint::named_at("ACC2", 2, 1));
    assert_eq!(p.reference, FrfPoint::at(1, 1));
    assert_eq!(p.quantity, FrfQuantity::Accelerance);
    assert_eq!(p.coherence, None);
    for (k, &f) in file.frequency_hz.iter().enumerate() {
        let w = 2.0 * std::f64::consts::PI * f;
        let want = receptance(f) * (-0.5 * w * w);
        // E20.12 in g/lbf: 13 significant digits (5e-13 relative of each
        // part); the conversion to SI adds a few ulps. 1e-11 |H| bounds it.
        assert!(
            (p.values[k] - want).norm() <= 1e-11 * want.norm(),
            "line {k}: {} vs {want}",
            p.values[k]
        );
    }
}

/// A file of two responses over two references with coherence, averages
/// and points of every kind the writer takes.
fn sample(frequency_hz: Vec<f64>) -> FrfFile {
    let points = [
        FrfPoint::at(1, 1),
        FrfPoint::named_at("acc2", 2, 1),
        FrfPoint::named("free"),
    ];
    let mut pairs = Vec::new();
    for (j, reference) in [FrfPoint::at(1, 1), FrfPoint::named_at("shaker", 3, -1)]
        .into_iter()
        .enumerate()
    {
        for (i, response) in points.iter().enumerate() {
            let values = frequency_hz
                .iter()
                .map(|&f| receptance(f) * C64::new(1.0 + i as f64, -0.3 * j as f64) / 3.0)
                .collect();
            pairs.push(FrfPair {
                response: response.clone(),
                reference: reference.clone(),
                quantity: if i == 2 {
                    FrfQuantity::Mobility
                } else {
                    FrfQuantity::Accelerance
                },
                values,
                coherence: (i != 1)
                    .then(|| frequency_hz.iter().map(|f| 1.0 / (1.0 + f / 1e3)).collect()),
                averages: Some(12),
                source: String::new(),
                exponential_tau_s: None,
            });
        }
    }
    FrfFile {
        path: "sample.uff".into(),
        format: FrfFormat::Uff58Binary,
        frequency_hz,
        pairs,
    }
}

fn even_grid() -> Vec<f64> {
    // 0.1 is not a binary fraction and 1.0 / 3.0 not even decimal: record 7
    // alone (6 digits) would not carry them.
    (0..37).map(|k| 1.0 / 3.0 + k as f64 * 0.1).collect()
}

fn uneven_grid() -> Vec<f64> {
    (0..23)
        .map(|k| 0.5 + (k as f64).powf(1.5) * 0.731)
        .collect()
}

fn same_points(a: &FrfFile, b: &FrfFile) {
    assert_eq!(a.pairs.len(), b.pairs.len());
    for (p, q) in a.pairs.iter().zip(&b.pairs) {
        assert_eq!(p.response, q.response);
        assert_eq!(p.reference, q.reference);
        assert_eq!(p.quantity, q.quantity);
        assert_eq!(p.averages, q.averages);
        assert_eq!(p.coherence.is_some(), q.coherence.is_some());
    }
}

#[test]
fn binary_round_trip_is_exact() {
    for grid in [even_grid(), uneven_grid()] {
        let file = sample(grid);
        let bytes = encode_frf(&file, FrfFormat::Uff58Binary).unwrap();
        assert_eq!(content_kind(&bytes), ContentKind::Frf);
        let back = parse(&bytes).unwrap();
        assert_eq!(back.format, FrfFormat::Uff58Binary);
        same_points(&file, &back);
        // Binary doubles, and the exact grid (ID line 5 or the stored
        // abscissa): bit for bit.
        assert_eq!(back.frequency_hz, file.frequency_hz);
        for (p, q) in file.pairs.iter().zip(&back.pairs) {
            assert_eq!(p.values, q.values);
            assert_eq!(p.coherence, q.coherence);
        }
    }
}

#[test]
fn ascii_round_trip_to_the_printed_precision() {
    for (grid, f_tol) in [(even_grid(), 0.0), (uneven_grid(), 5e-6)] {
        let file = sample(grid);
        let bytes = encode_frf(&file, FrfFormat::Uff58Ascii).unwrap();
        let back = parse(&bytes).unwrap();
        assert_eq!(back.format, FrfFormat::Uff58Ascii);
        same_points(&file, &back);
        // Even grid: exact (ID line 5 carries f0 and df). Uneven: the
        // abscissa is E13.5, 6 significant digits, half a unit of the 6th
        // digit is 5e-6 relative.
        for (f, g) in file.frequency_hz.iter().zip(&back.frequency_hz) {
            assert!((f - g).abs() <= f_tol * f, "{f} vs {g}");
        }
        for (p, q) in file.pairs.iter().zip(&back.pairs) {
            for (a, b) in p.values.iter().zip(&q.values) {
                // E20.12: 13 significant digits per part, half a unit of
                // the 13th digit is 5e-13 of the part, at most 5e-13 |H|
                // for each of the two parts.
                assert!((a - b).norm() <= 1e-12 * a.norm(), "{a} vs {b}");
            }
            if let (Some(c), Some(d)) = (&p.coherence, &q.coherence) {
                for (a, b) in c.iter().zip(d) {
                    // E20.12 of a value in (0, 1]: 5e-13.
                    assert!((a - b).abs() <= 5e-13, "{a} vs {b}");
                }
            }
        }
    }
}

#[test]
fn writer_refuses_what_would_not_read_back() {
    let mut file = sample(even_grid());
    file.pairs[0].response = FrfPoint::named_at("a name with blanks", 7, 1);
    let e = encode_frf(&file, FrfFormat::Uff58Ascii).unwrap_err();
    assert!(e.to_string().contains("entity name"), "{e}");
    let mut file = sample(even_grid());
    file.pairs[1].values[3] = C64::new(f64::NAN, 0.0);
    let e = encode_frf(&file, FrfFormat::Uff58Binary).unwrap_err();
    assert!(e.to_string().contains("line 4"), "{e}");
    let mut file = sample(even_grid());
    file.pairs[5].response = file.pairs[3].response.clone();
    let e = encode_frf(&file, FrfFormat::Uff58Binary).unwrap_err();
    assert!(e.to_string().contains("same pair"), "{e}");
}

/// One FRF dataset in ASCII, fixed columns, with records that tests replace.
struct Ds {
    rec6: String,
    rec7: String,
    rec8: String,
    rec9: String,
    rec10: String,
    data: Vec<String>,
}

impl Ds {
    fn new() -> Ds {
        Ds {
            rec6:
                "    4         1    0         0 NONE               2   1 NONE               1   1"
                    .into(),
            rec7: "         6         2         1  1.00000E+00  5.00000E-01  0.00000E+00".into(),
            rec8: "        18    0    0    0 Frequency            Hz".into(),
            rec9: "        12    1    0    0 Acceleration         m/s^2".into(),
            rec10: "        13    0    1    0 Force                N".into(),
            data: vec![
                "  1.000000000000E+00 -2.000000000000E+00  3.000000000000E+00  4.000000000000E+00"
                    .into(),
            ],
        }
    }

    fn text(&self) -> String {
        let mut s = String::from("    -1\n    58\nH\nNONE\nNONE\nNONE\nNONE\n");
        for r in [&self.rec6, &self.rec7, &self.rec8, &self.rec9, &self.rec10] {
            s.push_str(r);
            s.push('\n');
        }
        s.push_str("         0    0    0    0 NONE                 NONE\n");
        for d in &self.data {
            s.push_str(d);
            s.push('\n');
        }
        s.push_str("    -1\n");
        s
    }
}

#[test]
fn plain_dataset_reads() {
    let file = parse(Ds::new().text().as_bytes()).unwrap();
    assert_eq!(file.frequency_hz, [1.0, 1.5]);
    assert_eq!(
        file.pairs[0].values,
        [C64::new(1.0, -2.0), C64::new(3.0, 4.0)]
    );
    assert_eq!(file.pairs[0].response, FrfPoint::at(2, 1));
}

#[test]
fn bad_inputs_name_the_place() {
    // Each case: a modification, the problem expected, and text the
    // message must contain (dataset, line, record field).
    type Edit = fn(&mut Ds);
    let cases: [(Edit, &str); 9] = [
        (
            |d| d.rec6 = d.rec6.replacen("    4", "    1", 1),
            "dataset 1, line 8, record 6 field 1 (function type): function type 1 (time response) is not an FRF",
        ),
        (
            |d| d.rec6 = d.rec6.replacen("    4", "    2", 1),
            "function type 2 (auto spectrum) is not an FRF",
        ),
        (
            |d| d.rec7 = d.rec7.replacen("         6", "         4", 1),
            "line 9, record 7 field 1 (ordinate data type): ordinate data type 4 (real double) does not fit function type 4",
        ),
        (
            |d| d.rec8 = "        17    0    0    0 Time                 s".into(),
            "line 10, record 8 fields 1 and 6 (abscissa data type and units label): the abscissa is specific data type 17 with units label 's'",
        ),
        (
            |d| d.rec9 = "        12    1    0    0 Displacement         mm".into(),
            "line 11, record 9 fields 1 and 6 (data type and units label): cannot decide the FRF's quantity or unit: data type 12 says accelerance but the unit label 'mm' says receptance",
        ),
        (
            |d| d.rec9 = "         0    0    0    0 NONE                 NONE".into(),
            "line 11, record 9 fields 1 and 6",
        ),
        (
            |d| d.rec10 = "        13    0    1    0 Force                V".into(),
            "line 12, record 10 field 6 (ordinate denominator units label): cannot decide the FRF's quantity or unit: 'V' is not a force unit",
        ),
        (
            |d| d.data[0] = d.data[0].replacen("4.000000000000E+00", "               NaN", 1),
            "dataset 1, line 14, value 4 on the line: value 'NaN' is NaN or infinite",
        ),
        (
            |d| d.data.clear(),
            "record 7 (line 9) declares 4 values, but the data section holds 0",
        ),
    ];
    for (edit, want) in cases {
        let mut d = Ds::new();
        edit(&mut d);
        let (_, msg) = problem(parse(d.text().as_bytes()));
        assert!(msg.starts_with("frf.uff: "), "{msg}");
        assert!(msg.contains(want), "{msg}\nwanted: {want}");
    }
    // Truncated: the file ends after the data, without the closing '-1'.
    let text = Ds::new().text();
    let cut = text.strip_suffix("    -1\n").unwrap();
    let (p, msg) = problem(parse(cut.as_bytes()));
    assert!(matches!(p, Problem::UffTruncated { .. }), "{msg}");
    assert!(msg.contains("dataset 1, line 14"), "{msg}");
}

#[test]
fn file_level_refusals() {
    let a = Ds::new();
    // A second FRF on another grid.
    let mut b = Ds::new();
    b.rec6 = b.rec6.replacen("   2   1 NONE", "   3   1 NONE", 1);
    b.rec7 = b.rec7.replacen("5.00000E-01", "6.00000E-01", 1);
    let (p, msg) = problem(parse((a.text() + &b.text()).as_bytes()));
    assert!(matches!(p, Problem::FrfGridMismatch { .. }), "{msg}");
    assert!(
        msg.contains(
            "dataset 2, line 24, record 7: frequency line 2 is 1.6 Hz, but dataset 1 has 1.5 Hz"
        ),
        "{msg}"
    );
    // The same pair twice.
    let (p, msg) = problem(parse((a.text() + &a.text()).as_bytes()));
    assert!(
        matches!(p, Problem::FrfDuplicatePair { first: 1, .. }),
        "{msg}"
    );
    assert!(msg.contains("dataset 2, line 23, record 6"), "{msg}");
    // A coherence of a pair that has no FRF.
    let mut c = Ds::new();
    c.rec6 = c
        .rec6
        .replacen("    4", "    6", 1)
        .replacen("   2   1 NONE", "   5   1 NONE", 1);
    c.rec7 = c
        .rec7
        .replacen("         6         2", "         4         2", 1);
    c.data = vec!["  5.000000000000E-01  1.000000000000E+00".into()];
    let (p, msg) = problem(parse((a.text() + &c.text()).as_bytes()));
    assert!(matches!(p, Problem::FrfOrphanCoherence { .. }), "{msg}");
    assert!(msg.contains("response 5:+X and reference 1:+X"), "{msg}");
    // A coherence above 1.
    let mut c = Ds::new();
    c.rec6 = c.rec6.replacen("    4", "    6", 1);
    c.rec7 = c
        .rec7
        .replacen("         6         2", "         4         2", 1);
    c.data = vec!["  5.000000000000E-01  1.100000000000E+00".into()];
    let (p, msg) = problem(parse((a.text() + &c.text()).as_bytes()));
    assert_eq!(p, Problem::FrfBadCoherence { value: 1.1 });
    assert!(
        msg.contains("dataset 2, line 29, coherence value 2"),
        "{msg}"
    );
}

#[test]
fn units_system_of_dataset_164() {
    // An mm-based unit system (length factor 1000: 1 m = 1000 mm) and no
    // unit labels: values are mm/s^2 per N, i.e. 1e-3 (m/s^2)/N.
    let units = "    -1\n   164\n         5mm (milli newton)          2\n  1.00000000000000000D+03  1.00000000000000000D+00  1.00000000000000000D+00\n  2.73150000000000000D+02\n    -1\n";
    let mut d = Ds::new();
    d.rec9 = "        12    0    0    0 NONE                 NONE".into();
    d.rec10 = "        13    0    0    0 NONE                 NONE".into();
    let file = parse((units.to_string() + &d.text()).as_bytes()).unwrap();
    assert_eq!(file.pairs[0].values[0], C64::new(1e-3, -2e-3));
    // Without dataset 164: SI.
    let file = parse(d.text().as_bytes()).unwrap();
    assert_eq!(file.pairs[0].values[0], C64::new(1.0, -2.0));
    // Labels take precedence over dataset 164.
    let file = parse((units.to_string() + &Ds::new().text()).as_bytes()).unwrap();
    assert_eq!(file.pairs[0].values[0], C64::new(1.0, -2.0));
}

#[test]
fn time_reader_points_to_the_frf_reader() {
    let bytes = encode_frf(&sample(even_grid()), FrfFormat::Uff58Ascii).unwrap();
    let e = records::parse_record(
        &bytes,
        Path::new("frf.uff"),
        &records::ReadOptions::default(),
    )
    .unwrap_err();
    assert!(e.to_string().contains("this is an FRF file"), "{e}");
    // And the FRF reader points to the record reader.
    let time = std::fs::read(data("pyuff_ascii_even.uff")).unwrap();
    assert_eq!(content_kind(&time), ContentKind::TimeRecord);
    let (p, msg) = problem(parse(&time));
    assert_eq!(p, Problem::UffNotFrf { func_type: 1 });
    assert!(msg.contains("this is a time record"), "{msg}");
}
