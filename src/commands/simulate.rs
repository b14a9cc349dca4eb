//! `frameid simulate SCENARIO --out DIR`: one campaign with known truth.

use std::io::Write;

use anyhow::{Context, Result, bail};
use sim::{Acquisition, AnalyzerSettings};
use study::campaign_dir::write_campaign;
use study::{LoadedScenario, Scenario};

use crate::cli::{AcquisitionArg, SimulateArgs};

/// Runs the command; says what was written.
pub fn run(args: &SimulateArgs, out: &mut dyn Write) -> Result<()> {
    let loaded = LoadedScenario::load(&args.scenario)?;
    let mut scenario = loaded.scenario.clone();
    apply_overrides(&mut scenario, args)?;
    let simulator = scenario
        .simulator(loaded.model.clone())
        .with_context(|| args.scenario.display().to_string())?;
    let campaign = simulator.simulate(args.seed);
    write_campaign(
        &args.out,
        &loaded,
        &scenario,
        args.seed,
        &campaign,
        args.format.layout(),
    )?;
    writeln!(
        out,
        "{}: {} hits of {} samples at {} Hz -> {} (truth.json)",
        scenario.name,
        campaign.hits.len(),
        scenario.campaign.sampling.samples,
        scenario.campaign.sampling.sample_rate_hz,
        args.out.display()
    )?;
    Ok(())
}

fn apply_overrides(s: &mut Scenario, args: &SimulateArgs) -> Result<()> {
    if let Some(h) = args.hits {
        if h == 0 {
            bail!("--hits: must be at least 1");
        }
        s.campaign.hits = h;
    }
    if let Some(n) = args.noise {
        if !(n.is_finite() && n >= 0.0) {
            bail!("--noise: must be a fraction >= 0, got {n}");
        }
        s.campaign.noise.fraction = n;
    }
    match args.acquisition {
        Some(AcquisitionArg::Held) => s.campaign.acquisition = Acquisition::Held,
        Some(AcquisitionArg::Analyzer) if matches!(s.campaign.acquisition, Acquisition::Held) => {
            s.campaign.acquisition = Acquisition::Analyzer(AnalyzerSettings::default())
        }
        _ => {}
    }
    Ok(())
}
