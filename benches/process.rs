//! Whole-process speed: the release binary `frameid identify` with its
//! defaults (error bars on, no refinement) on 10- and 50-hit campaigns of the
//! three-storey frame (scenarios/frame-three-storey.toml, 2048 samples per
//! hit, 1 % noise), written to a temporary directory by `frameid simulate
//! --seed 1`; and the numpy reference script (benches/numpy_reference.py,
//! `--repeat 1`, one identification per process) on the same files when a
//! Python with numpy is found (`FRAMEID_BENCH_PYTHON`, else `python3`).
//!
//! Every run is a new process: start-up, reading the CSV files and writing
//! the tables are included. After the criterion figures the bench prints
//! the medians of all runs it made and the ratios of the speed targets
//! (10-hit frameid against 10-hit numpy, 50-hit against 10-hit frameid).

mod common;

use std::cell::RefCell;
use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

use common::{median, ms, python_with_numpy, simulate, time_run};
use criterion::{Criterion, SamplingMode, criterion_group, criterion_main};

/// Times `make()` once per iteration, recording every run in `runs`.
fn bench_command(
    c: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>,
    name: &str,
    runs: &RefCell<Vec<Duration>>,
    make: impl Fn() -> Command,
) {
    c.bench_function(name, |b| {
        b.iter_custom(|iters| {
            let mut total = Duration::ZERO;
            for _ in 0..iters {
                let t = time_run(&mut make());
                runs.borrow_mut().push(t);
                total += t;
            }
            total
        })
    });
}

fn frameid_identify(files: &[PathBuf]) -> Command {
    let mut command = Command::new(common::frameid());
    command.arg("identify").args(files);
    command
}

fn numpy_reference(python: &OsString, files: &[PathBuf], repeat: u32) -> Command {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/numpy_reference.py");
    let mut command = Command::new(python);
    command
        .arg(script)
        .args(["--repeat", &repeat.to_string()])
        .args(files);
    command
}

fn bench_process(c: &mut Criterion) {
    let dir = tempfile::tempdir().expect("temporary directory");
    let scenario = common::scenario("frame-three-storey.toml");
    let hits10 = simulate(&scenario, &dir.path().join("hits10"), &["--hits", "10"]);
    let hits50 = simulate(&scenario, &dir.path().join("hits50"), &["--hits", "50"]);
    let python = python_with_numpy();

    let runs: [RefCell<Vec<Duration>>; 4] = Default::default();
    let mut group = c.benchmark_group("process");
    group.sample_size(10).sampling_mode(SamplingMode::Flat);
    bench_command(
        &mut group,
        "frameid identify, 10-hit three-storey (defaults, error bars)",
        &runs[0],
        || frameid_identify(&hits10),
    );
    bench_command(
        &mut group,
        "frameid identify, 50-hit three-storey (defaults, error bars)",
        &runs[1],
        || frameid_identify(&hits50),
    );
    match &python {
        Ok(python) => {
            bench_command(
                &mut group,
                "numpy_reference.py, 10-hit three-storey",
                &runs[2],
                || numpy_reference(python, &hits10, 1),
            );
            bench_command(
                &mut group,
                "numpy_reference.py, 50-hit three-storey",
                &runs[3],
                || numpy_reference(python, &hits50, 1),
            );
        }
        Err(why) => println!("process: numpy reference skipped: {why}"),
    }
    group.finish();

    // With a filter that skips a bench its list stays empty.
    let medians: Vec<Option<Duration>> = runs
        .iter()
        .map(|r| {
            let r = r.borrow();
            (!r.is_empty()).then(|| median(&r))
        })
        .collect();
    if medians.iter().all(Option::is_none) {
        return;
    }
    println!("process: medians of every run (warm-up included)");
    for (label, m) in [
        "frameid 10 hits",
        "frameid 50 hits",
        "numpy 10 hits",
        "numpy 50 hits",
    ]
    .iter()
    .zip(&medians)
    {
        if let Some(m) = m {
            println!("  {label:16} {}", ms(*m));
        }
    }
    if let (Some(f10), Some(n10)) = (medians[0], medians[2]) {
        println!(
            "  frameid / numpy, 10 hits: {:.3} (target <= 0.05)",
            f10.as_secs_f64() / n10.as_secs_f64()
        );
    }
    // The script's own timer leaves out the interpreter's start and the
    // numpy import: the ratio against it is the stricter one.
    if let (Ok(python), Some(f10)) = (&python, medians[0]) {
        let output = common::run_ok(&mut numpy_reference(python, &hits10, 5));
        let text = String::from_utf8_lossy(&output.stdout);
        let in_script_ms = text.lines().find_map(|line| {
            let rest = line.split_once("median ")?.1;
            rest.split_once(" ms")?.0.parse::<f64>().ok()
        });
        match in_script_ms {
            Some(n10_ms) => println!(
                "  numpy 10 hits, in-script median of 5 (no start-up, no import): {n10_ms:.1} ms; \
                 frameid / that: {:.3}",
                f10.as_secs_f64() * 1e3 / n10_ms
            ),
            None => println!("  numpy_reference.py printed no timing line"),
        }
    }
    if let (Some(f10), Some(f50)) = (medians[0], medians[1]) {
        println!(
            "  frameid 50 hits / 10 hits: {:.2} (target <= 4)",
            f50.as_secs_f64() / f10.as_secs_f64()
        );
    }
}

criterion_group!(benches, bench_process);
criterion_main!(benches);
