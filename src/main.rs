//! The `frameid` binary: parse the command line, dispatch, and turn the
//! outcome into an exit status: 0 on success, 2 with a message on stderr
//! for any error (a failed write to standard output included), and the
//! conventional 141 (128 + SIGPIPE), quietly, when the reader of standard
//! output has gone away (`frameid ... | head`). An interrupt (SIGINT,
//! SIGTERM) removes the output being built and exits with 130.

use std::io::Write;
use std::process::ExitCode;

use clap::Parser;
use frameid::cli::{Cli, Command, StudyArgs};
use frameid::commands;

fn main() -> ExitCode {
    let cli = Cli::parse();
    // Outputs are built in hidden sibling directories and renamed into place;
    // an interrupt must not leave one behind.
    let _ = ctrlc::set_handler(|| {
        fsio::on_interrupt_remove();
        let _ = writeln!(std::io::stderr(), "interrupted: nothing was written");
        std::process::exit(130);
    });
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    let result = match cli.command.unwrap_or(Command::Study(StudyArgs::default())) {
        Command::Study(args) => commands::study::run(&args, &mut out),
        Command::Simulate(args) => commands::simulate::run(&args, &mut out),
        Command::Identify(args) => commands::identify::run(&args, &mut out),
        Command::Frf(args) => commands::frf::run(&args, &mut out),
        Command::Sweep(args) => commands::sweep::run(&args, &mut out),
        Command::Merge(args) => commands::sweep::merge(&args, &mut out),
        Command::Report(args) => commands::report::run(&args, &mut out),
    }
    .and_then(|()| out.flush().map_err(anyhow::Error::from));
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if broken_pipe(&e) => ExitCode::from(141),
        Err(e) => {
            let _ = writeln!(std::io::stderr(), "error: {e:#}");
            ExitCode::from(2)
        }
    }
}

/// Whether the error is a write to a pipe whose reader has gone.
fn broken_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        c.downcast_ref::<std::io::Error>()
            .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
    })
}
