//! The default study (`frameid` with no arguments, or `frameid study`): the
//! paper's two cases and the section-4 frame with added mass, each swept
//! over noise levels, then one HTML report.
//!
//! The scenario files are compiled in ([`study::scenario::BUILTIN`]), so the
//! study runs from any directory; its output goes to `frameid-study/`
//! (git-ignored).

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result};
use study::LoadedScenario;
use study::scenario::BUILTIN;
use study::sweep::Plan;

use crate::cli::StudyArgs;
use crate::commands::sweep::{execute, threads};
use crate::output::summary_table;

/// Trials per noise level of the default study (unless `--trials`): 5
/// levels x 3 scenarios x 50 = 750 simulated and identified campaigns.
pub const STUDY_TRIALS: usize = 50;

/// Runs the command.
pub fn run(args: &StudyArgs, out: &mut dyn Write) -> Result<()> {
    let threads = threads(args.threads)?;
    let trials = crate::commands::sweep::trials(args.trials)?.unwrap_or(STUDY_TRIALS);
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("{}: cannot create directory", args.out.display()))?;
    let start = Instant::now();
    let mut dirs = Vec::new();
    for (name, _) in BUILTIN {
        let loaded = LoadedScenario::builtin(name)?;
        let plan = Plan::new(&loaded, None, Some(trials), None)?;
        let dir = args.out.join(&loaded.scenario.name);
        let t = Instant::now();
        let done = execute(&loaded, &plan, &dir, None, threads)?;
        let summary = done.summary.expect("a full sweep has a summary");
        writeln!(
            out,
            "\n{} ({} trials, {:.1} s): median errors per noise level",
            loaded.scenario.name,
            done.trials,
            t.elapsed().as_secs_f64()
        )?;
        write!(out, "{}", summary_table(&summary))?;
        dirs.push(dir);
    }
    let html = args.out.join("report.html");
    let dir_refs: Vec<&Path> = dirs.iter().map(PathBuf::as_path).collect();
    let report = study::report::build("frameid default study", "frameid study", &dir_refs)?;
    reports::render_to_file(&report, &html)?;
    writeln!(
        out,
        "\nstudy finished in {:.1} s on {threads} thread(s); report: {}",
        start.elapsed().as_secs_f64(),
        html.display()
    )?;
    Ok(())
}
