//! Error bars end to end: the JSON and table output of `frameid identify`.
//! (The jackknife itself, against the spread of repeated campaigns, is
//! tested in `study/tests/jackknife.rs`.)

mod common;

use std::time::Instant;

use common::*;

/// `frameid simulate` of paper case 1 into `dir` with `extra` arguments; the hit files.
fn paper_case1_hits(dir: &std::path::Path, extra: &[&str]) -> Vec<String> {
    let scenario = repo("scenarios/paper-case1.toml");
    let mut args = vec!["simulate", s(&scenario), "--out", s(dir)];
    args.extend_from_slice(extra);
    ok(&args);
    hit_files(dir, "csv")
}

#[test]
fn identify_reports_error_bars_in_json_and_tables() {
    let dir = tempfile::tempdir().unwrap();
    let files = paper_case1_hits(dir.path(), &[]);
    let mut args: Vec<&str> = vec!["identify", "--json"];
    args.extend(files.iter().map(String::as_str));
    let t = Instant::now();
    let json: serde_json::Value = serde_json::from_str(&ok(&args)).unwrap();
    eprintln!(
        "identify --json of 10 hits with error bars: {:.2?}",
        t.elapsed()
    );
    let u = &json["uncertainty"];
    assert_eq!(u["method"], "jackknife");
    assert_eq!(u["resamples"], 10);
    assert_eq!(u["hits"], 10);
    assert_eq!(u["groups"], 10);
    assert_eq!(u["model_order"], json["model_order"]);
    for key in [
        "mass",
        "stiffness",
        "damping_mkr",
        "damping_rayleigh",
        "frequencies_hz",
        "damping_ratios",
        "rayleigh_alpha",
        "rayleigh_beta",
    ] {
        assert!(
            u[key]["mean"].is_array() || u[key]["mean"].is_number(),
            "{key}"
        );
        assert!(
            u[key]["std"].is_array() || u[key]["std"].is_number(),
            "{key}"
        );
    }
    // Error bars of the right size: K11 about 0.3 N/m out of 630.
    let k11 = u["stiffness"]["std"][0][0].as_f64().unwrap();
    assert!((0.05..2.0).contains(&k11), "{k11}");
    // The joint value lies within a few standard errors of the
    // leave-one-out mean.
    let m11 = json["mass"][0][0].as_f64().unwrap();
    let m11_mean = u["mass"]["mean"][0][0].as_f64().unwrap();
    let m11_std = u["mass"]["std"][0][0].as_f64().unwrap();
    assert!(
        (m11 - m11_mean).abs() < m11_std,
        "{m11} {m11_mean} {m11_std}"
    );
    assert!(
        json["warnings"].as_array().unwrap().is_empty(),
        "{}",
        json["warnings"]
    );

    let human = ok(&args[..1]
        .iter()
        .copied()
        .chain(files.iter().map(String::as_str))
        .collect::<Vec<_>>());
    assert!(human.contains("error bars: +- one standard error, jackknife over 10 hits"));
    assert!(
        human.contains("Stiffness K [N/m]") && human.contains(" ± "),
        "{human}"
    );
    assert!(human.contains("Hit quality"));

    // Skipped on request.
    args.push("--no-uncertainty");
    let json: serde_json::Value = serde_json::from_str(&ok(&args)).unwrap();
    assert!(json["uncertainty"].is_null());
    assert_eq!(json["uncertainty_skipped"], "--no-uncertainty");
}

#[test]
fn more_hits_than_groups_give_grouped_error_bars() {
    // 25 hits: 20 groups (five of two hits), named in the text and JSON;
    // the error bars keep the size of the delete-one jackknife's (K11 about
    // 0.3 N/m for 10 hits, sqrt(10/25) of that here).
    let dir = tempfile::tempdir().unwrap();
    let files = paper_case1_hits(dir.path(), &["--hits", "25"]);
    let mut args: Vec<&str> = vec!["identify", "--json"];
    args.extend(files.iter().map(String::as_str));
    let json: serde_json::Value = serde_json::from_str(&ok(&args)).unwrap();
    let u = &json["uncertainty"];
    assert_eq!(u["method"], "grouped jackknife");
    assert_eq!(
        (u["hits"].as_u64(), u["groups"].as_u64()),
        (Some(25), Some(20))
    );
    assert_eq!(u["resamples"], 20);
    // The 10-hit test's range (0.05..2.0) times sqrt(10/25).
    let k11 = u["stiffness"]["std"][0][0].as_f64().unwrap();
    assert!((0.03..1.3).contains(&k11), "{k11}");
    let human = ok(&args[..1]
        .iter()
        .copied()
        .chain(files.iter().map(String::as_str))
        .collect::<Vec<_>>());
    assert!(
        human.contains("error bars: +- one standard error, grouped jackknife over 25 hits in 20 groups (20 resamples"),
        "{human}"
    );
}
