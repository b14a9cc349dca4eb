#![deny(missing_docs)]
//! The frameid harness: scenarios with known truth, simulated campaigns,
//! Monte Carlo sweeps over noise levels, shards and merge, scores against
//! the truth and the Cramér–Rao bound, and the data of the HTML report.
//!
//! - [`scenario`]: scenario files (TOML) and the built-in ones, through one
//!   loader ([`LoadedScenario`]).
//! - [`experiment`]: one trial (simulate, then identify by the time route
//!   and refine, and/or by the FRF route on the same records) and the
//!   Cramér–Rao bound of a scenario.
//! - [`score`]: the scores of a trial and their typed keys ([`ScoreKey`]).
//! - [`sweep`]: plans, trials in parallel (bit-identical for any thread
//!   count and shard split), `trials.csv`, `summary.json`, `sweep.json`,
//!   shards and merge.
//! - [`representative`]: one campaign identified and compared with the
//!   truth, as the report shows it.
//! - [`campaign_report`]: the page of a campaign without truth (rig
//!   records), as `frameid identify --report` writes it.
//! - [`export`]: identified modes as UFF55 and the model's FRFs as
//!   UFF58, for correlation.
//! - [`frf_analysis`]: identification from measured FRFs, with the checks
//!   of the FRFs (coherence, reciprocity).
//! - [`frfs`]: FRFs and coherence of a screened campaign of records
//!   (`frameid frf`).
//! - [`document`]: the JSON documents of `frameid identify` (time and
//!   FRF routes), the typed outcome the binary renders.
//! - [`decimate`]: decimation of records sampled far above the modes'
//!   band, before identification.
//! - [`report`]: sweep directories into the `reports` crate's data model.
//! - [`campaign_dir`] and [`truth`]: a simulated campaign on disk.
//!
//! # Example
//!
//! A small sweep of the paper's case 1 in memory:
//!
//! ```
//! use study::{LoadedScenario, sweep};
//!
//! let loaded = LoadedScenario::builtin("paper-case1.toml")?;
//! let plan = sweep::Plan {
//!     scenario: loaded.scenario.clone(),
//!     noise_levels: vec![0.01],
//!     trials: 2,
//!     seed: 1,
//!     axis: None,
//! };
//! let truth = sweep::plan_truth(&plan)?;
//! let rows = sweep::run(&plan, &truth, None, 1, &|| {})?;
//! let summary = sweep::summarize(&plan, &truth, &plan.score_keys(), &rows);
//! let mass = summary.levels[0].scores[&study::ScoreKey::Matrix(study::score::MatrixEstimate::Mass)];
//! // 1 % noise on 10 hits: M within a fraction of a percent.
//! assert!(mass.median.unwrap() < 0.01);
//! # Ok::<(), study::StudyError>(())
//! ```

pub mod analysis;
pub mod campaign_dir;
pub mod campaign_report;
pub mod decimate;
pub mod document;
mod error;
pub mod experiment;
pub mod export;
pub mod frf_analysis;
pub mod frfs;
mod fsutil;
pub mod report;
pub mod representative;
pub mod scenario;
pub mod score;
pub mod sweep;
pub mod truth;

pub use error::StudyError;
pub use fsutil::{read_json, write_json};
pub use scenario::{LoadedScenario, Scenario, ScenarioError};
pub use score::ScoreKey;
