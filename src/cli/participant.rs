//! `handover participant new`: a pseudonymous participant with a counterbalancing slot.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::{Args, Subcommand, ValueEnum};
use handover::participant::{Handedness, ParticipantRecord, new_id, validate_id};
use handover::record::least_filled_slot;
use handover::session::condition_order;

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
        /// Where participant records live.
        #[arg(long, value_name = "DIR", default_value = "participants")]
        participants: PathBuf,
        /// Where session logs live (to count completed sessions per order).
        #[arg(long, value_name = "DIR", default_value = "logs")]
        logs: PathBuf,
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
        /// Where participant records live.
        #[arg(long, value_name = "DIR", default_value = "participants")]
        participants: PathBuf,
    },
}

#[derive(Debug, Clone, Copy, ValueEnum)]
enum HandArg {
    Left,
    Right,
}

pub fn run(args: ParticipantArgs) -> Result<()> {
    match args.command {
        ParticipantCommand::New { protocol, participants, logs, body_height, handedness } => {
            let study = load_study(protocol.as_deref())?;
            if let Some(h) = body_height
                && !(0.5..=2.5).contains(&h)
            {
                return Err(bad(format!("--body-height is {h}, expected metres between 0.5 and 2.5")));
            }
            let slot = least_filled_slot(&logs, 2);
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
            let path = record.create(&participants).with_context(|| "cannot create the participant record")?;
            let order: Vec<_> = condition_order(&study, slot).iter().map(|c| c.name()).collect();
            let labels = &study.protocol.session.program_labels;
            println!("{}", record.id);
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
        ParticipantCommand::Show { id, participants } => {
            validate_id(&id).map_err(|e| bad(e.to_string()))?;
            let rec = ParticipantRecord::load(&participants, &id).map_err(|e| bad(e.to_string()))?;
            println!("{}", serde_json::to_string_pretty(&rec)?);
            Ok(())
        }
    }
}
