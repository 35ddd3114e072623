//! Command-line interface: one module per subcommand, each turning its arguments into a
//! validated, typed configuration before any work starts.
//!
//! Exit codes: 0 success, 1 the work failed, 2 bad input or usage.

mod input;
mod score;

use clap::{Parser, Subcommand};

pub use input::BadInput;

/// Learn how a person likes to take objects from a robot, and run the study that measures it.
#[derive(Debug, Parser)]
#[command(name = "handover", version, about, long_about = None)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    Score(score::ScoreArgs),
}

/// Runs the chosen subcommand.
pub fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Score(args) => score::run(args),
    }
}

#[cfg(test)]
mod tests {
    use clap::CommandFactory;

    #[test]
    fn cli_definition_is_consistent() {
        super::Cli::command().debug_assert();
    }
}
