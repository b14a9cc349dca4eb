//! What frameid writes, and how it fails to: standard output that goes
//! away or fills up, output paths that are links or devices, permissions,
//! outputs that appear whole or not at all, sizes checked before anything
//! is allocated or written, and errors that name the flag or field at
//! fault.

mod common;

use std::os::unix::fs::PermissionsExt;
use std::path::Path;
use std::process::{Command, Stdio};

use common::*;

fn simulate(dir: &Path, extra: &[&str]) {
    let scenario = repo("scenarios/paper-case1.toml");
    let mut args = vec!["simulate", s(&scenario), "--hits", "4", "--out", s(dir)];
    args.extend(extra);
    ok(&args);
}

fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// `frameid identify` of the simulated hits in `dir`, through `sh -c` so
/// that its standard output can be redirected.
fn identify_through_shell(dir: &Path, redirect: &str) -> std::process::Output {
    let files = hit_files(dir, "csv").join(" ");
    Command::new("sh")
        .arg("-c")
        .arg(format!(
            "{} identify {files} --json --no-uncertainty {redirect}",
            env!("CARGO_BIN_EXE_frameid")
        ))
        .output()
        .unwrap()
}

#[test]
fn a_full_disk_is_an_error_and_a_closed_pipe_ends_quietly() {
    let dir = tempfile::tempdir().unwrap();
    simulate(dir.path(), &[]);
    let out = identify_through_shell(dir.path(), "> /dev/full");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("No space left on device"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    // The reader goes away: `| true` exits without reading (before identify
    // has its result), `| head -c 10` after 10 bytes (identify may have
    // written everything into the pipe's buffer by then). The shell prints
    // the status of the pipeline's first command.
    let files = hit_files(dir.path(), "csv").join(" ");
    for (reader, statuses) in [
        ("true", &["141"][..]),
        ("head -c 10 >/dev/null", &["141", "0"][..]),
    ] {
        let out = Command::new("bash")
            .arg("-c")
            .arg(format!(
                "{} identify {files} --json --no-uncertainty | {reader}; echo \"status=${{PIPESTATUS[0]}}\"",
                env!("CARGO_BIN_EXE_frameid")
            ))
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&out.stdout);
        let stderr = String::from_utf8_lossy(&out.stderr);
        // 141 = 128 + SIGPIPE, what a program killed by the signal reports.
        assert!(
            statuses
                .iter()
                .any(|s| stdout.contains(&format!("status={s}"))),
            "{reader}: {stdout} {stderr}"
        );
        assert!(stderr.is_empty(), "{reader}: nothing on stderr: {stderr}");
    }
}

#[test]
fn report_follows_links_and_refuses_devices() {
    let dir = tempfile::tempdir().unwrap();
    let sweep = dir.path().join("sweep");
    ok(&[
        "sweep",
        s(&repo("scenarios/paper-case1.toml")),
        "--noise",
        "0.01",
        "--trials",
        "2",
        "--out",
        s(&sweep),
    ]);
    let real = dir.path().join("real.html");
    std::fs::write(&real, "old").unwrap();
    let link = dir.path().join("report.html");
    std::os::unix::fs::symlink(&real, &link).unwrap();
    ok(&["report", s(&sweep), "--out", s(&link)]);
    assert!(
        std::fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink()
    );
    assert!(std::fs::read_to_string(&real).unwrap().contains("<html"));
    let (code, out, err) = run(&["report", s(&sweep), "--out", "/dev/null"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("/dev/null: is not a regular file"), "{err}");
    assert!(out.is_empty());
}

#[test]
fn outputs_respect_the_umask() {
    let dir = tempfile::tempdir().unwrap();
    let camp = dir.path().join("camp");
    let sweep = dir.path().join("sweep");
    let status = Command::new("sh")
        .arg("-c")
        .arg(format!(
            "umask 027 && {bin} simulate {sc} --hits 3 --out {camp} >/dev/null && {bin} sweep {sc} --noise 0.01 --trials 2 --out {sweep} >/dev/null",
            bin = env!("CARGO_BIN_EXE_frameid"),
            sc = s(&repo("scenarios/paper-case1.toml")),
            camp = s(&camp),
            sweep = s(&sweep),
        ))
        .status()
        .unwrap();
    assert!(status.success());
    let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
    for f in [
        camp.join("truth.json"),
        camp.join("hit01.csv"),
        sweep.join("summary.json"),
        sweep.join("trials.csv"),
        sweep.join("sweep.json"),
    ] {
        assert_eq!(mode(&f), 0o640, "{}", f.display());
    }
    assert_eq!(mode(&camp), 0o750);
    assert_eq!(mode(&sweep), 0o750);
}

#[test]
fn flags_are_named_as_flags_and_nothing_is_left_behind() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let scenario = repo("scenarios/paper-case1.toml");
    for (extra, needle) in [
        (vec!["--trials", "0"], "--trials: must be at least 1"),
        (vec!["--noise", "0.01,nan"], "--noise: level 2"),
        (
            vec!["--noise", "0.01,0.01"],
            "--noise: level 0.01 appears twice",
        ),
        (vec!["--threads", "0"], "--threads: must be at least 1"),
        (
            vec!["--threads", "100000"],
            "--threads: 100000 is more than",
        ),
        (vec!["--shard", "3/2"], "--shard: need 1 <= K <= N"),
    ] {
        let mut args = vec!["sweep", s(&scenario), "--out", s(&out)];
        args.extend(extra.iter().copied());
        let (code, stdout, err) = run(&args);
        assert_eq!(code, 2, "{extra:?}");
        assert!(err.contains(needle), "{extra:?}: {err}");
        assert!(!err.contains("paper-case1.toml"), "{extra:?}: {err}");
        assert!(stdout.is_empty());
    }
    let study = dir.path().join("study");
    let (code, _, err) = run(&["study", "--trials", "0", "--out", s(&study)]);
    assert_eq!(code, 2);
    assert!(err.contains("--trials: must be at least 1"), "{err}");
    assert!(names(dir.path()).is_empty(), "{:?}", names(dir.path()));
}

#[test]
fn sizes_are_checked_before_anything_is_allocated_or_written() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    // 100 000 hits: 4.6 GiB of samples in memory (over the 4 GiB limit) and
    // about 14 GiB of CSV: refused on the flag before anything is simulated.
    let scenario = repo("scenarios/paper-case1.toml");
    let (code, _, err) = run(&[
        "simulate",
        s(&scenario),
        "--hits",
        "100000",
        "--out",
        s(&out),
    ]);
    assert_eq!(code, 2);
    assert!(
        err.contains("--hits: 100000 hits") && err.contains("GiB"),
        "{err}"
    );
    assert!(!out.exists());
    // 20 000 hits fit in memory (0.9 GiB) but would write about 2.8 GiB of
    // CSV: that takes --force.
    let (code, _, err) = run(&[
        "simulate",
        s(&scenario),
        "--hits",
        "20000",
        "--out",
        s(&out),
    ]);
    assert_eq!(code, 2);
    assert!(err.contains("--force"), "{err}");
    assert!(!out.exists());
    // A scenario of 10^12 samples per record.
    let text = std::fs::read_to_string(repo("scenarios/paper-case1.toml"))
        .unwrap()
        .replace("samples = 2048", "samples = 1000000000000");
    let big = dir.path().join("big.toml");
    std::fs::write(&big, text).unwrap();
    let (code, _, err) = run(&["simulate", s(&big), "--out", s(&out)]);
    assert_eq!(code, 2);
    assert!(
        err.contains("big.toml: campaign.sampling.samples:") && err.contains("GiB"),
        "{err}"
    );
    assert!(!out.exists());
    // A billion trials: refused whole, but one shard of a billion runs its
    // one trial without allocating the others.
    let scenario = repo("scenarios/paper-case1.toml");
    let sweep = |extra: &[&str]| {
        let mut args = vec![
            "sweep",
            s(&scenario),
            "--noise",
            "0.01",
            "--trials",
            "1000000000",
            "--out",
            s(&out),
        ];
        args.extend(extra);
        run(&args)
    };
    let (code, _, err) = sweep(&[]);
    assert_eq!(code, 2);
    assert!(
        err.contains("trials.csv would take") && err.contains("--force"),
        "{err}"
    );
    let (code, stdout, err) = sweep(&["--shard", "1000000000/1000000000"]);
    assert_eq!(code, 0, "{err}");
    assert!(stdout.contains("1 trials"), "{stdout}");
}

#[test]
fn outputs_appear_whole_and_replace_only_outputs() {
    let dir = tempfile::tempdir().unwrap();
    let camp = dir.path().join("camp");
    simulate(&camp, &[]);
    assert_eq!(
        names(&camp),
        [
            "hit01.csv",
            "hit02.csv",
            "hit03.csv",
            "hit04.csv",
            "truth.json"
        ]
    );
    // A rerun with fewer hits replaces the campaign whole.
    ok(&[
        "simulate",
        s(&repo("scenarios/paper-case1.toml")),
        "--hits",
        "2",
        "--out",
        s(&camp),
    ]);
    assert_eq!(names(&camp), ["hit01.csv", "hit02.csv", "truth.json"]);
    // A stale temporary directory of a crashed run is cleaned.
    std::fs::create_dir(dir.path().join(".camp.frameid-tmp-crashed")).unwrap();
    simulate(&camp, &[]);
    assert_eq!(names(dir.path()), ["camp"]);
    // A directory that is not a campaign is not touched.
    let mine = dir.path().join("mine");
    std::fs::create_dir(&mine).unwrap();
    std::fs::write(mine.join("thesis.tex"), "keep").unwrap();
    let (code, _, err) = run(&[
        "simulate",
        s(&repo("scenarios/paper-case1.toml")),
        "--out",
        s(&mine),
    ]);
    assert_eq!(code, 2);
    assert!(err.contains("not a previous output"), "{err}");
    assert_eq!(names(&mine), ["thesis.tex"]);
}

#[test]
fn an_interrupted_sweep_leaves_the_previous_output_and_no_temporary_files() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sweep");
    let args = |trials: &str| {
        vec![
            "sweep".to_string(),
            s(&repo("scenarios/paper-case1.toml")).to_string(),
            "--noise".into(),
            "0.01".into(),
            "--trials".into(),
            trials.into(),
            "--threads".into(),
            "1".into(),
            "--out".into(),
            s(&out).to_string(),
        ]
    };
    ok(&args("2").iter().map(String::as_str).collect::<Vec<_>>());
    let before = std::fs::read(out.join("summary.json")).unwrap();
    let mut child = frameid()
        .args(args("100000"))
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Wait until the run has started building its directory.
    let started = std::time::Instant::now();
    while !names(dir.path()).iter().any(|n| n.contains("frameid-tmp")) {
        assert!(started.elapsed().as_secs() < 60, "the sweep never started");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    // SIGINT, as Ctrl-C sends it.
    Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(130));
    assert_eq!(names(dir.path()), ["sweep"]);
    assert_eq!(std::fs::read(out.join("summary.json")).unwrap(), before);
}

#[test]
fn report_refuses_a_directory_that_mixes_runs() {
    let dir = tempfile::tempdir().unwrap();
    let sweep = |name: &str, seed: &str| {
        let out = dir.path().join(name);
        ok(&[
            "sweep",
            s(&repo("scenarios/paper-case1.toml")),
            "--noise",
            "0.01",
            "--trials",
            "2",
            "--seed",
            seed,
            "--out",
            s(&out),
        ]);
        out
    };
    let a = sweep("a", "1");
    let b = sweep("b", "2");
    std::fs::copy(b.join("representative.json"), a.join("representative.json")).unwrap();
    let html = dir.path().join("r.html");
    let (code, _, err) = run(&["report", s(&a), "--out", s(&html)]);
    assert_eq!(code, 2);
    assert!(err.contains("mixes files of different runs"), "{err}");
    std::fs::copy(b.join("sweep.json"), a.join("sweep.json")).unwrap();
    let (code, _, err) = run(&["report", s(&a), "--out", s(&html)]);
    assert_eq!(code, 2);
    assert!(err.contains("mixes files of different runs"), "{err}");
    assert!(!html.exists());
}
