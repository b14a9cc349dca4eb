//! Golden outputs: what `frameid sweep` and `frameid identify` wrote before
//! the harness was split into libraries (the architecture issue). The
//! refactoring must not change a byte of them.
//!
//! - `tests/golden/{trials.csv,summary.json,sweep.json}`:
//!   `frameid sweep scenarios/paper-case1.toml --noise 0,0.01 --trials 6 --seed 3`
//!   (run from the repository root); its `representative.json` (676 kB) is
//!   kept as its SHA-256 only.
//! - `tests/golden/identify*.{json,txt}`: `frameid identify hit*.csv [--json]
//!   [--refine]` in the directory written by
//!   `frameid simulate scenarios/paper-case1.toml --seed 7 --hits 5`.

mod common;

use common::{frameid, repo, s};
use sha2::{Digest, Sha256};
use std::path::Path;

/// SHA-256 of the representative campaign written by the golden sweep.
const REPRESENTATIVE_SHA256: &str =
    "0fcdcf3e5d5c710de7df208ff30f49b8cf87d7ca9ab9de342bd49f43224272b1";

fn golden(name: &str) -> String {
    std::fs::read_to_string(repo("tests/golden").join(name)).expect("golden file")
}

/// Compares line by line so that a failure shows the first differing line.
fn assert_same(what: &str, got: &str, want: &str) {
    if got == want {
        return;
    }
    let first = got
        .lines()
        .zip(want.lines())
        .position(|(g, w)| g != w)
        .unwrap_or(got.lines().count().min(want.lines().count()));
    panic!(
        "{what} differs from the golden file at line {}:\n  got:  {:?}\n  want: {:?}",
        first + 1,
        got.lines().nth(first),
        want.lines().nth(first)
    );
}

#[test]
fn sweep_output_is_unchanged() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sweep");
    let status = frameid()
        .current_dir(repo(""))
        .args([
            "sweep",
            "scenarios/paper-case1.toml",
            "--noise",
            "0,0.01",
            "--trials",
            "6",
            "--seed",
            "3",
            "--out",
            s(&out),
        ])
        .output()
        .unwrap();
    assert!(
        status.status.success(),
        "{}",
        String::from_utf8_lossy(&status.stderr)
    );
    for name in ["trials.csv", "summary.json", "sweep.json"] {
        let got = std::fs::read_to_string(out.join(name)).unwrap();
        assert_same(name, &got, &golden(name));
    }
    let rep = std::fs::read(out.join("representative.json")).unwrap();
    let digest = format!("{:x}", Sha256::digest(&rep));
    assert_eq!(digest, REPRESENTATIVE_SHA256, "representative.json changed");
}

fn identify_in(dir: &Path, extra: &[&str]) -> String {
    let mut args = vec!["identify"];
    let files: Vec<String> = (1..=5).map(|i| format!("hit{i:02}.csv")).collect();
    args.extend(files.iter().map(String::as_str));
    args.extend(extra);
    let out = frameid().current_dir(dir).args(&args).output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

#[test]
fn identify_output_is_unchanged() {
    let dir = tempfile::tempdir().unwrap();
    let status = frameid()
        .args([
            "simulate",
            s(&repo("scenarios/paper-case1.toml")),
            "--seed",
            "7",
            "--hits",
            "5",
            "--out",
            s(dir.path()),
        ])
        .output()
        .unwrap();
    assert!(status.status.success());
    assert_same(
        "identify --json",
        &identify_in(dir.path(), &["--json"]),
        &golden("identify.json"),
    );
    assert_same(
        "identify --json --refine",
        &identify_in(dir.path(), &["--json", "--refine"]),
        &golden("identify-refine.json"),
    );
    assert_same(
        "identify (text)",
        &identify_in(dir.path(), &[]),
        &golden("identify.txt"),
    );
}
