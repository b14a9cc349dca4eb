//! The Rust half of the pyuff cross-check (`records/tests/pyuff_check.py`,
//! run by `.ci/python/run.sh`):
//!
//! ```text
//! cargo run -p records --example pyuff_check -- write DIR   # our files + expected.json
//! python records/tests/pyuff_check.py DIR                  # pyuff reads them, writes its own
//! cargo run -p records --example pyuff_check -- read DIR    # we read pyuff's files
//! ```
//!
//! `write` puts into DIR: `frf_ascii.uff`, `frf_binary.uff` (UFF58
//! function types 4 and 6, uneven grid in `frf_binary_uneven.uff`),
//! `modes.uff` (dataset 55) and `expected.json` (every value, node,
//! direction and function type written). `read` reads the files pyuff
//! wrote (`pyuff_*.uff`, listed with their values in `pyuff_expected.json`)
//! and compares. Exit status 1 on any mismatch.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use ident::FrfQuantity;
use ident::linalg::C64;
use records::frf::{ExportMode, ModeShapeExport, write_uff55};
use records::{FrfFile, FrfFormat, FrfPair, FrfPoint, FrfReadOptions, read_frf, write_frf};
use serde_json::{Value, json};

fn receptance(f: f64, m: f64, k: f64, c: f64) -> C64 {
    let w = 2.0 * std::f64::consts::PI * f;
    C64::new(1.0, 0.0) / C64::new(k - w * w * m, w * c)
}

fn sample(frequency_hz: Vec<f64>) -> FrfFile {
    let responses = [FrfPoint::at(1, 1), FrfPoint::at(2, 1), FrfPoint::at(3, -3)];
    let mut pairs = Vec::new();
    for (i, response) in responses.iter().enumerate() {
        let values = frequency_hz
            .iter()
            .map(|&f| {
                let w = 2.0 * std::f64::consts::PI * f;
                receptance(f, 1.0 + i as f64, 4e3, 3.0) * (-w * w)
            })
            .collect();
        pairs.push(FrfPair {
            response: response.clone(),
            reference: FrfPoint::at(2, 1),
            quantity: FrfQuantity::Accelerance,
            values,
            coherence: (i != 1)
                .then(|| frequency_hz.iter().map(|f| 0.5 + 0.5 / (1.0 + f)).collect()),
            averages: Some(10),
            source: String::new(),
            exponential_tau_s: None,
        });
    }
    FrfFile {
        path: PathBuf::new(),
        format: FrfFormat::Uff58Binary,
        frequency_hz,
        pairs,
    }
}

fn modes() -> ModeShapeExport {
    ModeShapeExport {
        points: vec![FrfPoint::at(1, 1), FrfPoint::at(2, 1), FrfPoint::at(3, 1)],
        modes: vec![
            ExportMode {
                frequency_hz: 3.25,
                damping_ratio: 0.02,
                shape: vec![
                    C64::new(0.445, 0.01),
                    C64::new(0.802, -0.02),
                    C64::new(1.0, 0.0),
                ],
                modal_a: Some(ExportMode::modal_a_from_mass(3.25, 0.02, 5.2)),
            },
            ExportMode {
                frequency_hz: 9.1,
                damping_ratio: 0.011,
                shape: vec![
                    C64::new(-1.0, 0.0),
                    C64::new(-0.555, 0.003),
                    C64::new(1.247, -0.1),
                ],
                modal_a: None,
            },
        ],
    }
}

/// The datasets of an FRF file as pyuff lists them: FRF, then its
/// coherence.
fn expected_sets(file: &FrfFile) -> Vec<Value> {
    let mut sets = Vec::new();
    for p in &file.pairs {
        let point = |q: &FrfPoint| (q.node.unwrap_or(0), q.direction.unwrap_or(0));
        let ((rn, rd), (sn, sd)) = (point(&p.response), point(&p.reference));
        sets.push(json!({
            "func_type": 4, "rsp_node": rn, "rsp_dir": rd, "ref_node": sn, "ref_dir": sd,
            "freq": file.frequency_hz,
            "re": p.values.iter().map(|z| z.re).collect::<Vec<_>>(),
            "im": p.values.iter().map(|z| z.im).collect::<Vec<_>>(),
        }));
        if let Some(c) = &p.coherence {
            sets.push(json!({
                "func_type": 6, "rsp_node": rn, "rsp_dir": rd, "ref_node": sn, "ref_dir": sd,
                "freq": file.frequency_hz, "re": c, "im": vec![0.0; c.len()],
            }));
        }
    }
    sets
}

fn write(dir: &Path) -> Result<(), String> {
    let even: Vec<f64> = (0..64).map(|k| 0.5 + k as f64 * 0.25).collect();
    let uneven: Vec<f64> = (0..40).map(|k| 1.0 + (k as f64).powf(1.3)).collect();
    let mut files = serde_json::Map::new();
    for (name, grid, format) in [
        ("frf_ascii.uff", even.clone(), FrfFormat::Uff58Ascii),
        ("frf_binary.uff", even, FrfFormat::Uff58Binary),
        ("frf_binary_uneven.uff", uneven, FrfFormat::Uff58Binary),
    ] {
        let file = sample(grid);
        write_frf(&dir.join(name), &file, format).map_err(|e| e.to_string())?;
        files.insert(name.into(), Value::Array(expected_sets(&file)));
    }
    let m = modes();
    write_uff55(&dir.join("modes.uff"), &m).map_err(|e| e.to_string())?;
    let modes_json: Vec<Value> = m
        .modes
        .iter()
        .map(|mode| {
            let eig = mode.eigenvalue();
            let a = mode.modal_a.unwrap_or_default();
            json!({
                "eig": [eig.re, eig.im], "modal_a": [a.re, a.im],
                "nodes": m.points.iter().map(|p| p.node).collect::<Vec<_>>(),
                "r1": mode.shape.iter().map(|z| [z.re, z.im]).collect::<Vec<_>>(),
            })
        })
        .collect();
    let expected = json!({ "frf": files, "modes": { "modes.uff": modes_json } });
    std::fs::write(
        dir.join("expected.json"),
        serde_json::to_string_pretty(&expected).map_err(|e| e.to_string())?,
    )
    .map_err(|e| e.to_string())
}

fn numbers(v: &Value) -> Vec<f64> {
    v.as_array()
        .map(|a| a.iter().filter_map(Value::as_f64).collect())
        .unwrap_or_default()
}

fn read(dir: &Path) -> Result<usize, String> {
    let text = std::fs::read_to_string(dir.join("pyuff_expected.json"))
        .map_err(|e| format!("pyuff_expected.json: {e}"))?;
    let expected: Value = serde_json::from_str(&text).map_err(|e| e.to_string())?;
    let files = expected
        .as_object()
        .ok_or("pyuff_expected.json: not an object")?;
    let mut failures = 0;
    for (name, sets) in files {
        let file =
            read_frf(&dir.join(name), &FrfReadOptions::default()).map_err(|e| e.to_string())?;
        let binary = sets["binary"].as_bool().unwrap_or(false);
        let mut pairs = file.pairs.iter();
        for set in sets["sets"].as_array().into_iter().flatten() {
            let func_type = set["func_type"].as_i64().unwrap_or(0);
            if func_type != 4 {
                continue;
            }
            let Some(p) = pairs.next() else {
                eprintln!("{name}: fewer FRFs than pyuff wrote");
                failures += 1;
                break;
            };
            let node = |k: &str| set[k].as_i64().unwrap_or(0);
            if p.response.node_dir() != Some((node("rsp_node"), node("rsp_dir") as i32))
                || p.reference.node_dir() != Some((node("ref_node"), node("ref_dir") as i32))
            {
                eprintln!(
                    "{name} {}: points {} / {} differ",
                    p.source, p.response, p.reference
                );
                failures += 1;
            }
            let (freq, re, im) = (
                numbers(&set["freq"]),
                numbers(&set["re"]),
                numbers(&set["im"]),
            );
            // pyuff prints the grid as E13.5 (record 7, or the uneven
            // abscissa): 5e-6 relative; 1e-5 bounds it.
            for (k, (&f, &g)) in freq.iter().zip(&file.frequency_hz).enumerate() {
                if (f - g).abs() > 1e-5 * f.abs().max(1e-3) {
                    eprintln!("{name} {}: line {k}: {g} Hz, pyuff wrote {f} Hz", p.source);
                    failures += 1;
                }
            }
            for (k, z) in p.values.iter().enumerate() {
                let want = C64::new(re[k], im[k]);
                // Binary: doubles, exact. ASCII: pyuff prints %20.11e (12
                // significant digits, 5e-12 of each part); 1e-11 |H|.
                let tol = if binary { 0.0 } else { 1e-11 * want.norm() };
                if (z - want).norm() > tol {
                    eprintln!(
                        "{name} {}: line {k}: read {z}, pyuff wrote {want}",
                        p.source
                    );
                    failures += 1;
                }
            }
            if set["coherence"].is_array() {
                let want = numbers(&set["coherence"]);
                match &p.coherence {
                    Some(c) if c.iter().zip(&want).all(|(a, b)| (a - b).abs() <= 1e-11) => {}
                    _ => {
                        eprintln!("{name} {}: coherence differs", p.source);
                        failures += 1;
                    }
                }
            }
        }
        println!("{name}: {} FRFs read", file.pairs.len());
    }
    Ok(failures)
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().collect();
    let (Some(mode), Some(dir)) = (args.get(1), args.get(2)) else {
        eprintln!("usage: pyuff_check write|read DIR");
        return ExitCode::from(2);
    };
    let dir = Path::new(dir);
    match mode.as_str() {
        "write" => match write(dir) {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => {
                eprintln!("write: {e}");
                ExitCode::FAILURE
            }
        },
        "read" => match read(dir) {
            Ok(0) => ExitCode::SUCCESS,
            Ok(n) => {
                eprintln!("{n} mismatches");
                ExitCode::FAILURE
            }
            Err(e) => {
                eprintln!("read: {e}");
                ExitCode::FAILURE
            }
        },
        _ => {
            eprintln!("usage: pyuff_check write|read DIR");
            ExitCode::from(2)
        }
    }
}
