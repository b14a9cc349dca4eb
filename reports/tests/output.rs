//! Writing the file atomically, and the model's JSON round trip.

mod common;

use std::fs;

use reports::ReportError;

fn entries(dir: &std::path::Path) -> Vec<String> {
    let mut v: Vec<String> = fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn render_to_file_writes_the_rendered_document_and_nothing_else() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("report.html");
    let report = common::report();
    reports::render_to_file(&report, &path).unwrap();
    assert_eq!(
        fs::read_to_string(&path).unwrap(),
        reports::render(&report).unwrap()
    );
    assert_eq!(entries(dir.path()), ["report.html"]);
    // Overwriting replaces the file.
    let mut smaller = report.clone();
    smaller.studies.truncate(1);
    reports::render_to_file(&smaller, &path).unwrap();
    assert_eq!(
        fs::read_to_string(&path).unwrap(),
        reports::render(&smaller).unwrap()
    );
    assert_eq!(entries(dir.path()), ["report.html"]);
}

#[test]
fn a_failed_render_leaves_the_old_file_alone() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("report.html");
    fs::write(&path, "previous").unwrap();
    let mut bad = common::report();
    bad.studies[0].accuracy.panels[0].quantities[0].median.pop();
    let err = reports::render_to_file(&bad, &path).unwrap_err();
    assert!(matches!(err, ReportError::Inconsistent { .. }), "{err}");
    assert_eq!(fs::read_to_string(&path).unwrap(), "previous");
    assert_eq!(entries(dir.path()), ["report.html"]);
}

#[test]
fn a_failed_write_reports_the_path_and_leaves_no_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("missing-dir").join("report.html");
    let err = reports::render_to_file(&common::report(), &path).unwrap_err();
    assert!(matches!(err, ReportError::Io(_)), "{err}");
    assert!(
        err.to_string().contains(&path.display().to_string()),
        "{err}"
    );
    assert!(entries(dir.path()).is_empty());
    // A directory in place of the file: refused, nothing written.
    let target = dir.path().join("taken");
    fs::create_dir(&target).unwrap();
    fs::write(target.join("keep"), "x").unwrap();
    assert!(reports::render_to_file(&common::report(), &target).is_err());
    assert_eq!(entries(dir.path()), ["taken"]);
}

#[test]
fn json_round_trip_keeps_nan_and_renders_the_same() {
    let mut report = common::report();
    let q = &mut report.studies[0].accuracy.panels[0].quantities[0];
    q.median[4] = f64::NAN;
    q.p5[4] = f64::NAN;
    q.p95[4] = f64::NAN;
    report.studies[0].representative.as_mut().unwrap().force[10] = f64::NAN;
    let json = serde_json::to_string(&report).unwrap();
    assert!(json.contains("null"), "serde_json writes NaN as null");
    assert!(
        !json.contains("\"scale\""),
        "the added optional field is omitted when unset"
    );
    let back: reports::Report = serde_json::from_str(&json).unwrap();
    assert!(back.studies[0].accuracy.panels[0].quantities[0].median[4].is_nan());
    assert_eq!(
        reports::render(&back).unwrap(),
        reports::render(&report).unwrap()
    );
}

#[test]
fn optional_fields_may_be_left_out_of_json() {
    let json = r#"{"key": "f1_rel", "label": "f1", "unit": "", "group": "frequency",
                  "median": [1e-3, null], "p5": [1e-4, null], "p95": [1e-2, null]}"#;
    let q: reports::Quantity = serde_json::from_str(json).unwrap();
    assert!(q.bound.is_none() && q.scale.is_none());
    assert!(q.median[1].is_nan());
    let json = r#"{"frequency_hz": 2.7, "damping_ratio": 0.005, "shape": [[1, 0], [0.6, null]]}"#;
    let m: reports::ModeShape = serde_json::from_str(json).unwrap();
    assert!(m.truth.is_none() && m.shape[1][1].is_nan());
}
