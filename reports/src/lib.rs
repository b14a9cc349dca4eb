//! Self-contained HTML reports of frameid studies.
//!
//! [`render`] turns a [`Report`] (see [`model`]) into one HTML file that an
//! engineer opens offline and prints: inline CSS, inline SVG charts drawn
//! with plotters, no script and nothing fetched. Per study it
//! shows the set-up, one representative campaign (force and acceleration
//! records, Hankel singular values, stabilization diagram, mode shapes,
//! FRFs), identified values against the truth with relative errors, and the
//! accuracy against noise from the Monte Carlo sweep.
//!
//! The rendering is deterministic: the same report gives the same bytes.
//! Non-finite values are skipped (and counted in the chart captions); values
//! a log axis cannot show are drawn at its bottom (and counted). Only input
//! whose parts cannot be matched up (e.g. a median vector whose length
//! differs from the number of noise levels) is refused with
//! [`ReportError::Inconsistent`].
//!
//! # Document structure
//! Stable hooks for tests and for anyone post-processing the file:
//! - `article.study#study-<i>` per study (1-based), `data-study` = name;
//!   inside, `section.setup`, `section.representative`,
//!   `section.comparison`, `section.accuracy` with ids
//!   `study-<i>-setup`, `study-<i>-representative`, ...
//! - every chart is a `figure.chart[data-chart]` holding exactly one
//!   `svg.chart[data-chart]` with a `<title>`; `data-chart` is one of
//!   `force`, `acceleration` (`data-floor`), `hankel`, `stabilization`,
//!   `mode-magnitude`, `mode-phase` (`data-mode`), `frf-magnitude`,
//!   `frf-phase` (`data-output`), `quantity` (`data-quantity` = key,
//!   `data-panel`), `damping-comparison`, `failure-rate` (`data-panel`);
//! - inside an SVG: `g.chart-title`, `g.axes` (grid, ticks, tick labels),
//!   `g.axis-label[data-axis=x|y]`, one
//!   `g.series[data-series][data-role=line|markers|band|rule][data-points]`
//!   per layer (markers: one element per point; lines: `polyline`s, broken
//!   at gaps; `data-points` = data points drawn), `g.legend` with one
//!   `g.legend-entry[data-series]` per series when there are several;
//! - series keys: `force`, `acceleration`; `retained`, `discarded`, rule
//!   `order` (Hankel); `new`, `frequency`, `damping`, `stable`, rules
//!   `mode-<k>` and `order` (stabilization); `identified`, `truth` (modes);
//!   `measured`, `identified`, `truth` (FRF); `band`, `median`, `bound`
//!   (quantity); `mkr-…` and `rayleigh-…` versions of those (damping
//!   comparison); `failure-rate`;
//! - tables: `table.setup`, `table.comparison[data-table]` whose error cells
//!   carry `data-rel-error` (full precision, or `none`), `table.failures`
//!   (`data-panel`), `table.efficiency`, `table.routes` (the time and FRF
//!   routes side by side; rows carry `data-noise`).
//!
//! # Example
//!
//! A study with no representative campaign and one accuracy measure over
//! three noise levels:
//!
//! ```
//! use reports::{Accuracy, Panel, Quantity, Report, SetupRow, Study};
//!
//! let quantity = Quantity {
//!     key: "f1_err".into(),
//!     label: "f1 relative error".into(),
//!     unit: String::new(),
//!     group: "frequency".into(),
//!     median: vec![1e-6, 2e-4, 2e-3],
//!     p5: vec![1e-7, 5e-5, 6e-4],
//!     p95: vec![3e-6, 6e-4, 5e-3],
//!     bound: None,
//!     scale: None, // the values span decades: a log axis
//! };
//! let study = Study {
//!     name: "paper-case1".into(),
//!     description: String::new(),
//!     seed: 1,
//!     setup: vec![SetupRow { label: "Sampling".into(), value: "64 Hz, 2048 samples".into() }],
//!     representative: None,
//!     accuracy: Accuracy {
//!         axis_name: None,
//!         panels: vec![Panel {
//!             axis_value: None,
//!             noise_levels: vec![0.0, 0.01, 0.05],
//!             trials: vec![20, 20, 20],
//!             failure_rate: vec![0.0, 0.0, 0.05],
//!             failure_reasons: Vec::new(),
//!             quantities: vec![quantity],
//!         }],
//!         efficiency: Vec::new(),
//!         routes: Vec::new(),
//!     },
//! };
//! let report = Report {
//!     title: "frameid report".into(),
//!     frameid_version: "0.1.0".into(),
//!     command: "frameid report out/sweep".into(),
//!     studies: vec![study],
//! };
//!
//! let html = reports::render(&report)?;
//! assert!(html.starts_with("<!DOCTYPE html>"));
//! assert!(html.contains(r#"<article class="study" id="study-1""#));
//! // The quantity's chart: an inline SVG inside its figure, no script.
//! let chart = html.find(r#"data-quantity="f1_err""#).expect("the f1_err chart");
//! assert!(html[chart..].contains("<svg"));
//! assert!(!html.contains("<script"));
//! // Deterministic: the same report gives the same bytes.
//! assert_eq!(reports::render(&report)?, html);
//!
//! // Medians that do not match the noise levels are refused.
//! let mut broken = report.clone();
//! broken.studies[0].accuracy.panels[0].quantities[0].median.pop();
//! assert!(matches!(reports::render(&broken), Err(reports::ReportError::Inconsistent { .. })));
//! # Ok::<(), reports::ReportError>(())
//! ```

#![deny(missing_docs)]

mod campaign;
mod chart;
mod error;
mod figures;
mod format;
mod html;
pub mod model;
mod svg;
mod validate;

use std::path::Path;

pub use error::ReportError;
pub use model::{
    Accuracy, CampaignReport, ComparisonRow, ComparisonTable, EfficiencyRow, FailureCount, Frf,
    ModeShape, Panel, Quantity, Report, Representative, RouteErrors, RouteRow, Scale, SetupRow,
    Stability, StabilizationPoint, Study, ValueRow, ValueTable,
};

/// Renders the report as one self-contained HTML document.
pub fn render(report: &Report) -> Result<String, ReportError> {
    validate::validate(report)?;
    html::render(report)
}

/// Renders the page of one campaign identified without a known truth (see
/// [`CampaignReport`]): same style and guarantees as [`render`].
pub fn render_campaign(report: &CampaignReport) -> Result<String, ReportError> {
    campaign::render(report)
}

/// Renders the campaign page and writes it to `path` atomically, as
/// [`render_to_file`] does.
pub fn render_campaign_to_file(
    report: &CampaignReport,
    path: impl AsRef<Path>,
) -> Result<(), ReportError> {
    let html = render_campaign(report)?;
    fsio::write_file(path.as_ref(), html.as_bytes()).map_err(ReportError::from)
}

/// Renders the report and writes it to `path` atomically (see
/// [`fsio::write_file`]): a temporary file in the same directory, flushed,
/// then renamed over `path`; a symbolic link is followed and a target that
/// is not a regular file is refused. On any error `path` is left as it was
/// and no temporary file remains.
pub fn render_to_file(report: &Report, path: impl AsRef<Path>) -> Result<(), ReportError> {
    let path = path.as_ref();
    let html = render(report)?;
    fsio::write_file(path, html.as_bytes()).map_err(ReportError::from)
}
