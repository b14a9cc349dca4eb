//! CSV records: what is accepted, how it is interpreted, and how every kind
//! of bad input is refused.

mod common;

use common::{parse_problem, spec};
use std::path::Path;

use records::{
    Channel, Format, Problem, ReadOptions, RecordError, RecordFile, parse_record, read_record,
    write_csv,
};

fn parse(content: &str) -> Result<RecordFile, RecordError> {
    parse_record(
        content.as_bytes(),
        Path::new("hit1.csv"),
        &ReadOptions::default(),
    )
}

fn parse_fs(content: &str, fs: f64) -> Result<RecordFile, RecordError> {
    parse_record(
        content.as_bytes(),
        Path::new("hit1.csv"),
        &ReadOptions::with_fs_hz(fs),
    )
}

#[test]
fn frameid_layout() {
    let r =
        parse("time,force,acc1,acc2\n0,1.5,0.25,-3\n0.001,2,0.5,-2\n0.002,0,1e-3,4.5\n").unwrap();
    assert_eq!(r.format, Format::Csv { delimiter: b',' });
    assert_eq!(r.len(), 3);
    assert_eq!(r.dt_s, 0.001);
    assert_eq!(r.start_s, 0.0);
    let names: Vec<&str> = r.channels.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, ["force", "acc1", "acc2"]);
    assert_eq!(r.channel(&spec("acc1")).unwrap().values, [0.25, 0.5, 1e-3]);
    assert_eq!(r.channel(&spec("#3")).unwrap().values, [-3.0, -2.0, 4.5]);
    assert!(
        r.channels
            .iter()
            .all(|c| c.unit.is_none() && c.node.is_none())
    );
}

#[test]
fn semicolon_decimal_comma_units_and_bom() {
    let text = "\u{feff}Time (s);Force [N];acc_1 (m/s^2);force_N\r\n\
                0,000;1,5;-0,25;7\r\n\
                0,002;2,5;1e-3;8\r\n\
                0,004;-3;0,5;9\r\n\r\n\r\n";
    let r = parse(text).unwrap();
    assert_eq!(r.format, Format::Csv { delimiter: b';' });
    assert_eq!(r.dt_s, 0.002);
    let f = r.channel(&spec("force")).unwrap();
    assert_eq!(f.unit.as_deref(), Some("N"));
    assert_eq!(f.values, [1.5, 2.5, -3.0]);
    let a = r.channel(&spec("ACC_1 [whatever]")).unwrap();
    assert_eq!(a.name, "acc_1");
    assert_eq!(a.unit.as_deref(), Some("m/s^2"));
    assert_eq!(a.values, [-0.25, 1e-3, 0.5]);
    // An underscore suffix is part of the name, not a unit.
    let n = r.channel(&spec("force_N")).unwrap();
    assert_eq!(n.unit, None);
}

#[test]
fn tabs_whitespace_and_milliseconds() {
    let text = "  time [ms] \t  force \t acc1\n  10 \t 1 \t 2 \n 10.5\t3\t4\n11\t5\t6\n\n";
    let r = parse(text).unwrap();
    assert_eq!(r.format, Format::Csv { delimiter: b'\t' });
    assert!((r.dt_s - 0.5e-3).abs() < 1e-15);
    assert!((r.start_s - 10e-3).abs() < 1e-15);
    assert_eq!(r.channel(&spec("acc1")).unwrap().values, [2.0, 4.0, 6.0]);
}

#[test]
fn no_time_column_uses_fs() {
    let r = parse_fs("force,acc1\n1,2\n3,4\n", 2048.0).unwrap();
    assert_eq!(r.dt_s, 1.0 / 2048.0);
    assert_eq!(r.start_s, 0.0);
    assert_eq!(r.channels.len(), 2);
}

#[test]
fn fs_must_agree_with_time_column() {
    let text = "time,force\n0,1\n0.001,2\n0.002,3\n";
    assert!(parse_fs(text, 1000.0).is_ok());
    let (p, msg) = parse_problem("hit1.csv", parse_fs(text, 2048.0));
    assert!(matches!(p, Problem::FsMismatch { .. }), "{msg}");
    assert!(msg.contains("fs_hz = 2048"), "{msg}");
}

/// A time column in milliseconds under a header without a unit was read as
/// seconds: at 64 Hz, dt 15.625 s, and M, K and damping wrong by orders of
/// magnitude with no warning. A bare `time` whose interval is 1 s or more
/// is refused naming the file, the column, the interval and the fix; a
/// stated unit or a sampling rate is believed.
#[test]
fn unitless_time_column_in_milliseconds_is_refused() {
    // 64 Hz written in milliseconds, as frameid writes numbers.
    let rows: String = (0..8)
        .map(|i| format!("{},{}.5,{}\n", i as f64 * 15.625, i, -i))
        .collect();
    for name in ["time", "Time", "t", "zeit"] {
        let text = format!("{name},force,acc1\n{rows}");
        let (p, msg) = parse_problem("hit1.csv", parse(&text));
        assert!(
            matches!(p, Problem::UndeclaredTimeUnit { dt_s, .. } if dt_s == 15.625),
            "{msg}"
        );
        assert!(
            msg.starts_with(&format!("hit1.csv: line 1, column 1 ({name}): ")),
            "{msg}"
        );
        assert!(msg.contains("15.625 s (0.064 Hz sampling)"), "{msg}");
        assert!(msg.contains(&format!("'{name} [ms]'")), "{msg}");
    }
    // The unit stated: milliseconds read as such, seconds believed.
    for header in ["time [ms]", "time_ms", "t (ms)"] {
        let r = parse(&format!("{header},force,acc1\n{rows}")).unwrap();
        assert_eq!(r.dt_s, 1.0 / 64.0, "{header}");
    }
    for header in ["time [s]", "time_s", "Time (sec)"] {
        let r = parse(&format!("{header},force,acc1\n{rows}")).unwrap();
        assert_eq!(r.dt_s, 15.625, "{header}");
    }
    // A sampling rate given and agreeing with the column is a statement too.
    let r = parse_fs(&format!("time,force,acc1\n{rows}"), 0.064).unwrap();
    assert_eq!(r.dt_s, 15.625);
    // Just below the threshold (1 Hz sampling is 1 s): taken as seconds.
    let r = parse("time,force\n0,1\n0.999,2\n1.998,3\n").unwrap();
    assert!((r.dt_s - 0.999).abs() < 1e-15);
    let (p, _) = parse_problem("hit1.csv", parse("time,force\n0,1\n1,2\n2,3\n"));
    assert!(matches!(p, Problem::UndeclaredTimeUnit { .. }));
}

/// frameid's writer states the unit where the reader needs it (an interval
/// of 1 s or more), so that such a record reads back; below, the header
/// stays `time`.
#[test]
fn slow_records_are_written_with_their_unit() {
    let dir = tempfile::tempdir().unwrap();
    for (dt_s, header) in [(2.0, "time [s]"), (0.5, "time")] {
        let rec = RecordFile {
            path: "slow.csv".into(),
            format: Format::Csv { delimiter: b',' },
            dt_s,
            start_s: 0.0,
            channels: vec![Channel {
                name: "force".into(),
                unit: None,
                node: None,
                direction: None,
                id_line: None,
                values: vec![1.0, 2.0, 3.0],
                lines: None,
            }],
        };
        let path = dir.path().join("slow.csv");
        write_csv(&path, &rec).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(text.starts_with(&format!("{header},force\n")), "{text}");
        assert_eq!(
            read_record(&path, &ReadOptions::default()).unwrap().dt_s,
            dt_s
        );
    }
}

#[test]
fn quoted_header_and_trailing_delimiter() {
    let text = "time,\"force, hammer [N]\",acc1,\n0,1,2,\n0.5,3,4,\n";
    let r = parse(text).unwrap();
    assert_eq!(r.channels.len(), 2);
    assert_eq!(r.channels[0].name, "force, hammer");
    assert_eq!(r.channels[0].unit.as_deref(), Some("N"));
    assert_eq!(r.channels[1].values, [2.0, 4.0]);
}

#[test]
fn coarse_but_exact_time_column() {
    // Three decimals at 1 kHz, as many exports print it.
    let mut text = String::from("time,force\n");
    for i in 0..5000 {
        text.push_str(&format!("{:.3},{}\n", i as f64 / 1000.0, i));
    }
    let r = parse(&text).unwrap();
    assert!((r.dt_s - 1e-3).abs() < 1e-12);
    // Six decimals at 4096 Hz: rounded, still accepted.
    let mut text = String::from("time,force\n");
    for i in 0..5000 {
        text.push_str(&format!("{:.6},{}\n", i as f64 / 4096.0, i));
    }
    let r = parse(&text).unwrap();
    assert!((r.fs_hz() - 4096.0).abs() < 1e-3);
}

// ----- bad input -----

#[test]
fn empty_file() {
    for text in ["", "\n\n  \n", "\u{feff}"] {
        let (p, msg) = parse_problem("hit1.csv", parse(text));
        assert_eq!(p, Problem::EmptyFile);
        assert!(msg.contains("empty"), "{msg}");
    }
}

#[test]
fn header_only() {
    let (p, msg) = parse_problem("hit1.csv", parse("time,force,acc1\n\n"));
    assert_eq!(p, Problem::HeaderOnly);
    assert_eq!(msg, "hit1.csv: line 1: header row but no data rows");
}

#[test]
fn non_numeric_cell() {
    let (p, msg) = parse_problem("hit1.csv", parse("time,force,acc1\n0,1,2\n0.1,abc,2\n"));
    assert_eq!(p, Problem::NonNumeric { text: "abc".into() });
    assert_eq!(
        msg,
        "hit1.csv: line 3, column 2 (force): 'abc' is not a number"
    );
    // A decimal comma is not accepted when comma is the delimiter: it
    // splits the cell, which shows as a ragged row.
    let (p, _) = parse_problem("hit1.csv", parse("time,force\n0,1,5\n"));
    assert!(matches!(p, Problem::RaggedRow { .. }));
    // Thousands separators are not numbers.
    let (p, msg) = parse_problem("hit1.csv", parse("time;force\n0;1.000,5\n"));
    assert!(matches!(p, Problem::NonNumeric { .. }), "{msg}");
}

#[test]
fn empty_cell() {
    let (p, msg) = parse_problem("hit1.csv", parse("time,force,acc1\n0,1,2\n0.1,,2\n"));
    assert_eq!(p, Problem::EmptyCell);
    assert!(msg.contains("line 3, column 2 (force)"), "{msg}");
}

#[test]
fn nan_and_infinity() {
    for bad in ["NaN", "nan", "inf", "-Infinity", "1e999"] {
        let text = format!("time,force,acc1\n0,1,2\n0.1,3,{bad}\n");
        let (p, msg) = parse_problem("hit1.csv", parse(&text));
        assert_eq!(p, Problem::NonFinite { text: bad.into() }, "{msg}");
        assert!(msg.contains("line 3, column 3 (acc1)"), "{msg}");
        assert!(msg.contains("NaN or infinite"), "{msg}");
    }
    let (p, _) = parse_problem("hit1.csv", parse("time,force\nNaN,1\n1,2\n"));
    assert!(matches!(p, Problem::NonFinite { .. }));
}

#[test]
fn non_uniform_time() {
    let text = "time,force\n0,1\n0.001,1\n0.002,1\n0.004,1\n0.005,1\n0.006,1\n";
    let (p, msg) = parse_problem("hit1.csv", parse(text));
    assert!(matches!(p, Problem::NonUniformStep { .. }), "{msg}");
    assert!(msg.contains("line 5, column 1 (time)"), "{msg}");
    assert!(msg.contains("not uniformly sampled"), "{msg}");
}

#[test]
fn decreasing_and_repeated_time() {
    let (p, msg) = parse_problem("hit1.csv", parse("time,force\n0,1\n0.002,1\n0.001,1\n"));
    assert!(matches!(p, Problem::TimeNotIncreasing { .. }));
    assert!(msg.contains("line 4, column 1 (time)"), "{msg}");
    assert!(msg.contains("decreasing"), "{msg}");
    let (_, msg) = parse_problem("hit1.csv", parse("time,force\n0,1\n0.001,1\n0.001,1\n"));
    assert!(msg.contains("line 4") && msg.contains("repeated"), "{msg}");
}

#[test]
fn ragged_row() {
    let (p, msg) = parse_problem("hit1.csv", parse("time,force,acc1\n0,1,2\n0.1,2\n"));
    assert_eq!(
        p,
        Problem::RaggedRow {
            expected: 3,
            found: 2
        }
    );
    assert_eq!(
        msg,
        "hit1.csv: line 3: row has 2 cells but the header has 3 columns"
    );
}

#[test]
fn no_time_column_and_no_fs() {
    let (p, msg) = parse_problem("hit1.csv", parse("force,acc1\n1,2\n3,4\n"));
    assert_eq!(p, Problem::NoTimeColumnNoFs);
    assert!(msg.contains("fs_hz"), "{msg}");
}

#[test]
fn single_sample_needs_fs() {
    let (p, _) = parse_problem("hit1.csv", parse("time,force\n0.5,1\n"));
    assert_eq!(p, Problem::SingleSample);
    let r = parse_fs("time,force\n0.5,1\n", 100.0).unwrap();
    assert_eq!((r.start_s, r.dt_s), (0.5, 0.01));
}

#[test]
fn misplaced_time_column_and_bad_names() {
    let (p, msg) = parse_problem("hit1.csv", parse("force,time,acc1\n1,0,2\n"));
    assert_eq!(p, Problem::MisplacedTimeColumn);
    assert!(msg.contains("line 1, column 2 (time)"), "{msg}");
    let (p, msg) = parse_problem("hit1.csv", parse("time,,acc1\n0,1,2\n"));
    assert_eq!(p, Problem::EmptyColumnName);
    assert!(msg.contains("column 2"), "{msg}");
    let (p, msg) = parse_problem("hit1.csv", parse("time [h],force\n0,1\n1,2\n"));
    assert_eq!(p, Problem::UnsupportedTimeUnit { unit: "h".into() });
    assert!(msg.contains("'h'"), "{msg}");
    let (p, _) = parse_problem("hit1.csv", parse("time\n0\n1\n"));
    assert_eq!(p, Problem::NoChannels);
}

#[test]
fn blank_line_inside_data() {
    let (p, msg) = parse_problem("hit1.csv", parse("time,force\n0,1\n\n0.1,2\n"));
    assert_eq!(p, Problem::BlankLine);
    assert!(msg.contains("line 3"), "{msg}");
}

#[test]
fn unterminated_quote() {
    let (p, msg) = parse_problem("hit1.csv", parse("time,\"force\n0,1\n"));
    assert_eq!(p, Problem::UnterminatedQuote);
    assert!(msg.contains("line 1, column 2"), "{msg}");
}

#[test]
fn binary_and_utf16_content() {
    let (p, _) = parse_problem(
        "hit1.csv",
        parse_record(
            b"time,force\n0,1\x00\n",
            Path::new("hit1.csv"),
            &ReadOptions::default(),
        ),
    );
    assert_eq!(p, Problem::NotText);
    let (p, msg) = parse_problem(
        "hit1.csv",
        parse_record(
            b"\xFF\xFEt\x00i\x00",
            Path::new("hit1.csv"),
            &ReadOptions::default(),
        ),
    );
    assert_eq!(p, Problem::Utf16);
    assert!(msg.contains("UTF-16"), "{msg}");
}

#[test]
fn invalid_fs_option() {
    for fs in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let e = parse_fs("force\n1\n", fs).unwrap_err();
        assert!(matches!(e, RecordError::InvalidOptions { .. }), "{e}");
    }
}

#[test]
fn missing_channel_lists_available() {
    let r = parse("time,force [N],acc1,acc2\n0,1,2,3\n0.1,1,2,3\n").unwrap();
    let e = r.channel(&spec("acc3")).unwrap_err();
    assert!(matches!(e, RecordError::ChannelNotFound { .. }));
    assert_eq!(
        e.to_string(),
        "hit1.csv: no channel matches 'acc3'; available channels: #1 force [N], #2 acc1, #3 acc2"
    );
    let e = r.channel(&spec("#4")).unwrap_err();
    assert!(e.to_string().contains("'#4'"));
    let e = r.channel(&spec("1:+X")).unwrap_err();
    assert!(e.to_string().contains("#2 acc1"));
}

#[test]
fn duplicate_names_are_ambiguous() {
    let r = parse("time,acc,ACC [g]\n0,1,2\n0.1,1,2\n").unwrap();
    let e = r.channel(&spec("acc")).unwrap_err();
    assert!(matches!(e, RecordError::AmbiguousChannel { .. }));
    assert!(e.to_string().contains("#1 acc, #2 ACC [g]"), "{e}");
    assert_eq!(r.channel(&spec("#2")).unwrap().name, "ACC");
}

// ----- writing -----

fn record(channels: Vec<(&str, Option<&str>, Vec<f64>)>, dt: f64, start: f64) -> RecordFile {
    RecordFile {
        path: "mem".into(),
        format: Format::Csv { delimiter: b',' },
        dt_s: dt,
        start_s: start,
        channels: channels
            .into_iter()
            .map(|(n, u, v)| Channel {
                name: n.into(),
                unit: u.map(Into::into),
                node: None,
                direction: None,
                id_line: None,
                values: v,
                lines: None,
            })
            .collect(),
    }
}

#[test]
fn write_read_bit_exact() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sim.csv");
    let tricky = vec![
        0.0,
        -0.0,
        0.1,
        1.0 / 3.0,
        -2.5e-7,
        5e-324,
        f64::MIN_POSITIVE,
        f64::MAX,
        -1e300,
        123456.789,
    ];
    let n = tricky.len();
    let rec = record(
        vec![
            ("force", Some("N"), tricky.clone()),
            (
                "acc1",
                Some("m/s^2"),
                tricky.iter().rev().copied().collect(),
            ),
            ("acc2", None, (0..n).map(|i| (i as f64).sin()).collect()),
        ],
        1.0 / 2048.0,
        0.0,
    );
    write_csv(&path, &rec).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(
        text.starts_with("time,force [N],acc1 [m/s^2],acc2\n0,0,"),
        "{text}"
    );
    let back = read_record(&path, &ReadOptions::default()).unwrap();
    assert_eq!(back.dt_s.to_bits(), rec.dt_s.to_bits());
    assert_eq!(back.start_s.to_bits(), rec.start_s.to_bits());
    for (a, b) in rec.channels.iter().zip(&back.channels) {
        assert_eq!(a.name, b.name);
        assert_eq!(a.unit, b.unit);
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&a.values), bits(&b.values));
    }
}

#[test]
fn writer_refuses_what_would_not_read_back() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.csv");
    let cases = vec![
        record(vec![("force", None, vec![1.0, f64::NAN])], 1e-3, 0.0),
        record(vec![("force", None, vec![1.0])], 1e-3, 0.0),
        record(vec![("force", None, vec![1.0, 2.0])], 0.0, 0.0),
        record(vec![("time", None, vec![1.0, 2.0])], 1e-3, 0.0),
        record(vec![("acc (raw)", None, vec![1.0, 2.0])], 1e-3, 0.0),
        record(
            vec![("a", None, vec![1.0, 2.0]), ("b", None, vec![1.0])],
            1e-3,
            0.0,
        ),
        record(vec![("force", None, vec![1.0, 2.0])], 1e-3, 1e300),
        record(vec![], 1e-3, 0.0),
    ];
    for rec in cases {
        let e = write_csv(&path, &rec).unwrap_err();
        assert!(
            matches!(e, RecordError::InvalidRecord { .. }),
            "{rec:?}: {e}"
        );
        assert!(
            e.to_string()
                .starts_with(&format!("{}: refusing to write: ", path.display()))
        );
        assert!(!path.exists());
    }
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}
