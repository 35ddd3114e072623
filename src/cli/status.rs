//! `handover status`: where the study stands, on one screen or as JSON.

use std::path::PathBuf;

use anyhow::Result;
use clap::{Args, ValueEnum};
use handover::study_status::{ParticipantState, StudyStatus, study_status};

use super::input::{StudyFolders, bad, load_protocol};

/// Where the study stands: participants (registered, waiting, in progress, completed,
/// dropped out, withdrawn), pilot sessions, the counterbalancing slots and the next
/// participant's order, the sessions not over with the command that continues each, and the
/// logs that cannot be read. Only reads; exit status 1 when a log cannot be read.
#[derive(Debug, Args)]
pub struct StatusArgs {
    #[command(flatten)]
    folders: StudyFolders,
    /// The study's protocol, for the condition orders (default: the embedded one).
    #[arg(long, value_name = "FILE")]
    protocol: Option<PathBuf>,
    /// Output on stdout.
    #[arg(long, value_enum, default_value_t = Format::Table)]
    format: Format,
}

#[derive(Debug, Clone, Copy, ValueEnum, PartialEq)]
enum Format {
    Table,
    Json,
}

pub fn run(args: StatusArgs) -> Result<()> {
    let (_, study) = load_protocol(args.protocol.as_deref())?;
    let dirs = args.folders.resolve();
    // A folder with neither records nor logs is not a study (a mistyped --study-dir, or
    // HANDOVER_STUDY_DIR unset): said, not printed as an empty study.
    if !dirs.participants.exists() && !dirs.logs.exists() {
        return Err(bad(format!(
            "{} is not a study: it has neither {} nor {} (name the study with --study-dir DIR or HANDOVER_STUDY_DIR; \
             `participant new` or a session makes them)",
            dirs.root.display(),
            dirs.participants.display(),
            dirs.logs.display()
        )));
    }
    let status = study_status(&dirs, &study);
    match args.format {
        Format::Json => outln!("{}", serde_json::to_string_pretty(&status)?),
        Format::Table => print_table(&status, &study.protocol.session.program_labels)?,
    }
    if !status.unreadable.is_empty() {
        anyhow::bail!("{} log(s) or log folder(s) cannot be read", status.unreadable.len());
    }
    if !status.unreadable_records.is_empty() {
        anyhow::bail!("{} participant record(s) cannot be read", status.unreadable_records.len());
    }
    let stale = status.outputs.iter().filter(|o| !o.holds_withdrawn.is_empty()).count();
    if stale > 0 {
        anyhow::bail!("{stale} output folder(s) hold the data of participants who withdrew: make them again");
    }
    if !status.unreadable_outputs.is_empty() {
        anyhow::bail!("{} output folder(s) or manifest(s) could not be looked at", status.unreadable_outputs.len());
    }
    Ok(())
}

fn print_table(s: &StudyStatus, labels: &[String]) -> Result<()> {
    outln!("Study: participants {} · logs {}", s.participants_dir.display(), s.logs_dir.display());
    let deleted =
        if s.deleted.is_empty() { String::new() } else { format!(" ({} with data deleted)", s.deleted.len()) };
    outln!("Participants: {}{deleted}", s.summary_line());
    for state in [ParticipantState::InProgress, ParticipantState::Waiting] {
        let ids: Vec<&str> = s.participants.iter().filter(|p| p.state == state).map(|p| p.id.as_str()).collect();
        if !ids.is_empty() {
            outln!("  {}: {}", state.name(), ids.join(", "));
        }
    }
    let p = &s.pilot_sessions;
    outln!(
        "Pilot sessions (dry runs, rehearsals, pilots): {} completed, {} aborted, {} not over",
        p.completed,
        p.aborted,
        p.not_over
    );
    outln!("Counterbalancing (completed sessions, registered participants waiting):");
    for slot in &s.slots {
        let order: Vec<String> = slot.order.iter().zip(labels).map(|(c, l)| format!("{l} = {c}")).collect();
        let next = if slot.slot == s.next_slot { "   ← the next new participant" } else { "" };
        outln!(
            "  slot {} ({}): {} completed, {} waiting{next}",
            slot.slot,
            order.join(", "),
            slot.completed,
            slot.waiting
        );
    }
    if s.open_sessions.is_empty() {
        outln!("Sessions not over: none");
    } else {
        outln!("Sessions not over:");
        for o in &s.open_sessions {
            let how = match (o.live, o.closed) {
                (true, _) => "running now",
                (false, true) => "stopped (quit or signal)",
                (false, false) => "interrupted (crash or kill)",
            };
            let pilot = if o.pilot { " [pilot]" } else { "" };
            outln!(
                "  {}{pilot}: {how}; {} trials, last event {}; {}",
                o.participant,
                o.trials,
                o.last_event,
                o.log.display()
            );
            if !o.live && o.resume.is_empty() {
                outln!("    the participant withdrew: not to be continued");
            } else if !o.live {
                outln!("    continue: {}", o.resume);
            }
        }
    }
    if !s.outputs.is_empty() {
        outln!("Output folders (by their manifest.json):");
        for o in &s.outputs {
            let cut = if o.complete { "" } else { ", cut short" };
            outln!(
                "  {} (handover {}, {}{cut}): {} session(s)",
                o.dir.display(),
                handover::text::printable(&o.command),
                o.written_at,
                o.sessions
            );
            if !o.holds_withdrawn.is_empty() {
                outln!(
                    "    holds the data of {} who withdrew: make it again (or delete it)",
                    o.holds_withdrawn.join(", ")
                );
            }
        }
    }
    for e in &s.unreadable_outputs {
        outln!("Output folders not looked at: {e}");
    }
    if !s.unreadable_records.is_empty() {
        outln!("Participant records that cannot be read (not counted):");
        for u in &s.unreadable_records {
            outln!("  {}", u.error);
        }
    }
    if !s.unreadable.is_empty() {
        outln!("Logs that cannot be read (not counted):");
        for u in &s.unreadable {
            outln!("  {}", u.error);
        }
    }
    Ok(())
}
