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
    // Before anything else: a build for vector instructions this CPU lacks would stop on
    // an illegal instruction somewhere later (ident::cpu).
    if let Some(message) = ident::cpu::unsupported_message() {
        let _ = writeln!(std::io::stderr(), "error: {message}");
        return ExitCode::from(2);
    }
    let cli = Cli::parse();
    // Outputs are built in hidden sibling directories and renamed into place;
    // an interrupt must not leave one behind.
    let _ = ctrlc::set_handler(|| {
        fsio::on_interrupt_remove();
        let _ = writeln!(std::io::stderr(), "interrupted: nothing was written");
        std::process::exit(130);
    });
    let result = match cli.command.unwrap_or(Command::Study(StudyArgs::default())) {
        Command::Study(args) => to_stdout(|out| commands::study::run(&args, out)),
        Command::Simulate(args) => to_stdout(|out| commands::simulate::run(&args, out)),
        // Its checks, fits and error bars are many short parallel passes in rayon's global
        // pool: they run best from a pool thread (ident::parallel::on_pool; 26.8 -> 25.2 ms
        // for a 10-hit campaign with error bars).
        Command::Identify(args) => {
            ident::parallel::on_pool(|| to_stdout(|out| commands::identify::run(&args, out)))
        }
        Command::Frf(args) => to_stdout(|out| commands::frf::run(&args, out)),
        Command::Sweep(args) => to_stdout(|out| commands::sweep::run(&args, out)),
        Command::Merge(args) => to_stdout(|out| commands::sweep::merge(&args, out)),
        Command::Report(args) => to_stdout(|out| commands::report::run(&args, out)),
        Command::Compare(args) => to_stdout(|out| commands::sweep::compare(&args, out)),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if broken_pipe(&e) => ExitCode::from(141),
        Err(e) if e.downcast_ref::<commands::sweep::Differs>().is_some() => {
            let _ = writeln!(std::io::stderr(), "{e}");
            ExitCode::from(1)
        }
        Err(e) => {
            let _ = writeln!(std::io::stderr(), "error: {e:#}");
            ExitCode::from(2)
        }
    }
}

/// Runs a command writing to the locked standard output (locked on the thread that runs
/// it), and flushes it.
fn to_stdout(
    run: impl FnOnce(&mut std::io::StdoutLock<'static>) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let mut out = std::io::stdout().lock();
    run(&mut out).and_then(|()| out.flush().map_err(anyhow::Error::from))
}

/// Whether the error is a write to a pipe whose reader has gone.
fn broken_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        c.downcast_ref::<std::io::Error>()
            .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
    })
}
