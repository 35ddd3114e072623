//! `handover participant new`: a pseudonymous participant with a counterbalancing slot.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::{Args, Subcommand};
use handover::counterbalance::completed_per_slot;
use handover::participant::{ParticipantRecord, Tombstone, new_id, validate_id};
use handover::record::is_log_file_name;
use handover::session::condition_order;
use handover::study_dir::{LOCK_FILE, ParticipantLock};

use super::input::{HandArg, StudyFolders, bad, body_height as checked_height, load_protocol};
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
    /// slot: the order (AB or BA) with the fewest participants who completed a real session
    /// or are registered and waiting for one.
    ///
    /// Writes: PARTICIPANTS/<id>.json (owner-only); the id on stdout.
    New {
        /// Protocol (default: the embedded protocols/bike-handover.json).
        #[arg(long, value_name = "FILE")]
        protocol: Option<PathBuf>,
        #[command(flatten)]
        folders: StudyFolders,
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
    /// with --delete-data, deletes their logs and record and keeps only
    /// PARTICIPANTS/<id>.deleted.json (the id and the dates), so that a copy of a deleted log
    /// is still left out. Only the files this program wrote are deleted, never through a
    /// link; anything else in their log folder is named and nothing is deleted.
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
        folders: StudyFolders,
    },
    /// Print a participant's record.
    ///
    /// Writes: the record on stdout; no file.
    Show {
        /// The participant's id.
        id: String,
        #[command(flatten)]
        folders: StudyFolders,
    },
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
                errln!("note: {} does not exist yet; it will be created", missing.display());
            }
            let counts = completed_per_slot(&dirs.logs, &dirs.participants, 2);
            for w in counts.warnings() {
                errln!("warning: {w}");
            }
            let slot = counts.least_filled();
            errln!("counterbalancing so far: {}", counts.describe());
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
            errln!(
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
            match ParticipantRecord::load(&dirs.participants, &id) {
                Ok(rec) => outln!("{}", serde_json::to_string_pretty(&rec)?),
                Err(e) => match Tombstone::load(&dirs.participants, &id) {
                    Ok(t) => {
                        outln!("{}", serde_json::to_string_pretty(&t)?);
                        errln!("{id} withdrew and their data was deleted: this is all that is kept");
                    }
                    Err(_) => return Err(bad(e.to_string())),
                },
            }
            Ok(())
        }
    }
}

/// `participant withdraw`.
fn withdraw(id: &str, delete_data: bool, yes: bool, f: &StudyFolders) -> Result<()> {
    validate_id(id).map_err(|e| bad(e.to_string()))?;
    let dirs = f.resolve();
    let record_path = ParticipantRecord::path(&dirs.participants, id).map_err(|e| bad(e.to_string()))?;
    if std::fs::symlink_metadata(&record_path).is_err() {
        if let Ok(t) = Tombstone::load(&dirs.participants, id) {
            errln!(
                "{id} withdrew ({}) and their data was deleted ({}): nothing left to do",
                t.withdrawn_at,
                t.data_deleted_at
            );
            return Ok(());
        }
        return Err(bad(format!("{}: no such participant record", record_path.display())));
    }
    let log_dir = dirs.logs.join(id);
    // Looked at without following a link: a link in place of their folder is refused, never
    // entered (it could lead to another participant's logs or out of the study).
    let log_dir_kind = std::fs::symlink_metadata(&log_dir).ok().map(|m| m.file_type());
    // No session of theirs may be live while their data changes.
    let _lock = if log_dir_kind.is_some_and(|t| t.is_dir()) {
        Some(ParticipantLock::acquire(&log_dir, id, "participant withdraw")?)
    } else {
        None
    };
    let now = chrono::Utc::now().to_rfc3339_opts(chrono::SecondsFormat::Secs, true);
    let rec = ParticipantRecord::withdraw(&dirs.participants, id, &now).map_err(|e| bad(e.to_string()))?;
    let withdrawn_at = rec.withdrawn_at.clone().unwrap_or_default();
    errln!("{id} withdrew ({withdrawn_at}): no new sessions; analyze leaves their sessions out");
    name_outputs_holding(&dirs.root, id);
    if !delete_data {
        return Ok(());
    }
    if log_dir_kind.is_some_and(|t| !t.is_dir()) {
        return Err(bad(format!(
            "{}: is a link or a file, not the folder this program makes for a participant's logs; \
             nothing deleted (the participant stays withdrawn): move it away and run again",
            log_dir.display()
        )));
    }
    let mut files = if log_dir_kind.is_some() { files_to_delete(&log_dir)? } else { Vec::new() };
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
        err!("Type the participant id ({id}) to delete them: ");
        let mut answer = String::new();
        std::io::stdin().lock().read_line(&mut answer)?;
        if answer.trim() != id {
            errln!("not confirmed: nothing deleted (the participant stays withdrawn)");
            return Err(bad("deletion not confirmed"));
        }
    }
    // The tombstone first: whatever happens next, a copy of a deleted log stays left out.
    let tombstone = Tombstone { id: id.to_string(), withdrawn_at, data_deleted_at: now };
    let tomb_path = tombstone.write(&dirs.participants).map_err(|e| bad(e.to_string()))?;
    for p in &files {
        std::fs::remove_file(p).with_context(|| format!("cannot delete {}", p.display()))?;
    }
    if log_dir_kind.is_some() {
        // Empty now: only the files listed were in it.
        std::fs::remove_dir(&log_dir).with_context(|| format!("cannot delete {}", log_dir.display()))?;
    }
    handover::private_files::sync_parent(&record_path);
    handover::private_files::sync_parent(&log_dir);
    errln!("deleted {} file(s) of {id}; kept {} (the id and dates, no data)", files.len(), tomb_path.display());
    Ok(())
}

/// Names every output folder under the study folder whose manifest says it holds `id`'s
/// data (tables, fits, priors and protocols made from them): each must be made again
/// without them, or deleted. Folders outside the study folder cannot be seen from here.
fn name_outputs_holding(root: &std::path::Path, id: &str) {
    let mut errors = Vec::new();
    let found: Vec<_> =
        handover::output_dir::manifests(root, &mut errors).into_iter().filter(|(_, m)| m.holds(id)).collect();
    for e in errors {
        errln!("warning: {e}");
    }
    if found.is_empty() {
        errln!("no output folder under {} holds {id}'s data (folders elsewhere are not searched)", root.display());
        return;
    }
    errln!(
        "warning: {} output folder(s) under {} still hold {id}'s data: make each again (its manifest.json names the command) or delete it:",
        found.len(),
        root.display()
    );
    for (dir, m) in found {
        errln!("  {} (handover {}, {})", dir.display(), handover::text::printable(&m.command), m.written_at);
    }
}

/// The files in a participant's log folder that `--delete-data` deletes: the regular files
/// this program writes there (logs and the session lock), found without following any link.
/// Anything else — a link, a folder, a FIFO, a file of another name — is named and nothing is
/// deleted: the program did not make it, so it does not know what it is.
fn files_to_delete(log_dir: &std::path::Path) -> Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    let mut strange = Vec::new();
    for e in std::fs::read_dir(log_dir).with_context(|| format!("cannot list {}", log_dir.display()))? {
        let e = e.with_context(|| format!("cannot list {}", log_dir.display()))?;
        let t = e.file_type().with_context(|| format!("cannot inspect {}", e.path().display()))?;
        let name = e.file_name();
        let ours = name.to_str().is_some_and(|n| is_log_file_name(n) || n == LOCK_FILE);
        if t.is_file() && ours {
            files.push(e.path());
        } else {
            let what = if t.is_symlink() {
                "a link"
            } else if t.is_dir() {
                "a folder"
            } else if t.is_file() {
                "a file this program does not write"
            } else {
                "not a regular file"
            };
            strange.push(format!("  {} ({what})", e.path().display()));
        }
    }
    if !strange.is_empty() {
        strange.sort();
        return Err(bad(format!(
            "{} holds what this program did not write; nothing deleted (the participant stays withdrawn). \
             Move these away, then run again:\n{}",
            log_dir.display(),
            strange.join("\n")
        )));
    }
    files.sort();
    Ok(files)
}
