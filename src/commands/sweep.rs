//! `frameid sweep` and `frameid merge`.

use std::path::Path;
use std::time::Instant;

use anyhow::{Result, anyhow, bail};

use crate::cli::{MergeArgs, SweepArgs};
use crate::experiment::{TrueModel, score_names};
use crate::format::sig;
use crate::scenario::LoadedScenario;
use crate::sweep::{self, Manifest, Plan, Shard, Summary};

/// Builds the plan from the scenario's [sweep] table and the overrides.
pub fn plan(
    loaded: &LoadedScenario,
    noise: Option<&[f64]>,
    trials: Option<usize>,
    seed: Option<u64>,
) -> Result<Plan> {
    let mut scenario = loaded.scenario.clone();
    if let Some(n) = noise {
        scenario.sweep.noise = n.to_vec();
    }
    if let Some(t) = trials {
        scenario.sweep.trials = t;
    }
    if let Some(s) = seed {
        scenario.sweep.seed = s;
    }
    scenario
        .check_study_settings()
        .map_err(|e| anyhow!("{}: {e}", loaded.path.display()))?;
    Ok(Plan {
        noise_levels: scenario.sweep.noise.clone(),
        trials: scenario.sweep.trials,
        seed: scenario.sweep.seed,
        axis: scenario.sweep.axis.clone(),
        scenario,
    })
}

/// Default worker count: every core.
pub fn default_threads() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// Runs a whole sweep (or one shard) and writes its directory.
pub fn run_sweep(
    loaded: &LoadedScenario,
    plan: &Plan,
    out: &Path,
    shard: Option<Shard>,
    threads: usize,
) -> Result<Option<Summary>> {
    let truth = TrueModel::new(loaded.model.clone())
        .map_err(|e| anyhow!("{}: {e}", loaded.path.display()))?;
    let names = score_names(truth.dofs(), plan.scenario.identification.refine);
    let rows = sweep::run(plan, &truth, shard, threads, true)?;
    let manifest = Manifest {
        frameid_version: env!("CARGO_PKG_VERSION").into(),
        scenario_path: loaded.path.display().to_string(),
        plan: plan.clone(),
        shard,
    };
    if shard.is_some() {
        sweep::write_dir(out, &manifest, &names, &rows, None)?;
        return Ok(None);
    }
    let summary = sweep::summarize(plan, &truth, &names, &rows);
    sweep::write_dir(out, &manifest, &names, &rows, Some(&summary))?;
    write_representative(&plan.scenario, &truth, plan.seed, out)?;
    Ok(Some(summary))
}

/// Writes `representative.json` (the report's example campaign). If its
/// identification fails (the sweep counts such failures), the report goes
/// without it: a warning, and no stale file is left.
pub fn write_representative(
    scenario: &crate::scenario::Scenario,
    truth: &TrueModel,
    seed: u64,
    out: &Path,
) -> Result<()> {
    let path = out.join("representative.json");
    match crate::representative::representative(scenario, truth, seed) {
        Ok(rep) => crate::fsutil::write_json(&path, &rep),
        Err(e) => {
            eprintln!("warning: no representative campaign in the report: {e:#}");
            if path.exists() {
                std::fs::remove_file(&path)
                    .map_err(|err| anyhow!("{}: cannot remove: {err}", path.display()))?;
            }
            Ok(())
        }
    }
}

pub fn run(args: &SweepArgs) -> Result<()> {
    let loaded = LoadedScenario::load(&args.scenario)?;
    let plan = plan(&loaded, args.noise.as_deref(), args.trials, args.seed)?;
    let shard: Option<Shard> = args.shard.as_deref().map(str::parse).transpose()?;
    let threads = args.threads.unwrap_or_else(default_threads);
    if threads == 0 {
        bail!("--threads: must be at least 1");
    }
    let start = Instant::now();
    let summary = run_sweep(&loaded, &plan, &args.out, shard, threads)?;
    let elapsed = start.elapsed().as_secs_f64();
    let total = plan.keys().len();
    let done = shard.map_or(total, |s| {
        (0..total).filter(|i| i % s.count == s.index - 1).count()
    });
    println!(
        "{}: {done} trials in {:.1} s on {threads} thread(s) ({:.1} trials/s) -> {}",
        plan.scenario.name,
        elapsed,
        done as f64 / elapsed,
        args.out.display()
    );
    match summary {
        Some(s) => print!("{}", summary_table(&s)),
        None => println!(
            "shard {}/{}: join the shards with `frameid merge`",
            shard.unwrap().index,
            shard.unwrap().count
        ),
    }
    Ok(())
}

pub fn merge(args: &MergeArgs) -> Result<()> {
    let dirs: Vec<&Path> = args.dirs.iter().map(|d| d.as_path()).collect();
    let summary = sweep::merge(&dirs, &args.out)?;
    let truth = TrueModel::new(summary.plan.scenario.model().map_err(|e| anyhow!("{e}"))?)
        .map_err(|e| anyhow!("{e}"))?;
    write_representative(&summary.plan.scenario, &truth, summary.plan.seed, &args.out)?;
    println!(
        "merged {} directories -> {}",
        dirs.len(),
        args.out.display()
    );
    print!("{}", summary_table(&summary));
    Ok(())
}

/// Median errors per noise level: frequencies and damping ratios (worst
/// mode), M, K and the damping estimates (MKR, Rayleigh and, if the sweep
/// refines, maximum likelihood).
pub fn summary_table(s: &Summary) -> String {
    let refined = s.plan.scenario.identification.refine;
    let mut out = String::from(
        "  axis         noise   fail  f err    xi err   M err    K err    R(MKR)   R(Rayl.)",
    );
    out.push_str(if refined {
        "  R(ML)    (medians, worst mode)\n"
    } else {
        "  (medians, worst mode)\n"
    });
    let dofs = s.plan.scenario.model().map_or(0, |m| m.dofs());
    for l in &s.levels {
        let med = |name: &str| l.scores.get(name).and_then(|st| st.median);
        let worst = |prefix: &str| {
            (1..=dofs)
                .filter_map(|j| med(&format!("{prefix}{j}_err")))
                .fold(None, |a: Option<f64>, x| Some(a.map_or(x, |a| a.max(x))))
        };
        let cell = |x: Option<f64>| x.map_or("-".to_string(), |v| format!("{v:.2e}"));
        out.push_str(&format!(
            "  {:<10} {:>6}%  {:>4}  {:>8} {:>8} {:>8} {:>8} {:>8} {:>8}",
            l.axis_value
                .as_ref()
                .map(ToString::to_string)
                .unwrap_or_default(),
            sig(100.0 * l.noise, 3),
            format!("{:.0}%", 100.0 * l.failure_rate),
            cell(worst("f")),
            cell(worst("xi")),
            cell(med("mass_err")),
            cell(med("stiffness_err")),
            cell(med("damping_mkr_err")),
            cell(med("damping_rayleigh_err")),
        ));
        if refined {
            out.push_str(&format!(" {:>8}", cell(med("damping_refined_err"))));
        }
        out.push('\n');
    }
    out
}
