//! `frameid simulate` run as a user would.

mod common;

use common::*;
use num_complex::Complex64;
use rustfft::FftPlanner;

#[test]
fn simulate_writes_records_and_truth() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("c1");
    let msg = ok(&[
        "simulate",
        s(&repo("scenarios/paper-case1.toml")),
        "--out",
        s(&out),
        "--hits",
        "3",
        "--seed",
        "5",
    ]);
    assert!(msg.contains("3 hits"), "{msg}");
    let hits = hit_files(&out, "csv");
    assert_eq!(hits.len(), 3);
    let text = std::fs::read_to_string(&hits[0]).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        "time,force [N],acc1 [m/s^2],acc2 [m/s^2]"
    );
    assert_eq!(text.lines().count(), 2049, "header + 2048 samples");
    let truth = read_json(&out.join("truth.json"));
    for key in [
        "mass",
        "stiffness",
        "damping",
        "frequencies_hz",
        "damping_ratios",
        "mode_shapes",
        "dt_s",
        "hit_floor",
        "settings",
        "hits",
        "seed",
    ] {
        assert!(truth.get(key).is_some(), "truth.json lacks {key}");
    }
    assert_eq!(truth["dt_s"].as_f64().unwrap(), 1.0 / 64.0);
    assert_eq!(truth["hit_floor"].as_u64().unwrap(), 1);
    assert_eq!(truth["seed"].as_u64().unwrap(), 5);
    assert_eq!(truth["settings"]["campaign"]["hits"].as_u64().unwrap(), 3);
    assert_eq!(
        matrix(&truth["mass"]),
        vec![vec![0.2913, 0.0153], vec![0.0153, 0.3387]]
    );
    let f: Vec<f64> = truth["frequencies_hz"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    // Eigenvalues of the paper's rounded M and K: 2.7249 and 9.1537 Hz.
    assert!(
        (f[0] - 2.7249).abs() < 1e-4 && (f[1] - 9.1537).abs() < 1e-4,
        "{f:?}"
    );
    let shape = &truth["mode_shapes"][0];
    assert_eq!(shape.as_array().unwrap().len(), 2);
}

#[test]
fn same_seed_identical_files_different_seed_differs() {
    let dir = tempfile::tempdir().unwrap();
    let run_seed = |name: &str, seed: &str| {
        let out = dir.path().join(name);
        ok(&[
            "simulate",
            s(&repo("scenarios/paper-case2.toml")),
            "--out",
            s(&out),
            "--hits",
            "2",
            "--seed",
            seed,
        ]);
        hit_files(&out, "csv")
            .iter()
            .map(|f| std::fs::read(f).unwrap())
            .collect::<Vec<_>>()
    };
    let a = run_seed("a", "9");
    let b = run_seed("b", "9");
    let c = run_seed("c", "10");
    assert_eq!(a, b);
    assert_ne!(a, c);
}

/// Averaged magnitude spectrum of a channel over the hits of a directory.
fn spectrum(files: &[String], column: usize) -> Vec<f64> {
    let mut planner = FftPlanner::<f64>::new();
    let mut acc: Vec<f64> = Vec::new();
    for f in files {
        let text = std::fs::read_to_string(f).unwrap();
        let x: Vec<Complex64> = text
            .lines()
            .skip(1)
            .map(|l| Complex64::new(l.split(',').nth(column).unwrap().parse().unwrap(), 0.0))
            .collect();
        let mut buf = x;
        planner.plan_fft_forward(buf.len()).process(&mut buf);
        if acc.is_empty() {
            acc = vec![0.0; buf.len() / 2];
        }
        for (a, v) in acc.iter_mut().zip(&buf) {
            *a += v.norm();
        }
    }
    acc
}

#[test]
fn paper_case1_spectra_peak_at_the_papers_frequencies() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("c1");
    ok(&[
        "simulate",
        s(&repo("scenarios/paper-case1.toml")),
        "--out",
        s(&out),
    ]);
    let hits = hit_files(&out, "csv");
    let df = 64.0 / 2048.0;
    for column in [2, 3] {
        let spec = spectrum(&hits, column);
        // Largest peak in each band around the paper's modes (eq. 37-38).
        let peak = |lo: f64, hi: f64| {
            let (k, _) = spec
                .iter()
                .enumerate()
                .filter(|(k, _)| (*k as f64 * df) >= lo && (*k as f64 * df) <= hi)
                .fold((0, 0.0), |b, (k, v)| if *v > b.1 { (k, *v) } else { b });
            k as f64 * df
        };
        // The DFT bin spacing is 1/32 Hz; the truth (the paper's rounded M
        // and K) sits at 2.7249 and 9.1537 Hz, within a bin of the paper's
        // 2.7314 and 9.1638 Hz.
        let (f1, f2) = (peak(1.0, 5.0), peak(6.0, 12.0));
        assert!(
            (f1 - 2.7314).abs() <= 1.5 * df,
            "column {column}: first peak {f1} Hz"
        );
        assert!(
            (f2 - 9.1638).abs() <= 1.5 * df,
            "column {column}: second peak {f2} Hz"
        );
    }
}

#[test]
fn uff_formats_are_written() {
    let dir = tempfile::tempdir().unwrap();
    for (fmt, name) in [("uff", "a"), ("uff-binary", "b")] {
        let out = dir.path().join(name);
        ok(&[
            "simulate",
            s(&repo("scenarios/paper-case1.toml")),
            "--out",
            s(&out),
            "--hits",
            "2",
            "--format",
            fmt,
        ]);
        assert_eq!(hit_files(&out, "uff").len(), 2);
    }
}

#[test]
fn bad_scenarios_are_refused_with_file_and_field() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.toml");
    let text = std::fs::read_to_string(repo("scenarios/paper-case1.toml"))
        .unwrap()
        .replace("floor = 1 ", "floor = 4 ");
    std::fs::write(&bad, text).unwrap();
    let out = dir.path().join("o");
    let (code, _, err) = run(&["simulate", s(&bad), "--out", s(&out)]);
    assert_eq!(code, 2);
    assert!(
        err.contains("bad.toml: campaign.hammer.floor: floor 4 does not exist"),
        "{err}"
    );
    assert!(!out.exists(), "nothing written for a bad scenario");
    let (code, _, err) = run(&["simulate", "no/such/file.toml", "--out", s(&out)]);
    assert_eq!(code, 2);
    assert!(
        err.contains("no/such/file.toml: cannot read scenario"),
        "{err}"
    );
    let (code, _, err) = run(&[
        "simulate",
        s(&repo("scenarios/paper-case1.toml")),
        "--out",
        s(&out),
        "--noise=-1",
    ]);
    assert_eq!(code, 2);
    assert!(err.contains("--noise"), "{err}");
}
