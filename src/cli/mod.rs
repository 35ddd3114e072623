//! Command-line interface: one module per subcommand, each turning its arguments into a
//! validated, typed configuration before any work starts.
//!
//! Exit codes: 0 success, 1 the work failed, 2 bad input or usage.

/// `println!` that returns an error instead of panicking when standard output is closed
/// (`handover … | head -1`); `main` then exits quietly.
macro_rules! outln {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        writeln!(std::io::stdout().lock(), $($arg)*)?
    }};
}

/// `print!` likewise.
macro_rules! out {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        write!(std::io::stdout().lock(), $($arg)*)?
    }};
}

mod analyze;
mod by_body;
mod console;
mod dry_run;
mod feasible;
mod front;
mod input;
mod participant;
mod protocol;
mod resume;
mod score;
mod simulate;

use clap::{Parser, Subcommand};

pub use input::BadInput;

/// Whether an error is a write to a closed standard output (a pipe whose reader left).
pub fn is_broken_pipe(err: &anyhow::Error) -> bool {
    err.chain().any(|e| {
        e.downcast_ref::<std::io::Error>().is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
            || e.downcast_ref::<serde_json::Error>()
                .is_some_and(|j| j.io_error_kind() == Some(std::io::ErrorKind::BrokenPipe))
            || e.downcast_ref::<csv::Error>().is_some_and(
                |c| matches!(c.kind(), csv::ErrorKind::Io(io) if io.kind() == std::io::ErrorKind::BrokenPipe),
            )
    })
}

/// Learn how a person likes to take objects from a robot, and run the study that measures it.
#[derive(Debug, Parser)]
#[command(name = "handover", version, about, long_about = None)]
pub struct Cli {
    /// Without a command, the operator console opens on the embedded default protocol.
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Open the operator console and run a study session.
    Run(console::RunArgs),
    /// The learning engine as a JSON tool: score a menu of queries, update a belief.
    Score(score::ScoreArgs),
    /// The feasible arm configurations of a protocol's handover queries.
    Feasible(feasible::FeasibleArgs),
    /// Reproduce the paper's simulation studies (planar 2-DoF, 7-DoF arm, two sets).
    Simulate(simulate::SimulateArgs),
    /// The comfort–accuracy front of the comfort-aware selectors (hybrid β, budgeted ε).
    Front(front::FrontArgs),
    /// Validate a protocol file.
    Protocol(protocol::ProtocolArgs),
    /// Create pseudonymous participants.
    Participant(participant::ParticipantArgs),
    /// Run whole sessions with simulated participants (pilot logs).
    DryRun(dry_run::DryRunArgs),
    /// Continue an interrupted session from its log.
    Resume(resume::ResumeArgs),
    /// Analyse session logs (Fig. 10, Table I), optionally verifying every derived value.
    Analyze(analyze::AnalyzeArgs),
    /// Print a shell completion script on stdout, e.g.
    /// `handover completions bash > ~/.local/share/bash-completion/completions/handover`.
    Completions {
        /// The shell.
        #[arg(value_enum)]
        shell: clap_complete::Shell,
    },
    /// Print the manual page (roff) on stdout, e.g. `handover man > handover.1; man ./handover.1`.
    Man,
}

/// Runs the chosen subcommand.
pub fn run(cli: Cli) -> anyhow::Result<()> {
    let Some(command) = cli.command else {
        return console::run(console::RunArgs::default_for_bare());
    };
    match command {
        Command::Run(args) => console::run(args),
        Command::Score(args) => score::run(args),
        Command::Feasible(args) => feasible::run(args),
        Command::Simulate(args) => simulate::run(args),
        Command::Front(args) => front::run(args),
        Command::Protocol(args) => protocol::run(args),
        Command::Participant(args) => participant::run(args),
        Command::DryRun(args) => dry_run::run(args),
        Command::Resume(args) => resume::run(args),
        Command::Analyze(args) => analyze::run(args),
        Command::Completions { shell } => {
            use clap::CommandFactory;
            let mut out = std::io::stdout().lock();
            clap_complete::generate(shell, &mut Cli::command(), "handover", &mut out);
            Ok(())
        }
        Command::Man => {
            use clap::CommandFactory;
            clap_mangen::Man::new(Cli::command()).render(&mut std::io::stdout().lock())?;
            Ok(())
        }
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
