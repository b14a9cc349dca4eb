//! `frameid sweep` and `frameid merge`.

use std::io::{IsTerminal, Write};
use std::path::Path;
use std::time::Instant;

use anyhow::{Result, bail};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use study::LoadedScenario;
use study::sweep::{self, Plan, Shard};

use crate::cli::{CompareArgs, MergeArgs, SweepArgs};
use crate::output::summary_table;

/// Default worker count: every core.
pub fn default_threads() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// Most worker threads: far beyond any machine's cores, below what an
/// operating system refuses to start.
pub const MAX_THREADS: usize = 1024;

/// Largest output written without `--force`, bytes.
pub const MAX_OUTPUT_BYTES: u128 = 1 << 30;

/// Checks `--threads`.
pub fn threads(arg: Option<usize>) -> Result<usize> {
    match arg {
        Some(0) => bail!("--threads: must be at least 1"),
        Some(n) if n > MAX_THREADS => bail!("--threads: {n} is more than {MAX_THREADS}"),
        Some(n) => Ok(n),
        None => Ok(default_threads()),
    }
}

/// Checks `--trials`.
pub fn trials(arg: Option<usize>) -> Result<Option<usize>> {
    match arg {
        Some(0) => bail!("--trials: must be at least 1"),
        t => Ok(t),
    }
}

/// Checks `--noise`: fractions >= 0, each once.
pub fn noise_levels(arg: Option<&[f64]>) -> Result<Option<&[f64]>> {
    let Some(levels) = arg else {
        return Ok(None);
    };
    for (i, &n) in levels.iter().enumerate() {
        if !(n.is_finite() && n >= 0.0) {
            bail!("--noise: level {} must be a fraction >= 0, got {n}", i + 1);
        }
        if levels[..i].contains(&n) {
            bail!("--noise: level {n} appears twice");
        }
    }
    Ok(Some(levels))
}

/// Refuses an output estimated above [`MAX_OUTPUT_BYTES`] unless forced.
pub fn check_output_size(what: &str, bytes: u128, force: bool) -> Result<()> {
    if bytes > MAX_OUTPUT_BYTES && !force {
        bail!(
            "{what} would take about {:.1} GiB (more than {} GiB); pass --force to write it anyway",
            bytes as f64 / (1u64 << 30) as f64,
            MAX_OUTPUT_BYTES >> 30
        );
    }
    Ok(())
}

/// A progress bar for `len` trials on stderr when it is a terminal.
pub fn progress_bar(name: &str, len: usize) -> ProgressBar {
    if !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let b = ProgressBar::with_draw_target(Some(len as u64), ProgressDrawTarget::stderr());
    b.set_style(
        ProgressStyle::with_template("{prefix} [{bar:30}] {pos}/{len} trials, {eta} left")
            .expect("valid template")
            .progress_chars("=> "),
    );
    b.set_prefix(name.to_string());
    b
}

/// Runs a sweep (or shard) with a progress bar; prints warnings on stderr.
pub fn execute(
    loaded: &LoadedScenario,
    plan: &Plan,
    out: &Path,
    shard: Option<Shard>,
    threads: usize,
) -> Result<sweep::Execution> {
    let bar = progress_bar(&plan.scenario.name, plan.shard_keys(shard).len());
    let done = sweep::execute(&loaded.path, plan, out, shard, threads, &|| bar.inc(1))?;
    bar.finish_and_clear();
    for w in &done.warnings {
        crate::warn(w);
    }
    Ok(done)
}

/// Runs the command.
pub fn run(args: &SweepArgs, out: &mut dyn Write) -> Result<()> {
    // Flags first: an error names the flag, not the scenario file.
    let noise = noise_levels(args.noise.as_deref())?;
    let trials = trials(args.trials)?;
    let shard: Option<Shard> = args
        .shard
        .as_deref()
        .map(|s| s.parse().map_err(|e| anyhow::anyhow!("--shard: {e}")))
        .transpose()?;
    let threads = threads(args.threads)?;
    let loaded = LoadedScenario::load(&args.scenario)?;
    let mut plan = Plan::new(&loaded, noise, trials, args.seed)?;
    if let Some(route) = args.route {
        plan = plan.with_route(route)?;
    }
    check_output_size(
        &format!("{}/trials.csv", args.out.display()),
        plan.output_bytes(shard),
        args.force,
    )?;
    let start = Instant::now();
    let done = execute(&loaded, &plan, &args.out, shard, threads)?;
    let elapsed = start.elapsed().as_secs_f64();
    writeln!(
        out,
        "{}: {} trials in {:.1} s on {threads} thread(s) ({:.1} trials/s) -> {}",
        plan.scenario.name,
        done.trials,
        elapsed,
        done.trials as f64 / elapsed,
        args.out.display()
    )?;
    match (&done.summary, shard) {
        (Some(s), _) => write!(out, "{}", summary_table(s))?,
        (None, Some(shard)) => writeln!(
            out,
            "shard {}/{}: join the shards with `frameid merge`",
            shard.index, shard.count
        )?,
        (None, None) => {}
    }
    Ok(())
}

/// Runs `frameid merge`.
pub fn merge(args: &MergeArgs, out: &mut dyn Write) -> Result<()> {
    let dirs: Vec<&Path> = args.dirs.iter().map(|d| d.as_path()).collect();
    let merged = sweep::merge(&dirs, &args.out)?;
    for w in &merged.warnings {
        crate::warn(w);
    }
    writeln!(
        out,
        "merged {} directories -> {}",
        dirs.len(),
        args.out.display()
    )?;
    write!(out, "{}", summary_table(&merged.summary))?;
    Ok(())
}

/// The sweeps compared differ beyond the threshold (exit code 1, like `diff`).
#[derive(Debug)]
pub struct Differs {
    /// Medians and efficiencies above the threshold.
    pub changed: usize,
    /// The threshold.
    pub threshold: f64,
}

impl std::fmt::Display for Differs {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} median(s) or efficienc(ies) differ by more than {} Monte Carlo standard errors",
            self.changed, self.threshold
        )
    }
}

impl std::error::Error for Differs {}

/// Runs `frameid compare`: the comparison on standard output, then an error
/// ([`Differs`]) if anything differs beyond the threshold.
pub fn compare(args: &CompareArgs, out: &mut dyn Write) -> Result<()> {
    use study::sweep::compare::{Difference, Statistic};
    let c = study::sweep::compare::compare_dirs(
        &args.first,
        &args.second,
        args.threshold,
        &args.ignore,
    )?;
    if args.json {
        serde_json::to_writer_pretty(&mut *out, &c)?;
        writeln!(out)?;
    } else {
        let line = |d: &Difference| {
            let what = match d.statistic {
                Statistic::Median => "median",
                Statistic::Efficiency => "efficiency",
            };
            let axis = if d.axis_value.is_empty() {
                String::new()
            } else {
                format!(", axis {}", d.axis_value)
            };
            format!(
                "{what} of {} at noise {}{axis}: {:.4e} -> {:.4e} ({:.2} standard errors of {:.2e})",
                d.score, d.noise, d.first, d.second, d.z, d.standard_error
            )
        };
        writeln!(
            out,
            "{} cells, {} medians and efficiencies compared, {} without a Monte Carlo error (compared exactly){}",
            c.cells,
            c.compared,
            c.without_error,
            if c.ignored.is_empty() {
                String::new()
            } else {
                format!("; left out: {}", c.ignored.join(", "))
            }
        )?;
        if let Some(d) = &c.largest {
            writeln!(out, "largest difference: {}", line(d))?;
        }
        if c.agrees() {
            writeln!(
                out,
                "agree: every difference within {} standard errors",
                c.threshold
            )?;
        }
        for d in &c.changed {
            writeln!(out, "changed: {}", line(d))?;
        }
    }
    if c.agrees() {
        Ok(())
    } else {
        Err(Differs {
            changed: c.changed.len(),
            threshold: c.threshold,
        }
        .into())
    }
}
