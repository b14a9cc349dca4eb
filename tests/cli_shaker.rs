//! Shaker records end to end: random, burst-random and chirp campaigns are
//! recognised as continuous excitation (`--excitation auto`), skip the
//! hammer checks, get the coherence check, and identify M and K; forcing
//! `--excitation hammer` on them refuses them as records without a hit,
//! and hammer campaigns are still recognised as such.

mod common;

use std::path::Path;

use common::*;

/// Paper case 1 driven by a shaker at floor 1 (`excitation`, the body of a
/// `[campaign.excitation]` table); 6 records written under `dir`.
fn campaign(dir: &Path, name: &str, excitation: &str) -> Vec<String> {
    let base = std::fs::read_to_string(repo("scenarios/paper-case1.toml")).unwrap();
    let path = dir.join(format!("{name}.toml"));
    std::fs::write(
        &path,
        format!("{base}\n[campaign.excitation]\nfloor = 1\n{excitation}\n"),
    )
    .unwrap();
    let out = dir.join(name);
    ok(&[
        "simulate",
        s(&path),
        "--hits",
        "6",
        "--seed",
        "1",
        "--out",
        s(&out),
    ]);
    hit_files(&out, "csv")
}

const MASS: [[f64; 2]; 2] = PAPER_CASE1_MASS;
const STIFFNESS: [[f64; 2]; 2] = PAPER_CASE1_STIFFNESS;

#[test]
fn shaker_campaigns_are_identified_as_continuous() {
    let dir = tempfile::tempdir().unwrap();
    let truth = |t: [[f64; 2]; 2]| -> Vec<Vec<f64>> { t.iter().map(|r| r.to_vec()).collect() };
    for (name, table) in [
        (
            "random",
            "kind = \"random\"\nrms_n = 2.0\nmin_frequency_hz = 1.0\nmax_frequency_hz = 24.0",
        ),
        (
            "burst",
            "kind = \"burst-random\"\nrms_n = 2.0\nmin_frequency_hz = 1.0\nmax_frequency_hz = 24.0\nburst_fraction = 0.5",
        ),
        (
            "chirp",
            "kind = \"chirp\"\namplitude_n = 2.0\nstart_frequency_hz = 1.0\nend_frequency_hz = 24.0",
        ),
    ] {
        let files = campaign(dir.path(), name, table);
        let v = identify_no_uncertainty(&files, &[]);
        for q in v["hit_quality"].as_array().unwrap() {
            assert_eq!(q["excitation"], "continuous", "{name}: {q:#}");
            // Crest factors: random 3-5, burst random 4-5, chirp 1.5; the
            // hammer threshold is 8.
            assert!(q["crest_factor"].as_f64().unwrap() < 6.0, "{name}");
            let coherence = q["coherence"].as_array().unwrap();
            assert_eq!(coherence.len(), 2);
            // Coherence of clean records averaged over the lines the force
            // excites: 0.86-0.93 (see
            // QualitySettings::min_coherence).
            for c in coherence {
                assert!(c.as_f64().unwrap() > 0.75, "{name}: {c}");
            }
            assert!(q["flags"].as_array().unwrap().is_empty(), "{name}: {q:#}");
        }
        assert_eq!(v["inconsistent_hits"], serde_json::json!([]), "{name}");
        // M and K from six 32 s shaker records at 1 % noise: within 1 % of
        // the truth (measured M 0.32-0.51 %, K 0.08-0.13 %).
        let (m, k) = (
            rel_fro(&matrix(&v["mass"]), &truth(MASS)),
            rel_fro(&matrix(&v["stiffness"]), &truth(STIFFNESS)),
        );
        eprintln!("{name}: M {m:.5}, K {k:.5}");
        assert!(m < 0.01 && k < 0.01, "{name}: M {m}, K {k}");
        // Forced to be hammer records, random and chirp forces have no hit
        // (burst random, half zeros, does peak far above its median
        // deviation and is then taken as one long pulse).
        if name == "burst" {
            continue;
        }
        let mut args: Vec<&str> = vec!["identify", "--excitation", "hammer"];
        args.extend(files.iter().map(String::as_str));
        let (code, out, err) = run(&args);
        assert_eq!(code, 2, "{name}: {err}");
        assert!(out.is_empty());
        assert!(err.contains("no hit"), "{name}: {err}");
    }
    // Hammer records are still hammer records.
    let out = dir.path().join("hammer");
    ok(&[
        "simulate",
        s(&repo("scenarios/paper-case1.toml")),
        "--hits",
        "3",
        "--seed",
        "1",
        "--out",
        s(&out),
    ]);
    let v = identify_no_uncertainty(&hit_files(&out, "csv"), &[]);
    for q in v["hit_quality"].as_array().unwrap() {
        assert_eq!(q["excitation"], "hammer");
        assert!(q["crest_factor"].as_f64().unwrap() > 8.0);
    }
    // A bad flag value names the flag.
    let (code, _, err) = run(&["identify", "--excitation", "pendulum", s(&out)]);
    assert_eq!(code, 2);
    assert!(
        err.contains("--excitation") && err.contains("pendulum"),
        "{err}"
    );
}
