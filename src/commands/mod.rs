//! One module per subcommand. Each takes its parsed arguments and returns
//! `anyhow::Result`; errors carry the file, line or field and what is wrong.

pub mod frf;
pub mod identify;
pub mod report;
pub mod simulate;
pub mod study;
pub mod sweep;
