//! Modes beyond the model, end to end: a frame whose records carry a mode
//! the shear model lacks (a torsional mode coupled to the sensors, between
//! the two floor modes) is identified, not refused. The model's modes are
//! chosen as the subset closest to a shear frame, the other mode is
//! reported as out of model with its frequency, damping and shape, `--modes`
//! and `--band` choose explicitly, and `--strict` refuses.

mod common;

use std::path::{Path, PathBuf};

use common::*;
use serde_json::Value;

/// Paper case 1 plus a torsional mode at `torsion_hz` seen by both
/// accelerometers; 10 hits written under `dir`.
fn campaign(dir: &Path, torsion_hz: f64) -> Vec<String> {
    let base = std::fs::read_to_string(repo("scenarios/paper-case1.toml")).unwrap();
    let scenario = format!(
        "{base}\n[[campaign.rig.extra_modes]]\nlabel = \"torsion\"\nfrequency_hz = {torsion_hz}\ndamping_ratio = 0.008\nmodal_mass_kg = 0.3\ninput_participation = 0.4\nsensor_participation = [0.4, -0.6]\n"
    );
    let path: PathBuf = dir.join("torsion.toml");
    std::fs::write(&path, scenario).unwrap();
    let out = dir.join("hits");
    ok(&[
        "simulate",
        s(&path),
        "--hits",
        "10",
        "--seed",
        "2",
        "--out",
        s(&out),
    ]);
    hit_files(&out, "csv")
}

/// Relative Frobenius error of a JSON matrix against `truth`.
fn rel(v: &Value, truth: [[f64; 2]; 2]) -> f64 {
    let m = matrix(v);
    let t: Vec<Vec<f64>> = truth.iter().map(|r| r.to_vec()).collect();
    rel_fro(&m, &t)
}

const MASS: [[f64; 2]; 2] = PAPER_CASE1_MASS;
const STIFFNESS: [[f64; 2]; 2] = PAPER_CASE1_STIFFNESS;

/// M and K with the extra mode left out of the model, 10 hits at 1 %
/// noise: measured 0.06-0.09 % from the truth (M 0.059 %, K 0.086 % with the
/// mode at 6.1 Hz; 0.068 %, 0.062 % at 12.5 Hz); 0.5 % leaves room for
/// other seeds while a wrongly chosen mode gives over 20 % (see below).
const TOL: f64 = 0.005;

#[test]
fn a_mode_the_shear_model_lacks_is_reported_not_refused() {
    let dir = tempfile::tempdir().unwrap();
    for torsion_hz in [6.1, 12.5] {
        let files = campaign(dir.path(), torsion_hz);
        let v = identify_no_uncertainty(&files, &[]);
        assert_eq!(v["mode_selection"], "shear-frame", "{torsion_hz} Hz");
        let out = v["out_of_model_modes"].as_array().unwrap();
        assert_eq!(out.len(), 1, "{out:#?}");
        let f = out[0]["frequency_hz"].as_f64().unwrap();
        // The extra mode's frequency and damping ratio: measured 0.001 %
        // and 0.3 % off (6.10006 and 12.50019 Hz, 0.00802 and 0.00800 for
        // 0.008); the bounds, 0.5 % and a quarter of the damping, still
        // tell the mode from the floor modes (2.7, 9.2 Hz) and from a
        // heavily damped one.
        assert!((f / torsion_hz - 1.0).abs() < 0.005, "{f} Hz");
        assert!((out[0]["damping_ratio"].as_f64().unwrap() - 0.008).abs() < 0.002);
        assert_eq!(out[0]["mode_shape"].as_array().unwrap().len(), 2);
        let (m, k) = (rel(&v["mass"], MASS), rel(&v["stiffness"], STIFFNESS));
        eprintln!(
            "torsion {torsion_hz} Hz: out-of-model {f} Hz, damping {}; M {m:.5}, K {k:.5}",
            out[0]["damping_ratio"]
        );
        assert!(m < TOL && k < TOL, "{torsion_hz} Hz: M {m}, K {k}");
        let warnings = v["warnings"].to_string();
        assert!(
            warnings.contains("1 structural mode(s) outside the 2-DOF model"),
            "{warnings}"
        );
    }
}

#[test]
fn the_user_chooses_with_modes_or_band_and_strict_refuses() {
    let dir = tempfile::tempdir().unwrap();
    let files = campaign(dir.path(), 6.1);
    // --modes near the floor modes: the same model as the automatic choice.
    let auto = identify_no_uncertainty(&files, &[]);
    let near = identify_no_uncertainty(&files, &["--modes", "2.7,9.2"]);
    assert_eq!(near["mode_selection"], "near");
    assert_eq!(near["mass"], auto["mass"]);
    // --modes naming the torsional mode: the user is obeyed (and M is then
    // far from the truth, which is the user's choice to make).
    let wrong = identify_no_uncertainty(&files, &["--modes", "2.7,6.1"]);
    let f: Vec<f64> = wrong["modes"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|m| m["used"] == true)
        .map(|m| m["frequency_hz"].as_f64().unwrap())
        .collect();
    assert!((f[1] - 6.1).abs() < 0.05, "{f:?}");
    assert!(rel(&wrong["mass"], MASS) > 0.2);
    // --band holding all three: the shear-frame choice inside it.
    let band = identify_no_uncertainty(&files, &["--band", "2:10"]);
    assert_eq!(band["mode_selection"], "band");
    assert_eq!(band["mass"], auto["mass"]);
    // A band with one mode: refused, naming the band and the modes found.
    let mut args: Vec<&str> = vec!["identify"];
    args.extend(files.iter().map(String::as_str));
    let (code, out, err) = run(&[args.clone(), vec!["--band", "5:7"]].concat());
    assert_eq!(code, 2, "{err}");
    assert!(out.is_empty());
    assert!(
        err.contains("the band 5-7 Hz holds 1 structural mode"),
        "{err}"
    );
    // Bad flags name the flag.
    let (code, _, err) = run(&[args.clone(), vec!["--band", "9:3"]].concat());
    assert_eq!(code, 2);
    assert!(err.contains("--band: the low edge 9 Hz"), "{err}");
    let (code, _, err) = run(&[args.clone(), vec!["--modes", "2.7,x"]].concat());
    assert_eq!(code, 2);
    assert!(err.contains("--modes: 'x' is not a number"), "{err}");
    // --strict refuses a campaign with modes beyond the model.
    let (code, out, err) = run(&[args, vec!["--strict"]].concat());
    assert_eq!(code, 2, "{err}");
    assert!(out.is_empty());
    assert!(err.contains("the records show 3 structural modes"), "{err}");
}

/// `--report`: the page of a campaign without truth shows the extra mode as
/// out of the model (in the table and on the stabilization diagram), the
/// identified values as the JSON gives them, and per floor the measured FRF
/// with its coherence against the identified model.
#[test]
fn the_campaign_report_shows_the_out_of_model_mode_and_the_measured_frfs() {
    let dir = tempfile::tempdir().unwrap();
    let files = campaign(dir.path(), 6.1);
    let page = dir.path().join("identification.html");
    let mut args: Vec<&str> = vec!["identify", "--json", "--no-uncertainty"];
    args.extend(files.iter().map(String::as_str));
    args.extend(["--report", s(&page)]);
    let v: Value = serde_json::from_str(&ok(&args)).unwrap();
    let html = std::fs::read_to_string(&page).unwrap();
    assert!(html.starts_with("<!DOCTYPE html>"));
    assert!(!html.contains("<script"), "self-contained, no script");
    for hook in [
        "section class=\"source\"",
        "section class=\"modes\"",
        "section class=\"values\"",
        "section class=\"frf\"",
        "data-chart=\"stabilization\"",
    ] {
        assert!(html.contains(hook), "{hook}");
    }
    // One mode row out of the model, two in it.
    assert_eq!(html.matches("data-in-model=\"false\"").count(), 1);
    assert_eq!(html.matches("data-in-model=\"true\"").count(), 2);
    let extra = &html[html.find("data-in-model=\"false\"").unwrap()..];
    let f: f64 = extra
        .split("<td class=\"num\">")
        .nth(1)
        .and_then(|t| t.split('<').next())
        .unwrap()
        .parse()
        .unwrap();
    let json_f = v["out_of_model_modes"][0]["frequency_hz"].as_f64().unwrap();
    // The table shows five significant digits of the same number.
    assert!((f - json_f).abs() < 1e-4 * json_f, "{f} against {json_f}");
    // The extra mode is marked on the stabilization diagram.
    assert!(html.contains("data-series=\"extra-1\""));
    // Magnitude, phase and coherence of both floors' FRFs to the force.
    for j in 1..=2 {
        for chart in ["magnitude", "phase", "coherence"] {
            let id = format!("<figure class=\"chart\" id=\"campaign-frf-{j}-{chart}\"");
            assert_eq!(html.matches(&id).count(), 1, "{id}");
        }
    }
    // The identified mass matrix as the JSON gives it (full precision in
    // data-value).
    let m = matrix(&v["mass"]);
    let table = &html[html.find("data-table=\"mass-matrix-m\"").unwrap()..];
    let value = |label: &str| -> f64 {
        let row = &table[table.find(&format!(">{label}<")).unwrap()..];
        let at = row.find("data-value=\"").unwrap() + "data-value=\"".len();
        row[at..row[at..].find('"').unwrap() + at].parse().unwrap()
    };
    assert_eq!(value("M11"), m[0][0]);
    assert_eq!(value("M12"), m[0][1]);
    assert_eq!(value("M22"), m[1][1]);
}
