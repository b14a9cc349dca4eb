//! Renders the synthetic three-study report used by the tests, for looking
//! at in a browser, and prints its size and render time.
//!
//! `cargo run -p reports --release --example synthetic_report -- out.html`

#[path = "../tests/common/mod.rs"]
mod common;

use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let path = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "synthetic-report.html".into());
    let report = common::report();
    let start = Instant::now();
    let html = reports::render(&report)?;
    let elapsed = start.elapsed();
    reports::render_to_file(&report, &path)?;
    println!(
        "{} studies, {} bytes, rendered in {:.1} ms, written to {path}",
        report.studies.len(),
        html.len(),
        elapsed.as_secs_f64() * 1e3
    );
    Ok(())
}
