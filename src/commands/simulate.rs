//! `frameid simulate SCENARIO --out DIR`: one campaign with known truth.

use std::io::Write;

use anyhow::{Result, bail};
use sim::{Acquisition, AnalyzerSettings};
use study::campaign_dir::write_campaign;
use study::{LoadedScenario, Scenario};

use crate::cli::{AcquisitionArg, RecordFormat, SimulateArgs};

/// Runs the command; says what was written.
pub fn run(args: &SimulateArgs, out: &mut dyn Write) -> Result<()> {
    let loaded = LoadedScenario::load(&args.scenario)?;
    let mut scenario = loaded.scenario.clone();
    apply_overrides(&mut scenario, args)?;
    let simulator = scenario
        .simulator(loaded.model.clone())
        .map_err(|e| match e {
            // The hit count may come from --hits: name the flag.
            sim::SimError::Invalid { field, problem }
                if field == "campaign.hits" && args.hits.is_some() =>
            {
                anyhow::anyhow!("--hits: {problem}")
            }
            other => anyhow::Error::new(other).context(args.scenario.display().to_string()),
        })?;
    let c = &scenario.campaign;
    crate::commands::sweep::check_output_size(
        &args.out.display().to_string(),
        c.hits as u128
            * c.sampling.samples as u128
            * (loaded.model.dofs() as u128 + 1)
            * bytes_per_value(args.format),
        args.force,
    )?;
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

/// Bytes a value takes in a record file: the shortest round-trip decimal
/// and a separator in CSV (up to 24), 20 columns plus a share of the line
/// end in UFF ASCII (4E20.12), 8 in binary UFF.
fn bytes_per_value(format: RecordFormat) -> u128 {
    match format {
        RecordFormat::Csv => 24,
        RecordFormat::Uff => 21,
        RecordFormat::UffBinary => 8,
    }
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
