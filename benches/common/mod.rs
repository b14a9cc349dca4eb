//! Helpers of the whole-process benches (`process`, `long_record`): the
//! release binary that `cargo bench` builds, campaigns written by
//! `frameid simulate`, peak memory of a child process and the Python that
//! runs the numpy reference script.

#![allow(dead_code)] // each bench uses a part of this module

use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// The `frameid` binary built with the bench profile (release settings).
pub fn frameid() -> PathBuf {
    PathBuf::from(env!("CARGO_BIN_EXE_frameid"))
}

/// A scenario file bundled with the repository.
pub fn scenario(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenarios")
        .join(name)
}

/// Runs `command` to completion with its output captured; panics with its
/// standard error if it fails (a bench whose set-up fails measures nothing).
pub fn run_ok(command: &mut Command) -> Output {
    let output = command
        .output()
        .unwrap_or_else(|e| panic!("cannot start {command:?}: {e}"));
    assert!(
        output.status.success(),
        "{command:?} failed ({}):\n{}",
        output.status,
        String::from_utf8_lossy(&output.stderr)
    );
    output
}

/// `frameid simulate SCENARIO --out DIR --seed 1 EXTRA...`; returns the hit
/// files written, in order.
pub fn simulate(scenario: &Path, out: &Path, extra: &[&str]) -> Vec<PathBuf> {
    run_ok(
        Command::new(frameid())
            .arg("simulate")
            .arg(scenario)
            .arg("--out")
            .arg(out)
            .args(["--seed", "1"])
            .args(extra),
    );
    let mut files: Vec<PathBuf> = std::fs::read_dir(out)
        .expect("simulate wrote its output directory")
        .map(|entry| entry.expect("readable directory entry").path())
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with("hit") && n.ends_with(".csv"))
        })
        .collect();
    files.sort();
    assert!(!files.is_empty(), "simulate wrote no hit files");
    files
}

/// Wall time of one run of `command` (output discarded); panics if it fails.
pub fn time_run(command: &mut Command) -> Duration {
    let start = Instant::now();
    let status = command
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .unwrap_or_else(|e| panic!("cannot start {command:?}: {e}"));
    let elapsed = start.elapsed();
    assert!(status.success(), "{command:?} failed ({status})");
    elapsed
}

/// GNU time, which reports a child's peak resident set size.
const GNU_TIME: &str = "/usr/bin/time";

/// Whether peak memory can be measured (GNU time installed: Debian package
/// `time`).
pub fn can_measure_memory() -> bool {
    Command::new(GNU_TIME)
        .args(["-v", "true"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// Runs `program args` under `/usr/bin/time -v`, output discarded; returns
/// the wall time measured here and the peak resident set size in bytes
/// that GNU time reports (`Maximum resident set size (kbytes)`). Starting
/// GNU time adds about a millisecond, negligible against the runs timed
/// this way (the long-record runs take a large fraction of a second and
/// more).
pub fn time_run_with_memory(program: &Path, args: &[OsString]) -> (Duration, u64) {
    let start = Instant::now();
    let output = Command::new(GNU_TIME)
        .arg("-v")
        .arg(program)
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .output()
        .unwrap_or_else(|e| panic!("cannot start {GNU_TIME}: {e}"));
    let elapsed = start.elapsed();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        output.status.success(),
        "{} failed ({}):\n{stderr}",
        program.display(),
        output.status
    );
    let kib: u64 = stderr
        .lines()
        .find_map(|line| {
            line.trim()
                .strip_prefix("Maximum resident set size (kbytes):")
                .map(|v| v.trim().parse().expect("GNU time prints an integer"))
        })
        .expect("GNU time -v reports the maximum resident set size");
    (elapsed, kib * 1024)
}

/// The Python interpreter for the numpy reference script:
/// `FRAMEID_BENCH_PYTHON` if set, else `python3`, if it imports numpy.
pub fn python_with_numpy() -> Result<OsString, String> {
    let python = std::env::var_os("FRAMEID_BENCH_PYTHON").unwrap_or_else(|| "python3".into());
    match Command::new(&python)
        .args(["-c", "import numpy"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
    {
        Ok(s) if s.success() => Ok(python),
        Ok(_) => Err(format!(
            "{} cannot import numpy (set FRAMEID_BENCH_PYTHON to a Python with numpy)",
            python.to_string_lossy()
        )),
        Err(e) => Err(format!(
            "cannot start {}: {e} (set FRAMEID_BENCH_PYTHON to a Python with numpy)",
            python.to_string_lossy()
        )),
    }
}

/// Median of a non-empty list of durations.
pub fn median(times: &[Duration]) -> Duration {
    let mut sorted = times.to_vec();
    sorted.sort();
    let n = sorted.len();
    assert!(n > 0, "median of no runs");
    if n % 2 == 1 {
        sorted[n / 2]
    } else {
        (sorted[n / 2 - 1] + sorted[n / 2]) / 2
    }
}

/// Seconds with three significant-ish decimals for the summary lines.
pub fn ms(d: Duration) -> String {
    format!("{:.1} ms", d.as_secs_f64() * 1e3)
}
