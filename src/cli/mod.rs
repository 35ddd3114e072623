//! Command-line interface: one module per subcommand, each turning its arguments into a
//! validated, typed configuration before any work starts.
//!
//! Exit codes: 0 success, 1 the work failed, 2 bad input or usage.

/// `println!` that returns an error instead of panicking when standard output is closed
/// (`handover … | head -1`); `main` then exits quietly. On a terminal, control characters
/// from file content are shown escaped ([`handover::text::printable_lines`]); piped or
/// redirected, the output (a CSV, JSON) is exact.
macro_rules! outln {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let text = format!($($arg)*);
        writeln!(std::io::stdout().lock(), "{}", $crate::cli::for_stdout(&text))?
    }};
}

/// `print!` likewise.
macro_rules! out {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let text = format!($($arg)*);
        write!(std::io::stdout().lock(), "{}", $crate::cli::for_stdout(&text))?
    }};
}

/// `eprintln!` for messages, which are read on a terminal: control characters from file
/// content (an escape sequence in a label, a note, a robot status) are shown escaped, never
/// sent to the terminal.
macro_rules! errln {
    ($($arg:tt)*) => {{
        let text = format!($($arg)*);
        eprintln!("{}", handover::text::printable_lines(&text))
    }};
}

/// `eprint!` likewise (a prompt).
macro_rules! err {
    ($($arg:tt)*) => {{
        let text = format!($($arg)*);
        eprint!("{}", handover::text::printable_lines(&text))
    }};
}

/// Standard output's text as written: escaped on a terminal, exact otherwise.
pub fn for_stdout(text: &str) -> std::borrow::Cow<'_, str> {
    use std::io::IsTerminal;
    static TERMINAL: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    if *TERMINAL.get_or_init(|| std::io::stdout().is_terminal()) {
        handover::text::printable_lines(text)
    } else {
        std::borrow::Cow::Borrowed(text)
    }
}

mod analyze;
mod analyze_measured;
mod analyze_population;
mod analyze_report;
mod by_body;
mod console;
mod dry_run;
mod feasible;
mod figures;
mod follow;
mod front;
mod input;
mod live;
mod observations;
mod participant;
mod plan;
mod progress;
mod protocol;
mod reference;
mod resume;
mod robot;
mod robot_check;
mod score;
mod shards;
mod simulate;
mod status;
mod sweep;
mod vocabulary;

use clap::{Parser, Subcommand};

pub use input::BadInput;
pub use vocabulary::warn_renamed;

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

/// A two-sided Wilcoxon p as the reports print it: to three decimals, or a bound below 0.001.
fn wilcoxon_p(p: f64) -> String {
    if p < 0.001 { "p<0.001".to_string() } else { format!("p={p:.3}") }
}

/// How long a run took and on how many worker threads, as a run's header line ends:
/// "12.3 s on 2 threads".
fn timing(seconds: f64, threads: usize) -> String {
    format!("{seconds:.1} s on {threads} thread{}", if threads == 1 { "" } else { "s" })
}

/// Learn how a person likes to take objects from a robot, and run the study that measures it.
#[derive(Debug, Parser)]
#[command(
    name = "handover",
    version = handover::record::VERSION,
    about,
    long_about = None,
    after_help = "Without a command, handover opens the operator console (as `handover run`) on the embedded default protocol."
)]
pub struct Cli {
    /// Without a command, the operator console opens on the embedded default protocol.
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Open the operator console and run a study session.
    ///
    /// Writes: the session's log LOGS/<id>/<id>_<UTC time>.mcap (owner-only, never
    /// overwritten) and, while it runs, LOGS/<id>/.session.lock; for the participant "new",
    /// their record PARTICIPANTS/<id>.json when the session starts.
    Run(console::RunArgs),
    /// The feasible arm configurations of a protocol's handover queries.
    ///
    /// Writes: a table, JSON or CSV on stdout (docs/outputs.md: feasible.csv); with --plot, one SVG
    /// per query into that folder.
    Feasible(feasible::FeasibleArgs),
    /// Check a protocol file, or make one with another prior or population.
    ///
    /// Writes: check, the problems or a summary on stdout and no file; with, OUT/protocol.json.
    Protocol(protocol::ProtocolArgs),
    /// Create, show and withdraw pseudonymous participants.
    ///
    /// Writes: participant records PARTICIPANTS/<id>.json (new, withdraw); withdraw
    /// --delete-data deletes that participant's logs and record.
    Participant(participant::ParticipantArgs),
    /// Run whole sessions with simulated participants (pilot logs).
    ///
    /// Writes: one pilot log per simulated participant, LOGS/<id>/<id>_<UTC time>.mcap,
    /// stamped at a session's pace; the measures on stdout.
    DryRun(dry_run::DryRunArgs),
    /// Plan a study before recruiting: its power at several sizes, from simulated studies.
    ///
    /// Writes: a table on stdout; with --out DIR, studies.csv, study_objects.csv, power.csv,
    /// objects.csv and power.svg into DIR (docs/outputs.md); with --keep-logs LOGS, the first
    /// simulated study's pilot logs.
    Plan(plan::PlanArgs),
    /// Continue an interrupted session from its log.
    ///
    /// Writes: a new log beside the old one (the old one is kept, never changed) holding every
    /// event of the old one and the rest of the session; a finished session is only read.
    Resume(resume::ResumeArgs),
    /// Follow a session's log from a second terminal: the robot operator's read-only screen.
    ///
    /// Writes: nothing (reads the log as the console writes it).
    Follow(follow::FollowArgs),
    /// Where the study stands: participants by state, pilots, counterbalancing, sessions to
    /// resume and unreadable logs.
    ///
    /// Writes: a table (or JSON) on stdout; no file.
    Status(status::StatusArgs),
    /// Check the lab's ROS 2 setup without moving anything: who is on the other side of each
    /// topic the console uses, with which message type and QoS, and why nothing can match.
    ///
    /// Writes: a report on stdout; no file. Exit status 1 when a topic a session needs has
    /// nothing matching on its other side.
    RobotCheck(robot_check::RobotCheckArgs),
    /// Analyse session logs (Fig. 10, Table I), optionally verifying every derived value.
    ///
    /// Writes: a table (or JSON) on stdout; with --out DIR, the tidy CSVs of docs/outputs.md,
    /// fig10.svg, fig10_predictive.svg, objects.svg, alpha.svg and table1.md into DIR (pilot
    /// sessions into DIR/pilot). Never writes to a log.
    Analyze(analyze::AnalyzeArgs),
    /// Research tools: the paper's simulations, their sweeps and the engine as a JSON tool.
    ///
    /// Writes: see each command.
    #[command(subcommand)]
    Research(Research),
    /// Print a shell completion script on stdout, e.g.
    /// `handover completions bash > ~/.local/share/bash-completion/completions/handover`.
    ///
    /// Writes: the script on stdout; no file.
    Completions {
        /// The shell.
        #[arg(value_enum)]
        shell: clap_complete::Shell,
    },
    /// Print the manual page on stdout: roff (`handover man > handover.1; man ./handover.1`) or
    /// Markdown (docs/reference.md is this output).
    ///
    /// Writes: the page on stdout; no file.
    Man {
        /// The page's format.
        #[arg(long, value_enum, default_value_t = ManFormat::Roff)]
        format: ManFormat,
    },
    /// `research score`, under its name in 0.1.0.
    #[command(hide = true)]
    Score(score::ScoreArgs),
    /// `research simulate`, under its name in 0.1.0.
    #[command(hide = true)]
    Simulate(simulate::SimulateArgs),
    /// `research front`, under its name in 0.1.0.
    #[command(hide = true)]
    Front(front::FrontArgs),
    /// `research observations`, under its name in 0.1.0.
    #[command(hide = true)]
    Observations(observations::ObservationsArgs),
}

/// The research commands (`handover research …`): the paper's simulation studies, two of its
/// footnotes as sweeps, and the engine as a JSON tool.
#[derive(Debug, Subcommand)]
enum Research {
    /// Reproduce the paper's simulation studies (planar 2-DoF, 7-DoF arm, two sets).
    ///
    /// Writes: a table on stdout; with --out DIR, metrics.csv, summary.csv, tests.csv and one
    /// SVG per measure (two-sets: two_sets.csv) into DIR (docs/outputs.md).
    Simulate(simulate::SimulateArgs),
    /// The comfort–accuracy front of the comfort-aware selectors (hybrid β, budgeted ε).
    ///
    /// Writes: a table on stdout; with --out DIR, front.csv and front.svg into DIR.
    Front(front::FrontArgs),
    /// Region, configuration and measured-arm observations side by side, over seeds.
    ///
    /// Writes: a table on stdout; with --out DIR, observations.csv and observations.svg into DIR.
    Observations(observations::ObservationsArgs),
    /// The learning engine as a JSON tool: score a menu of queries, update a belief.
    ///
    /// Writes: the scores (and the updated belief) as JSON on stdout; no file.
    Score(score::ScoreArgs),
}

/// The formats of `handover man`.
#[derive(Debug, Clone, Copy, clap::ValueEnum, PartialEq)]
pub enum ManFormat {
    Roff,
    Markdown,
}

/// Runs the chosen subcommand.
pub fn run(cli: Cli) -> anyhow::Result<()> {
    let Some(command) = cli.command else {
        return console::run(console::RunArgs::default_for_bare());
    };
    match command {
        Command::Run(args) => console::run(args),
        Command::Feasible(args) => feasible::run(args),
        Command::Research(Research::Simulate(args)) | Command::Simulate(args) => simulate::run(args),
        Command::Research(Research::Front(args)) | Command::Front(args) => front::run(args),
        Command::Research(Research::Observations(args)) | Command::Observations(args) => observations::run(args),
        Command::Research(Research::Score(args)) | Command::Score(args) => score::run(args),
        Command::Protocol(args) => protocol::run(args),
        Command::Participant(args) => participant::run(args),
        Command::DryRun(args) => dry_run::run(args),
        Command::Plan(args) => plan::run(args),
        Command::Resume(args) => resume::run(args),
        Command::Follow(args) => follow::run(args),
        Command::Status(args) => status::run(args),
        Command::RobotCheck(args) => robot_check::run(args),
        Command::Analyze(args) => analyze::run(args),
        Command::Completions { shell } => {
            use clap::CommandFactory;
            let mut out = std::io::stdout().lock();
            clap_complete::generate(shell, &mut Cli::command(), "handover", &mut out);
            Ok(())
        }
        Command::Man { format: ManFormat::Roff } => {
            use clap::CommandFactory;
            clap_mangen::Man::new(Cli::command()).render(&mut std::io::stdout().lock())?;
            Ok(())
        }
        Command::Man { format: ManFormat::Markdown } => {
            use clap::CommandFactory;
            use std::io::Write as _;
            write!(std::io::stdout().lock(), "{}", reference::markdown(&Cli::command()))?;
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
