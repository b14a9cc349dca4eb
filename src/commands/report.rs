//! `frameid report DIR... --out FILE.html`.

use std::io::Write;
use std::path::Path;

use anyhow::Result;

use crate::cli::ReportArgs;

/// Runs the command.
pub fn run(args: &ReportArgs, out: &mut dyn Write) -> Result<()> {
    let dirs: Vec<&Path> = args.dirs.iter().map(|d| d.as_path()).collect();
    let command = std::env::args().collect::<Vec<_>>().join(" ");
    let report = study::report::build(&args.title, &command, &dirs)?;
    reports::render_to_file(&report, &args.out)?;
    let size = std::fs::metadata(&args.out).map(|m| m.len()).unwrap_or(0);
    writeln!(out, "report: {} ({} kB)", args.out.display(), size / 1024)?;
    Ok(())
}
