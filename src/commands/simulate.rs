//! `frameid simulate SCENARIO --out DIR`: one campaign with known truth.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use sim::{Acquisition, AnalyzerSettings, Campaign};

use crate::cli::{AcquisitionArg, RecordFormat, SimulateArgs};
use crate::fsutil::write_json;
use crate::records::{self, Channel, Format, RecordFile};
use crate::scenario::{LoadedScenario, Scenario};
use crate::truth::{HitTruth, Truth};

/// Runs the command; prints what was written.
pub fn run(args: &SimulateArgs) -> Result<()> {
    let loaded = LoadedScenario::load(&args.scenario)?;
    let mut scenario = loaded.scenario.clone();
    apply_overrides(&mut scenario, args)?;
    let simulator = scenario
        .simulator(loaded.model.clone())
        .map_err(|e| anyhow::anyhow!("{}: {e}", args.scenario.display()))?;
    let campaign = simulator.simulate(args.seed);
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("{}: cannot create directory", args.out.display()))?;
    remove_stale_hits(&args.out)?;
    let files = write_campaign(&args.out, &campaign, args.format)?;
    let hits = files
        .iter()
        .zip(&campaign.hits)
        .map(|(f, h)| HitTruth {
            file: f
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default(),
            pulses: h.pulses.clone(),
        })
        .collect();
    let truth = Truth::new(&loaded.model, &scenario, args.seed, hits)
        .map_err(|e| anyhow::anyhow!("{}: {e}", args.scenario.display()))?;
    write_json(&args.out.join("truth.json"), &truth)?;
    println!(
        "{}: {} hits of {} samples at {} Hz -> {} (truth.json)",
        scenario.name,
        campaign.hits.len(),
        scenario.campaign.sampling.samples,
        scenario.campaign.sampling.sample_rate_hz,
        args.out.display()
    );
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

/// Deletes `hitNN.csv` / `hitNN.uff` files left by an earlier run, so the
/// directory holds exactly this campaign.
fn remove_stale_hits(dir: &Path) -> Result<()> {
    for entry in std::fs::read_dir(dir)
        .with_context(|| format!("{}: cannot list directory", dir.display()))?
    {
        let path = entry?.path();
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let is_hit = name
            .strip_prefix("hit")
            .and_then(|r| r.split_once('.'))
            .is_some_and(|(num, ext)| {
                !num.is_empty()
                    && num.bytes().all(|b| b.is_ascii_digit())
                    && (ext == "csv" || ext == "uff")
            });
        if is_hit {
            std::fs::remove_file(&path)
                .with_context(|| format!("{}: cannot remove stale record", path.display()))?;
        }
    }
    Ok(())
}

/// The channels of one hit as a record: `force` at the hit floor, then
/// `acc1` ... `accN`, with UFF node = floor and direction +X.
pub fn hit_record(campaign: &Campaign, hit: usize, path: PathBuf, format: Format) -> RecordFile {
    let h = &campaign.hits[hit];
    let mut channels = vec![Channel {
        name: "force".into(),
        unit: Some("N".into()),
        node: Some(campaign.hit_floor as i64),
        direction: Some(1),
        id_line: None,
        values: h.force.clone(),
    }];
    for (i, acc) in h.accelerations.iter().enumerate() {
        channels.push(Channel {
            name: format!("acc{}", i + 1),
            unit: Some("m/s^2".into()),
            node: Some(i as i64 + 1),
            direction: Some(1),
            id_line: None,
            values: acc.clone(),
        });
    }
    RecordFile {
        path,
        format,
        dt_s: campaign.dt_s,
        start_s: 0.0,
        channels,
    }
}

/// Writes every hit; returns the paths in hit order.
pub fn write_campaign(
    dir: &Path,
    campaign: &Campaign,
    format: RecordFormat,
) -> Result<Vec<PathBuf>> {
    let width = campaign.hits.len().to_string().len().max(2);
    let (ext, fmt) = match format {
        RecordFormat::Csv => ("csv", Format::Csv { delimiter: b',' }),
        RecordFormat::Uff => ("uff", Format::Uff58Ascii),
        RecordFormat::UffBinary => ("uff", Format::Uff58Binary),
    };
    let mut paths = Vec::new();
    for i in 0..campaign.hits.len() {
        let path = dir.join(format!("hit{:0width$}.{ext}", i + 1));
        let rec = hit_record(campaign, i, path.clone(), fmt);
        match format {
            RecordFormat::Csv => records::write_csv(&path, &rec)?,
            RecordFormat::Uff => records::write_uff58(&path, &rec, false)?,
            RecordFormat::UffBinary => records::write_uff58(&path, &rec, true)?,
        }
        paths.push(path);
    }
    Ok(paths)
}
