//! `frameid report DIR... --out FILE.html`.

use std::path::Path;

use anyhow::{Result, anyhow};

use crate::cli::ReportArgs;

pub fn run(args: &ReportArgs) -> Result<()> {
    let dirs: Vec<&Path> = args.dirs.iter().map(|d| d.as_path()).collect();
    let command = std::env::args().collect::<Vec<_>>().join(" ");
    let report = crate::report::build(&args.title, &command, &dirs)?;
    reports::render_to_file(&report, &args.out).map_err(|e| anyhow!("{e}"))?;
    let size = std::fs::metadata(&args.out).map(|m| m.len()).unwrap_or(0);
    println!("report: {} ({} kB)", args.out.display(), size / 1024);
    Ok(())
}
