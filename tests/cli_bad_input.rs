//! `frameid identify` on wrong input, run as a user would: every case is
//! refused with exit code 2, a message naming the file (and line, column or
//! flag) and the problem, and nothing on standard output.

mod common;

use std::path::{Path, PathBuf};

use common::*;

/// A campaign simulated by the binary: `hits` CSV files of `scenario`.
fn campaign(dir: &Path, scenario: &str, hits: usize) -> Vec<String> {
    let sc = repo("scenarios").join(scenario);
    ok(&[
        "simulate",
        s(&sc),
        "--out",
        s(dir),
        "--hits",
        &hits.to_string(),
    ]);
    hit_files(dir, "csv")
}

/// Runs `frameid identify args...` and checks the refusal: exit code 2,
/// empty stdout, stderr containing every needle. Returns stderr.
fn refused(args: &[&str], needles: &[&str]) -> String {
    let mut all = vec!["identify"];
    all.extend_from_slice(args);
    let (code, out, err) = run(&all);
    assert_eq!(code, 2, "{all:?}: exit code {code}\n{err}");
    assert!(out.is_empty(), "{all:?}: stdout not empty: {out}");
    assert!(!err.contains("panicked"), "{all:?}: {err}");
    for n in needles {
        assert!(err.contains(n), "{all:?}: expected '{n}' in:\n{err}");
    }
    err
}

/// Copies a CSV record with line `line` (1-based) replaced by `edit`.
fn edited(
    src: &str,
    dir: &Path,
    name: &str,
    mut edit: impl FnMut(usize, &str) -> String,
) -> String {
    let text = std::fs::read_to_string(src).unwrap();
    let out: Vec<String> = text
        .lines()
        .enumerate()
        .map(|(i, l)| edit(i + 1, l))
        .collect();
    let path: PathBuf = dir.join(name);
    std::fs::write(&path, out.join("\n") + "\n").unwrap();
    path.to_string_lossy().into_owned()
}

/// Replaces cell `col` (0-based) of a CSV line.
fn cell(line: &str, col: usize, value: &str) -> String {
    let mut cells: Vec<String> = line.split(',').map(String::from).collect();
    cells[col] = value.to_string();
    cells.join(",")
}

#[test]
fn empty_file() {
    let dir = tempfile::tempdir().unwrap();
    let f = dir.path().join("empty.csv");
    std::fs::write(&f, "").unwrap();
    refused(&[s(&f)], &["empty.csv: the file is empty"]);
}

#[test]
fn header_only() {
    let dir = tempfile::tempdir().unwrap();
    let f = dir.path().join("header.csv");
    std::fs::write(&f, "time,force [N],acc1 [m/s^2],acc2 [m/s^2]\n").unwrap();
    refused(
        &[s(&f)],
        &["header.csv: line 1: header row but no data rows"],
    );
}

#[test]
fn non_numeric_cell() {
    let dir = tempfile::tempdir().unwrap();
    let files = campaign(&dir.path().join("c"), "paper-case1.toml", 2);
    let bad = edited(&files[0], dir.path(), "text.csv", |i, l| {
        if i == 6 {
            cell(l, 1, "1,5e-3")
        } else {
            l.into()
        }
    });
    // "1,5e-3" splits into two cells: a ragged row; a word is not a number.
    refused(&[&bad, &files[1]], &["text.csv: line 6"]);
    let bad = edited(&files[0], dir.path(), "word.csv", |i, l| {
        if i == 6 { cell(l, 2, "n/a") } else { l.into() }
    });
    refused(
        &[&bad, &files[1]],
        &["word.csv: line 6, column 3 (acc1 [m/s^2]): 'n/a' is not a number"],
    );
}

#[test]
fn nan_and_infinite_values() {
    let dir = tempfile::tempdir().unwrap();
    let files = campaign(&dir.path().join("c"), "paper-case1.toml", 2);
    let nan = edited(&files[0], dir.path(), "nan.csv", |i, l| {
        if i == 7 { cell(l, 1, "NaN") } else { l.into() }
    });
    refused(
        &[&files[1], &nan],
        &["nan.csv: line 7, column 2 (force [N]): value 'NaN' is NaN or infinite"],
    );
    let inf = edited(&files[0], dir.path(), "inf.csv", |i, l| {
        if i == 900 {
            cell(l, 3, "-inf")
        } else {
            l.into()
        }
    });
    refused(
        &[&inf],
        &["inf.csv: line 900, column 4 (acc2 [m/s^2]): value '-inf' is NaN or infinite"],
    );
}

#[test]
fn non_uniform_and_decreasing_time() {
    let dir = tempfile::tempdir().unwrap();
    let files = campaign(&dir.path().join("c"), "paper-case1.toml", 1);
    let uneven = edited(&files[0], dir.path(), "uneven.csv", |i, l| {
        if i == 101 {
            cell(l, 0, "1.55")
        } else {
            l.into()
        }
    });
    refused(
        &[&uneven],
        &[
            "uneven.csv: line 101, column 1 (time)",
            "not uniformly sampled",
        ],
    );
    // Lines 101 and 102 swapped: time goes back.
    let text = std::fs::read_to_string(&files[0]).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let decreasing = edited(&files[0], dir.path(), "decreasing.csv", |i, l| match i {
        101 => lines[101].into(),
        102 => lines[100].into(),
        _ => l.into(),
    });
    refused(
        &[&decreasing],
        &[
            "decreasing.csv: line 102, column 1 (time)",
            "is not after the previous time",
            "(decreasing)",
        ],
    );
}

#[test]
fn records_of_different_sampling() {
    let dir = tempfile::tempdir().unwrap();
    let files = campaign(&dir.path().join("c"), "paper-case1.toml", 2);
    let fast = edited(&files[1], dir.path(), "fast.csv", |i, l| {
        if i == 1 {
            l.into()
        } else {
            cell(l, 0, &format!("{}", (i - 2) as f64 / 128.0))
        }
    });
    refused(
        &[&files[0], &fast],
        &[&format!(
            "campaign records differ in sampling: {fast} has dt = 0.0078125 s (128 Hz) but {} has dt = 0.015625 s (64 Hz)",
            files[0]
        )],
    );
}

#[test]
fn named_channel_that_does_not_exist() {
    let dir = tempfile::tempdir().unwrap();
    let files = campaign(dir.path(), "paper-case1.toml", 1);
    refused(
        &[&files[0], "--input", "hammer"],
        &[
            &format!("{}: no channel matches 'hammer'", files[0]),
            "available channels: #1 force [N], #2 acc1 [m/s^2], #3 acc2 [m/s^2]",
        ],
    );
    refused(
        &[&files[0], "--outputs", "acc1,acc3"],
        &[&format!("{}: no channel matches 'acc3'", files[0])],
    );
    refused(
        &[&files[0], "--collocated", "acc3:force"],
        &["--collocated: no output named 'acc3'; outputs: acc1, acc2"],
    );
}

#[test]
fn fewer_outputs_than_degrees_of_freedom() {
    let dir = tempfile::tempdir().unwrap();
    // Three floors, two accelerometers selected: the records show three
    // structural modes. frameid cannot tell a floor without an
    // accelerometer from a mode the shear model lacks (the real-structures
    // issue: never refused by default), so it identifies a 2-DOF model,
    // reports the third mode and says both readings; --strict refuses.
    let files = campaign(&dir.path().join("three"), "frame-three-storey.toml", 3);
    let mut args: Vec<&str> = vec!["identify"];
    args.extend(files.iter().map(String::as_str));
    args.extend(["--outputs", "acc1,acc2"]);
    let out = ok(&args);
    assert!(
        out.contains("1 structural mode(s) outside the 2-DOF model")
            && out.contains("a floor without an accelerometer"),
        "{out}"
    );
    args.push("--strict");
    refused(
        &args[1..],
        &[
            "the records show 3 structural modes",
            "only 2 outputs are selected (acc1, acc2): fewer outputs than degrees of freedom",
            "select them all with --outputs",
        ],
    );
    // One output: MKR and the Rayleigh fit cannot work.
    let two = campaign(&dir.path().join("two"), "paper-case1.toml", 2);
    refused(
        &[&two[0], &two[1], "--outputs", "acc1"],
        &["only 1 output selected (acc1)", "--outputs"],
    );
}

#[test]
fn orders_that_the_outputs_or_the_data_cannot_give() {
    let dir = tempfile::tempdir().unwrap();
    let files = campaign(dir.path(), "paper-case1.toml", 2);
    // More modes than outputs can carry: order below 2 per output.
    refused(
        &[&files[0], &files[1], "--order", "2"],
        &[
            "--order 2: a realization of order 2 has at most 1 mode(s), but 2 outputs",
            "use --order 4 or more",
        ],
    );
    // Beyond what the observer and the Hankel matrix support.
    refused(
        &[&files[0], &files[1], "--order", "60"],
        &["--order 60: larger than the largest order 40 that 2 records"],
    );
}

#[test]
fn input_not_collocated_with_the_named_output() {
    let dir = tempfile::tempdir().unwrap();
    let files = campaign(dir.path(), "paper-case1.toml", 2);
    refused(
        &[&files[0], &files[1], "--collocated", "acc2:force"],
        &[
            "input 'force' is not collocated with output 'acc2'",
            "mixed signs",
            "--collocated OUT:IN (outputs: acc1, acc2)",
            &files[0],
        ],
    );
}

#[test]
fn record_without_a_hit() {
    let dir = tempfile::tempdir().unwrap();
    let files = campaign(&dir.path().join("c"), "paper-case1.toml", 3);
    let zero = edited(&files[1], dir.path(), "zero.csv", |i, l| {
        if i == 1 { l.into() } else { cell(l, 1, "0") }
    });
    // Force with only noise (a fixed pseudo-random sequence).
    let mut state: u64 = 7;
    let noise = edited(&files[1], dir.path(), "noise.csv", |i, l| {
        if i == 1 {
            return l.into();
        }
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        let u = (state >> 11) as f64 / (1u64 << 53) as f64;
        cell(l, 1, &format!("{}", 0.002 * (u - 0.5)))
    });
    // Among other hits such a record is inconsistent with them: dropped with
    // warnings naming it (the no-hit diagnosis among them), refused by
    // --strict.
    for (bad, diagnosis, flag) in [
        (
            &zero,
            "zero.csv: no hit: the force channel 'force' is constant",
            "zero.csv: channel force: dead channel",
        ),
        (
            &noise,
            "noise.csv: no hit: the force channel 'force' peaks at",
            "noise.csv: channel force: level",
        ),
    ] {
        let out = ok(&["identify", &files[0], bad, &files[2]]);
        assert!(out.contains(diagnosis), "{out}");
        assert!(out.contains(flag), "{out}");
        assert!(out.contains("dropped 1 of 3 hits"), "{out}");
        refused(
            &[&files[0], bad, &files[2], "--strict"],
            &["--strict: 1 of 3 hits are inconsistent", flag],
        );
    }
    // With one other hit there is nothing to compare with: the record
    // without a hit is refused, or dropped on request.
    refused(
        &[&files[0], &noise],
        &[
            "noise.csv: no hit: the force channel 'force' peaks at",
            "only noise",
            "--drop-bad-hits",
        ],
    );
    let out = ok(&["identify", &files[0], &noise, "--drop-bad-hits"]);
    assert!(
        out.contains("dropped 1 of 2 hits") && out.contains("noise.csv (no hit)"),
        "{out}"
    );
}

#[test]
fn record_too_short_for_the_orders() {
    let dir = tempfile::tempdir().unwrap();
    let files = campaign(&dir.path().join("c"), "paper-case1.toml", 1);
    let text = std::fs::read_to_string(&files[0]).unwrap();
    let short = dir.path().join("short.csv");
    std::fs::write(
        &short,
        text.lines().take(61).collect::<Vec<_>>().join("\n") + "\n",
    )
    .unwrap();
    refused(
        &[s(&short)],
        &[
            "short.csv: too short for the automatic orders: 60 samples",
            "are needed",
            "record longer or lower the orders",
        ],
    );
    refused(
        &[s(&short), "--observer-order", "20", "--order", "30"],
        &[
            "short.csv: too short for --order 30 and --observer-order 20: 60 samples, 106 are needed",
        ],
    );
}

/// A missing sample is named at its line. The simulator prints times to
/// the last bit, and the gap moved the end-point interval by more than
/// that: the refusal named line 3 of a 2048-row file with the gap at line
/// 502.
#[test]
fn missing_sample_is_named_at_its_line() {
    let dir = tempfile::tempdir().unwrap();
    let files = campaign(&dir.path().join("c"), "paper-case1.toml", 1);
    let text = std::fs::read_to_string(&files[0]).unwrap();
    let kept: Vec<&str> = text
        .lines()
        .enumerate()
        .filter(|&(i, _)| i + 1 != 502)
        .map(|(_, l)| l)
        .collect();
    let gap = dir.path().join("gap.csv");
    std::fs::write(&gap, kept.join("\n") + "\n").unwrap();
    refused(
        &[s(&gap)],
        &[
            "gap.csv: line 502, column 1 (time): time step 0.03125 differs from the median step 0.015625",
            "missing or repeated sample?",
        ],
    );
}

/// Declared units are converted: records in g and kN identify the same M,
/// K and damping as the same records in m/s^2 and N (they were read as
/// m/s^2 and N: M 9.8 times too large, or 1000 times too small, exit 0).
/// A unit that is no acceleration (a displacement, a voltage) is refused
/// naming the file and channel.
#[test]
fn declared_units_are_converted_or_refused() {
    let dir = tempfile::tempdir().unwrap();
    let files = campaign(&dir.path().join("c"), "paper-case1.toml", 4);
    // Every value divided by its unit's SI value, printed to the last bit.
    let convert = |src: &str, name: &str, units: [(&str, f64); 3]| -> String {
        edited(src, dir.path(), name, |i, l| {
            if i == 1 {
                let mut h = l.to_string();
                for (old, (new, _)) in ["force [N]", "acc1 [m/s^2]", "acc2 [m/s^2]"]
                    .iter()
                    .zip(units)
                {
                    h = h.replace(old, new);
                }
                return h;
            }
            let mut cells: Vec<String> = l.split(',').map(String::from).collect();
            for (c, (_, si)) in units.iter().enumerate() {
                let v: f64 = cells[c + 1].parse().unwrap();
                cells[c + 1] = format!("{:e}", v / si);
            }
            cells.join(",")
        })
    };
    let g = 9.806_65;
    let mut converted = vec![convert(
        &files[0],
        "kn.csv",
        [("force [kN]", 1e3), ("acc1 [g]", g), ("acc2 [g]", g)],
    )];
    converted.push(convert(
        &files[1],
        "g.csv",
        [("force [N]", 1.0), ("acc1 [g]", g), ("acc2 [mm/s^2]", 1e-3)],
    ));
    converted.extend_from_slice(&files[2..]);
    let si = identify_no_uncertainty(&files, &[]);
    let other = identify_no_uncertainty(&converted, &[]);
    for key in ["mass", "stiffness", "damping_rayleigh"] {
        // The values come back from the units within a rounding or two
        // (1e-16 relative); the identification's own conditioning makes
        // that at most ~1e-12 of the matrices.
        let e = rel_fro(&matrix(&other[key]), &matrix(&si[key]));
        assert!(e < 1e-9, "{key}: {e}");
    }
    for (unit, what) in [
        ("mm", "a displacement unit"),
        ("V", "not an acceleration unit"),
    ] {
        let bad = edited(&files[0], dir.path(), "bad.csv", |i, l| {
            if i == 1 {
                l.replace("acc2 [m/s^2]", &format!("acc2 [{unit}]"))
            } else {
                l.into()
            }
        });
        refused(
            &[&files[1], &bad],
            &[&format!(
                "bad.csv: channel #3 acc2 [{unit}] is in '{unit}', {what}; outputs must be accelerations"
            )],
        );
    }
}

/// A time column in milliseconds under a bare `time` header was read as
/// seconds: paper case 1 at 64 Hz became 0.064 Hz, and identify printed K
/// 1e6 times too small with exit 0. It is refused now, naming the file, the
/// column, the interval read and how to state the unit; with the unit
/// stated the campaign identifies as in seconds.
#[test]
fn time_in_milliseconds_without_a_unit_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let files = campaign(&dir.path().join("c"), "paper-case1.toml", 3);
    let in_ms = |src: &str, name: &str, header: &str| -> String {
        edited(src, dir.path(), name, |i, l| {
            if i == 1 {
                return l.replacen("time", header, 1);
            }
            let t: f64 = l.split(',').next().unwrap().parse().unwrap();
            cell(l, 0, &format!("{}", t * 1e3))
        })
    };
    // Every record in milliseconds (one alone is refused anyway: its
    // sampling differs from the others').
    let bare: Vec<String> = files
        .iter()
        .enumerate()
        .map(|(k, f)| in_ms(f, &format!("bare{k}.csv"), "time"))
        .collect();
    let bare: Vec<&str> = bare.iter().map(String::as_str).collect();
    refused(
        &bare,
        &[
            "bare0.csv: line 1, column 1 (time): the time axis states no unit",
            "15.625 s (0.064 Hz sampling)",
            "'time [ms]'",
        ],
    );
    let stated: Vec<String> = files
        .iter()
        .enumerate()
        .map(|(k, f)| in_ms(f, &format!("ms{k}.csv"), "time [ms]"))
        .collect();
    let si = identify_no_uncertainty(&files, &[]);
    let ms = identify_no_uncertainty(&stated, &[]);
    for key in ["mass", "stiffness", "damping_rayleigh"] {
        // Measured 0: the reader recovers dt = 1/64 s bit for bit from the
        // milliseconds. 1e-9 allows an interval off by a rounding or two
        // (1e-16 relative), which the identification's conditioning makes
        // at most ~1e-12 of the matrices (as for the units above).
        let e = rel_fro(&matrix(&ms[key]), &matrix(&si[key]));
        assert!(e < 1e-9, "{key}: {e}");
    }
}

/// Copies a CSV record cut to start `k` samples before its force peak
/// (column 1): a trigger that fired late.
fn cut_before_peak(src: &str, dir: &Path, name: &str, k: usize) -> String {
    let text = std::fs::read_to_string(src).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let force = |l: &str| -> f64 { l.split(',').nth(1).unwrap().parse::<f64>().unwrap().abs() };
    let peak = (1..lines.len())
        .max_by(|&a, &b| force(lines[a]).total_cmp(&force(lines[b])))
        .unwrap();
    let mut out = vec![lines[0]];
    out.extend_from_slice(&lines[peak - k..]);
    let path = dir.join(name);
    std::fs::write(&path, out.join("\n") + "\n").unwrap();
    path.to_string_lossy().into_owned()
}

/// Analyzer records that start just before their force peak have lost
/// part of the band-limited pulse (the filter's precursor): with every
/// hit of paper case 1 starting 1 sample before its peak, M came out 54 %
/// off (3000x at the peak itself) with exit 0 and only a note that the
/// pre-trigger was too short. They are refused naming the files, also
/// under --drop-bad-hits (every hit would go). Held records have no
/// precursor: with --intersample zoh the same cut is identified.
#[test]
fn records_starting_in_the_hit_are_refused_unless_held() {
    let dir = tempfile::tempdir().unwrap();
    let files = campaign(&dir.path().join("c"), "paper-case1.toml", 4);
    let late: Vec<String> = files
        .iter()
        .enumerate()
        .map(|(i, f)| cut_before_peak(f, dir.path(), &format!("late{i}.csv"), 1))
        .collect();
    let mut args: Vec<&str> = late.iter().map(String::as_str).collect();
    refused(
        &args,
        &[
            "late0.csv",
            "late3.csv",
            "record starts in the hit",
            "peaks at sample 1,",
            "record a longer pre-trigger",
        ],
    );
    args.push("--drop-bad-hits");
    refused(&args, &["late2.csv", "record starts in the hit"]);

    let held_dir = dir.path().join("held");
    ok(&[
        "simulate",
        s(&repo("scenarios").join("paper-case1.toml")),
        "--out",
        s(&held_dir),
        "--hits",
        "4",
        "--acquisition",
        "held",
    ]);
    let held: Vec<String> = hit_files(&held_dir, "csv")
        .iter()
        .enumerate()
        .map(|(i, f)| cut_before_peak(f, dir.path(), &format!("held{i}.csv"), 0))
        .collect();
    let v = identify_no_uncertainty(&held, &["--intersample", "zoh"]);
    let truth = read_json(&held_dir.join("truth.json"));
    // Four held hits at 1 % noise (seeded): M within 1e-3, the noise's
    // reach (measured 6.1e-4 here; ten held hits of seed 101: 7.7e-4 uncut,
    // 1.7e-4 cut at the hit), while a record missing part of its force
    // gives errors of 1e-1 and more.
    let err = rel_fro(&matrix(&v["mass"]), &matrix(&truth["mass"]));
    assert!(err < 1e-3, "held records cut at the hit: M error {err}");
}
