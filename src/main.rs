//! The `frameid` binary: parse the command line, dispatch, map errors to
//! a message on stderr and exit code 2.

use std::process::ExitCode;

use clap::Parser;
use frameid::cli::{Cli, Command, StudyArgs};
use frameid::commands;

fn main() -> ExitCode {
    let cli = Cli::parse();
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    let result = match cli.command.unwrap_or(Command::Study(StudyArgs::default())) {
        Command::Study(args) => commands::study::run(&args, &mut out),
        Command::Simulate(args) => commands::simulate::run(&args, &mut out),
        Command::Identify(args) => commands::identify::run(&args, &mut out),
        Command::Sweep(args) => commands::sweep::run(&args, &mut out),
        Command::Merge(args) => commands::sweep::merge(&args, &mut out),
        Command::Report(args) => commands::report::run(&args, &mut out),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(2)
        }
    }
}
