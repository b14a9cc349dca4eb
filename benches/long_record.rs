//! One long record: paper case 1 (scenarios/paper-case1.toml) with one hit
//! of 10^6 samples (4.3 hours at 64 Hz, an 80 MB CSV file), written to a
//! temporary directory by `frameid simulate --seed 1`. Times the release
//! binary on it, a new process per run, `frameid identify FILE` (defaults;
//! one hit has no error bars) and `frameid identify FILE --refine`, and
//! reports the peak resident set size of those runs as GNU time
//! (`/usr/bin/time -v`) measures it. Without GNU time the runs are timed
//! alone and the memory line says it was not measured.
//!
//! Each run takes from a fraction of a second to many seconds, so each
//! bench makes criterion's minimum of 10 samples, one run each.

mod common;

use std::cell::RefCell;
use std::ffi::OsString;
use std::path::Path;
use std::process::Command;
use std::time::Duration;

use common::{can_measure_memory, median, ms, time_run, time_run_with_memory};
use criterion::{Criterion, SamplingMode, criterion_group, criterion_main};

/// Samples in the long record.
const SAMPLES: usize = 1_000_000;

/// paper-case1.toml with one hit of `SAMPLES` samples: the two keys are
/// rewritten in the text so that every other setting stays the bundled one.
fn long_scenario(dir: &Path) -> std::path::PathBuf {
    let text = std::fs::read_to_string(common::scenario("paper-case1.toml"))
        .expect("bundled scenario reads");
    let (mut hits, mut samples) = (0, 0);
    let rewritten: Vec<String> = text
        .lines()
        .map(|line| {
            let key = line.split('=').next().unwrap_or("").trim();
            match key {
                "hits" => {
                    hits += 1;
                    "hits = 1".to_string()
                }
                "samples" => {
                    samples += 1;
                    format!("samples = {SAMPLES}")
                }
                _ => line.to_string(),
            }
        })
        .collect();
    assert_eq!(
        (hits, samples),
        (1, 1),
        "paper-case1.toml has one `hits` and one `samples` key"
    );
    let path = dir.join("paper-case1-long.toml");
    std::fs::write(&path, rewritten.join("\n") + "\n").expect("temporary scenario writes");
    path
}

/// Wall time and peak resident set size (bytes) of every run.
#[derive(Default)]
struct Runs {
    times: Vec<Duration>,
    peak_bytes: Vec<u64>,
}

fn bench_long(c: &mut Criterion) {
    let dir = tempfile::tempdir().expect("temporary directory");
    let scenario = long_scenario(dir.path());
    let files = common::simulate(&scenario, &dir.path().join("long"), &[]);
    assert_eq!(files.len(), 1, "one hit file");
    let file = OsString::from(&files[0]);
    let memory = can_measure_memory();
    if !memory {
        println!(
            "long_record: peak memory not measured: /usr/bin/time (GNU time, Debian package `time`) \
             is missing"
        );
    }

    let cases: [(&str, Vec<OsString>); 2] = [
        (
            "frameid identify, one 10^6-sample record (paper case 1)",
            vec!["identify".into(), file.clone()],
        ),
        (
            "frameid identify --refine, one 10^6-sample record (paper case 1)",
            vec!["identify".into(), file.clone(), "--refine".into()],
        ),
    ];
    let runs: [RefCell<Runs>; 2] = Default::default();
    let mut group = c.benchmark_group("long record");
    group
        .sample_size(10)
        .sampling_mode(SamplingMode::Flat)
        .warm_up_time(Duration::from_millis(1))
        .measurement_time(Duration::from_secs(10));
    let binary = common::frameid();
    for ((name, args), runs) in cases.iter().zip(&runs) {
        group.bench_function(*name, |b| {
            b.iter_custom(|iters| {
                let mut total = Duration::ZERO;
                for _ in 0..iters {
                    let mut runs = runs.borrow_mut();
                    let t = if memory {
                        let (t, peak) = time_run_with_memory(&binary, args);
                        runs.peak_bytes.push(peak);
                        t
                    } else {
                        time_run(Command::new(&binary).args(args))
                    };
                    runs.times.push(t);
                    total += t;
                }
                total
            })
        });
    }
    group.finish();

    // A filter that skips both benches leaves nothing to report.
    if runs.iter().all(|r| r.borrow().times.is_empty()) {
        return;
    }
    println!("long record: every run (warm-up included)");
    for ((name, _), runs) in cases.iter().zip(&runs) {
        let runs = runs.borrow();
        if runs.times.is_empty() {
            continue;
        }
        let peak = runs
            .peak_bytes
            .iter()
            .max()
            .map(|b| format!("{:.1} MiB", *b as f64 / (1024.0 * 1024.0)))
            .unwrap_or_else(|| "not measured".into());
        println!(
            "  {name}: median {} of {} runs, peak resident set {peak}",
            ms(median(&runs.times)),
            runs.times.len()
        );
    }
}

criterion_group!(benches, bench_long);
criterion_main!(benches);
