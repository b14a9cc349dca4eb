//! The `frameid` binary: parse the command line, dispatch, map errors to
//! a message on stderr and exit code 2.

use std::process::ExitCode;

use clap::Parser;
use frameid::cli::{Cli, Command, StudyArgs};
use frameid::commands;

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command.unwrap_or(Command::Study(StudyArgs::default())) {
        Command::Study(args) => commands::study::run(&args),
        Command::Simulate(args) => commands::simulate::run(&args),
        Command::Identify(args) => commands::identify::run(&args),
        Command::Sweep(args) => commands::sweep::run(&args),
        Command::Merge(args) => commands::sweep::merge(&args),
        Command::Report(args) => commands::report::run(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(2)
        }
    }
}
