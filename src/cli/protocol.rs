//! `handover protocol check [FILE]`: validate a protocol and summarise it; `handover
//! protocol with`: a protocol with another prior or population section.

use std::path::PathBuf;

use anyhow::Result;
use clap::{Args, Subcommand};
use handover::belief::ResamplePolicy;
use handover::output_dir;
use handover::protocol::ObservationModel;
use handover::protocol::Study;

use handover::session::check_runs;

use super::input::{
    HandArg, Section, bad, body_height as checked_height, load_protocol, output_dir_error, parse_json, read_text,
    with_sections,
};
use handover::kinematics::Hand;
use handover::protocol::{Body, PopulationSpec, PriorSpec, for_body};

/// Work with protocol files.
#[derive(Debug, Args)]
pub struct ProtocolArgs {
    #[command(subcommand)]
    command: ProtocolCommand,
}

#[derive(Debug, Subcommand)]
enum ProtocolCommand {
    /// Validate a protocol (every problem with its field's path; exit 2 if any) and print a summary.
    ///
    /// Writes: the problems or the summary on stdout; no file.
    Check {
        /// The protocol JSON file (default: the embedded protocols/bike-handover.json).
        file: Option<PathBuf>,
        /// Check it for a participant of this body height (m): the arm and the poses scaled
        /// as a session scales them, every grip of every query reachable.
        #[arg(long, value_name = "M", conflicts_with = "bodies")]
        body_height: Option<f64>,
        /// Check it for a participant with this dominant hand (a left hand: the mirrored arm
        /// and mirrored poses).
        #[arg(long, value_enum, conflicts_with = "bodies")]
        handedness: Option<HandArg>,
        /// Report which body heights from 1.50 to 1.95 m (every 5 cm), with either hand, it
        /// serves.
        #[arg(long)]
        bodies: bool,
    },
    /// A protocol with another prior or population: the next study's, from the fitted
    /// population of this one (`analyze --fit-population --out DIR` writes DIR/prior.json
    /// and DIR/population.json).
    ///
    /// Writes: OUT/protocol.json, the protocol with those sections in place of its own,
    /// checked as `protocol check` checks (refused if it exists); its summary on stdout.
    #[command(group = clap::ArgGroup::new("section").required(true).multiple(true).args(["prior_file", "population_file"]))]
    With {
        /// The protocol JSON file (default: the embedded protocols/bike-handover.json).
        file: Option<PathBuf>,
        /// A `learning.prior` section (q* in degrees): the robot's prior over λ.
        #[arg(long, value_name = "FILE")]
        prior_file: Option<PathBuf>,
        /// A `population` section (q* in degrees): whom dry runs and plans draw people from.
        #[arg(long, value_name = "FILE")]
        population_file: Option<PathBuf>,
        /// The folder the new protocol.json is written into.
        #[arg(long, value_name = "DIR")]
        out: PathBuf,
    },
}

/// The heights `--bodies` checks (m): 1.50, 1.55, …, 1.95.
const BODY_RANGE_CM: (u32, u32, u32) = (150, 195, 5);

pub fn run(args: ProtocolArgs) -> Result<()> {
    match args.command {
        ProtocolCommand::With { file, prior_file, population_file, out } => {
            let (text, study) = load_protocol(file.as_deref())?;
            let mut sections = Vec::new();
            if let Some(path) = &prior_file {
                let name = path.display().to_string();
                sections.push(Section::prior(&parse_json::<PriorSpec>(&read_text(path)?, &name)?, &name)?);
            }
            if let Some(path) = &population_file {
                let name = path.display().to_string();
                sections.push(Section::population(&parse_json::<PopulationSpec>(&read_text(path)?, &name)?, &name)?);
            }
            let (text, study) = with_sections(&text, &study, &sections)?;
            let study = std::sync::Arc::new(study);
            check_runs(std::sync::Arc::clone(&study))
                .map_err(|e| bad(format!("{}: the protocol does not run: {e}", study.source_name)))?;
            let path = out.join("protocol.json");
            if std::fs::symlink_metadata(&path).is_ok() {
                return Err(bad(format!(
                    "{}: exists; a protocol is never overwritten: give another --out",
                    path.display()
                )));
            }
            // The sessions a prior or population was fitted from are held by what is made of it.
            let mut held = Vec::new();
            for input in prior_file.iter().chain(&population_file) {
                if let Some(m) = output_dir::manifest_of(input).map_err(output_dir_error)? {
                    for s in m.sessions {
                        if !held.contains(&s) {
                            held.push(s);
                        }
                    }
                }
            }
            output_dir::prepare(&out, "protocol with", None, &held).map_err(output_dir_error)?;
            handover::private_files::write_new(&path, text.as_bytes())
                .map_err(|e| bad(format!("{}: cannot write the protocol: {e}", path.display())))?;
            output_dir::finish(&out, "protocol with", None, &held)?;
            out!("{}", summary(&study));
            outln!("wrote {}", path.display());
            Ok(())
        }
        ProtocolCommand::Check { file, bodies: true, .. } => {
            let (text, study) = load_protocol(file.as_deref())?;
            outln!(
                "{}: bodies served (height × dominant hand; the arm and the poses scaled as a session scales them):",
                study.source_name
            );
            let (mut served, mut all) = (0, 0);
            for cm in (BODY_RANGE_CM.0..=BODY_RANGE_CM.1).step_by(BODY_RANGE_CM.2 as usize) {
                let h = f64::from(cm) / 100.0;
                for hand in [Hand::Right, Hand::Left] {
                    all += 1;
                    let body = Body { height_m: Some(h), hand };
                    match for_body(&text, &study.source_name, body) {
                        Ok((_, s)) => {
                            served += 1;
                            let sizes: Vec<usize> = s.all_queries().map(|q| q.feasible.configs.len()).collect();
                            outln!(
                                "  {h:.2} m  {:<5}  served (feasible sets of {}–{} configurations)",
                                hand.name(),
                                sizes.iter().min().unwrap_or(&0),
                                sizes.iter().max().unwrap_or(&0)
                            );
                        }
                        Err(e) => {
                            let first = e
                                .problems
                                .first()
                                .map_or(String::new(), |p| format!(", e.g. {}: {}", p.path, p.message));
                            outln!("  {h:.2} m  {:<5}  not served: {} problem(s){first}", hand.name(), e.problems.len())
                        }
                    }
                }
            }
            outln!("{served} of {all} bodies served");
            Ok(())
        }
        ProtocolCommand::Check { file, body_height, handedness, bodies: false } => {
            let (text, study) = load_protocol(file.as_deref())?;
            let study = if body_height.is_some() || handedness.is_some() {
                let height_m = body_height.map(|h| checked_height("--body-height", h)).transpose()?;
                let body = Body { height_m, hand: handedness.map(Into::into).unwrap_or_default() };
                for_body(&text, &study.source_name, body).map_err(|e| bad(e.to_string()))?.1
            } else {
                study
            };
            let study = std::sync::Arc::new(study);
            // What a session builds, and one learning step: an accepted protocol runs.
            check_runs(std::sync::Arc::clone(&study))
                .map_err(|e| bad(format!("{}: the protocol does not run: {e}", study.source_name)))?;
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
        "  arm: {} arm, upper arm {:.3} m, forearm {:.3} m, hand {:.3} m{}\n",
        s.arm.side.name(),
        s.arm.upper_arm,
        s.arm.forearm,
        s.arm.hand,
        match p.pose_scaling {
            Some(ps) => format!(
                "; poses written for a {} m body, scaled ×{:.3} to this arm's reach",
                ps.reference_body_height_m,
                s.pose_scale()
            ),
            None => "; poses used as written".to_string(),
        }
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
    let observation = match (l.observation, &l.measurement) {
        (ObservationModel::Configuration, _) => "the label model's configuration of the grip taken".to_string(),
        (ObservationModel::Measured, Some(m)) => format!(
            "the arm measured at the grasp (σ {}° per joint; joints {}; a sample within ±{} s, else the grip region taken)",
            m.sigma_deg.iter().map(|s| s.to_string()).collect::<Vec<_>>().join("/"),
            m.joint_names.join(", "),
            m.window_s
        ),
        (ObservationModel::Region | ObservationModel::Measured, _) => "the grip region taken".to_string(),
    };
    out += &format!(
        "  learning: {} particles, α = {}, learns {}, observes {observation}, resamples {resampling}\n",
        l.particles, l.alpha, l.learn
    );
    out += &prior_summary(l);
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
    out += &format!(
        "  simulated participants (dry-run, plan): {}, α = {}\n",
        if p.population.is_some() {
            "the protocol's population"
        } else {
            "the default population (each learned component centred on its prior range, sd a sixth of it)"
        },
        s.population().alpha
    );
    out
}

/// The learned components' priors, one line per part of λ (q* in degrees).
fn prior_summary(l: &handover::protocol::LearningSpec) -> String {
    use handover::belief::ComponentPrior;
    let dim = l.prior.q_star_deg.len();
    let mut out = String::new();
    for (part, unit, priors, offset) in [("q*", "°", &l.prior.q_star_deg, 0), ("w", "", &l.prior.w, dim)] {
        let learned: Vec<String> = priors
            .iter()
            .enumerate()
            .filter(|&(j, _)| l.learn.learns(offset + j, dim))
            .map(|(j, c)| match *c {
                ComponentPrior::Fixed { value } => format!("{part}{} {value}{unit}", j + 1),
                ComponentPrior::Uniform { min, max } => format!("{part}{} uniform [{min}, {max}]{unit}", j + 1),
                ComponentPrior::Gaussian { mean, sd, min, max } => {
                    format!("{part}{} normal {mean:.1} ± {sd:.1}{unit} on [{min}, {max}]{unit}", j + 1)
                }
            })
            .collect();
        if !learned.is_empty() {
            out += &format!("  prior of {part}: {}\n", learned.join("; "));
        }
    }
    out
}
