//! frameid harness: scenarios, simulated campaigns on disk, identification
//! runs, sweeps and reports. The `frameid` binary is thin glue over this
//! library; the numerics live in the `sim` and `ident` crates.

pub mod cli;
pub mod commands;
pub mod experiment;
pub mod format;
pub mod fsutil;
pub mod quality;
pub mod records;
pub mod report;
pub mod representative;
pub mod scenario;
pub mod sweep;
pub mod truth;
pub mod uncertainty;
