//! A simulated campaign on disk: one record file per hit and `truth.json`.

use std::path::{Path, PathBuf};

use records::{Channel, Format, RecordFile};
use sim::Campaign;

use crate::error::StudyError;
use crate::fsutil::write_json;
use crate::scenario::LoadedScenario;
use crate::truth::{HitTruth, Truth};

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
        lines: None,
    }];
    for (i, acc) in h.accelerations.iter().enumerate() {
        channels.push(Channel {
            name: format!("acc{}", i + 1),
            unit: Some("m/s^2".into()),
            node: Some(i as i64 + 1),
            direction: Some(1),
            id_line: None,
            values: acc.clone(),
            lines: None,
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

/// File extension of a layout.
fn extension(format: Format) -> &'static str {
    match format {
        Format::Csv { .. } => "csv",
        Format::Uff58Ascii | Format::Uff58Binary => "uff",
    }
}

/// Writes every hit as `hitNN.<ext>` in `dir` in the given layout; returns
/// the paths in hit order.
pub fn write_hits(
    dir: &Path,
    campaign: &Campaign,
    format: Format,
) -> Result<Vec<PathBuf>, StudyError> {
    let width = campaign.hits.len().to_string().len().max(2);
    let ext = extension(format);
    let mut paths = Vec::new();
    for i in 0..campaign.hits.len() {
        let path = dir.join(format!("hit{:0width$}.{ext}", i + 1));
        let rec = hit_record(campaign, i, path.clone(), format);
        records::write_record(&path, &rec, format.file_format())?;
        paths.push(path);
    }
    Ok(paths)
}

/// Writes a simulated campaign of `loaded` (its scenario as used, overrides
/// applied, in `scenario`) into `dir`: the hits and `truth.json`. The
/// directory appears whole or not at all (see [`fsio::OutputDir`]); a
/// previous campaign there (a directory with `truth.json`) is replaced, any
/// other non-empty directory is refused.
pub fn write_campaign(
    dir: &Path,
    loaded: &LoadedScenario,
    scenario: &crate::scenario::Scenario,
    seed: u64,
    campaign: &Campaign,
    format: Format,
) -> Result<Vec<PathBuf>, StudyError> {
    let out = fsio::OutputDir::create(dir, "truth.json")?;
    let files = write_hits(out.path(), campaign, format)?;
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
    let truth = Truth::new(&loaded.model, scenario, seed, hits).map_err(|error| {
        StudyError::Simulation {
            context: loaded.path.display().to_string(),
            error,
        }
    })?;
    write_json(&out.path().join("truth.json"), &truth)?;
    let final_dir = out.commit()?;
    Ok(files
        .iter()
        .map(|f| final_dir.join(f.file_name().expect("hit files have names")))
        .collect())
}
