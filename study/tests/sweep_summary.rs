//! What a sweep's summary holds and how the report reads it: the bound
//! and the efficiencies of every panel, and nothing a reader cannot take
//! back.

use std::path::Path;

use study::sweep::{self, Plan, Summary};
use study::{LoadedScenario, ScoreKey, StudyError};

fn paper_case1() -> String {
    std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios/paper-case1.toml"),
    )
    .unwrap()
}

/// Paper case 1 without its `[damping]` table: no damping at all (the
/// default of a scenario that gives none).
fn undamped() -> LoadedScenario {
    let text = paper_case1().replace(
        "[damping]\nkind = \"rayleigh\"\nalpha = 0.1755     # 1/s\nbeta = 3.2283e-5   # s\n",
        "",
    );
    assert!(!text.contains("[damping]"), "the table was taken out");
    LoadedScenario::from_text(&text, Path::new("undamped.toml")).unwrap()
}

#[test]
fn a_sweep_of_an_undamped_structure_is_refused_naming_the_file_and_field() {
    // Its damping ratios are modal analysis' round-off (~4e-15, of either
    // sign): the xi and damping scores and their bound have nothing to be
    // relative to.
    let err = Plan::new(&undamped(), Some(&[0.01]), Some(1), None).unwrap_err();
    assert!(matches!(err, StudyError::Scenario(_)), "{err:?}");
    let text = err.to_string();
    assert!(
        text.starts_with("undamped.toml: damping: mode 1 of the structure is undamped"),
        "{text}"
    );
}

#[test]
fn a_bound_that_is_not_a_number_stays_out_of_the_summary() {
    // A plan built by hand skips Plan::new's check: its bound at 1 % noise
    // comes out with a null damping bound and negative damping-ratio
    // bounds; the summary must still read back as it was written.
    let plan = Plan {
        scenario: undamped().scenario,
        noise_levels: vec![0.01],
        trials: 1,
        seed: 1,
        axis: None,
    };
    let truth = sweep::plan_truth(&plan).unwrap();
    let rows = sweep::run(&plan, &truth, None, 1, &|| {}).unwrap();
    let summary = sweep::summarize(&plan, &truth, &plan.score_keys(), &rows);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("summary.json");
    study::write_json(&path, &summary).unwrap();
    let back: Summary = study::read_json(&path, "a sweep summary").unwrap();
    assert_eq!(back, summary);
    let level = &summary.levels[0];
    assert!(level.bound.is_none(), "{:?}", level.bound);
    assert!(level.efficiency.is_empty(), "{:?}", level.efficiency);
}

#[test]
fn the_report_tables_hold_every_axis_value() {
    // Two panels (band-limited and ZOH identification of the same
    // campaigns), both routes: the efficiency and route tables must give
    // the ZOH panel's numbers too, each row naming its axis value.
    let text = paper_case1().replace("refine = true", "refine = false\nroute = \"both\"")
        + "\n[sweep]\nnoise = [0.01]\ntrials = 1\n[sweep.axis]\nsetting = \"intersample\"\nvalues = [\"bandlimited\", \"zoh\"]\n";
    let loaded = LoadedScenario::from_text(&text, Path::new("axis.toml")).unwrap();
    let plan = Plan::new(&loaded, None, None, None).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("s");
    let run = sweep::execute(Path::new("axis.toml"), &plan, &out, None, 1, &|| {}).unwrap();
    let summary = run.summary.unwrap();
    let study = study::report::study(&out).unwrap();
    let acc = &study.accuracy;
    for (level, value) in summary.levels.iter().zip(["bandlimited", "zoh"]) {
        let mass = ScoreKey::Matrix(study::score::MatrixEstimate::Mass);
        let expected = level.efficiency[&mass];
        let quantity = format!("mass matrix (intersample = {value})");
        let row = acc
            .efficiency
            .iter()
            .find(|e| e.quantity == quantity && e.estimator == "MKR")
            .unwrap_or_else(|| panic!("no efficiency row '{quantity}': {:?}", acc.efficiency));
        assert_eq!(row.efficiency, expected);
        let route = acc
            .routes
            .iter()
            .find(|r| r.quantity == quantity)
            .unwrap_or_else(|| panic!("no route row '{quantity}'"));
        assert_eq!(route.time.efficiency, expected);
        assert_eq!(route.time.median, level.scores[&mass].median.unwrap());
    }
    // One efficiency row per estimator and quantity of each panel.
    assert_eq!(
        acc.efficiency.len(),
        summary
            .levels
            .iter()
            .map(|l| l.efficiency.len())
            .sum::<usize>()
    );
}
