//! `handover protocol check FILE`: validate a protocol and summarise it.

use std::path::PathBuf;

use anyhow::Result;
use clap::{Args, Subcommand};
use handover::belief::ResamplePolicy;
use handover::protocol::Study;
use handover::select::OutcomeModel;

use handover::session::check_runs;

use super::input::{bad, load_study};

/// Work with protocol files.
#[derive(Debug, Args)]
pub struct ProtocolArgs {
    #[command(subcommand)]
    command: ProtocolCommand,
}

#[derive(Debug, Subcommand)]
enum ProtocolCommand {
    /// Validate a protocol (every problem with its field's path; exit 2 if any) and print a summary.
    Check {
        /// The protocol JSON file.
        file: PathBuf,
    },
}

pub fn run(args: ProtocolArgs) -> Result<()> {
    match args.command {
        ProtocolCommand::Check { file } => {
            let study = std::sync::Arc::new(load_study(Some(&file))?);
            // What a session builds, and one learning step: an accepted protocol runs.
            check_runs(std::sync::Arc::clone(&study))
                .map_err(|e| bad(format!("{}: the protocol does not run: {e}", file.display())))?;
            out!("{}", summary(&study));
            Ok(())
        }
    }
}

/// A short human-readable summary of a valid protocol.
pub fn summary(s: &Study) -> String {
    let p = &s.protocol;
    let l = &p.learning;
    let mut out = format!("{}: valid protocol '{}' (sha256 {})\n", s.source_name, p.name, &s.sha256[..12]);
    out += &format!(
        "  arm: upper arm {:.3} m, forearm {:.3} m, hand {:.3} m\n",
        s.arm.upper_arm, s.arm.forearm, s.arm.hand
    );
    for o in &p.objects {
        let regions: Vec<_> = o.regions.iter().map(|r| r.id.as_str()).collect();
        out += &format!("  object {} ({}): regions {}\n", o.id, o.label, regions.join(", "));
    }
    let sizes: Vec<usize> = s.all_queries().map(|q| q.feasible.configs.len()).collect();
    out += &format!(
        "  training menu: {} queries; test set: {} queries; feasible sets of {}–{} configurations\n",
        s.training.len(),
        s.test.len(),
        sizes.iter().min().unwrap_or(&0),
        sizes.iter().max().unwrap_or(&0)
    );
    let resampling = match l.resampling {
        ResamplePolicy::EveryUpdate => "after every update".to_string(),
        ResamplePolicy::EssBelow { fraction } => format!("when ESS < {fraction} N"),
    };
    let observation = match l.observation {
        OutcomeModel::Configuration => "the label model's configuration of the grip taken",
        OutcomeModel::Region => "the grip region taken",
    };
    out += &format!(
        "  learning: {} particles, α = {}, learns {}, observes {observation}, resamples {resampling}\n",
        l.particles, l.alpha, l.learn
    );
    let conds: Vec<_> = p.session.conditions.iter().map(|c| c.name()).collect();
    out += &format!(
        "  session: conditions {} (counterbalanced, shown as {}), {} training trials each, {} test trials{}\n",
        conds.join(" / "),
        p.session.program_labels.join(" / "),
        p.session.trials_per_condition,
        s.test.len(),
        if p.session.shuffle_test { " in a shuffled order" } else { "" }
    );
    out += &format!(
        "  questionnaire: {} items × {} programs on a {}-point scale, then a forced choice\n",
        p.questionnaire.items.len(),
        p.session.conditions.len(),
        p.questionnaire.scale.len()
    );
    out
}
