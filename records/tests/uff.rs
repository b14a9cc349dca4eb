//! UFF dataset 58: files from independent writers (hand-made per the
//! published layout, pyuff, a big-endian binary composed here), round trips
//! of frameid's writer, and refusals of bad input.

mod common;

use common::{parse_problem, spec};
use std::path::{Path, PathBuf};

use records::{
    Channel, Format, Problem, ReadOptions, RecordError, RecordFile, Uff58Encoding, parse_record,
    read_record, write_uff58,
};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

fn read(name: &str) -> RecordFile {
    read_record(&data(name), &ReadOptions::default()).unwrap_or_else(|e| panic!("{e}"))
}

fn parse(content: &[u8]) -> Result<RecordFile, RecordError> {
    parse_record(content, Path::new("hit.uff"), &ReadOptions::default())
}

fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

// ----- independent writers -----

#[test]
fn handmade_single_precision_even() {
    let r = read("handmade_single_even.uff");
    assert_eq!(r.format, Format::Uff58Ascii);
    assert_eq!(r.len(), 10);
    assert_eq!(r.dt_s, 0.0025);
    assert_eq!(r.start_s, -0.01);
    assert_eq!(r.channels.len(), 2);

    let f = r.channel(&spec("id:hammer")).unwrap();
    assert_eq!(f.name, "Hammer force floor 3");
    assert_eq!(f.id_line.as_deref(), Some("Hammer force floor 3"));
    assert_eq!((f.node, f.direction), (Some(3), Some(1)));
    assert_eq!(f.unit.as_deref(), Some("N"));
    assert_eq!(
        f.values,
        [
            0.0, 1.25, 12.5, 48.75, 31.25, 6.0, -0.5, 0.0625, 0.0, -0.003125
        ]
    );

    // Entity names with blanks ("FLOOR 2") force the fixed-column reading
    // of record 6; the values use Fortran's 0.ddddd mantissa.
    let a = r.channel(&spec("2:-X")).unwrap();
    assert_eq!(a.name, "Accelerometer floor 2");
    assert_eq!(a.unit.as_deref(), Some("m/s^2"));
    assert_eq!(
        a.values,
        [
            0.0, 0.001, -0.0234, 0.5, 1.75, -2.125, 0.875, -0.0625, 0.0156, -0.0039
        ]
    );
}

#[test]
fn handmade_double_uneven_crlf_milliseconds() {
    let r = read("handmade_double_uneven_crlf.uff");
    assert_eq!(r.len(), 7);
    // Abscissa 500.00, 500.25, ... ms.
    assert!((r.start_s - 0.5).abs() < 1e-15);
    assert!((r.dt_s - 0.25e-3).abs() < 1e-15);
    let c = &r.channels[0];
    // Blank ID line 1: the name comes from node and direction.
    assert_eq!(c.name, "101:+Z");
    assert_eq!(c.id_line, None);
    assert_eq!(c.unit.as_deref(), Some("g"));
    assert_eq!(r.channel(&spec("node101:z")).unwrap().name, "101:+Z");
    // 13-digit values read exactly, including one whose 20-column field
    // touches the abscissa field before it.
    assert_eq!(
        c.values,
        [
            1.234567890123,
            -9.87654321e-05,
            3.0e-300,
            0.0,
            -1.0e100,
            2.5,
            7.000000000001e-3
        ]
    );
}

/// The signals `make_pyuff.py` wrote: channel k at t = i/2048.
fn pyuff_signal(k: usize, i: usize) -> f64 {
    let t = i as f64 / 2048.0;
    let kf = k as f64;
    (2.0 * std::f64::consts::PI * (5.0 * (kf + 1.0)) * t + 0.25 * kf).sin()
        * (-3.0 * t).exp()
        * 10f64.powi(k as i32 - 1)
}

fn check_pyuff(r: &RecordFile, rel: f64) {
    assert_eq!(r.len(), 300);
    let ids = ["Hammer floor 3", "Floor 1 acc", "Floor 2 acc"];
    let dof = [(3, 1), (1, 1), (2, -1)];
    let units = ["N", "m/s^2", "m/s^2"];
    for k in 0..3 {
        let c = &r.channels[k];
        assert_eq!(c.name, ids[k]);
        assert_eq!((c.node, c.direction), (Some(dof[k].0), Some(dof[k].1)));
        assert_eq!(c.unit.as_deref(), Some(units[k]));
        let amp = 10f64.powi(k as i32 - 1);
        for (i, &v) in c.values.iter().enumerate() {
            let want = pyuff_signal(k, i);
            assert!(
                (v - want).abs() <= rel * want.abs() + 1e-14 * amp,
                "channel {k} sample {i}: {v} vs {want}"
            );
        }
    }
}

#[test]
fn pyuff_ascii_and_binary_even() {
    // pyuff prints 12 significant digits (%20.11e) and the increment with
    // 6 (%13.5e): 1/2048 becomes 4.88281e-04.
    let a = read("pyuff_ascii_even.uff");
    assert_eq!(a.format, Format::Uff58Ascii);
    check_pyuff(&a, 5.0001e-12);
    assert!((a.dt_s * 2048.0 - 1.0).abs() < 1e-6);
    assert_eq!(a.start_s, 0.0);
    let b = read("pyuff_binary_even.uff");
    assert_eq!(b.format, Format::Uff58Binary);
    check_pyuff(&b, 0.0);
    assert_eq!(b.dt_s, a.dt_s);
}

#[test]
fn pyuff_ascii_and_binary_uneven() {
    // Abscissa values stored with every sample: (x, y) pairs.
    let a = read("pyuff_ascii_uneven.uff");
    check_pyuff(&a, 5.0001e-12);
    assert!((a.dt_s * 2048.0 - 1.0).abs() < 1e-6);
    // pyuff's 58b header declares half the bytes it writes for uneven data;
    // the reader accepts exactly that case. Binary abscissa values are
    // exact, so the interval is too.
    let b = read("pyuff_binary_uneven.uff");
    check_pyuff(&b, 0.0);
    assert_eq!(b.dt_s, 1.0 / 2048.0);
}

/// A 58b dataset composed here field by field: big-endian, real single
/// precision, start 0.1 s, dt 1 ms.
fn big_endian_single() -> (Vec<u8>, [f32; 5]) {
    let vals: [f32; 5] = [0.5, -1.25, 3.0e-3, 1.0e6, -0.0];
    let mut f = Vec::new();
    let mut line = |s: &str| {
        f.extend_from_slice(s.as_bytes());
        f.push(b'\n');
    };
    line("    -1");
    line(&format!(
        "{:>6}b{:>6}{:>6}{:>12}{:>12}{:>6}{:>6}{:>12}{:>12}",
        58, 2, 2, 11, 20, 0, 0, 0, 0
    ));
    line("Roof accelerometer");
    line("NONE");
    line("01-Apr-24  09:00:00");
    line("NONE");
    line("NONE");
    line("    1         7    1         0 ROOF               7   2 HAMMER             3   1");
    line("         2         5         1  1.00000E-01  1.00000E-03  0.00000E+00");
    line("        17    0    0    0 Time                 s                   ");
    line("        12    1    0    0 Acceleration         m/s^2               ");
    line("         0    0    0    0 NONE                 NONE                ");
    line("         0    0    0    0 NONE                 NONE                ");
    for v in vals {
        f.extend_from_slice(&v.to_be_bytes());
    }
    f.extend_from_slice(b"    -1\n");
    (f, vals)
}

#[test]
fn independent_big_endian_single_binary() {
    let (bytes, vals) = big_endian_single();
    let r = parse(&bytes).unwrap();
    assert_eq!(r.format, Format::Uff58Binary);
    assert_eq!((r.start_s, r.dt_s), (0.1, 0.001));
    let c = r.channel(&spec("7:+Y")).unwrap();
    assert_eq!(c.name, "Roof accelerometer");
    let want: Vec<f64> = vals.iter().map(|&v| f64::from(v)).collect();
    assert_eq!(bits(&c.values), bits(&want));
}

// ----- frameid's writer -----

fn sample_record() -> RecordFile {
    let n = 1001;
    let tricky = [0.0, -0.0, 5e-324, f64::MIN_POSITIVE, f64::MAX, -1e300, 0.1];
    let mk = |k: usize| -> Vec<f64> {
        (0..n)
            .map(|i| {
                if i < tricky.len() && k == 1 {
                    tricky[i]
                } else {
                    ((i * (k + 3)) as f64 * 0.01).sin() * 10f64.powi(k as i32 - 2) / 3.0
                }
            })
            .collect()
    };
    RecordFile {
        path: "mem".into(),
        format: Format::Uff58Ascii,
        dt_s: 1.0 / 2048.0,
        start_s: -0.0123,
        channels: vec![
            Channel {
                name: "force".into(),
                unit: Some("N".into()),
                node: Some(3),
                direction: Some(1),
                id_line: None,
                values: mk(0),
                lines: None,
            },
            Channel {
                name: "acc1".into(),
                unit: Some("m/s^2".into()),
                node: Some(1),
                direction: Some(-1),
                id_line: None,
                values: mk(1),
                lines: None,
            },
            Channel {
                name: "acc 2, roof".into(),
                unit: None,
                node: None,
                direction: None,
                id_line: None,
                values: mk(2),
                lines: None,
            },
        ],
    }
}

fn assert_same_channels(a: &RecordFile, b: &RecordFile, exact: bool) {
    assert_eq!(a.len(), b.len());
    assert_eq!(a.dt_s.to_bits(), b.dt_s.to_bits());
    assert_eq!(a.start_s.to_bits(), b.start_s.to_bits());
    assert_eq!(a.channels.len(), b.channels.len());
    for (x, y) in a.channels.iter().zip(&b.channels) {
        assert_eq!(x.name, y.name);
        assert_eq!(x.unit, y.unit);
        assert_eq!(x.node.unwrap_or(0), y.node.unwrap_or(0));
        assert_eq!(x.direction.unwrap_or(0), y.direction.unwrap_or(0));
        if exact {
            assert_eq!(bits(&x.values), bits(&y.values), "{}", x.name);
        } else {
            for (u, v) in x.values.iter().zip(&y.values) {
                // 13 significant digits: half a unit of the last is 5e-13.
                assert!((u - v).abs() <= 5e-13 * u.abs(), "{u} vs {v}");
            }
        }
    }
}

#[test]
fn binary_round_trip_is_bit_exact() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sim.uff");
    let rec = sample_record();
    write_uff58(&path, &rec, Uff58Encoding::Binary).unwrap();
    let back = read_record(&path, &ReadOptions::default()).unwrap();
    assert_eq!(back.format, Format::Uff58Binary);
    assert_same_channels(&rec, &back, true);
    // Reading, writing and reading again changes nothing at all.
    let path2 = dir.path().join("again.uff");
    write_uff58(&path2, &back, Uff58Encoding::Binary).unwrap();
    let again = read_record(&path2, &ReadOptions::default()).unwrap();
    assert_eq!(
        RecordFile {
            path: path.clone(),
            ..again
        },
        back
    );
}

#[test]
fn full_precision_ascii_round_trip_is_bit_exact() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sim.uff");
    let rec = sample_record();
    write_uff58(&path, &rec, Uff58Encoding::AsciiFullPrecision).unwrap();
    let back = read_record(&path, &ReadOptions::default()).unwrap();
    assert_eq!(back.format, Format::Uff58Ascii);
    assert_same_channels(&rec, &back, true);
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(text.lines().all(|l| l.len() <= 80));
}

#[test]
fn standard_ascii_round_trip_keeps_13_digits() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sim.uff");
    let rec = sample_record();
    write_uff58(&path, &rec, Uff58Encoding::Ascii).unwrap();
    let back = read_record(&path, &ReadOptions::default()).unwrap();
    assert_same_channels(&rec, &back, false);
    // Values that have at most 13 significant digits come back exactly.
    let text = std::fs::read_to_string(&path).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    // Layout: record 7 in 3I10,3E13.5; data in 4E20.12, 80 columns.
    assert_eq!(lines[0], "    -1");
    assert_eq!(lines[1], "    58");
    assert_eq!(lines[2].trim_end(), "force");
    assert!(lines[6].starts_with("frameid dt_s=0.00048828125 start_s=-0.0123"));
    assert_eq!(
        lines[7],
        "    1         1    0         0 NONE               3   1 NONE               0   0"
    );
    assert_eq!(
        lines[8],
        "         4      1001         1 -1.23000E-02  4.88281E-04  0.00000E+00"
    );
    assert_eq!(lines[10].get(47..).map(str::trim_end), Some("N"));
    assert_eq!(lines[13].len(), 80);
    assert_eq!(&lines[13][..20], "  0.000000000000E+00");
}

#[test]
fn record7_wins_over_a_stale_tag() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sim.uff");
    let mut rec = sample_record();
    rec.channels.truncate(1);
    write_uff58(&path, &rec, Uff58Encoding::Ascii).unwrap();
    // Another program changed the increment in record 7 but kept ID line 5.
    let text = std::fs::read_to_string(&path)
        .unwrap()
        .replace("4.88281E-04", "1.00000E-03");
    let r = parse(text.as_bytes()).unwrap();
    assert_eq!(r.dt_s, 0.001);
    assert_eq!(r.start_s, -0.0123);
}

#[test]
fn writer_refusals() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.uff");
    let cases: [fn(&mut RecordFile); 9] = [
        |r| r.channels[0].name = "x".repeat(81),
        |r| r.channels[0].name = "Kraft µ".into(),
        |r| r.channels[0].name = " padded".into(),
        |r| r.channels[0].name = "NONE".into(),
        |r| r.channels[0].unit = Some("u".repeat(21)),
        |r| r.channels[0].direction = Some(7),
        |r| r.channels[0].node = Some(99_999_999_999),
        |r| r.channels[0].values[3] = f64::INFINITY,
        |r| r.dt_s = -1.0,
    ];
    for change in cases {
        let mut rec = sample_record();
        change(&mut rec);
        for binary in [false, true] {
            let e = write_uff58(
                &path,
                &rec,
                if binary {
                    Uff58Encoding::Binary
                } else {
                    Uff58Encoding::Ascii
                },
            )
            .unwrap_err();
            assert!(matches!(e, RecordError::InvalidRecord { .. }), "{e}");
        }
    }
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

// ----- bad input -----

const REC6: &str =
    "    1         1    0         0 NONE               3   1 NONE               3   1";
const REC7: &str = "         2         4         1  0.00000E+00  1.00000E-03  0.00000E+00";
const DATA: &str = "  1.00000E+00  2.00000E+00  3.00000E+00  4.00000E+00";

/// An ASCII dataset 58 with the given record 6, record 7 and data lines.
fn ds58(id: &str, rec6: &str, rec7: &str, data: &[&str]) -> String {
    let mut s = format!("    -1\n    58\n{id}\nNONE\nNONE\nNONE\nNONE\n{rec6}\n{rec7}\n");
    s.push_str("        17    0    0    0 Time                 s                   \n");
    s.push_str("        12    0    0    0 Acc                  m/s^2               \n");
    s.push_str("         0    0    0    0 NONE                 NONE                \n");
    s.push_str("         0    0    0    0 NONE                 NONE                \n");
    for d in data {
        s.push_str(d);
        s.push('\n');
    }
    s.push_str("    -1\n");
    s
}

fn good() -> String {
    ds58("acc", REC6, REC7, &[DATA])
}

#[test]
fn minimal_dataset_reads() {
    let r = parse(good().as_bytes()).unwrap();
    assert_eq!(r.channels[0].values, [1.0, 2.0, 3.0, 4.0]);
}

#[test]
fn truncated_datasets() {
    let text = good();
    let lines: Vec<&str> = text.lines().collect();
    let cut = |n: usize| lines[..n].join("\n") + "\n";
    let (p, msg) = parse_problem("hit.uff", parse(cut(1).as_bytes()));
    assert!(matches!(p, Problem::UffTruncated { .. }));
    assert!(
        msg.contains("dataset 1, line 1") && msg.contains("before the dataset number"),
        "{msg}"
    );
    let (_, msg) = parse_problem("hit.uff", parse(cut(6).as_bytes()));
    assert!(
        msg.contains("truncated") && msg.contains("before record 5 of 11"),
        "{msg}"
    );
    let (_, msg) = parse_problem("hit.uff", parse(cut(14).as_bytes()));
    assert!(
        msg.contains("truncated") && msg.contains("inside the data (4 of 4 values read)"),
        "{msg}"
    );
    // A dataset that closes before its header is complete.
    let short = "    -1\n    58\nacc\nNONE\n    -1\n";
    let (_, msg) = parse_problem("hit.uff", parse(short.as_bytes()));
    assert_eq!(
        msg,
        "hit.uff: dataset 1, line 5: dataset is truncated: its closing '-1' comes before record 3 of 11"
    );
}

#[test]
fn unsupported_function_type() {
    let rec6 = REC6.replacen("    1", "    4", 1);
    let (p, msg) = parse_problem(
        "hit.uff",
        parse(ds58("frf", &rec6, REC7, &[DATA]).as_bytes()),
    );
    assert_eq!(p, Problem::UffUnsupportedFunction { func_type: 4 });
    assert_eq!(
        msg,
        "hit.uff: dataset 1, line 8, record 6 field 1 (function type): function type 4 \
         (frequency response function) is not supported; only 1 (time response) is \
         (this is an FRF file: read it as FRFs)"
    );
}

#[test]
fn bad_record6_fields() {
    let rec6 = "    1       abc    0         0 NONE               3   1 NONE               3   1";
    let (p, msg) = parse_problem("hit.uff", parse(ds58("a", rec6, REC7, &[DATA]).as_bytes()));
    assert!(matches!(p, Problem::UffBadField { .. }));
    assert!(
        msg.contains("line 8, record 6 field 2 (function identification number, columns 6-15)")
            && msg.contains("'abc'"),
        "{msg}"
    );
    let rec6 = REC6.replacen("   3   1 NONE", "   3   9 NONE", 1);
    let (_, msg) = parse_problem("hit.uff", parse(ds58("a", &rec6, REC7, &[DATA]).as_bytes()));
    assert!(
        msg.contains("record 6 field 7 (response direction)") && msg.contains("-6..6"),
        "{msg}"
    );
}

#[test]
fn bad_record7_fields() {
    let cases = [
        (
            "         2         x         1  0.00000E+00  1.00000E-03  0.00000E+00",
            "record 7 field 2 (number of values, columns 11-20): bad value 'x': not an integer",
        ),
        (
            "         2         4         7  0.00000E+00  1.00000E-03  0.00000E+00",
            "record 7 field 3 (abscissa spacing): bad value '7'",
        ),
        (
            "         2         4         1  0.00000E+00  0.00000E+00  0.00000E+00",
            "record 7 field 5 (abscissa increment): bad value '0.00000E+00'",
        ),
        (
            "         2         0         1  0.00000E+00  1.00000E-03  0.00000E+00",
            "record 7 field 2 (number of values): bad value '0'",
        ),
        (
            "         2         4         1  0.0000?E+00  1.00000E-03  0.00000E+00",
            "record 7 field 4 (abscissa minimum, columns 31-43)",
        ),
    ];
    for (rec7, want) in cases {
        let (p, msg) = parse_problem("hit.uff", parse(ds58("a", REC6, rec7, &[DATA]).as_bytes()));
        assert!(matches!(p, Problem::UffBadField { .. }), "{msg}");
        assert!(msg.contains("dataset 1, line 9, "), "{msg}");
        assert!(msg.contains(want), "{msg}\nwanted: {want}");
    }
}

#[test]
fn unsupported_ordinate_type() {
    for (t, name) in [(6, "complex double"), (5, "complex single"), (3, "unknown")] {
        let rec7 = REC7.replacen("         2", &format!("{t:>10}"), 1);
        let (p, msg) = parse_problem("hit.uff", parse(ds58("a", REC6, &rec7, &[DATA]).as_bytes()));
        assert_eq!(p, Problem::UffUnsupportedOrdinate { ord_type: t });
        assert!(
            msg.contains("line 9, record 7 field 1") && msg.contains(name),
            "{msg}"
        );
    }
}

#[test]
fn data_count_mismatch() {
    let rec7 = REC7.replacen("         4", "         5", 1);
    let (p, msg) = parse_problem("hit.uff", parse(ds58("a", REC6, &rec7, &[DATA]).as_bytes()));
    assert_eq!(
        p,
        Problem::UffCountMismatch {
            declared: 5,
            found: 4,
            record7_line: 9
        }
    );
    assert_eq!(
        msg,
        "hit.uff: dataset 1, line 15: record 7 (line 9) declares 5 values, but the data section holds 4"
    );
}

#[test]
fn bad_data_values() {
    let (p, msg) = parse_problem(
        "hit.uff",
        parse(
            ds58(
                "a",
                REC6,
                REC7,
                &["  1.00000E+00  2.0000xE+00  3.00000E+00  4.00000E+00"],
            )
            .as_bytes(),
        ),
    );
    assert_eq!(
        p,
        Problem::NonNumeric {
            text: "2.0000xE+00".into()
        }
    );
    assert!(msg.contains("line 14, value 2 on the line"), "{msg}");
    let (p, msg) = parse_problem(
        "hit.uff",
        parse(
            ds58(
                "a",
                REC6,
                REC7,
                &["  1.00000E+00          NaN  3.00000E+00  4.00000E+00"],
            )
            .as_bytes(),
        ),
    );
    assert!(matches!(p, Problem::NonFinite { .. }));
    assert!(
        msg.contains("line 14, value 2 on the line") && msg.contains("NaN or infinite"),
        "{msg}"
    );
}

#[test]
fn datasets_of_one_file_must_agree() {
    let three = REC7.replacen("         4", "         3", 1);
    let text = good()
        + &ds58(
            "b",
            REC6,
            &three,
            &["  1.00000E+00  2.00000E+00  3.00000E+00"],
        );
    let (p, msg) = parse_problem("hit.uff", parse(text.as_bytes()));
    assert!(matches!(p, Problem::UffDatasetMismatch { .. }));
    assert!(
        msg.contains(
            "dataset 2, line 24, record 7: the number of samples is 3, but dataset 1 has 4"
        ),
        "{msg}"
    );
    let slow = REC7.replacen("1.00000E-03", "2.00000E-03", 1);
    let text = good() + &ds58("b", REC6, &slow, &[DATA]);
    let (_, msg) = parse_problem("hit.uff", parse(text.as_bytes()));
    assert!(
        msg.contains("the sampling interval is 0.002 s, but dataset 1 has 0.001 s"),
        "{msg}"
    );
    let late = REC7.replacen("0.00000E+00  1.00000E-03", "5.00000E-01  1.00000E-03", 1);
    let text = good() + &ds58("b", REC6, &late, &[DATA]);
    let (_, msg) = parse_problem("hit.uff", parse(text.as_bytes()));
    assert!(msg.contains("the start time is 0.5 s"), "{msg}");
}

#[test]
fn other_datasets_are_skipped_but_needed_58() {
    let d151 = "    -1\n   151\nmodel\ndescription\nprogram\n    -1\n";
    let r = parse((d151.to_string() + &good() + d151).as_bytes()).unwrap();
    assert_eq!(r.channels.len(), 1);
    let (p, msg) = parse_problem("hit.uff", parse(d151.as_bytes()));
    assert_eq!(p, Problem::UffNoDataset58 { found: vec![151] });
    assert!(
        msg.contains("no dataset 58") && msg.contains("datasets found: 151"),
        "{msg}"
    );
    let (p, _) = parse_problem(
        "hit.uff",
        parse((d151.to_string() + "    -1\n  2411\n").as_bytes()),
    );
    assert!(matches!(p, Problem::UffTruncated { .. }));
}

#[test]
fn garbage_between_datasets() {
    let text = good() + "hello\n" + &good();
    let (p, msg) = parse_problem("hit.uff", parse(text.as_bytes()));
    assert_eq!(
        p,
        Problem::UffExpectedDelimiter {
            found: "hello".into()
        }
    );
    assert!(msg.contains("line 16"), "{msg}");
}

#[test]
fn abscissa_must_be_time() {
    let text = good().replacen(
        "        17    0    0    0 Time                 s   ",
        "        18    0    0    0 Frequency            Hz  ",
        1,
    );
    let (_, msg) = parse_problem("hit.uff", parse(text.as_bytes()));
    assert!(
        msg.contains("line 10, record 8 field 6 (abscissa units label)") && msg.contains("'Hz'"),
        "{msg}"
    );
}

/// An abscissa labelled `NONE` is taken in seconds, unless the interval is
/// then 1 s or more (milliseconds read as seconds): refused, naming the
/// dataset and record 8. A stated unit or a sampling rate is believed.
#[test]
fn unitless_abscissa_in_milliseconds_is_refused() {
    let ms = REC7.replacen("1.00000E-03", "1.56250E+01", 1);
    let unitless = |rec7: &str| {
        ds58("acc", REC6, rec7, &[DATA]).replacen(
            "        17    0    0    0 Time                 s   ",
            "        17    0    0    0 Time                 NONE",
            1,
        )
    };
    let (p, msg) = parse_problem("hit.uff", parse(unitless(&ms).as_bytes()));
    assert!(
        matches!(p, Problem::UndeclaredTimeUnit { dt_s, .. } if dt_s == 15.625),
        "{msg}"
    );
    assert!(
        msg.contains("dataset 1, line 10, record 8 field 6 (abscissa units label)")
            && msg.contains("0.064 Hz sampling")
            && msg.contains("abscissa units label to ms"),
        "{msg}"
    );
    // Stated in milliseconds, in seconds, or with the rate: read.
    let stated = ds58("acc", REC6, &ms, &[DATA]);
    assert_eq!(parse(stated.as_bytes()).unwrap().dt_s, 15.625);
    let stated_ms = stated.replacen("Time                 s ", "Time                 ms", 1);
    assert_eq!(parse(stated_ms.as_bytes()).unwrap().dt_s, 15.625e-3);
    let opts = ReadOptions::with_fs_hz(0.064);
    let r = parse_record(unitless(&ms).as_bytes(), Path::new("hit.uff"), &opts).unwrap();
    assert_eq!(r.dt_s, 15.625);
    // A plausible interval without a unit is seconds, as before.
    assert_eq!(parse(unitless(REC7).as_bytes()).unwrap().dt_s, 1e-3);
}

#[test]
fn fs_option_must_agree() {
    let opts = ReadOptions::with_fs_hz(1000.0);
    assert!(parse_record(good().as_bytes(), Path::new("hit.uff"), &opts).is_ok());
    let opts = ReadOptions::with_fs_hz(1024.0);
    let e = parse_record(good().as_bytes(), Path::new("hit.uff"), &opts).unwrap_err();
    assert!(e.to_string().contains("fs_hz = 1024 was given"), "{e}");
}

// ----- binary -----

fn binary_file() -> Vec<u8> {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("b.uff");
    let mut rec = sample_record();
    rec.channels.truncate(1);
    rec.channels[0].values.truncate(10);
    write_uff58(&path, &rec, Uff58Encoding::Binary).unwrap();
    std::fs::read(&path).unwrap()
}

fn replace(bytes: &[u8], from: &str, to: &str) -> Vec<u8> {
    let pos = bytes
        .windows(from.len())
        .position(|w| w == from.as_bytes())
        .unwrap();
    let mut out = bytes[..pos].to_vec();
    out.extend_from_slice(to.as_bytes());
    out.extend_from_slice(&bytes[pos + from.len()..]);
    out
}

#[test]
fn binary_layout() {
    let b = binary_file();
    let header =
        "    58b     1     2          11          80     0     0           0           0\n";
    assert_eq!(&b[7..7 + header.len()], header.as_bytes());
    assert!(b.ends_with(b"    -1\n"));
    // The closing delimiter follows the data directly.
    let n = b.len();
    let last = f64::from_le_bytes(b[n - 15..n - 7].try_into().unwrap());
    assert_eq!(last, sample_record().channels[0].values[9]);
}

#[test]
fn binary_byte_count_mismatch() {
    let b = replace(&binary_file(), "          80     0", "          72     0");
    let (p, msg) = parse_problem("hit.uff", parse(&b));
    assert!(matches!(
        p,
        Problem::UffByteCountMismatch {
            declared: 72,
            expected: 80,
            ..
        }
    ));
    assert!(
        msg.contains("dataset 1, line 2, binary header field 6 (number of bytes): binary header declares 72 data bytes, but record 7 implies 80 (10 values of 8 bytes)"),
        "{msg}"
    );
}

#[test]
fn binary_truncated() {
    let b = binary_file();
    let (p, msg) = parse_problem("hit.uff", parse(&b[..b.len() - 20]));
    assert!(matches!(p, Problem::UffTruncated { .. }));
    assert!(
        msg.contains("inside the binary data: 80 bytes declared, 67 present"),
        "{msg}"
    );
    let (_, msg) = parse_problem("hit.uff", parse(&b[..b.len() - 7]));
    assert!(msg.contains("before the closing '-1'"), "{msg}");
}

#[test]
fn binary_unsupported_layouts() {
    let b = replace(&binary_file(), "58b     1     2", "58b     1     1");
    let (p, msg) = parse_problem("hit.uff", parse(&b));
    assert!(matches!(p, Problem::UffUnsupportedBinary { .. }));
    assert!(
        msg.contains("binary header field 4 (floating point format)") && msg.contains("DEC VMS"),
        "{msg}"
    );
    let b = replace(&binary_file(), "58b     1     2", "58b     3     2");
    let (_, msg) = parse_problem("hit.uff", parse(&b));
    assert!(msg.contains("byte ordering 3"), "{msg}");
    let b = replace(&binary_file(), "          11", "          12");
    let (_, msg) = parse_problem("hit.uff", parse(&b));
    assert!(
        msg.contains("number of ASCII lines") && msg.contains("11 ASCII header records"),
        "{msg}"
    );
}

#[test]
fn binary_nan_value() {
    let mut b = binary_file();
    let n = b.len();
    b[n - 23..n - 15].copy_from_slice(&f64::NAN.to_le_bytes());
    let (p, msg) = parse_problem("hit.uff", parse(&b));
    assert!(matches!(p, Problem::NonFinite { .. }));
    assert!(
        msg.contains("binary value 9 (byte 65 of the data)"),
        "{msg}"
    );
}
