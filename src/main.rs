//! `fleetdyn`: the command-line shell over the library. The arguments are parsed ([`cli`]),
//! resolved into the library's settings, run ([`commands`]), and the failure's category decides
//! the exit code: 0 success, 1 input, 2 usage, 3 io, 4 model.

mod cli;
mod commands;

use clap::Parser as _;
use std::process::ExitCode;

fn main() -> ExitCode {
    let cli = cli::Cli::parse();
    match cli.resolve().and_then(commands::execute) {
        Ok(()) => ExitCode::SUCCESS,
        Err(f) => {
            eprintln!("error: {}", f.error);
            ExitCode::from(f.category.exit_code())
        }
    }
}
