//! Campaigns, channel selection across formats, and atomic writing.

use std::path::{Path, PathBuf};

use records::{
    CampaignMismatch, Channel, ChannelSpec, Format, IoOp, ReadOptions, RecordError, RecordFile,
    Uff58Encoding, check_campaign, read_campaign, read_record, read_records, write_csv,
    write_uff58,
};

fn record(n: usize, dt: f64) -> RecordFile {
    RecordFile {
        path: "mem".into(),
        format: Format::Csv { delimiter: b',' },
        dt_s: dt,
        start_s: 0.0,
        channels: ["force", "acc1", "acc2"]
            .iter()
            .enumerate()
            .map(|(k, name)| Channel {
                name: name.to_string(),
                unit: None,
                node: Some(k as i64),
                direction: Some(1),
                id_line: None,
                values: (0..n).map(|i| (i * (k + 1)) as f64 * 0.5).collect(),
                lines: None,
            })
            .collect(),
    }
}

fn write(dir: &Path, name: &str, rec: &RecordFile) -> PathBuf {
    let p = dir.join(name);
    if name.ends_with(".csv") {
        write_csv(&p, rec).unwrap();
    } else {
        write_uff58(
            &p,
            rec,
            if name.ends_with(".bin.uff") {
                Uff58Encoding::Binary
            } else {
                Uff58Encoding::Ascii
            },
        )
        .unwrap();
    }
    p
}

#[test]
fn campaign_of_matching_records() {
    let dir = tempfile::tempdir().unwrap();
    let paths = [
        write(dir.path(), "hit1.csv", &record(100, 1e-3)),
        write(dir.path(), "hit2.uff", &record(100, 1e-3)),
        write(dir.path(), "hit3.bin.uff", &record(100, 1e-3)),
    ];
    let recs = read_campaign(&paths, &ReadOptions::default()).unwrap();
    assert_eq!(recs.len(), 3);
    assert_eq!(recs[1].format, Format::Uff58Ascii);
    assert_eq!(recs[2].format, Format::Uff58Binary);
}

#[test]
fn records_are_read_in_order_and_the_first_failing_file_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let mut paths: Vec<PathBuf> = (0..12)
        .map(|k| write(dir.path(), &format!("hit{k:02}.csv"), &record(50 + k, 1e-3)))
        .collect();
    let opts = ReadOptions::default();
    let recs = read_records(&paths, &opts).unwrap();
    // Read in parallel, returned in the order given.
    let lens: Vec<usize> = recs.iter().map(|r| r.len()).collect();
    assert_eq!(lens, (50..62).collect::<Vec<_>>());
    assert!(recs.iter().zip(&paths).all(|(r, p)| &r.path == p));
    // Two missing files: the error names the first in the list, whatever
    // the threads finish first, as a sequential read would.
    paths[9] = dir.path().join("missing-b.csv");
    paths[4] = dir.path().join("missing-a.csv");
    for threads in [1, 4] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let e = pool.install(|| read_records(&paths, &opts)).unwrap_err();
        let sequential = paths
            .iter()
            .map(|p| read_record(p, &opts))
            .collect::<Result<Vec<_>, _>>()
            .unwrap_err();
        assert_eq!(e.to_string(), sequential.to_string());
        assert!(e.to_string().contains("missing-a.csv"), "{e}");
    }
}

#[test]
fn campaign_of_different_lengths_is_read() {
    let dir = tempfile::tempdir().unwrap();
    let a = write(dir.path(), "hit1.csv", &record(100, 1e-3));
    let b = write(dir.path(), "hit2.csv", &record(120, 1e-3));
    let c = write(dir.path(), "hit3.uff", &record(99, 1e-3));
    let recs = read_campaign(&[a, b, c], &ReadOptions::default()).unwrap();
    let lens: Vec<usize> = recs.iter().map(|r| r.len()).collect();
    assert_eq!(lens, [100, 120, 99]);
}

#[test]
fn campaign_sampling_mismatch_names_both_files() {
    let dir = tempfile::tempdir().unwrap();
    let a = write(dir.path(), "hit1.csv", &record(100, 1.0 / 2048.0));
    let b = write(dir.path(), "hit2.bin.uff", &record(100, 1.0 / 2000.0));
    let e = read_campaign(&[&a, &b], &ReadOptions::default()).unwrap_err();
    let msg = e.to_string();
    assert!(
        matches!(
            e,
            RecordError::Campaign {
                mismatch: CampaignMismatch::SamplingInterval { .. },
                ..
            }
        ),
        "{msg}"
    );
    assert!(
        msg.starts_with("campaign records differ in sampling: ")
            && msg.contains(&format!("{} has dt = 0.0005 s (2000 Hz)", b.display()))
            && msg.contains(&format!(
                "but {} has dt = 0.00048828125 s (2048 Hz)",
                a.display()
            )),
        "{msg}"
    );
}

#[test]
fn campaign_tolerates_uff_six_digit_interval() {
    // pyuff stored 1/2048 s as 4.88281e-04; a CSV at 2048 Hz is the same
    // sampling.
    let dir = tempfile::tempdir().unwrap();
    let csv = write(dir.path(), "hit1.csv", &record(300, 1.0 / 2048.0));
    let uff = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/pyuff_ascii_even.uff");
    let recs = read_campaign(&[csv, uff], &ReadOptions::default()).unwrap();
    assert_ne!(recs[0].dt_s, recs[1].dt_s);
}

#[test]
fn campaign_errors() {
    let none: [&Path; 0] = [];
    assert!(matches!(
        read_campaign(&none, &ReadOptions::default()),
        Err(RecordError::EmptyCampaign)
    ));
    assert!(matches!(
        check_campaign(&[]),
        Err(RecordError::EmptyCampaign)
    ));
    let dir = tempfile::tempdir().unwrap();
    let a = write(dir.path(), "hit1.csv", &record(10, 1e-3));
    let missing = dir.path().join("hit2.csv");
    let e = read_campaign(&[&a, &missing], &ReadOptions::default()).unwrap_err();
    assert!(matches!(e, RecordError::Io { op: IoOp::Read, .. }));
    assert!(
        e.to_string()
            .starts_with(&format!("{}: cannot read the file: ", missing.display())),
        "{e}"
    );
}

#[test]
fn selecting_channels_of_an_analyzer_file() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/pyuff_binary_even.uff");
    let r = read_record(&path, &ReadOptions::default()).unwrap();
    let get = |s: &str| {
        r.channel(&s.parse::<ChannelSpec>().unwrap())
            .map(|c| c.name.clone())
    };
    assert_eq!(get("id:hammer").unwrap(), "Hammer floor 3");
    assert_eq!(get("id:Floor 1 ACC").unwrap(), "Floor 1 acc");
    assert_eq!(get("2:-X").unwrap(), "Floor 2 acc");
    assert_eq!(get("node3:+x").unwrap(), "Hammer floor 3");
    assert_eq!(get("#2").unwrap(), "Floor 1 acc");
    assert_eq!(get("floor 2 ACC").unwrap(), "Floor 2 acc");
    let e = get("id:floor").unwrap_err();
    assert!(matches!(e, RecordError::AmbiguousChannel { .. }));
    assert!(e.to_string().contains("#1 Hammer floor 3 [N] (node 3 +X), #2 Floor 1 acc [m/s^2] (node 1 +X), #3 Floor 2 acc [m/s^2] (node 2 -X)"), "{e}");
    let e = get("4:+X").unwrap_err();
    assert_eq!(
        e.to_string(),
        format!(
            "{}: no channel matches '4:+X'; available channels: #1 Hammer floor 3 [N] (node 3 +X), \
             #2 Floor 1 acc [m/s^2] (node 1 +X), #3 Floor 2 acc [m/s^2] (node 2 -X)",
            path.display()
        )
    );
}

#[test]
fn failed_writes_leave_no_trace() {
    let dir = tempfile::tempdir().unwrap();
    // Directory that does not exist.
    let p = dir.path().join("missing/out.csv");
    let e = write_csv(&p, &record(10, 1e-3)).unwrap_err();
    assert!(matches!(e, RecordError::Output(_)), "{e}");
    assert!(
        e.to_string()
            .contains("cannot create a temporary file next to it")
    );
    // Target is a directory: refused before anything is written.
    let target = dir.path().join("taken");
    std::fs::create_dir(&target).unwrap();
    std::fs::write(target.join("keep"), "x").unwrap();
    let e = write_uff58(&target, &record(10, 1e-3), Uff58Encoding::Binary).unwrap_err();
    assert!(matches!(e, RecordError::Output(_)), "{e}");
    assert!(e.to_string().contains("is a directory"), "{e}");
    let names: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, ["taken"]);
    // A refused record does not touch an existing file.
    let p = dir.path().join("hit.csv");
    write_csv(&p, &record(10, 1e-3)).unwrap();
    let before = std::fs::read(&p).unwrap();
    let mut bad = record(10, 1e-3);
    bad.channels[1].values[4] = f64::NAN;
    assert!(write_csv(&p, &bad).is_err());
    assert!(write_uff58(&p, &bad, Uff58Encoding::Ascii).is_err());
    assert_eq!(std::fs::read(&p).unwrap(), before);
    // Overwriting works and leaves only the target.
    write_uff58(&p, &record(10, 1e-3), Uff58Encoding::Ascii).unwrap();
    assert_eq!(
        read_record(&p, &ReadOptions::default()).unwrap().format,
        Format::Uff58Ascii
    );
    let mut names: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    names.sort();
    assert_eq!(names, ["hit.csv", "taken"]);
}

#[cfg(unix)]
#[test]
fn written_files_are_not_private() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "hit.csv", &record(10, 1e-3));
    let mode = std::fs::metadata(&p).unwrap().permissions().mode() & 0o777;
    // 0666 minus the umask, as for any ordinarily created file (a
    // temporary file alone would be 0600).
    let probe = dir.path().join("probe");
    std::fs::write(&probe, "").unwrap();
    let ordinary = std::fs::metadata(&probe).unwrap().permissions().mode() & 0o777;
    assert_eq!(mode, ordinary);
}

#[test]
fn names_with_parentheses_match_whole() {
    let mut rec = record(4, 1e-3);
    rec.channels[1].name = "Acc (roof)".into();
    rec.channels[2].name = "Acc".into();
    let get = |s: &str| {
        rec.channel(&s.parse::<ChannelSpec>().unwrap())
            .map(|c| c.name.clone())
    };
    assert_eq!(get("acc (ROOF)").unwrap(), "Acc (roof)");
    assert_eq!(get("acc [m/s^2]").unwrap(), "Acc");
    assert_eq!(get("Acc").unwrap(), "Acc");
}

/// Declared units are converted to N and m/s^2, each file by its own; units
/// that are no force or acceleration are refused naming file and channel.
/// (Read as SI, `acc1 [g]` scaled M by 9.8 and `force [kN]` by 1/1000 with
/// nothing said.)
#[test]
fn selection_converts_declared_units_to_si_and_refuses_others() {
    let parse = |name: &str, header: &str| {
        let text = format!("time,{header}\n0,2,3,4\n0.5,-1,0.25,8\n");
        records::parse_csv(text.as_bytes(), Path::new(name), &ReadOptions::default()).unwrap()
    };
    let force = [ChannelSpec::Name("force".into())];
    let si = parse("si.csv", "force [N],acc1 [m/s^2],acc2");
    let mixed = parse("mixed.csv", "force [kN],acc1 [g],acc2 [mm/s^2]");
    let c = records::select(&[si, mixed], &force, None).unwrap();
    // SI and unit-less channels bit for bit.
    assert_eq!(
        c.records[0]
            .inputs
            .row(0)
            .iter()
            .copied()
            .collect::<Vec<_>>(),
        [2.0, -1.0]
    );
    assert_eq!(
        c.records[0]
            .outputs
            .row(0)
            .iter()
            .copied()
            .collect::<Vec<_>>(),
        [3.0, 0.25]
    );
    assert_eq!(
        c.records[0]
            .outputs
            .row(1)
            .iter()
            .copied()
            .collect::<Vec<_>>(),
        [4.0, 8.0]
    );
    // Each value times its unit's SI value (one rounding).
    assert_eq!(
        c.records[1]
            .inputs
            .row(0)
            .iter()
            .copied()
            .collect::<Vec<_>>(),
        [2e3, -1e3]
    );
    assert_eq!(
        c.records[1]
            .outputs
            .row(0)
            .iter()
            .copied()
            .collect::<Vec<_>>(),
        [3.0 * 9.806_65, 0.25 * 9.806_65]
    );
    assert_eq!(
        c.records[1]
            .outputs
            .row(1)
            .iter()
            .copied()
            .collect::<Vec<_>>(),
        [4.0 * 1e-3, 8.0 * 1e-3]
    );
    for (header, needle) in [
        (
            "force [V],acc1,acc2",
            "bad.csv: channel #1 force [V] is in 'V', not a force unit; inputs must be forces",
        ),
        (
            "force,acc1 [mm],acc2",
            "bad.csv: channel #2 acc1 [mm] is in 'mm', a displacement unit; outputs must be accelerations",
        ),
        (
            "force,acc1,acc2 [m/s]",
            "bad.csv: channel #3 acc2 [m/s] is in 'm/s', a velocity unit",
        ),
        (
            "force,acc1,acc2 [mV]",
            "bad.csv: channel #3 acc2 [mV] is in 'mV', not an acceleration unit",
        ),
    ] {
        let good = parse("good.csv", "force,acc1,acc2");
        let e = records::select(&[good, parse("bad.csv", header)], &force, None).unwrap_err();
        assert!(matches!(e, RecordError::ChannelUnit { .. }), "{e}");
        assert!(e.to_string().starts_with(needle), "{e}");
    }
}
