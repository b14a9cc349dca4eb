//! The default study (`frameid` with no arguments, or `frameid study`): the
//! paper's two cases and the section-4 frame with added mass, each swept
//! over noise levels, then one HTML report.
//!
//! The scenario files are compiled in, so the study runs from any
//! directory; its output goes to `frameid-study/` (git-ignored).

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, anyhow, bail};

use crate::cli::StudyArgs;
use crate::commands::sweep::{default_threads, plan, run_sweep, summary_table};
use crate::scenario::{LoadedScenario, Scenario};

/// The study's scenarios: (file name, contents).
pub const SCENARIOS: [(&str, &str); 3] = [
    (
        "paper-case1.toml",
        include_str!("../../scenarios/paper-case1.toml"),
    ),
    (
        "paper-case2.toml",
        include_str!("../../scenarios/paper-case2.toml"),
    ),
    (
        "frame-added-mass.toml",
        include_str!("../../scenarios/frame-added-mass.toml"),
    ),
];

/// Trials per noise level of the default study (unless `--trials`): 5
/// levels x 3 scenarios x 50 = 750 simulated and identified campaigns.
pub const STUDY_TRIALS: usize = 50;

/// Parses a built-in scenario.
pub fn builtin(name: &str, text: &str) -> Result<LoadedScenario> {
    let path = PathBuf::from(format!("scenarios/{name}"));
    let scenario = Scenario::parse(text, &path)?;
    let model = scenario
        .model()
        .map_err(|e| anyhow!("{}: {e}", path.display()))?;
    scenario
        .check_study_settings()
        .map_err(|e| anyhow!("{}: {e}", path.display()))?;
    Ok(LoadedScenario {
        path,
        scenario,
        model,
    })
}

pub fn run(args: &StudyArgs) -> Result<()> {
    let threads = args.threads.unwrap_or_else(default_threads);
    if threads == 0 {
        bail!("--threads: must be at least 1");
    }
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("{}: cannot create directory", args.out.display()))?;
    let start = Instant::now();
    let mut dirs = Vec::new();
    for (name, text) in SCENARIOS {
        let loaded = builtin(name, text)?;
        let plan = plan(
            &loaded,
            None,
            Some(args.trials.unwrap_or(STUDY_TRIALS)),
            None,
        )?;
        let dir = args.out.join(&loaded.scenario.name);
        let t = Instant::now();
        let summary =
            run_sweep(&loaded, &plan, &dir, None, threads)?.expect("a full sweep has a summary");
        println!(
            "\n{} ({} trials, {:.1} s): median errors per noise level",
            loaded.scenario.name,
            plan.keys().len(),
            t.elapsed().as_secs_f64()
        );
        print!("{}", summary_table(&summary));
        dirs.push(dir);
    }
    let html = args.out.join("report.html");
    let dir_refs: Vec<&Path> = dirs.iter().map(PathBuf::as_path).collect();
    let report = crate::report::build("frameid default study", "frameid study", &dir_refs)?;
    reports::render_to_file(&report, &html).map_err(|e| anyhow!("{e}"))?;
    println!(
        "\nstudy finished in {:.1} s on {threads} thread(s); report: {}",
        start.elapsed().as_secs_f64(),
        html.display()
    );
    Ok(())
}
