//! The `frameid` command line: clap arguments ([`cli`]), one module per
//! subcommand ([`commands`]) that turns them into library calls, and the
//! rendering of outcomes as text or JSON ([`output`]). The work is done by
//! the libraries beside it: `records` (files, channel selection, quality
//! checks), `ident` (identification), `sim` (simulation), `study`
//! (scenarios, sweeps, scoring) and `reports` (HTML).

pub mod cli;
pub mod commands;
pub mod output;

/// Prints a warning on stderr; a closed stderr is not an error worth
/// failing for (the result is on stdout or in files).
pub fn warn(message: &str) {
    use std::io::Write;
    let _ = writeln!(std::io::stderr(), "warning: {message}");
}
