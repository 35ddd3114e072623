//! `handover participant new`: a pseudonymous participant with a counterbalancing slot.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::{Args, Subcommand, ValueEnum};
use handover::participant::{BODY_HEIGHT_M, Handedness, ParticipantRecord, new_id, validate_id};
use handover::record::least_filled_slot;
use handover::session::condition_order;
use handover::study_dir::StudyDirs;

use super::input::{bad, load_study};

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
    New {
        /// Protocol (default: the embedded protocols/bike-handover.json).
        #[arg(long, value_name = "FILE")]
        protocol: Option<PathBuf>,
        /// The study directory (records in DIR/participants, logs in DIR/logs).
        #[arg(long, value_name = "DIR")]
        study_dir: Option<PathBuf>,
        /// Where participant records live (default: STUDY_DIR/participants).
        #[arg(long, value_name = "DIR")]
        participants: Option<PathBuf>,
        /// Where session logs live, to count completed sessions per order (default:
        /// STUDY_DIR/logs).
        #[arg(long, value_name = "DIR")]
        logs: Option<PathBuf>,
        /// Body height in metres (for the arm model).
        #[arg(long, value_name = "M")]
        body_height: Option<f64>,
        /// Preferred hand.
        #[arg(long, value_enum)]
        handedness: Option<HandArg>,
    },
    /// Print a participant's record.
    Show {
        /// The participant's id.
        id: String,
        /// The study directory (records in DIR/participants).
        #[arg(long, value_name = "DIR")]
        study_dir: Option<PathBuf>,
        /// Where participant records live (default: STUDY_DIR/participants).
        #[arg(long, value_name = "DIR")]
        participants: Option<PathBuf>,
    },
}

#[derive(Debug, Clone, Copy, ValueEnum)]
enum HandArg {
    Left,
    Right,
}

pub fn run(args: ParticipantArgs) -> Result<()> {
    match args.command {
        ParticipantCommand::New { protocol, study_dir, participants, logs, body_height, handedness } => {
            let study = load_study(protocol.as_deref())?;
            let dirs = StudyDirs::resolve(study_dir.as_deref(), participants.as_deref(), logs.as_deref());
            if let Some(h) = body_height
                && !(BODY_HEIGHT_M.0..=BODY_HEIGHT_M.1).contains(&h)
            {
                return Err(bad(format!(
                    "--body-height is {h}, expected metres from {} to {}",
                    BODY_HEIGHT_M.0, BODY_HEIGHT_M.1
                )));
            }
            for missing in dirs.missing() {
                eprintln!("note: {} does not exist yet; it will be created", missing.display());
            }
            let slot = least_filled_slot(&dirs.logs, 2);
            let record = ParticipantRecord {
                id: new_id(&mut rand::rng()),
                slot,
                created_at: chrono::Utc::now().to_rfc3339_opts(chrono::SecondsFormat::Secs, true),
                body_height_m: body_height,
                handedness: handedness.map(|h| match h {
                    HandArg::Left => Handedness::Left,
                    HandArg::Right => Handedness::Right,
                }),
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
        ParticipantCommand::Show { id, study_dir, participants } => {
            validate_id(&id).map_err(|e| bad(e.to_string()))?;
            let dirs = StudyDirs::resolve(study_dir.as_deref(), participants.as_deref(), None);
            let rec = ParticipantRecord::load(&dirs.participants, &id).map_err(|e| bad(e.to_string()))?;
            outln!("{}", serde_json::to_string_pretty(&rec)?);
            Ok(())
        }
    }
}
