//! Inputs found by the fuzz targets in `fuzz/`, kept as regression tests.
//! Every file in `tests/data/fuzz/` goes through the same checks as
//! the `roundtrip` fuzz target; some also have specific expectations.

use std::path::{Path, PathBuf};

use records::{
    Csv, FileFormat, ReadOptions, RecordError, RecordFile, Uff58, Uff58Encoding, parse_record,
};

fn dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/fuzz")
}

fn same(a: &RecordFile, b: &RecordFile, exact_dt: bool) {
    assert_eq!(a.len(), b.len());
    assert_eq!(a.start_s.to_bits(), b.start_s.to_bits());
    if exact_dt {
        assert_eq!(a.dt_s.to_bits(), b.dt_s.to_bits());
    } else {
        assert!((a.dt_s - b.dt_s).abs() <= 1e-9 * a.dt_s);
    }
    for (x, y) in a.channels.iter().zip(&b.channels) {
        assert_eq!((&x.name, &x.unit), (&y.name, &y.unit));
        let bits = |v: &[f64]| v.iter().map(|f| f.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&x.values), bits(&y.values));
    }
}

/// The property the `roundtrip` fuzz target checks.
fn round_trips(data: &[u8], name: &str) {
    let opts = ReadOptions::default();
    let Ok(rec) = parse_record(data, Path::new(name), &opts) else {
        return;
    };
    for enc in [Uff58Encoding::Binary, Uff58Encoding::AsciiFullPrecision] {
        match Uff58(enc).encode(&rec) {
            Ok(bytes) => same(
                &rec,
                &parse_record(&bytes, Path::new("back.uff"), &opts).unwrap(),
                true,
            ),
            Err(RecordError::InvalidRecord { .. }) => {}
            Err(e) => panic!("{name}: {e}"),
        }
    }
    match Csv.encode(&rec) {
        Ok(bytes) => same(
            &rec,
            &parse_record(&bytes, Path::new("back.csv"), &opts)
                .unwrap_or_else(|e| panic!("{name}: own CSV refused: {e}")),
            false,
        ),
        Err(RecordError::InvalidRecord { .. }) => {}
        Err(e) => panic!("{name}: {e}"),
    }
}

#[test]
fn all_fuzz_findings_round_trip() {
    let mut n = 0;
    for entry in std::fs::read_dir(dir()).unwrap() {
        let path = entry.unwrap().path();
        let data = std::fs::read(&path).unwrap();
        round_trips(&data, &path.display().to_string());
        n += 1;
    }
    assert!(n > 0);
}

/// A 58b file whose ID line 1 is padded with NUL bytes: the reader kept the
/// NULs in the channel name, and the CSV writer wrote a file its reader
/// refuses as binary. NUL padding now reads as blanks, and the CSV writer
/// refuses names with control characters.
#[test]
fn nul_padded_id_line() {
    let data = std::fs::read(dir().join("roundtrip-nul-padded-id-line.uff")).unwrap();
    let rec = parse_record(&data, Path::new("x.uff"), &ReadOptions::default()).unwrap();
    assert!(!rec.channels[0].name.contains('\0'));
    assert!(rec.channels[0].name.starts_with("acc0"));
    assert!(Csv.encode(&rec).is_ok());
    let mut bad = rec.clone();
    bad.channels[0].name.push('\0');
    assert!(matches!(
        Csv.encode(&bad),
        Err(RecordError::InvalidRecord { .. })
    ));
}

/// A 58b file with dt = 4.88281e-14 s and start -0.0123 s: the CSV writer
/// accepted it, but start + i*dt rounded to the ulps of 0.0123 carries dt
/// only to about 1e-5. The CSV writer now checks that the time column will
/// give dt back to 1e-9 and refuses otherwise.
#[test]
fn csv_cannot_carry_tiny_dt_after_large_start() {
    let data = std::fs::read(dir().join("roundtrip-csv-dt-lost-to-start-offset.uff")).unwrap();
    let rec = parse_record(&data, Path::new("x.uff"), &ReadOptions::default()).unwrap();
    assert_eq!(rec.dt_s, 4.88281e-14);
    let e = Csv.encode(&rec).unwrap_err();
    assert!(e.to_string().contains("cannot carry dt_s"), "{e}");
    assert!(Uff58(Uff58Encoding::Binary).encode(&rec).is_ok());
}

/// Record 7 with abscissa minimum -1.23E-402, which underflows to -0.0:
/// CSV wrote the first time as start + 0*dt = +0.0, so the start changed
/// sign. Readers now return +0.0 for a zero start.
#[test]
fn negative_zero_start() {
    let data = std::fs::read(dir().join("roundtrip-negative-zero-start.uff")).unwrap();
    let rec = parse_record(&data, Path::new("x.uff"), &ReadOptions::default()).unwrap();
    assert_eq!(rec.start_s.to_bits(), 0.0f64.to_bits());
    let csv = parse_record(
        b"time,a\n-0,1\n0.5,2\n",
        Path::new("x.csv"),
        &ReadOptions::default(),
    );
    assert_eq!(csv.unwrap().start_s.to_bits(), 0.0f64.to_bits());
}
