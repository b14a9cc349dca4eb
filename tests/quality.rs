//! Bad hits end to end: `frameid identify` reports them, `--strict`
//! refuses them and `--drop-bad-hits` identifies without them. (The checks
//! themselves are tested in `study/tests/quality.rs`.)

mod common;

use std::path::Path;

use common::*;
use serde_json::Value;
use sim::{AdcSettings, Campaign, DoubleHit, Simulator};
use study::LoadedScenario;

fn scenario(name: &str) -> LoadedScenario {
    LoadedScenario::load(&repo("scenarios").join(name)).unwrap()
}

/// A simulator of a bundled scenario after `edit`.
fn simulator(name: &str, edit: impl FnOnce(&mut study::Scenario)) -> (Simulator, LoadedScenario) {
    let s = scenario(name);
    let mut sc = s.scenario.clone();
    edit(&mut sc);
    (sc.simulator(s.model.clone()).unwrap(), s)
}

/// Writes a campaign's hits as CSV under `dir`; returns the paths.
fn write(dir: &Path, c: &Campaign) -> Vec<String> {
    std::fs::create_dir_all(dir).unwrap();
    study::campaign_dir::write_hits(dir, c, records::Format::Csv { delimiter: b',' })
        .unwrap()
        .iter()
        .map(|p| p.to_string_lossy().into_owned())
        .collect()
}

fn identify_json(files: &[String], extra: &[&str]) -> Value {
    let mut args: Vec<&str> = vec!["identify", "--json"];
    args.extend(files.iter().map(String::as_str));
    args.extend_from_slice(extra);
    serde_json::from_str(&ok(&args)).unwrap()
}

fn rel_to_model(v: &Value, m: &nalgebra::DMatrix<f64>) -> f64 {
    let rows = matrix(v);
    let truth: Vec<Vec<f64>> = (0..m.nrows())
        .map(|i| (0..m.ncols()).map(|j| m[(i, j)]).collect())
        .collect();
    rel_fro(&rows, &truth)
}

#[test]
fn bad_hits_are_reported_refused_or_dropped() {
    let dir = tempfile::tempdir().unwrap();
    // Paper case 1, 1 % noise: 10 clean hits, 2 double hits, 2 clipped.
    let (clean, s) = simulator("paper-case1.toml", |_| {});
    let (double, _) = simulator("paper-case1.toml", |s| {
        s.campaign.hits = 2;
        s.campaign.hammer.double_hit = Some(DoubleHit {
            delay_s: 0.1,
            ratio: 0.3,
        });
    });
    let (clipped, _) = simulator("paper-case1.toml", |s| {
        s.campaign.hits = 2;
        s.campaign.noise.adc = Some(AdcSettings {
            force_range_n: 1.0,
            acceleration_range_m_s2: 3.0,
            bits: None,
        });
    });
    let mut files = write(&dir.path().join("clean"), &clean.simulate(1));
    let dh = write(&dir.path().join("double"), &double.simulate(2));
    let cl = write(&dir.path().join("clipped"), &clipped.simulate(3));
    files.extend(dh.iter().cloned());
    files.extend(cl.iter().cloned());
    let bad: Vec<&String> = dh.iter().chain(&cl).collect();

    // Reported: a warning naming each bad file and its check, and the
    // metrics of every hit.
    let all = identify_json(&files, &["--no-uncertainty"]);
    let warnings: Vec<String> = all["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|w| w.as_str().unwrap().to_string())
        .collect();
    for f in &dh {
        assert!(
            warnings
                .iter()
                .any(|w| w.starts_with(f.as_str()) && w.contains("double hit")),
            "{f}: {warnings:?}"
        );
    }
    for f in &cl {
        assert!(
            warnings
                .iter()
                .any(|w| w.starts_with(f.as_str()) && w.contains("clipping")),
            "{f}: {warnings:?}"
        );
    }
    assert!(
        warnings
            .iter()
            .filter(|w| !w.starts_with("dropped "))
            .all(|w| bad.iter().any(|b| w.starts_with(b.as_str()))),
        "only the bad hits are warned about: {warnings:?}"
    );
    // Clipped accelerations no longer follow the model the other hits agree
    // on: without flags those hits are dropped as inconsistent (with a
    // warning), the double hits (whose transfer is intact) are kept.
    let inconsistent: Vec<&str> = all["inconsistent_hits"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f["file"].as_str().unwrap())
        .collect();
    assert!(
        inconsistent.iter().all(|f| cl.iter().any(|c| c == f)),
        "{inconsistent:?}"
    );
    assert_eq!(
        all["dropped_hits"].as_array().unwrap().len(),
        inconsistent.len()
    );
    let hq = all["hit_quality"].as_array().unwrap();
    assert_eq!(hq.len(), 14);
    for (h, f) in hq.iter().zip(&files) {
        assert_eq!(h["file"].as_str().unwrap(), f);
        let flags = h["flags"].as_array().unwrap();
        assert_eq!(flags.is_empty(), !bad.contains(&f), "{f}: {flags:?}");
        for key in ["hit", "hit_time_s", "noise_samples", "pulse", "channels"] {
            assert!(h.get(key).is_some(), "{key}");
        }
        assert_eq!(h["channels"].as_array().unwrap().len(), 3);
        assert!(h["channels"][2]["snr_db"].as_f64().unwrap() > 30.0);
    }
    assert_eq!(hq[10]["flags"][0]["check"], "double-hit");
    assert_eq!(hq[12]["flags"][0]["check"], "clipping");

    // Refused with --strict: exit code 2, every bad file and its check named.
    let mut args: Vec<&str> = vec!["identify", "--strict"];
    args.extend(files.iter().map(String::as_str));
    let (code, out, err) = run(&args);
    assert_eq!(code, 2, "{err}");
    assert!(out.is_empty());
    assert!(
        err.contains("--strict: 4 of 14 hits fail the quality checks"),
        "{err}"
    );
    for f in &dh {
        assert!(err.contains(&format!("{f}: double hit")), "{err}");
    }
    for f in &cl {
        assert!(err.contains(&format!("{f}: clipping")), "{err}");
    }

    // Dropped: M and K within 1 % of the truth again.
    let dropped = identify_json(&files, &["--drop-bad-hits", "--no-uncertainty"]);
    let names: Vec<&str> = dropped["dropped_hits"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap())
        .collect();
    assert_eq!(names, bad.iter().map(|s| s.as_str()).collect::<Vec<_>>());
    assert_eq!(dropped["source"]["hits"], 10);
    let w = dropped["warnings"].to_string();
    assert!(w.contains("dropped 4 of 14 hits"), "{w}");
    let (m_all, k_all) = (
        rel_to_model(&all["mass"], &s.model.mass),
        rel_to_model(&all["stiffness"], &s.model.stiffness),
    );
    let (m, k) = (
        rel_to_model(&dropped["mass"], &s.model.mass),
        rel_to_model(&dropped["stiffness"], &s.model.stiffness),
    );
    eprintln!(
        "relative errors with the bad hits: M {m_all:.4}, K {k_all:.4}; without: M {m:.4}, K {k:.4}"
    );
    assert!(m < 0.01 && k < 0.01, "M {m}, K {k}");
    assert!(m_all > m && k_all > k, "the bad hits spoil the result");
}

#[test]
fn a_campaign_of_bad_hits_only_leaves_nothing_to_drop() {
    let dir = tempfile::tempdir().unwrap();
    let (double, _) = simulator("paper-case1.toml", |s| {
        s.campaign.hits = 2;
        s.campaign.hammer.double_hit = Some(DoubleHit {
            delay_s: 0.2,
            ratio: 0.5,
        });
    });
    let files = write(dir.path(), &double.simulate(1));
    let mut args: Vec<&str> = vec!["identify", "--drop-bad-hits"];
    args.extend(files.iter().map(String::as_str));
    let (code, out, err) = run(&args);
    assert_eq!(code, 2);
    assert!(out.is_empty());
    assert!(
        err.contains("--drop-bad-hits: all 2 hits fail the quality checks, none remain"),
        "{err}"
    );
    assert!(err.contains(&format!("{}: double hit", files[1])), "{err}");
    // Without flags the same campaign is identified, with the warnings.
    let (code, out, err) = run(&args[..1]
        .iter()
        .copied()
        .chain(files.iter().map(String::as_str))
        .collect::<Vec<_>>());
    assert_eq!(code, 0, "{err}");
    assert!(
        out.contains("Hit quality") && out.contains("double hit"),
        "{out}"
    );
}
