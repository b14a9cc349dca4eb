//! `frameid identify` run as a user would: on records written by
//! `frameid simulate` and on the paper's published realizations.

mod common;

use std::path::Path;

use common::*;
use serde_json::Value;

fn simulate(dir: &Path, scenario: &str, extra: &[&str]) -> Vec<String> {
    let mut args = vec!["simulate", scenario, "--out", s(dir)];
    args.extend_from_slice(extra);
    ok(&args);
    let ext = if extra.iter().any(|a| a.starts_with("uff")) {
        "uff"
    } else {
        "csv"
    };
    hit_files(dir, ext)
}

fn identify_json(files: &[String], extra: &[&str]) -> Value {
    let mut args: Vec<&str> = vec!["identify", "--json"];
    args.extend(files.iter().map(String::as_str));
    args.extend_from_slice(extra);
    serde_json::from_str(&ok(&args)).unwrap()
}

fn floats(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

#[test]
fn identifies_simulated_analyzer_records_within_the_one_percent_noise_tolerances() {
    let dir = tempfile::tempdir().unwrap();
    let files = simulate(dir.path(), s(&repo("scenarios/paper-case1.toml")), &[]);
    assert_eq!(files.len(), 10);
    let truth = read_json(&dir.path().join("truth.json"));
    let id = identify_json(&files, &[]);
    assert_eq!(id["intersample"], "bandlimited");
    // Scenario noise is 1 % over 10 hits: the identifier issue's tolerances.
    assert!(rel_fro(&matrix(&id["mass"]), &matrix(&truth["mass"])) < 0.01);
    assert!(rel_fro(&matrix(&id["stiffness"]), &matrix(&truth["stiffness"])) < 0.01);
    assert!(rel_fro(&matrix(&id["damping_rayleigh"]), &matrix(&truth["damping"])) < 0.1);
    let used: Vec<&Value> = id["modes"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|m| m["used"] == true)
        .collect();
    let f_truth = floats(&truth["frequencies_hz"]);
    assert_eq!(used.len(), 2);
    for (m, f) in used.iter().zip(&f_truth) {
        assert!((m["frequency_hz"].as_f64().unwrap() / f - 1.0).abs() < 5e-4);
        for key in [
            "damping_ratio",
            "mode_shape",
            "emac",
            "mpc",
            "msv",
            "cmi",
            "structural",
        ] {
            assert!(m.get(key).is_some(), "mode lacks {key}");
        }
        assert_eq!(m["mode_shape"].as_array().unwrap().len(), 2);
    }
    for key in [
        "rayleigh",
        "damping_mkr",
        "consistency",
        "hankel_singular_values",
        "warnings",
        "model_order",
    ] {
        assert!(id.get(key).is_some(), "result lacks {key}");
    }
    assert!(id["rayleigh"]["alpha"].as_f64().unwrap() > 0.0);
    assert!(
        id["warnings"].as_array().unwrap().is_empty(),
        "{}",
        id["warnings"]
    );
}

#[test]
fn held_records_with_zoh_and_noise_free_are_exact() {
    let dir = tempfile::tempdir().unwrap();
    let files = simulate(
        dir.path(),
        s(&repo("scenarios/frame-three-storey.toml")),
        &["--acquisition", "held", "--noise", "0", "--hits", "2"],
    );
    let truth = read_json(&dir.path().join("truth.json"));
    let id = identify_json(&files, &["--intersample", "zoh"]);
    // The CSV holds every double exactly and the held model is exact: only
    // rounding remains (measured ~1e-12).
    assert!(rel_fro(&matrix(&id["mass"]), &matrix(&truth["mass"])) < 1e-8);
    assert!(rel_fro(&matrix(&id["stiffness"]), &matrix(&truth["stiffness"])) < 1e-8);
    assert!(rel_fro(&matrix(&id["damping_mkr"]), &matrix(&truth["damping"])) < 1e-7);
}

#[test]
fn csv_and_uff_records_give_the_same_identification() {
    let dir = tempfile::tempdir().unwrap();
    let sc = repo("scenarios/paper-case2.toml");
    let csv = simulate(&dir.path().join("csv"), s(&sc), &["--hits", "4"]);
    let bin = simulate(
        &dir.path().join("bin"),
        s(&sc),
        &["--hits", "4", "--format", "uff-binary"],
    );
    let asc = simulate(
        &dir.path().join("asc"),
        s(&sc),
        &["--hits", "4", "--format", "uff"],
    );
    let a = identify_json(&csv, &[]);
    let b = identify_json(&bin, &[]);
    let c = identify_json(&asc, &[]);
    // Binary UFF stores the doubles: bit-identical results.
    for key in ["mass", "stiffness", "damping_mkr", "damping_rayleigh"] {
        assert_eq!(a[key], b[key], "{key}");
    }
    // ASCII UFF prescribes 13 significant digits (4E20.12): differences
    // at the 1e-12 level of the data, amplified by the identification's
    // conditioning to well below 1e-8.
    for key in ["mass", "stiffness", "damping_mkr"] {
        assert!(rel_fro(&matrix(&c[key]), &matrix(&a[key])) < 1e-8, "{key}");
    }
}

#[test]
fn paper_case1_realization_reproduces_the_published_numbers() {
    let id = identify_json(
        &[],
        &[
            "--realization",
            s(&repo("scenarios/paper-case1-realization.json")),
            "--intersample",
            "zoh",
        ],
    );
    let modes = id["modes"].as_array().unwrap();
    // Eq. 37-40; the realization's 4-digit rounding moves f by <= 2e-4 Hz.
    assert!((modes[0]["frequency_hz"].as_f64().unwrap() - 2.7314).abs() < 2e-4);
    assert!((modes[1]["frequency_hz"].as_f64().unwrap() - 9.1638).abs() < 2e-4);
    // Eq. 44-46 to the spread that the 4-digit rounding of A, B, C, D
    // causes (0.2 % for the diagonal terms, see ident/tests/paper.rs).
    let m = matrix(&id["mass"]);
    let k = matrix(&id["stiffness"]);
    assert!(
        (m[0][0] / 0.2913 - 1.0).abs() < 2e-3 && (m[1][1] / 0.3387 - 1.0).abs() < 2e-3,
        "{m:?}"
    );
    assert!(
        (k[0][0] / 630.44 - 1.0).abs() < 2e-3 && (k[0][1] / -425.83 - 1.0).abs() < 2e-3,
        "{k:?}"
    );
    assert_eq!(id["polarity_flipped"], false);
    assert!(id["hankel_singular_values"].as_array().unwrap().is_empty());
}

#[test]
fn paper_case2_realization_flags_and_flips_the_polarity() {
    let id = identify_json(
        &[],
        &[
            "--realization",
            s(&repo("scenarios/paper-case2-realization.json")),
            "--intersample",
            "zoh",
        ],
    );
    assert_eq!(id["polarity_flipped"], true);
    let warnings = id["warnings"].to_string();
    assert!(warnings.contains("polarity"), "{warnings}");
    let m = matrix(&id["mass"]);
    // Eq. 61: M11 = 1.3771 (positive definite after the flip).
    assert!((m[0][0] / 1.3771 - 1.0).abs() < 3e-3, "{m:?}");
    // K as implied by eq. 64 (not the misprinted eq. 62): K11 ~ 949.8.
    let k = matrix(&id["stiffness"]);
    assert!(
        (k[0][0] / 949.8 - 1.0).abs() < 0.01 && (k[0][0] / 630.44 - 1.0).abs() > 0.3,
        "{k:?}"
    );
    let human = ok(&[
        "identify",
        "--realization",
        s(&repo("scenarios/paper-case2-realization.json")),
        "--intersample",
        "zoh",
    ]);
    assert!(human.contains("Input polarity was inverted"), "{human}");
    assert!(human.contains("Mass M [kg]"));
}

#[test]
fn bad_input_gets_a_clear_message_and_exit_code_2() {
    let dir = tempfile::tempdir().unwrap();
    let files = simulate(
        dir.path(),
        s(&repo("scenarios/paper-case1.toml")),
        &["--hits", "2"],
    );
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["identify", "missing.csv"], "missing.csv"),
        (vec!["identify", &files[0], "--input", "hammer"], "hammer"),
        (
            vec!["identify", &files[0], "--collocated", "5:0"],
            "--collocated: output index 5 is out of range",
        ),
        (
            vec!["identify", &files[0], "--collocated", "acc9:force"],
            "no output named 'acc9'",
        ),
        (
            vec!["identify", "--realization", &files[0]],
            "not valid JSON",
        ),
    ];
    for (args, needle) in cases {
        let (code, out, err) = run(&args);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert!(
            err.contains(needle),
            "{args:?}: expected '{needle}' in: {err}"
        );
        assert!(out.is_empty(), "{args:?}: nothing on stdout");
    }
    let bad = dir.path().join("bad.json");
    std::fs::write(
        &bad,
        r#"{"dt": 0.015625, "A": [[1, 0], [0]], "B": [[1], [0]], "C": [[1, 0]], "D": [[0]]}"#,
    )
    .unwrap();
    let (code, _, err) = run(&["identify", "--realization", s(&bad)]);
    assert_eq!(code, 2);
    assert!(err.contains("`A[1]` has 1 entries, row 0 has 2"), "{err}");
}

#[test]
fn refine_recovers_non_proportional_damping_with_honest_standard_errors() {
    let dir = tempfile::tempdir().unwrap();
    let files = simulate(
        dir.path(),
        s(&repo("scenarios/paper-case1-dashpot.toml")),
        &[],
    );
    let truth = read_json(&dir.path().join("truth.json"));
    let id = identify_json(&files, &["--refine", "--no-uncertainty"]);
    let r = &id["refined"];
    assert_eq!(r["converged"], true, "{}", r["stop"]);
    let t = matrix(&truth["damping"]);
    let refined = matrix(&r["damping"]);
    let std = matrix(&r["damping_std"]);
    let rel_std = std.iter().flatten().map(|x| x * x).sum::<f64>().sqrt()
        / t.iter().flatten().map(|x| x * x).sum::<f64>().sqrt();
    let err = rel_fro(&refined, &t);
    // The refinement's error is of the size of its reported standard error
    // (the Frobenius error of an efficient estimator has RMS equal to the
    // Frobenius norm of the entry standard errors; 3x covers one campaign).
    assert!(
        err < 3.0 * rel_std,
        "refined damping error {err} vs reported {rel_std}"
    );
    // Rayleigh damping cannot represent the dashpot: wrong by construction
    // (12.6 % in the sweeps), the refined one within ~1 %.
    let rayleigh = rel_fro(&matrix(&id["damping_rayleigh"]), &t);
    assert!(
        rayleigh > 0.05 && err < 0.02,
        "Rayleigh {rayleigh}, refined {err}"
    );
    assert!(rel_fro(&matrix(&r["mass"]), &matrix(&truth["mass"])) < 0.01);
    assert_eq!(r["modes"].as_array().unwrap().len(), 2);
    let human = ok(&[
        &["identify", "--refine", "--no-uncertainty"][..],
        &files.iter().map(String::as_str).collect::<Vec<_>>(),
    ]
    .concat());
    assert!(human.contains("Refined by maximum likelihood"), "{human}");
}

#[test]
fn a_hit_near_a_node_of_a_mode_is_named() {
    // Floors of 0.3 kg, storeys of 600 and 400 N/m coupled by 7 N/m: the first mode
    // (5.8 Hz) barely moves floor 1, where the hammer hits (0.13 % of the driving
    // point's response, measured); with a coupling of 100 N/m it carries 15 %.
    let dir = tempfile::tempdir().unwrap();
    let paper = std::fs::read_to_string(repo("scenarios/paper-case1.toml")).unwrap();
    let scenario = |k12: f64| {
        let text: String = paper
            .lines()
            .map(|l| {
                if l.starts_with("mass = ") {
                    "mass = [[0.3, 0.0], [0.0, 0.3]]".to_string()
                } else if l.starts_with("stiffness = ") {
                    format!("stiffness = [[600.0, -{k12:.1}], [-{k12:.1}, 400.0]]")
                } else {
                    l.to_string()
                }
            })
            .collect::<Vec<_>>()
            .join("\n");
        let path = dir.path().join(format!("k{k12}.toml"));
        std::fs::write(&path, text).unwrap();
        path
    };
    let warnings = |k12: f64| {
        let out = dir.path().join(format!("k{k12}"));
        let files = simulate(&out, s(&scenario(k12)), &["--seed", "1", "--hits", "10"]);
        let json = identify_json(&files, &[]);
        json["warnings"]
            .as_array()
            .unwrap()
            .iter()
            .map(|w| w.as_str().unwrap().to_string())
            .filter(|w| w.contains("driving point's response"))
            .collect::<Vec<_>>()
    };
    let near = warnings(7.0);
    assert_eq!(near.len(), 1, "{near:?}");
    assert!(
        near[0].starts_with("mode 1 (5.810 Hz) carries only 0.13 % of the driving point's response: the hit is near a node of that mode"),
        "{}",
        near[0]
    );
    assert!(warnings(100.0).is_empty());
}
