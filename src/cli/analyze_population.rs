//! `analyze --fit-population`: the population of preferences fitted from the sessions
//! (`analysis::fit_population`), as a table, JSON, population.json (a protocol's
//! `population` section, for `plan --population` and `dry-run --population`) and
//! population.csv.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::{Context, Result};
use clap::Args;
use handover::analysis::{Analysed, PopulationFit, PopulationSettings, fit_population};
use handover::stats::Paired;
use serde::Serialize;

#[derive(Debug, Args)]
pub struct PopulationArgs {
    /// Also fit the population the participants come from: each participant's λ drawn from
    /// a normal per learned component truncated to the prior's support, fitted by maximum
    /// marginal likelihood over every handover of every session (stochastic EM), with 95 %
    /// intervals (docs/engine.md), and each participant's estimate under it (partial
    /// pooling) beside their session's own. With --out, writes population.json (a protocol's
    /// `population` section: give it to `plan --population` or `dry-run --population`),
    /// prior.json (the next study's `learning.prior`: the fitted population as the robot's
    /// prior; `handover protocol with`), population.csv and pooled.csv.
    #[arg(long)]
    fit_population: bool,
}

/// One group's fit, as JSON and CSV carry it.
#[derive(Debug, Serialize)]
pub struct PopulationReport {
    pub pilot: bool,
    #[serde(flatten)]
    pub fit: PopulationFit,
    /// Sessions with a known truth (dry runs): the distance of q* to the truth, the pooled
    /// estimate's minus the session's own, per participant.
    pub pooling: Option<Paired>,
}

/// One row of pooled.csv: a participant's learned component, alone and pooled.
#[derive(Default, Serialize)]
struct PersonRow<'a> {
    participant: &'a str,
    session_id: &'a str,
    part: &'a str,
    joint: usize,
    unit: &'static str,
    session_mean: f64,
    session_sd: f64,
    pooled_mean: f64,
    pooled_sd: f64,
    /// The simulated participant's true value (dry runs).
    truth: Option<f64>,
}

/// The scale from radians (q*) or weights to the unit a protocol uses.
fn unit_of(part: &str) -> (&'static str, f64) {
    if part == "q_star" { ("deg", 180.0 / std::f64::consts::PI) } else { ("weight", 1.0) }
}

/// A participant's true value of a learned component, when the log records one.
fn truth_of(a: &Analysed, part: &str, joint: usize) -> Option<f64> {
    let t = a.analysis.start.simulated_truth.as_ref()?;
    if part == "q_star" { t.q_star.get(joint).copied() } else { t.w.get(joint).copied() }
}

/// The distance (degrees) of the learned q* to the truth, pooled minus the session's own,
/// over the sessions with a known truth.
fn pooling(fit: &PopulationFit, group: &[&Analysed]) -> Option<Paired> {
    let q: Vec<(usize, usize)> =
        fit.components.iter().enumerate().filter(|(_, c)| c.part == "q_star").map(|(j, c)| (j, c.joint)).collect();
    let differences: Vec<f64> = group
        .iter()
        .zip(&fit.people)
        .filter_map(|(a, p)| {
            let truth: Vec<f64> = q.iter().map(|&(_, joint)| truth_of(a, "q_star", joint)).collect::<Option<_>>()?;
            let distance = |est: &[f64]| {
                q.iter().zip(&truth).map(|(&(j, _), t)| (est[j] - t).powi(2)).sum::<f64>().sqrt().to_degrees()
            };
            Some(distance(&p.pooled_mean) - distance(&p.session_mean))
        })
        .collect();
    if q.is_empty() {
        return None;
    }
    Paired::over_groups("distance_to_truth_deg", 0, "pooled", "session", &[differences])
}

/// One row of population.csv: a learned component of λ in the units a protocol uses.
#[derive(Default, Serialize)]
struct Row<'a> {
    part: &'a str,
    joint: usize,
    unit: &'static str,
    mean: f64,
    /// 95 % interval ends; empty where the data do not identify them.
    mean_low: Option<f64>,
    mean_high: Option<f64>,
    sd: f64,
    sd_low: Option<f64>,
    sd_high: Option<f64>,
    support_min: f64,
    support_max: f64,
    #[serde(serialize_with = "handover::private_files::csv_bool")]
    sd_at_floor: bool,
    sessions: usize,
}

impl PopulationArgs {
    /// The fit of each group (real, pilot) that has sessions.
    pub fn run(&self, real: &[&Analysed], pilot: &[&Analysed]) -> Result<Vec<PopulationReport>> {
        if !self.fit_population {
            return Ok(Vec::new());
        }
        let mut out = Vec::new();
        for (is_pilot, group) in [(false, real), (true, pilot)] {
            let kind = if is_pilot { "pilot" } else { "real" };
            if group.len() < 2 {
                if !group.is_empty() {
                    errln!("--fit-population: one {kind} session; a population is fitted from two or more");
                }
                continue;
            }
            let evidence: Vec<_> = group.iter().map(|a| a.analysis.evidence.clone()).collect();
            errln!("fitting the population of the {} {kind} sessions …", group.len());
            let fit = fit_population(&evidence, PopulationSettings::default())
                .with_context(|| format!("cannot fit the population of the {kind} sessions"))?;
            let pooling = pooling(&fit, group);
            out.push(PopulationReport { pilot: is_pilot, fit, pooling });
        }
        Ok(out)
    }
}

/// population.json (the section), prior.json (the next study's `learning.prior`),
/// population.csv and pooled.csv of one group, in `dir`.
pub fn write(dir: &Path, report: &PopulationReport, group: &[&Analysed]) -> Result<()> {
    let Some(first) = group.first() else { return Ok(()) };
    let spec = report.fit.spec(&first.analysis.evidence.prior);
    let text = serde_json::to_string_pretty(&spec)? + "\n";
    handover::private_files::write_output(&dir.join("population.json"), text.as_bytes())?;
    // The sessions' prior as their protocol wrote it (the logged text changes only the arm).
    let written: handover::protocol::Protocol = serde_json::from_str(&first.log.protocol_text)
        .with_context(|| format!("{}: its protocol", first.log.path.display()))?;
    let prior = report.fit.prior_spec(&written.learning.prior);
    let text = serde_json::to_string_pretty(&prior)? + "\n";
    handover::private_files::write_output(&dir.join("prior.json"), text.as_bytes())?;
    let (mut fitted, mut kept) = (Vec::new(), Vec::new());
    for c in &report.fit.components {
        let name = c.name();
        let (next, old) = if c.part == "q_star" {
            (&prior.q_star_deg, &written.learning.prior.q_star_deg)
        } else {
            (&prior.w, &written.learning.prior.w)
        };
        if next.get(c.joint) == old.get(c.joint) { kept.push(name) } else { fitted.push(name) }
    }
    errln!(
        "{}: the fitted population is the prior of {}{}",
        dir.join("prior.json").display(),
        if fitted.is_empty() { "no component".to_string() } else { fitted.join(", ") },
        if kept.is_empty() {
            String::new()
        } else {
            format!("; {} keep the written prior (the data do not determine their spread)", kept.join(", "))
        }
    );
    let rows: Vec<Row> = report
        .fit
        .components
        .iter()
        .map(|c| {
            let (unit, scale) = unit_of(c.part);
            let end = |v: f64| v.is_finite().then_some(v * scale);
            Row {
                part: c.part,
                joint: c.joint + 1,
                unit,
                mean: c.mean * scale,
                mean_low: end(c.mean_low),
                mean_high: end(c.mean_high),
                sd: c.sd * scale,
                sd_low: end(c.sd_low),
                sd_high: end(c.sd_high),
                support_min: c.min * scale,
                support_max: c.max * scale,
                sd_at_floor: c.sd_at_floor,
                sessions: report.fit.sessions,
            }
        })
        .collect();
    handover::private_files::write_csv(&dir.join("population.csv"), rows)?;
    let mut people = Vec::new();
    for (a, p) in group.iter().zip(&report.fit.people) {
        for (j, c) in report.fit.components.iter().enumerate() {
            let (unit, scale) = unit_of(c.part);
            people.push(PersonRow {
                participant: &a.analysis.start.participant,
                session_id: &a.analysis.start.session_id,
                part: c.part,
                joint: c.joint + 1,
                unit,
                session_mean: p.session_mean[j] * scale,
                session_sd: p.session_sd[j] * scale,
                pooled_mean: p.pooled_mean[j] * scale,
                pooled_sd: p.pooled_sd[j] * scale,
                truth: truth_of(a, c.part, c.joint).map(|t| t * scale),
            });
        }
    }
    handover::private_files::write_csv(&dir.join("pooled.csv"), people)?;
    Ok(())
}

/// The fit as the table `analyze` prints.
pub fn table(report: &PopulationReport) -> String {
    let f = &report.fit;
    let kind = if report.pilot { "pilot" } else { "real" };
    let mut s = format!(
        "\nPOPULATION — fitted from {} {kind} sessions ({} handovers; the people's α = {} as the protocol assumed)\n",
        f.sessions, f.handovers, f.alpha
    );
    let _ = writeln!(s, "{:<8} {:>24} {:>24} {:>18}", "", "mean [95 % CI]", "sd [95 % CI]", "support");
    for c in &f.components {
        let (_, scale) = unit_of(c.part);
        let (name, unit) = (c.name(), if c.part == "q_star" { "°" } else { "" });
        let cell = |v: f64, lo: f64, hi: f64| {
            if lo.is_finite() && hi.is_finite() {
                format!("{:.1}{unit} [{:.1}, {:.1}]", v * scale, lo * scale, hi * scale)
            } else {
                format!("{:.1}{unit} [—]", v * scale)
            }
        };
        let _ = writeln!(
            s,
            "{name:<8} {:>24} {:>24} {:>18}{}",
            cell(c.mean, c.mean_low, c.mean_high),
            cell(c.sd, c.sd_low, c.sd_high),
            format!("[{:.0}, {:.0}]", c.min * scale, c.max * scale),
            if c.sd_at_floor { "  sd at the floor: not told from a narrower population" } else { "" }
        );
    }
    // Which components the data leave without an interval ([—] above), named as the rows are.
    let open: Vec<String> = f
        .components
        .iter()
        .filter(|c| ![c.mean_low, c.mean_high, c.sd_low, c.sd_high].iter().all(|v| v.is_finite()))
        .map(|c| c.name())
        .collect();
    let _ = writeln!(
        s,
        "stochastic EM, {} iterations; random-walk acceptance per participant: min {:.2}, median {:.2}{}",
        f.iterations,
        f.min_acceptance,
        f.median_acceptance,
        match open.len() {
            0 => String::new(),
            n if n == f.components.len() => "; the data identify no component: no intervals".to_string(),
            _ => format!("; the data do not identify {} ([—]): no interval there", open.join(", ")),
        }
    );
    if let Some(p) = &report.pooling {
        let _ = writeln!(
            s,
            "partial pooling, {} participants with a known truth: distance of q* to the truth, pooled − session alone: {:+.1}° [{:+.1}, {:+.1}], median {:+.1}°, pooled farther for {:.0} %{}",
            p.n,
            p.mean_difference,
            p.ci_low,
            p.ci_high,
            p.median_difference,
            100.0 * p.share_first_higher,
            p.p_value.map_or(String::new(), |v| format!(" (Wilcoxon {})", super::wilcoxon_p(v)))
        );
    }
    if !f.identified {
        let _ = writeln!(
            s,
            "the pooled estimates assume the fitted spreads: where a spread is not determined they treat people as more alike than the data show (their sds too small); use the session's own"
        );
    }
    s
}
