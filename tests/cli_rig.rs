//! Rig realism, end to end: what a rig's imperfections do to M, K and the
//! damping, and what frameid does about them.

mod common;

use common::*;
use serde_json::Value;

/// Sensor masses: an accelerometer's mass is part of its floor's lumped
/// mass, so the records see it and M includes it; `--sensor-mass` gives M
/// without it. The section-4 frame with 60 g sensors (a heavy triaxial
/// accelerometer and its cable on a 1.5 kg floor), 10 hits at 1 % noise.
#[test]
fn a_known_sensor_mass_is_taken_off_the_identified_mass() {
    let dir = tempfile::tempdir().unwrap();
    let base = std::fs::read_to_string(repo("scenarios/frame-bare.toml")).unwrap();
    let scenario = base.replace("sensor_mass_kg = 0.005", "sensor_mass_kg = 0.060");
    assert_eq!(scenario.matches("sensor_mass_kg = 0.060").count(), 2);
    let path = dir.path().join("heavy-sensors.toml");
    std::fs::write(&path, scenario).unwrap();
    let out = dir.path().join("hits");
    ok(&[
        "simulate",
        s(&path),
        "--noise",
        "0.01",
        "--seed",
        "4",
        "--out",
        s(&out),
    ]);
    let truth = read_json(&out.join("truth.json"));
    let files = hit_files(&out, "csv");
    let v: Value = identify_no_uncertainty(&files, &["--sensor-mass", "0.06"]);
    let (m, t) = (matrix(&v["mass"]), matrix(&truth["mass"]));
    let bare = matrix(&v["without_sensors"]["mass"]);
    let bare_truth: Vec<Vec<f64>> = (0..2)
        .map(|i| {
            (0..2)
                .map(|j| t[i][j] - if i == j { 0.06 } else { 0.0 })
                .collect()
        })
        .collect();
    let (e, e_bare) = (rel_fro(&m, &t), rel_fro(&bare, &bare_truth));
    eprintln!(
        "M {e:.2e}, M without sensors {e_bare:.2e}; truth M11 {}",
        t[0][0]
    );
    // The identified M includes the sensors (measured 0.062 % from the
    // truth with them); without them it matches the bare floors to the
    // same accuracy (0.064 %): the subtraction is exact, only the
    // identification's own error remains. 0.5 %, as the other 1 %-noise
    // tests, is far below the 5 % the sensors make.
    assert!(
        e < 0.005 && e_bare < 0.005,
        "M {e}, without sensors {e_bare}"
    );
    let wrong = rel_fro(&m, &bare_truth);
    // The sensors are 4 % of each floor: M is that far from the bare truth.
    assert!(wrong > 0.03, "the sensors are visible in M: {wrong}");
    for i in 0..2 {
        assert_eq!(v["without_sensors"]["sensor_mass_kg"][i], 0.06);
        assert!((m[i][i] - bare[i][i] - 0.06).abs() < 1e-12);
    }
    // A sensor heavier than its floor, or a wrong count, is refused naming
    // the flag.
    let mut args: Vec<&str> = vec!["identify", "--no-uncertainty"];
    args.extend(files.iter().map(String::as_str));
    for bad in ["5", "0.01,0.02,0.03", "-0.1"] {
        let mut a = args.clone();
        let flag = format!("--sensor-mass={bad}");
        a.push(&flag);
        let (code, stdout, err) = run(&a);
        assert_eq!(code, 2, "{bad}: {err}");
        assert!(err.contains("--sensor-mass"), "{bad}: {err}");
        assert!(stdout.is_empty());
    }
}

/// Paper case 1 with `snippet` appended to its scenario, 10 hits at 1 %
/// noise (seed 5), identified without error bars; returns the JSON and the
/// truth.
fn rig_campaign(dir: &std::path::Path, name: &str, snippet: &str) -> (Value, Value) {
    let base = std::fs::read_to_string(repo("scenarios/paper-case1.toml")).unwrap();
    let path = dir.join(format!("{name}.toml"));
    std::fs::write(&path, format!("{base}\n{snippet}\n")).unwrap();
    let out = dir.join(name);
    ok(&[
        "simulate",
        s(&path),
        "--noise",
        "0.01",
        "--seed",
        "5",
        "--out",
        s(&out),
    ]);
    let v = identify_no_uncertainty(&hit_files(&out, "csv"), &[]);
    (v, read_json(&out.join("truth.json")))
}

/// Relative errors of M, K and the Rayleigh damping against the truth.
fn errors(v: &Value, truth: &Value) -> [f64; 3] {
    [
        rel_fro(&matrix(&v["mass"]), &matrix(&truth["mass"])),
        rel_fro(&matrix(&v["stiffness"]), &matrix(&truth["stiffness"])),
        rel_fro(&matrix(&v["damping_rayleigh"]), &matrix(&truth["damping"])),
    ]
}

/// Each rig effect of `[campaign.rig]` and `[campaign.noise.coloured]`,
/// alone, on the same campaign: what it does to M, K and the damping, and
/// what frameid does about it. Figures measured with seed 5; the clean
/// campaign gives M 5.8e-4, K 2.0e-4, damping 6.6e-4.
///
/// | effect | M | K | damping | frameid |
/// |---|---|---|---|---|
/// | DC offset 0.05 m/s^2 on acc1 | 4.1e-4 | 2.2e-4 | 6.7e-4 | removed: the pre-trigger mean is subtracted (left in: 6.5e-4, 1.8e-4, 1.1e-3, OKID's observer absorbs a small constant) |
/// | DC offset 0.2 N on the force | 5.6e-4 | 2.0e-4 | 6.6e-4 | removed as on acc1 (left in, the same offset in every hit of the three-storey frame moved M by 6-23 % unflagged) |
/// | soft tip (force filtered before the structure) | 7.7e-4 | 2.0e-4 | 7.1e-4 | harmless: input and output see the same force |
/// | coloured noise (2 %, low-pass at 2 Hz) | 2.1e-3 | 6.0e-4 | 3.4e-2 | within the noise |
/// | accelerometer resonance at 60 Hz (3 %) | 1.5e-2 | 2.3e-2 | 1.9e-2 | cannot be seen in a 0-25 Hz band: it scales the high end of every accelerance; documented |
/// | gain 1.05 on acc2 in every hit | 7.1e-2 | 5.1e-2 | 6.7e-2 | cannot be seen from consistent hits (a gain change between hits is flagged, see tests/consistency.rs) |
/// | gain 0.95 on the force | 5.0e-2 | 5.0e-2 | 5.0e-2 | cannot be seen: M, K and damping scale by 1/gain |
/// | force transducer behind a 20 Hz low-pass | 0.18 | 0.26 | 0.21 | flagged: the driving-point feedthrough comes out negative |
///
/// | linear drift 0.002 m/s^3 on acc2 | 1.5e-3 | 3.1e-4 | 1.3e-3 | flagged and removed: the baseline line through the pre-trigger and the record's tail is subtracted (left in: M 1.5 %, K 0.8 %, damping 49 %) |
#[test]
fn each_rig_effect_does_what_the_table_says() {
    let dir = tempfile::tempdir().unwrap();
    let cases: [(&str, &str, [f64; 3], Option<&str>); 9] = [
        (
            "drift",
            "[[campaign.rig.channels]]\nchannel = \"acc2\"\ndrift_per_s = 0.002",
            [0.005, 0.005, 0.01],
            Some("linear drift"),
        ),
        (
            "offset",
            "[[campaign.rig.channels]]\nchannel = \"acc1\"\noffset = 0.05",
            [0.005, 0.005, 0.01],
            Some("constant offset"),
        ),
        (
            "force-offset",
            "[[campaign.rig.channels]]\nchannel = \"force\"\noffset = 0.2",
            [0.005, 0.005, 0.01],
            Some("constant offset"),
        ),
        (
            "soft-tip",
            "[campaign.rig.force_filter]\ncorner_hz = 20.0\norder = 2\napplies_to = \"applied\"",
            [0.005, 0.005, 0.01],
            None,
        ),
        (
            "coloured",
            "[campaign.noise.coloured]\nfraction = 0.02\nspectrum = { kind = \"low-pass\", corner_hz = 2.0 }",
            [0.01, 0.005, 0.1],
            None,
        ),
        (
            "accelerometer",
            "[campaign.rig.accelerometer]\nresonance_hz = 60.0\ndamping_ratio = 0.03",
            [0.05, 0.05, 0.05],
            None,
        ),
        (
            "gain",
            "[[campaign.rig.channels]]\nchannel = \"acc2\"\ngain = 1.05",
            [0.1, 0.1, 0.1],
            None,
        ),
        (
            "force-gain",
            "[[campaign.rig.channels]]\nchannel = \"force\"\ngain = 0.95",
            [0.06, 0.06, 0.06],
            None,
        ),
        (
            "transducer-lowpass",
            "[campaign.rig.force_filter]\ncorner_hz = 20.0\norder = 2\napplies_to = \"measured\"",
            [1.0, 1.0, 1.0],
            Some("feedthrough"),
        ),
    ];
    for (name, snippet, bounds, warning) in cases {
        let (v, truth) = rig_campaign(dir.path(), name, snippet);
        let e = errors(&v, &truth);
        eprintln!("{name}: M {:.2e} K {:.2e} damping {:.2e}", e[0], e[1], e[2]);
        // Bounds: for the effects that leave M and K alone, the 0.5 % (1 %
        // for the damping) of the other 1 %-noise tests, far above the
        // measured figures of the table; for coloured noise twice the
        // measured figure rounded up (0.01, 0.005, 0.1); for the effects
        // frameid cannot see, above the measured error (other seeds move
        // it by tens of percent) and below what would signal a change.
        for (k, what) in ["M", "K", "damping"].iter().enumerate() {
            assert!(e[k] < bounds[k], "{name}: {what} {}", e[k]);
        }
        // The effects that cannot be seen do move M: pinned, so that a change
        // in what frameid does about them shows here. A force gain of 0.95
        // scales M by 1 / 0.95 (5.3 %, less the identification's own error).
        if name == "force-gain" {
            assert!((e[0] - 0.05).abs() < 0.005, "force gain: M {}", e[0]);
        }
        if name == "gain" || name == "accelerometer" {
            assert!(e[0] > 0.01, "{name}: M {}", e[0]);
        }
        let warnings = v["warnings"].to_string();
        match warning {
            Some(w) => assert!(warnings.contains(w), "{name}: {warnings}"),
            None => assert!(
                !warnings.contains("feedthrough"),
                "{name}: unexpected {warnings}"
            ),
        }
        // No other effect (coloured noise among them) is taken for a drift
        // or an offset.
        if !["drift", "offset", "force-offset"].contains(&name) {
            assert!(!warnings.contains("drift"), "{name}: {warnings}");
        }
    }
}
