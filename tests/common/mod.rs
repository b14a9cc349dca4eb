//! Helpers for tests that run the real `frameid` binary.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

pub fn frameid() -> Command {
    Command::new(env!("CARGO_BIN_EXE_frameid"))
}

/// Runs `frameid args...`; returns (exit code, stdout, stderr).
pub fn run(args: &[&str]) -> (i32, String, String) {
    let out: Output = frameid().args(args).output().expect("frameid runs");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// Runs and asserts success; returns stdout.
pub fn ok(args: &[&str]) -> String {
    let (code, out, err) = run(args);
    assert_eq!(code, 0, "frameid {args:?} failed:\n{err}\n{out}");
    out
}

pub fn repo(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(path)
}

pub fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

/// The hit files of a simulate output directory, sorted.
pub fn hit_files(dir: &Path, ext: &str) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| {
            p.extension().is_some_and(|e| e == ext)
                && p.file_name().unwrap().to_string_lossy().starts_with("hit")
        })
        .map(|p| p.to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

pub fn read_json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

pub fn matrix(v: &serde_json::Value) -> Vec<Vec<f64>> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|r| {
            r.as_array()
                .unwrap()
                .iter()
                .map(|x| x.as_f64().unwrap())
                .collect()
        })
        .collect()
}

/// Relative Frobenius distance of two matrices given as rows.
pub fn rel_fro(a: &[Vec<f64>], b: &[Vec<f64>]) -> f64 {
    let mut num = 0.0;
    let mut den = 0.0;
    for (ra, rb) in a.iter().zip(b) {
        for (x, y) in ra.iter().zip(rb) {
            num += (x - y) * (x - y);
            den += y * y;
        }
    }
    (num / den).sqrt()
}

/// `frameid identify --json --no-uncertainty FILES EXTRA...`, asserted to
/// succeed, parsed.
pub fn identify_no_uncertainty(files: &[String], extra: &[&str]) -> serde_json::Value {
    let mut args: Vec<&str> = vec!["identify", "--json", "--no-uncertainty"];
    args.extend(files.iter().map(String::as_str));
    args.extend_from_slice(extra);
    serde_json::from_str(&ok(&args)).unwrap()
}

/// Paper case 1's mass and stiffness (scenarios/paper-case1.toml), kg and
/// N/m.
pub const PAPER_CASE1_MASS: [[f64; 2]; 2] = [[0.2913, 0.0153], [0.0153, 0.3387]];
pub const PAPER_CASE1_STIFFNESS: [[f64; 2]; 2] = [[630.44, -425.83], [-425.83, 439.01]];
