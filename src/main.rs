//! The `handover` command line: parse, dispatch, map errors to exit codes.

mod cli;

use std::process::ExitCode;

use clap::Parser;

fn main() -> ExitCode {
    cli::warn_renamed(&std::env::args_os().collect::<Vec<_>>());
    let args = cli::Cli::parse();
    match cli::run(args) {
        Ok(()) => ExitCode::SUCCESS,
        // A closed standard output (`handover … | head -1`) is not an error.
        Err(err) if cli::is_broken_pipe(&err) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("handover: {}", handover::text::printable_lines(&format!("{err:#}")));
            if err.chain().any(|e| e.is::<cli::BadInput>()) { ExitCode::from(2) } else { ExitCode::from(1) }
        }
    }
}
