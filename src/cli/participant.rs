//! `handover participant new`: a pseudonymous participant with a counterbalancing slot.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::{Args, Subcommand};
use handover::counterbalance::completed_per_slot;
use handover::participant::{ParticipantRecord, new_id, validate_id};
use handover::session::condition_order;
use handover::study_dir::{ParticipantLock, StudyDirs};

use super::input::{HandArg, bad, body_height as checked_height, load_protocol};
use handover::protocol::{Body, for_body};

/// Manage pseudonymous participants (no names are ever stored).
#[derive(Debug, Args)]
pub struct ParticipantArgs {
    #[command(subcommand)]
    command: ParticipantCommand,
}

#[derive(Debug, Subcommand)]
enum ParticipantCommand {
    /// Create a random, uninformative id and participants/<id>.json with its counterbalancing
    /// slot: the order (AB or BA) with the fewest completed real sessions in the logs.
    ///
    /// Writes: PARTICIPANTS/<id>.json (owner-only); the id on stdout.
    New {
        /// Protocol (default: the embedded protocols/bike-handover.json).
        #[arg(long, value_name = "FILE")]
        protocol: Option<PathBuf>,
        #[command(flatten)]
        folders: Folders,
        /// Body height in metres (for the arm model).
        #[arg(long, value_name = "M")]
        body_height: Option<f64>,
        /// The dominant hand: the participant takes the objects with it, and a left hand is
        /// modelled as the mirrored arm with mirrored poses (default: right).
        #[arg(long, value_enum)]
        handedness: Option<HandArg>,
    },
    /// Record that a participant withdrew: no new session is started for them, `analyze`
    /// leaves their sessions out and their counterbalancing slot is free again. With
    /// --delete-data, also delete every file of theirs in the study folders (their logs and
    /// their record), after listing the files and asking for the id to be typed back.
    ///
    /// Writes: the record's withdrawal time into PARTICIPANTS/<id>.json (an atomic rewrite);
    /// with --delete-data, deletes their logs and record instead.
    Withdraw {
        /// The participant's id.
        id: String,
        /// Also delete the participant's logs and record.
        #[arg(long)]
        delete_data: bool,
        /// Delete without asking (for scripts; the list is still printed).
        #[arg(long, requires = "delete_data")]
        yes: bool,
        #[command(flatten)]
        folders: Folders,
    },
    /// Print a participant's record.
    ///
    /// Writes: the record on stdout; no file.
    Show {
        /// The participant's id.
        id: String,
        #[command(flatten)]
        folders: Folders,
    },
}

/// The study folders of a participant subcommand.
#[derive(Debug, Args)]
struct Folders {
    /// The study directory (records in DIR/participants, logs in DIR/logs).
    #[arg(long, value_name = "DIR")]
    study_dir: Option<PathBuf>,
    /// Where participant records live (default: STUDY_DIR/participants).
    #[arg(long = "participants-dir", value_name = "DIR")]
    participants: Option<PathBuf>,
    /// Where session logs live (default: STUDY_DIR/logs).
    #[arg(long, value_name = "DIR")]
    logs: Option<PathBuf>,
}

impl Folders {
    fn resolve(&self) -> StudyDirs {
        StudyDirs::resolve(self.study_dir.as_deref(), self.participants.as_deref(), self.logs.as_deref())
    }
}

pub fn run(args: ParticipantArgs) -> Result<()> {
    match args.command {
        ParticipantCommand::New { protocol, folders, body_height, handedness } => {
            let (text, study) = load_protocol(protocol.as_deref())?;
            let dirs = folders.resolve();
            let body_height = body_height.map(|h| checked_height("--body-height", h)).transpose()?;
            let body = Body { height_m: body_height, hand: handedness.map(Into::into).unwrap_or_default() };
            // A body the protocol cannot serve is refused now, not with the participant in
            // the room: no record is written and no slot is taken.
            if let Err(e) = for_body(&text, &study.source_name, body) {
                return Err(bad(format!(
                    "{body} cannot be served by this protocol (no record created, no slot taken): {e}"
                )));
            }
            for missing in dirs.missing() {
                eprintln!("note: {} does not exist yet; it will be created", missing.display());
            }
            let counts = completed_per_slot(&dirs.logs, &dirs.participants, 2);
            for w in counts.warnings() {
                eprintln!("warning: {w}");
            }
            let slot = counts.least_filled();
            let record = ParticipantRecord {
                id: new_id(&mut rand::rng()),
                slot,
                created_at: chrono::Utc::now().to_rfc3339_opts(chrono::SecondsFormat::Secs, true),
                body_height_m: body_height,
                handedness: handedness.map(Into::into),
                withdrawn_at: None,
            };
            let path = record.create(&dirs.participants).with_context(|| "cannot create the participant record")?;
            let order: Vec<_> = condition_order(&study, slot).iter().map(|c| c.name()).collect();
            let labels = &study.protocol.session.program_labels;
            outln!("{}", record.id);
            eprintln!(
                "created {} (slot {slot}: {} = {}, {} = {})",
                path.display(),
                labels[0],
                order[0],
                labels[1],
                order[1]
            );
            Ok(())
        }
        ParticipantCommand::Withdraw { id, delete_data, yes, folders } => withdraw(&id, delete_data, yes, &folders),
        ParticipantCommand::Show { id, folders } => {
            validate_id(&id).map_err(|e| bad(e.to_string()))?;
            let dirs = folders.resolve();
            let rec = ParticipantRecord::load(&dirs.participants, &id).map_err(|e| bad(e.to_string()))?;
            outln!("{}", serde_json::to_string_pretty(&rec)?);
            Ok(())
        }
    }
}

/// `participant withdraw`.
fn withdraw(id: &str, delete_data: bool, yes: bool, f: &Folders) -> Result<()> {
    validate_id(id).map_err(|e| bad(e.to_string()))?;
    let dirs = f.resolve();
    let record_path = ParticipantRecord::path(&dirs.participants, id).map_err(|e| bad(e.to_string()))?;
    if !record_path.exists() {
        return Err(bad(format!("{}: no such participant record", record_path.display())));
    }
    let log_dir = dirs.logs.join(id);
    // No session of theirs may be live while their data changes.
    let _lock =
        if log_dir.is_dir() { Some(ParticipantLock::acquire(&log_dir, id, "participant withdraw")?) } else { None };
    let now = chrono::Utc::now().to_rfc3339_opts(chrono::SecondsFormat::Secs, true);
    let rec = ParticipantRecord::withdraw(&dirs.participants, id, &now).map_err(|e| bad(e.to_string()))?;
    eprintln!(
        "{id} withdrew ({}): no new sessions; analyze leaves their sessions out",
        rec.withdrawn_at.unwrap_or_default()
    );
    if !delete_data {
        return Ok(());
    }
    let mut files: Vec<PathBuf> = Vec::new();
    if log_dir.is_dir() {
        let mut stack = vec![log_dir.clone()];
        while let Some(d) = stack.pop() {
            for e in std::fs::read_dir(&d).with_context(|| format!("cannot list {}", d.display()))? {
                let p = e?.path();
                if p.is_dir() { stack.push(p) } else { files.push(p) }
            }
        }
    }
    files.sort();
    files.push(record_path.clone());
    outln!("These {} file(s) of {id} will be deleted:", files.len());
    for p in &files {
        outln!("  {}", p.display());
    }
    if !yes {
        use std::io::{BufRead, IsTerminal};
        if !std::io::stdin().is_terminal() {
            return Err(bad("--delete-data asks for confirmation on a terminal; pass --yes to delete without asking"));
        }
        eprint!("Type the participant id ({id}) to delete them: ");
        let mut answer = String::new();
        std::io::stdin().lock().read_line(&mut answer)?;
        if answer.trim() != id {
            eprintln!("not confirmed: nothing deleted (the participant stays withdrawn)");
            return Err(bad("deletion not confirmed"));
        }
    }
    for p in &files {
        std::fs::remove_file(p).with_context(|| format!("cannot delete {}", p.display()))?;
    }
    if log_dir.is_dir() {
        std::fs::remove_dir_all(&log_dir).with_context(|| format!("cannot delete {}", log_dir.display()))?;
    }
    handover::private_files::sync_parent(&record_path);
    handover::private_files::sync_parent(&log_dir);
    eprintln!("deleted {} file(s) of {id}", files.len());
    Ok(())
}
