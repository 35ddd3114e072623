//! The tidy tables `analyze --out` writes, one `Serialize` row struct per file; their
//! columns are documented in `docs/outputs.md` (and checked against it by `tests/integration/outputs.rs`).

use std::path::Path;

use serde::Serialize;

use super::seeds::distance_to_truth_deg;
use super::{AlphaFit, AlphaSummary, Analysed, StudySummary, objects_by_body, rfc3339_ms, trial_columns};
use crate::kinematics::JOINT_NAMES;
use crate::private_files::{csv_bool, csv_bool_opt, write_csv};
use crate::session::program_letter;

/// A number that is written only when it is one (an empty field otherwise).
fn finite(x: f64) -> Option<f64> {
    x.is_finite().then_some(x)
}

/// `sessions.csv`.
#[derive(Serialize, Default)]
struct SessionRow<'a> {
    session_id: &'a str,
    participant: &'a str,
    #[serde(serialize_with = "csv_bool")]
    pilot: bool,
    slot: usize,
    condition_order: String,
    program_a: Option<&'a str>,
    program_b: Option<&'a str>,
    #[serde(serialize_with = "csv_bool")]
    completed: bool,
    #[serde(serialize_with = "csv_bool")]
    truncated: bool,
    events: usize,
    forced_choice_program: Option<String>,
    forced_choice_condition: Option<&'a str>,
    started_at: &'a str,
    /// A u64: text, so that no reader rounds it.
    seed: String,
    body_height_m: Option<f64>,
    hand: &'static str,
    log: String,
}

/// `notes.csv`.
#[derive(Serialize, Default)]
struct NoteCsvRow<'a> {
    session_id: &'a str,
    participant: &'a str,
    event_index: usize,
    time: String,
    text: &'a str,
}

/// `robot.csv`.
#[derive(Serialize, Default)]
struct RobotCsvRow<'a> {
    session_id: &'a str,
    participant: &'a str,
    event_index: usize,
    phase: &'a str,
    condition: Option<&'a str>,
    program: Option<&'a str>,
    trial: usize,
    query: &'a str,
    attempt: u32,
    command: Option<&'a str>,
    link: &'a str,
    frame: &'a str,
    commanded_at: String,
    moving_at: Option<String>,
    outcome: Option<&'a str>,
    outcome_at: Option<String>,
    seconds_to_outcome: Option<f64>,
    detail: &'a str,
    reports: usize,
    stale_reports: usize,
}

/// `test_log_likelihood.csv`.
#[derive(Serialize, Default)]
struct TestLogLikelihoodRow<'a> {
    session_id: &'a str,
    participant: &'a str,
    condition: &'a str,
    program: String,
    iteration: usize,
    log_likelihood_mean: f64,
    log_likelihood_predictive: f64,
}

/// `fig10_tests.csv`.
#[derive(Serialize, Default)]
struct Fig10TestRow<'a> {
    iteration: usize,
    first: &'a str,
    second: &'a str,
    pairs: usize,
    mean_difference: f64,
    ci_low: Option<f64>,
    ci_high: Option<f64>,
    median_difference: f64,
    share_first_higher: f64,
    p_value: Option<f64>,
}

/// `beliefs.csv` (long).
#[derive(Serialize, Default)]
struct BeliefRow<'a> {
    session_id: &'a str,
    participant: &'a str,
    condition: &'a str,
    program: String,
    iteration: usize,
    parameter: &'static str,
    joint: &'static str,
    estimate: &'static str,
    value: f64,
    unit: &'static str,
}

/// `belief_summary.csv`.
#[derive(Serialize, Default)]
struct BeliefSummaryRow<'a> {
    session_id: &'a str,
    participant: &'a str,
    condition: &'a str,
    program: String,
    iteration: usize,
    entropy_nats: f64,
    ess: f64,
    distance_to_truth_deg: Option<f64>,
}

/// `questionnaire.csv`.
#[derive(Serialize, Default)]
struct QuestionnaireRow<'a> {
    session_id: &'a str,
    participant: &'a str,
    condition_order: String,
    condition: &'a str,
    program: String,
    item: &'a str,
    value: i64,
}

/// `objects_by_body.csv`.
#[derive(Serialize, Default)]
struct ObjectsByBodyRow {
    height_band_m: String,
    hand: &'static str,
    sessions: usize,
    object: String,
    /// `share` or `difference`.
    measure: &'static str,
    /// A share's condition, or a difference's `<first> minus <second>`.
    condition: String,
    mean: f64,
    ci_low: Option<f64>,
    ci_high: Option<f64>,
    p_value: Option<f64>,
}

/// `alpha.csv`.
#[derive(Serialize, Default)]
struct AlphaRow<'a> {
    participant: &'a str,
    session_id: Option<&'a str>,
    handovers: Option<usize>,
    alpha: Option<f64>,
    ci_low: Option<f64>,
    ci_high: Option<f64>,
    #[serde(serialize_with = "csv_bool_opt")]
    ci_low_open: Option<bool>,
    #[serde(serialize_with = "csv_bool_opt")]
    ci_high_open: Option<bool>,
    #[serde(serialize_with = "csv_bool_opt")]
    at_range_end: Option<bool>,
    /// The pooled row's when its sessions share one α (empty when their protocols differ).
    protocol_alpha: Option<f64>,
    #[serde(serialize_with = "csv_bool_opt")]
    protocol_alpha_supported: Option<bool>,
}

/// `alpha_curve.csv`.
#[derive(Serialize, Default)]
struct AlphaCurveRow<'a> {
    participant: &'a str,
    /// Empty for the pooled curve.
    session_id: Option<&'a str>,
    alpha: f64,
    log_evidence: f64,
}

fn condition_order(a: &Analysed) -> String {
    a.analysis.runs.iter().map(|r| r.condition.as_str()).collect::<Vec<_>>().join("-")
}

/// Writes every table of a group of sessions (all real or all pilot) into `dir`.
pub fn write_tables(dir: &Path, group: &[&Analysed], s: &StudySummary, alpha: &AlphaSummary) -> std::io::Result<()> {
    fn ids<'a>(a: &&'a Analysed) -> (&'a str, &'a str) {
        (a.analysis.start.session_id.as_str(), a.analysis.start.participant.as_str())
    }
    write_csv(
        &dir.join("sessions.csv"),
        group.iter().map(|a| {
            let x = &a.analysis;
            let cond = |p: usize| x.runs.get(p).map(|r| r.condition.as_str());
            SessionRow {
                session_id: &x.start.session_id,
                participant: &x.start.participant,
                pilot: x.start.pilot,
                slot: x.start.slot,
                condition_order: condition_order(a),
                program_a: cond(0),
                program_b: cond(1),
                completed: x.completed,
                truncated: !a.log.finished,
                events: a.log.events.len(),
                forced_choice_program: x.choice.map(program_letter),
                forced_choice_condition: x.choice.and_then(cond),
                started_at: &x.start.started_at,
                seed: x.start.seed.to_string(),
                body_height_m: x.body.height_m,
                hand: x.body.hand.name(),
                log: a.log.path.display().to_string(),
            }
        }),
    )?;
    // trials.csv: its rows carry their own columns (the joints' names among them).
    let mut w = csv::Writer::from_writer(Vec::new());
    let mut head = vec!["session_id".to_string(), "participant".to_string()];
    head.extend(trial_columns());
    w.write_record(&head)?;
    for a in group {
        let (id, who) = ids(a);
        for t in &a.analysis.trial_rows {
            let mut row = vec![id.to_string(), who.to_string()];
            row.extend(t.values());
            w.write_record(&row)?;
        }
    }
    let text = w.into_inner().map_err(|e| e.into_error())?;
    crate::private_files::write_output(&dir.join("trials.csv"), &text)?;
    write_csv(
        &dir.join("notes.csv"),
        group.iter().flat_map(|a| {
            let (session_id, participant) = ids(a);
            a.analysis.notes.iter().map(move |n| NoteCsvRow {
                session_id,
                participant,
                event_index: n.event_index,
                time: rfc3339_ms(n.time_ns),
                text: &n.text,
            })
        }),
    )?;
    // Only sessions with a robot have commands: without one, no file rather than a header.
    if group.iter().any(|a| !a.analysis.robot.is_empty()) {
        write_csv(
            &dir.join("robot.csv"),
            group.iter().flat_map(|a| {
                let (session_id, participant) = ids(a);
                a.analysis.robot.iter().map(move |r| RobotCsvRow {
                    session_id,
                    participant,
                    event_index: r.event_index,
                    phase: r.phase,
                    condition: r.condition,
                    program: r.program.as_deref(),
                    trial: r.trial,
                    query: &r.query,
                    attempt: r.attempt,
                    command: r.command.as_deref(),
                    link: r.link,
                    frame: &r.frame,
                    commanded_at: rfc3339_ms(r.commanded_ns),
                    moving_at: r.moving_ns.map(rfc3339_ms),
                    outcome: r.outcome.map(|(s, _)| s.name()),
                    outcome_at: r.outcome.map(|(_, t)| rfc3339_ms(t)),
                    seconds_to_outcome: r.seconds(),
                    detail: &r.detail,
                    reports: r.reports,
                    stale_reports: r.stale_reports,
                })
            }),
        )?;
    }
    write_csv(
        &dir.join("test_log_likelihood.csv"),
        group.iter().flat_map(|a| {
            let (session_id, participant) = ids(a);
            a.analysis.runs.iter().flat_map(move |r| {
                r.test_ll_estimate.iter().zip(&r.test_ll_predictive).enumerate().map(move |(iteration, (m, p))| {
                    TestLogLikelihoodRow {
                        session_id,
                        participant,
                        condition: &r.condition,
                        program: program_letter(r.program),
                        iteration,
                        log_likelihood_mean: *m,
                        log_likelihood_predictive: *p,
                    }
                })
            })
        }),
    )?;
    write_csv(
        &dir.join("fig10_tests.csv"),
        s.fig10_tests.iter().map(|t| Fig10TestRow {
            iteration: t.iteration,
            first: &t.first,
            second: &t.second,
            pairs: t.n,
            mean_difference: t.mean_difference,
            ci_low: finite(t.ci_low),
            ci_high: finite(t.ci_high),
            median_difference: t.median_difference,
            share_first_higher: t.share_first_higher,
            p_value: t.p_value,
        }),
    )?;
    let runs = || {
        group.iter().flat_map(|a| {
            let (session_id, participant) = ids(a);
            a.analysis.runs.iter().flat_map(move |r| r.beliefs.iter().map(move |b| (session_id, participant, a, r, b)))
        })
    };
    write_csv(
        &dir.join("beliefs.csv"),
        runs().flat_map(|(session_id, participant, _, r, b)| {
            let estimates = [
                ("mean", &b.mean),
                ("map", &b.map),
                ("ci90_low", &b.ci_low),
                ("ci90_high", &b.ci_high),
                ("grid_mode", &b.grid_mode),
            ];
            estimates.into_iter().flat_map(move |(estimate, l)| {
                let q_star = l.q_star.iter().zip(JOINT_NAMES).map(|(v, j)| ("q_star", j, v.to_degrees(), "deg"));
                let w = l.w.iter().zip(JOINT_NAMES).map(|(v, j)| ("w", j, *v, ""));
                q_star.chain(w).map(move |(parameter, joint, value, unit)| BeliefRow {
                    session_id,
                    participant,
                    condition: &r.condition,
                    program: program_letter(r.program),
                    iteration: b.iteration,
                    parameter,
                    joint,
                    estimate,
                    value,
                    unit,
                })
            })
        }),
    )?;
    write_csv(
        &dir.join("belief_summary.csv"),
        runs().map(|(session_id, participant, a, r, b)| BeliefSummaryRow {
            session_id,
            participant,
            condition: &r.condition,
            program: program_letter(r.program),
            iteration: b.iteration,
            entropy_nats: b.entropy,
            ess: b.ess,
            distance_to_truth_deg: distance_to_truth_deg(&a.analysis, b),
        }),
    )?;
    write_csv(
        &dir.join("questionnaire.csv"),
        group.iter().flat_map(|a| {
            let (session_id, participant) = ids(a);
            let order = condition_order(a);
            a.analysis.likert.iter().map(move |(p, item, value)| QuestionnaireRow {
                session_id,
                participant,
                condition_order: order.clone(),
                condition: a.analysis.runs.get(*p).map_or("", |r| r.condition.as_str()),
                program: program_letter(*p),
                item,
                value: *value,
            })
        }),
    )?;
    let sessions: Vec<_> = group.iter().map(|a| &a.analysis).collect();
    write_csv(
        &dir.join("objects_by_body.csv"),
        objects_by_body(&sessions).into_iter().flat_map(|r| {
            let rows = [
                ("share", r.first.clone(), r.first_share, None),
                ("share", r.second.clone(), r.second_share, None),
                ("difference", format!("{} minus {}", r.first, r.second), r.difference, r.p_value),
            ];
            rows.map(|(measure, condition, (mean, lo, hi), p_value)| ObjectsByBodyRow {
                height_band_m: r.band.clone(),
                hand: r.hand,
                sessions: r.sessions,
                object: r.object.clone(),
                measure,
                condition,
                mean,
                ci_low: finite(lo),
                ci_high: finite(hi),
                p_value,
            })
        }),
    )?;
    write_alpha_tables(dir, alpha)
}

fn alpha_row<'a>(
    participant: &'a str,
    session_id: Option<&'a str>,
    fit: Option<&AlphaFit>,
    protocol_alpha: Option<f64>,
    protocol_alpha_supported: Option<bool>,
) -> AlphaRow<'a> {
    AlphaRow {
        participant,
        session_id,
        handovers: fit.map(|f| f.choices),
        alpha: fit.map(|f| f.alpha),
        ci_low: fit.map(|f| f.low),
        ci_high: fit.map(|f| f.high),
        ci_low_open: fit.map(|f| f.low_open),
        ci_high_open: fit.map(|f| f.high_open),
        at_range_end: fit.map(|f| f.at_range_end),
        protocol_alpha,
        protocol_alpha_supported,
    }
}

/// `alpha.csv` (one row per session and one pooled) and `alpha_curve.csv`.
fn write_alpha_tables(dir: &Path, a: &AlphaSummary) -> std::io::Result<()> {
    let pooled_alpha = match a.protocol_alphas.as_slice() {
        [(x, _)] => Some(*x),
        _ => None,
    };
    let supported = a.protocol_alphas.iter().try_fold(true, |acc, (_, ok)| ok.map(|b| acc && b));
    write_csv(
        &dir.join("alpha.csv"),
        a.sessions
            .iter()
            .map(|s| {
                alpha_row(
                    &s.participant,
                    Some(&s.session_id),
                    s.fit.as_ref(),
                    Some(s.protocol_alpha),
                    s.protocol_alpha_supported,
                )
            })
            .chain(std::iter::once(alpha_row("pooled", None, a.pooled.as_ref(), pooled_alpha, supported))),
    )?;
    let curves = a
        .sessions
        .iter()
        .filter_map(|s| Some((s.participant.as_str(), Some(s.session_id.as_str()), s.fit.as_ref()?)))
        .chain(a.pooled.as_ref().map(|f| ("pooled", None, f)));
    write_csv(
        &dir.join("alpha_curve.csv"),
        curves.flat_map(|(participant, session_id, f)| {
            f.curve.iter().map(move |&(alpha, log_evidence)| AlphaCurveRow {
                participant,
                session_id,
                alpha,
                log_evidence,
            })
        }),
    )
}
