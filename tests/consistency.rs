//! Hits inconsistent with the others, end to end: `frameid identify` drops
//! them with a warning naming the file, the channel (and the line of a
//! single sample), says so in its JSON, identifies exactly what the clean
//! hits give, and `--strict` refuses the campaign. (The checks themselves
//! are tested in `records::consistency` and, as a property over random
//! faults, in `study/tests/consistency.rs`.)

mod common;

use std::path::{Path, PathBuf};

use common::*;
use serde_json::Value;

/// Six clean hits of paper case 1 as CSV files (columns: time, force, acc1,
/// acc2) in `dir`.
fn clean_campaign(dir: &Path) -> Vec<PathBuf> {
    let out = dir.join("clean");
    ok(&[
        "simulate",
        s(&repo("scenarios/paper-case1.toml")),
        "--hits",
        "6",
        "--seed",
        "11",
        "--out",
        s(&out),
    ]);
    hit_files(&out, "csv")
        .into_iter()
        .map(PathBuf::from)
        .collect()
}

/// A copy of `from` at `to` with column `col` (0 = time) of every data row
/// rewritten by `edit(row, value)` (`row` 0 is the first data row).
fn edited(from: &Path, to: &Path, col: usize, edit: impl Fn(usize, &str) -> String) -> PathBuf {
    let text = std::fs::read_to_string(from).unwrap();
    let mut lines = text.lines();
    let mut out = String::from(lines.next().unwrap());
    out.push('\n');
    for (row, line) in lines.enumerate() {
        let mut cells: Vec<String> = line.split(',').map(str::to_string).collect();
        cells[col] = edit(row, &cells[col]);
        out.push_str(&cells.join(","));
        out.push('\n');
    }
    std::fs::write(to, out).unwrap();
    to.to_path_buf()
}

fn json(files: &[PathBuf], extra: &[&str]) -> Value {
    let mut args: Vec<&str> = vec!["identify", "--json", "--no-uncertainty"];
    args.extend(files.iter().map(|p| s(p)));
    args.extend_from_slice(extra);
    serde_json::from_str(&ok(&args)).unwrap()
}

/// Runs the campaign with `bad` at position 2 of the clean hits (replacing
/// clean hit 3): the bad file is flagged with `kind` on `channel`, dropped,
/// named in a warning containing `says`, and M, K and the damping are
/// exactly those of the five clean hits; `--strict` refuses it.
fn check_dropped(clean: &[PathBuf], bad: &Path, kinds: &[&str], channel: Option<&str>, says: &str) {
    let mut files = clean.to_vec();
    files[2] = bad.to_path_buf();
    let v = json(&files, &[]);
    let flags = v["inconsistent_hits"].as_array().unwrap();
    assert!(!flags.is_empty(), "{bad:?} not flagged: {v:#}");
    for f in flags {
        assert_eq!(f["file"], s(bad), "only the bad hit is flagged: {flags:#?}");
        assert_eq!(f["record"], 2);
    }
    assert!(
        flags
            .iter()
            .any(|f| kinds.iter().any(|k| f["kind"] == *k)
                && channel.is_none_or(|c| f["channel"] == c)),
        "{kinds:?} on {channel:?}: {flags:#?}"
    );
    assert_eq!(v["dropped_hits"], serde_json::json!([s(bad)]));
    assert_eq!(v["source"]["hits"], 5);
    let warnings = v["warnings"].to_string();
    assert!(warnings.contains(says), "{says}: {warnings}");
    assert!(warnings.contains("dropped 1 of 6 hits"), "{warnings}");

    // Exactly the identification of the five clean hits.
    let rest: Vec<PathBuf> = clean
        .iter()
        .enumerate()
        .filter(|(i, _)| *i != 2)
        .map(|(_, p)| p.clone())
        .collect();
    let ref5 = json(&rest, &[]);
    for key in ["mass", "stiffness", "damping_mkr", "damping_rayleigh"] {
        assert_eq!(v[key], ref5[key], "{key}");
    }

    // --strict: exit 2, the file and channel named on stderr, nothing on
    // stdout.
    let mut args: Vec<&str> = vec!["identify", "--strict"];
    args.extend(files.iter().map(|p| s(p)));
    let (code, out, err) = run(&args);
    assert_eq!(code, 2, "{err}");
    assert!(out.is_empty(), "{out}");
    assert!(
        err.contains("--strict: 1 of 6 hits are inconsistent"),
        "{err}"
    );
    let named = match channel {
        Some(c) => format!("{}: channel {c}: ", s(bad)),
        None => format!("{}: ", s(bad)),
    };
    assert!(err.contains(&named), "{named}: {err}");
}

#[test]
fn dead_copied_spiked_and_mis_gained_hits_are_dropped_or_refused() {
    let dir = tempfile::tempdir().unwrap();
    let clean = clean_campaign(dir.path());
    let hit3 = &clean[2];
    let bad = |name: &str| dir.path().join(name);

    // A dead accelerometer (the case that moved M22 by 41 % silently).
    let dead = edited(hit3, &bad("dead.csv"), 3, |_, _| "0".into());
    check_dropped(
        &clean,
        &dead,
        &["dead-channel"],
        Some("acc2"),
        "constant at 0",
    );

    // acc1 is a copy of the force column.
    let text = std::fs::read_to_string(hit3).unwrap();
    let force: Vec<String> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(1).unwrap().to_string())
        .collect();
    let copied = edited(hit3, &bad("copied.csv"), 2, |row, _| force[row].clone());
    check_dropped(
        &clean,
        &copied,
        &["copied-channel"],
        Some("acc1"),
        "equals force",
    );

    // One sample of 1e30 in acc1: named by its line (data row 700 is line
    // 702 after the header).
    let spiked = edited(hit3, &bad("spiked.csv"), 2, |row, v| {
        if row == 700 { "1e30".into() } else { v.into() }
    });
    check_dropped(
        &clean,
        &spiked,
        &["spike"],
        Some("acc1"),
        "line 702 holds 1.000e30",
    );

    // One force sample of 1e12 N: a spike, not "not collocated".
    let force_spike = edited(hit3, &bad("force-spike.csv"), 1, |row, v| {
        if row == 900 { "1e12".into() } else { v.into() }
    });
    check_dropped(
        &clean,
        &force_spike,
        &["spike"],
        Some("force"),
        "line 902 holds 1.000e12",
    );

    // A 20 % gain error on acc2 in one hit: only the joint model sees it.
    let gained = edited(hit3, &bad("gain.csv"), 3, |_, v| {
        format!("{:e}", 1.2 * v.parse::<f64>().unwrap())
    });
    check_dropped(
        &clean,
        &gained,
        &["transfer"],
        Some("acc2"),
        "1.200 times the median gain",
    );

    // The two accelerometers swapped in one hit.
    let swapped = {
        let acc2: Vec<String> = text
            .lines()
            .skip(1)
            .map(|l| l.split(',').nth(3).unwrap().to_string())
            .collect();
        let acc1: Vec<String> = text
            .lines()
            .skip(1)
            .map(|l| l.split(',').nth(2).unwrap().to_string())
            .collect();
        let half = edited(hit3, &bad("half.csv"), 2, |row, _| acc2[row].clone());
        edited(&half, &bad("swapped.csv"), 3, |row, _| acc1[row].clone())
    };
    check_dropped(
        &clean,
        &swapped,
        &["residual", "transfer"],
        None,
        "against the model of the hits that agree best",
    );
}

#[test]
fn a_record_given_twice_or_five_times_is_used_once() {
    let dir = tempfile::tempdir().unwrap();
    let clean = clean_campaign(dir.path());
    let first = s(&clean[0]).to_string();
    let once = json(&clean, &[]);
    // Given twice, and five times: every repeat is dropped with a warning
    // naming the file it repeats; the result is that of the distinct hits.
    for repeats in [2, 5] {
        let mut files = clean.clone();
        for _ in 1..repeats {
            files.push(clean[0].clone());
        }
        let v = json(&files, &[]);
        let flags = v["inconsistent_hits"].as_array().unwrap();
        assert_eq!(flags.len(), repeats - 1, "{flags:#?}");
        for f in flags {
            assert_eq!(f["kind"], "duplicate");
            assert!(f["message"].as_str().unwrap().contains(&first), "{f}");
        }
        assert_eq!(v["source"]["hits"], 6);
        for key in ["mass", "stiffness", "damping_mkr"] {
            assert_eq!(v[key], once[key], "{key}");
        }
    }
    // Error bars are those of the six distinct hits, not zero.
    let mut files = clean.clone();
    files.push(clean[0].clone());
    let mut args: Vec<&str> = vec!["identify", "--json"];
    args.extend(files.iter().map(|p| s(p)));
    let v: Value = serde_json::from_str(&ok(&args)).unwrap();
    assert_eq!(v["uncertainty"]["hits"], 6);
    let sd = v["uncertainty"]["mass"]["std"][0][0].as_f64().unwrap();
    assert!(sd > 0.0, "{sd}");
}

#[test]
fn a_clean_campaign_is_not_flagged() {
    let dir = tempfile::tempdir().unwrap();
    let clean = clean_campaign(dir.path());
    let v = json(&clean, &[]);
    assert_eq!(v["inconsistent_hits"], serde_json::json!([]));
    assert_eq!(v["dropped_hits"], serde_json::json!([]));
    assert_eq!(v["consistency_notes"], serde_json::json!([]));
}
