//! FRFs as CSV: the measured Cristallo FRFs (headerless Python complex
//! notation), the header convention, round trips and refusals.

use std::path::{Path, PathBuf};

use ident::FrfQuantity;
use ident::linalg::C64;
use records::{
    ContentKind, FrfFile, FrfFormat, FrfPair, FrfPoint, FrfReadOptions, Problem, RecordError,
    content_kind, encode_frf, parse_frf, read_frf,
};

/// The shared real data, `../shared/realdata/cristallo` from the workspace
/// root. Required: the test fails when it is missing.
fn cristallo(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/realdata/cristallo");
    let path = dir.join(name);
    assert!(
        path.is_file(),
        "{} is missing: the shared real data (../shared/realdata/cristallo beside the repository) is required",
        path.display()
    );
    path
}

fn floors(force_floor: i64) -> FrfReadOptions {
    FrfReadOptions {
        // The platform labels the values g/N, but their high-frequency
        // asymptotes fit (m/s^2)/N (see the data's README): SI.
        quantity: Some(FrfQuantity::Accelerance),
        unit: None,
        reference: Some(FrfPoint::named_at("force", force_floor, 1)),
        responses: Some(
            (1..=3)
                .map(|k| FrfPoint::named_at(format!("floor{k}"), k, 1))
                .collect(),
        ),
    }
}

#[test]
fn cristallo_files_read() {
    for (name, force) in [("test_2.csv", 2), ("test_3.csv", 3)] {
        let path = cristallo(name);
        let bytes = std::fs::read(&path).unwrap();
        assert_eq!(content_kind(&bytes), ContentKind::Frf, "{name}");
        let file = read_frf(&path, &floors(force)).unwrap();
        assert_eq!(file.format, FrfFormat::CsvComplex);
        assert_eq!(file.frequency_hz.len(), 4096);
        assert_eq!(file.frequency_hz[0], 0.03125);
        assert_eq!(file.frequency_hz[4095], 128.0);
        // 0.03125 Hz steps, a binary fraction: every line exactly.
        for (k, &f) in file.frequency_hz.iter().enumerate() {
            assert_eq!(f, 0.03125 * (k + 1) as f64);
        }
        assert_eq!(file.pairs.len(), 3);
        for (k, p) in file.pairs.iter().enumerate() {
            assert_eq!(p.response.node, Some(k as i64 + 1));
            assert_eq!(p.reference, FrfPoint::named_at("force", force, 1));
            assert_eq!(p.quantity, FrfQuantity::Accelerance);
            assert_eq!(p.source, format!("column {}", k + 2));
        }
    }
    // Values copied by hand from the files (lines 1, 100 and 4096); the
    // decimal text parses to the same double.
    let f2 = read_frf(&cristallo("test_2.csv"), &floors(2)).unwrap();
    assert_eq!(
        f2.pairs[0].values[0],
        C64::new(-0.0285156946629286, -0.0434577353298664)
    );
    assert_eq!(f2.frequency_hz[99], 3.125);
    assert_eq!(
        f2.pairs[2].values[99],
        C64::new(-0.0511912629008293, 0.000834720733109862)
    );
    assert_eq!(f2.pairs[1].values[4095], C64::new(0.203006833791733, 0.0));
    let f3 = read_frf(&cristallo("test_3.csv"), &floors(3)).unwrap();
    assert_eq!(
        f3.pairs[1].values[99],
        C64::new(-0.052111491560936, 0.0198164414614439)
    );
    assert_eq!(f3.pairs[2].values[4095], C64::new(0.204280704259872, 0.0));
}

#[test]
fn cristallo_needs_its_options() {
    let path = cristallo("test_2.csv");
    let full = floors(2);
    let cases = [
        (
            FrfReadOptions {
                quantity: None,
                ..full.clone()
            },
            "FrfReadOptions::quantity",
        ),
        (
            FrfReadOptions {
                reference: None,
                ..full.clone()
            },
            "FrfReadOptions::reference",
        ),
        (
            FrfReadOptions {
                responses: None,
                ..full.clone()
            },
            "FrfReadOptions::responses",
        ),
    ];
    for (opts, want) in cases {
        let e = read_frf(&path, &opts).unwrap_err();
        let msg = e.to_string();
        assert!(
            matches!(
                e,
                RecordError::Parse {
                    problem: Problem::FrfMissingOption { .. },
                    ..
                }
            ),
            "{msg}"
        );
        assert!(
            msg.contains("test_2.csv: line 1: ") && msg.contains(want),
            "{msg}"
        );
    }
    // Two responses for three columns.
    let mut opts = full.clone();
    opts.responses.as_mut().unwrap().pop();
    let e = read_frf(&path, &opts).unwrap_err();
    assert!(
        e.to_string().contains("has 3 FRF columns but 2 responses"),
        "{e}"
    );
    // A unit instead of the quantity converts: g/N.
    let opts = FrfReadOptions {
        quantity: None,
        unit: Some("g/N".into()),
        ..full
    };
    let g = read_frf(&path, &opts).unwrap();
    assert_eq!(
        g.pairs[0].values[0],
        C64::new(-0.0285156946629286, -0.0434577353298664) * 9.80665
    );
}

fn sample() -> FrfFile {
    let frequency_hz: Vec<f64> = (0..50).map(|k| 0.25 + k as f64 * 0.1).collect();
    let h = |f: f64, i: usize| C64::new(1.0, 0.0) / C64::new(100.0 - f * f, 0.3 * f + i as f64);
    let pairs = vec![
        FrfPair {
            response: FrfPoint::named_at("acc1", 1, 1),
            reference: FrfPoint::named_at("force", 2, 1),
            quantity: FrfQuantity::Accelerance,
            values: frequency_hz.iter().map(|&f| h(f, 0)).collect(),
            coherence: Some(frequency_hz.iter().map(|&f| 1.0 / (1.0 + f)).collect()),
            averages: None,
            source: String::new(),
            exponential_tau_s: None,
        },
        FrfPair {
            response: FrfPoint::named("acc 2"),
            reference: FrfPoint::named_at("force", 2, 1),
            quantity: FrfQuantity::Accelerance,
            values: frequency_hz.iter().map(|&f| h(f, 1) * 1e-7).collect(),
            coherence: None,
            averages: None,
            source: String::new(),
            exponential_tau_s: None,
        },
    ];
    FrfFile {
        path: "sample.csv".into(),
        format: FrfFormat::Csv,
        frequency_hz,
        pairs,
    }
}

fn parse(text: &str, opts: &FrfReadOptions) -> Result<FrfFile, RecordError> {
    parse_frf(text.as_bytes(), Path::new("frf.csv"), opts)
}

#[test]
fn csv_round_trips_are_exact() {
    let file = sample();
    let bytes = encode_frf(&file, FrfFormat::Csv).unwrap();
    let text = String::from_utf8(bytes).unwrap();
    assert!(text.starts_with(
        "frequency_hz,re H(acc1@1:+X/force@2:+X) [(m/s^2)/N],im H(acc1@1:+X/force@2:+X) [(m/s^2)/N],coh(acc1@1:+X/force@2:+X),re H(acc 2/force@2:+X)"
    ));
    assert_eq!(content_kind(text.as_bytes()), ContentKind::Frf);
    let back = parse(&text, &FrfReadOptions::default()).unwrap();
    // Shortest round-trip digits: bit for bit.
    assert_eq!(back.frequency_hz, file.frequency_hz);
    for (p, q) in file.pairs.iter().zip(&back.pairs) {
        assert_eq!(p.response, q.response);
        assert_eq!(p.reference, q.reference);
        assert_eq!(p.quantity, q.quantity);
        assert_eq!(p.values, q.values);
        assert_eq!(p.coherence, q.coherence);
    }
    // Headerless: values and grid exact, points from the options.
    let bytes = encode_frf(&file, FrfFormat::CsvComplex).unwrap();
    assert_eq!(content_kind(&bytes), ContentKind::Frf);
    let opts = FrfReadOptions {
        quantity: Some(FrfQuantity::Accelerance),
        reference: Some(file.pairs[0].reference.clone()),
        responses: Some(file.pairs.iter().map(|p| p.response.clone()).collect()),
        ..FrfReadOptions::default()
    };
    let back = parse_frf(&bytes, Path::new("h.csv"), &opts).unwrap();
    assert_eq!(back.frequency_hz, file.frequency_hz);
    for (p, q) in file.pairs.iter().zip(&back.pairs) {
        assert_eq!(p.values, q.values);
        assert_eq!(q.coherence, None);
    }
}

#[test]
fn header_convention_units_convert() {
    let text = "freq [Hz];re H(a/f) [g/N];im H(a/f) [g/N];re H(d/f) [mm/N];im H(d/f) [mm/N]\n\
                1,0;1;2;3;4\n2;5;6;7;8\n";
    let file = parse(text, &FrfReadOptions::default()).unwrap();
    assert_eq!(file.frequency_hz, [1.0, 2.0]);
    assert_eq!(file.pairs[0].quantity, FrfQuantity::Accelerance);
    assert_eq!(file.pairs[0].values[0], C64::new(9.80665, 2.0 * 9.80665));
    assert_eq!(file.pairs[1].quantity, FrfQuantity::Receptance);
    assert_eq!(file.pairs[1].values[1], C64::new(7e-3, 8e-3));
    assert_eq!(file.pairs[1].source, "columns 4-5");
}

#[test]
fn csv_refusals_name_file_line_and_column() {
    let none = FrfReadOptions::default();
    let head = "frequency_hz,re H(a/f) [(m/s^2)/N],im H(a/f) [(m/s^2)/N]\n";
    let cases: [(String, &str); 8] = [
        (
            format!("{head}1,1,2\n2,NaN,3\n"),
            "frf.csv: line 3, column 2 (re H(a/f) [(m/s^2)/N]): value 'NaN' is NaN or infinite",
        ),
        (
            format!("{head}1,1,2\n1,2,3\n"),
            "frf.csv: line 3, column 1 (frequency_hz): frequency 1 Hz is not above the previous line (1 Hz)",
        ),
        (
            format!("{head}1,1\n"),
            "frf.csv: line 2: row has 2 cells but the header has 3 columns",
        ),
        (
            "frequency_hz,re H(a/f) [(m/s^2)/N]\n1,2\n".into(),
            "column 2 (re H(a/f) [(m/s^2)/N]): the pair a/f has a 're' column but no 'im H(...)' column",
        ),
        (
            "frequency_hz,re H(a/f),im H(a/f)\n1,2,3\n".into(),
            "frf.csv: line 1, column 2 (re H(a/f)): the file does not state the unit of this column",
        ),
        (
            "frequency_hz,re H(a/f) [V/N],im H(a/f) [V/N]\n1,2,3\n".into(),
            "column 2 (re H(a/f) [V/N]): FRF unit 'V/N' is not known",
        ),
        (
            "frequency_hz,acc1 [m/s^2]\n1,2\n".into(),
            "column 2 (acc1 [m/s^2]): not an FRF column",
        ),
        (
            "0.5+0j;1+2j\n1.0+1j;3+4j\n".into(),
            "frf.csv: line 1: the file does not state the quantity",
        ),
    ];
    for (text, want) in cases {
        let msg = parse(&text, &none).unwrap_err().to_string();
        assert!(msg.contains(want), "{msg}\nwanted: {want}");
    }
    // The frequency of a headerless row must be real.
    let opts = FrfReadOptions {
        quantity: Some(FrfQuantity::Receptance),
        reference: Some(FrfPoint::named("f")),
        responses: Some(vec![FrfPoint::named("a")]),
        ..none
    };
    let msg = parse("0.5+0j;1+2j\n1.0+1j;3+4j\n", &opts)
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains("line 2, column 1 (frequency): '1.0+1j' is not a complex number (a frequency has imaginary part 0)"),
        "{msg}"
    );
    let msg = parse("0.5+0j;1+2j\n1.0+0j;3+4x\n", &opts)
        .unwrap_err()
        .to_string();
    assert!(msg.contains("line 2, column 2 (H1): '3+4x'"), "{msg}");
}
