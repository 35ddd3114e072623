//! `analyze --measurements FILE`: sessions re-fitted with arm measurements taken by a motion
//! capture system, beside their logged fits.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use anyhow::{Context, Result};
use clap::Args;
use handover::analysis::{Analysed, MeasuredRefit, MeasurementSeries, refit};
use handover::kinematics::{JOINT_NAMES, JOINTS};
use handover::protocol::{MeasurementSpec, Study, limits};
use handover::record::study_of;
use handover::session::program_letter;
use serde::Serialize;

use super::input::bad;

/// Options of the measured re-fit.
#[derive(Debug, Args)]
pub struct MeasuredArgs {
    /// A CSV of time-stamped joint angles (a `time` column, seconds since the Unix epoch or
    /// RFC 3339, and `<joint>_deg` or `<joint>_rad` per joint, named as the protocol's
    /// `learning.measurement.joint_names`, else the model's joint names), or a C3D file
    /// (`.c3d`; joint names `<point label>.<x|y|z>` of angle points in degrees, with
    /// --c3d-start): each session is re-fitted with every grasp observed as the latest sample
    /// at or before its time (the live rule), and both fits are reported side by side (with --out, measured_fit.csv).
    #[arg(long, value_name = "FILE")]
    measurements: Option<PathBuf>,
    /// The measuring system's names of the model's 7 joints, in the model's order (a C3D
    /// file's `<point label>.<x|y|z>`) [default: the protocol's
    /// `learning.measurement.joint_names`, else the model's joint names].
    #[arg(long, value_delimiter = ',', value_name = "NAME,…")]
    joint_names: Option<Vec<String>>,
    /// The wall-clock time of a C3D file's first frame (RFC 3339), which C3D does not record.
    #[arg(long, value_name = "TIME")]
    c3d_start: Option<String>,
    /// The measuring system's σ per joint, degrees: one value for every joint or one per
    /// joint [default: the protocol's `learning.measurement.sigma_deg`].
    #[arg(long, value_delimiter = ',', value_name = "DEG,…")]
    sigma_deg: Option<Vec<f64>>,
    /// How long before a grasp its sample may lie, s [default: the protocol's, else 0.5].
    #[arg(long, value_name = "S")]
    window_s: Option<f64>,
}

/// One session's re-fit, as JSON and the table have it.
#[derive(Debug, Serialize)]
pub struct RefitReport {
    pub session_id: String,
    pub pilot: bool,
    pub participant: String,
    pub logged_observation: &'static str,
    pub grasps: usize,
    pub measured: usize,
    pub disagreements: usize,
    pub rows: Vec<FitRow>,
}

/// One component of one program's posterior under one fit (measured_fit.csv).
#[derive(Debug, Clone, Serialize, Default)]
pub struct FitRow {
    pub session_id: String,
    pub participant: String,
    pub program: String,
    pub condition: &'static str,
    /// `logged` (the log's observation model) or `measured`.
    pub fit: &'static str,
    pub observation: &'static str,
    /// `q_star` (degrees) or `w`.
    pub parameter: &'static str,
    pub joint: &'static str,
    pub mean: f64,
    pub ci_low: f64,
    pub ci_high: f64,
    pub iteration: usize,
    pub ess: f64,
}

impl MeasuredArgs {
    pub fn given(&self) -> bool {
        self.measurements.is_some()
    }

    /// Refuses options without a file and bad values before any work (exit 2).
    pub fn check(&self) -> Result<()> {
        if self.measurements.is_none()
            && (self.sigma_deg.is_some() || self.window_s.is_some() || self.joint_names.is_some())
        {
            return Err(bad("--sigma-deg, --window-s and --joint-names are for --measurements"));
        }
        if let Some(names) = &self.joint_names {
            if names.len() != JOINTS {
                return Err(bad(format!("--joint-names has {} names, expected {JOINTS}", names.len())));
            }
            if let Some(n) = names.iter().find(|n| !(1..=64).contains(&n.len())) {
                return Err(bad(format!("--joint-names has '{}', expected 1 to 64 characters", n.escape_debug())));
            }
        }
        match (self.is_c3d(), &self.c3d_start) {
            (true, None) => return Err(bad("--measurements FILE.c3d needs --c3d-start (its first frame's time)")),
            (false, Some(_)) => return Err(bad("--c3d-start is for --measurements FILE.c3d")),
            (true, Some(_)) => {
                self.c3d_start_ns()?;
            }
            (false, None) => {}
        }
        if let Some(s) = &self.sigma_deg {
            if s.len() != 1 && s.len() != JOINTS {
                return Err(bad(format!("--sigma-deg has {} values, expected 1 or {JOINTS}", s.len())));
            }
            let (lo, hi) = limits::SIGMA_DEG;
            if let Some(v) = s.iter().find(|v| !(v.is_finite() && (lo..=hi).contains(*v))) {
                return Err(bad(format!("--sigma-deg has {v}, expected {lo} to {hi:.1} degrees")));
            }
        }
        if let Some(w) = self.window_s {
            let (lo, hi) = limits::MEASUREMENT_WINDOW_S;
            if !(w.is_finite() && (lo..=hi).contains(&w)) {
                return Err(bad(format!("--window-s is {w}, expected {lo} to {hi} seconds")));
            }
        }
        Ok(())
    }

    fn is_c3d(&self) -> bool {
        self.measurements.as_ref().and_then(|p| p.extension()).is_some_and(|e| e.eq_ignore_ascii_case("c3d"))
    }

    fn c3d_start_ns(&self) -> Result<u64> {
        let text = self.c3d_start.as_deref().unwrap_or_default();
        chrono::DateTime::parse_from_rfc3339(text)
            .ok()
            .and_then(|t| t.timestamp_nanos_opt())
            .and_then(|n| u64::try_from(n).ok())
            .ok_or_else(|| bad(format!("--c3d-start is '{text}', expected an RFC 3339 time after 1970")))
    }

    /// The measuring system for a session: the options over the session's protocol.
    fn spec(&self, a: &Analysed, study: &Study) -> Result<MeasurementSpec> {
        let logged = study.protocol.learning.measurement.clone();
        let sigma_deg = match (&self.sigma_deg, &logged) {
            (Some(s), _) if s.len() == 1 => vec![s[0]; JOINTS],
            (Some(s), _) => s.clone(),
            (None, Some(m)) => m.sigma_deg.clone(),
            (None, None) => {
                return Err(bad(format!(
                    "{}: its protocol states no measuring system: give --sigma-deg",
                    a.log.path.display()
                )));
            }
        };
        Ok(MeasurementSpec {
            sigma_deg,
            joint_names: match (&self.joint_names, &logged) {
                (Some(names), _) => names.clone(),
                (None, Some(m)) => m.joint_names.clone(),
                (None, None) => JOINT_NAMES.iter().map(|n| n.to_string()).collect(),
            },
            window_s: self.window_s.or(logged.map(|m| m.window_s)).unwrap_or(0.5),
        })
    }

    /// Re-fits every session; bad files and options are input errors (exit 2).
    pub fn run(&self, analysed: &[Analysed]) -> Result<Vec<RefitReport>> {
        let Some(path) = &self.measurements else { return Ok(Vec::new()) };
        // The file is read once per set of joint names (once, when the sessions share a
        // protocol).
        let mut read: Vec<(Vec<String>, MeasurementSeries)> = Vec::new();
        let mut out = Vec::new();
        for a in analysed {
            let study = Arc::new(study_of(&a.log)?);
            let spec = self.spec(a, &study)?;
            let k = match read.iter().position(|(names, _)| *names == spec.joint_names) {
                Some(k) => k,
                None => {
                    let s = if self.is_c3d() {
                        MeasurementSeries::read_c3d(path, &spec.joint_names, self.c3d_start_ns()?)
                    } else {
                        MeasurementSeries::read_csv(path, &spec.joint_names)
                    }
                    .map_err(|e| bad(e.to_string()))?;
                    read.push((spec.joint_names.clone(), s));
                    read.len() - 1
                }
            };
            let r = refit(&a.log, study, &read[k].1, &spec)
                .with_context(|| format!("cannot re-fit {}", a.log.path.display()))?;
            out.push(report(a, &r));
        }
        Ok(out)
    }
}

fn report(a: &Analysed, r: &MeasuredRefit) -> RefitReport {
    let start = &a.log.start;
    let mut rows = Vec::new();
    for run in &r.runs {
        for (fit, observation, b) in
            [("logged", r.logged_observation.name(), &run.logged), ("measured", "measured", &run.measured)]
        {
            for (parameter, scale, mean, low, high) in [
                ("q_star", 180.0 / std::f64::consts::PI, &b.mean.q_star, &b.ci_low.q_star, &b.ci_high.q_star),
                ("w", 1.0, &b.mean.w, &b.ci_low.w, &b.ci_high.w),
            ] {
                for d in 0..JOINTS.min(mean.len()) {
                    rows.push(FitRow {
                        session_id: start.session_id.clone(),
                        participant: start.participant.clone(),
                        program: program_letter(run.program),
                        condition: run.condition,
                        fit,
                        observation,
                        parameter,
                        joint: JOINT_NAMES[d],
                        mean: mean[d] * scale,
                        ci_low: low[d] * scale,
                        ci_high: high[d] * scale,
                        iteration: b.iteration,
                        ess: b.ess,
                    });
                }
            }
        }
    }
    RefitReport {
        session_id: start.session_id.clone(),
        pilot: start.pilot,
        participant: start.participant.clone(),
        logged_observation: r.logged_observation.name(),
        grasps: r.grasps,
        measured: r.measured,
        disagreements: r.disagreements,
        rows,
    }
}

/// The side-by-side table: per session and program, q* by each fit (mean [90 % interval], °).
pub fn table(reports: &[RefitReport]) -> String {
    let mut s = String::from("\nMEASURED RE-FIT (posterior mean of q* [90 % credible interval], degrees)\n");
    for r in reports {
        s += &format!(
            "{} ({}): {} of {} grasps measured within the window, {} implied another grip than the key\n",
            r.participant, r.session_id, r.measured, r.grasps, r.disagreements
        );
        let programs: Vec<&String> = {
            let mut p: Vec<&String> = r.rows.iter().map(|x| &x.program).collect();
            p.dedup();
            p
        };
        for program in programs {
            let of = |fit: &str, joint: &str| {
                r.rows
                    .iter()
                    .find(|x| &x.program == program && x.fit == fit && x.parameter == "q_star" && x.joint == joint)
            };
            let condition = r.rows.iter().find(|x| &x.program == program).map_or("", |x| x.condition);
            s += &format!(
                "  Program {program} ({condition}): {:<28} {:>24} {:>24}\n",
                "joint",
                format!("logged ({})", r.logged_observation),
                "measured"
            );
            for joint in JOINT_NAMES {
                let cell = |x: Option<&FitRow>| {
                    x.map_or(String::new(), |x| format!("{:.1} [{:.1}, {:.1}]", x.mean, x.ci_low, x.ci_high))
                };
                s += &format!(
                    "  {:<40} {:>24} {:>24}\n",
                    format!("  {joint}"),
                    cell(of("logged", joint)),
                    cell(of("measured", joint))
                );
            }
        }
    }
    s
}

/// measured_fit.csv: one row per session, program, fit and component; real sessions in
/// `dir`, pilot sessions in `dir/pilot` (as the other tables).
pub fn write_csv(dir: &Path, reports: &[RefitReport]) -> Result<()> {
    for pilot in [false, true] {
        let group: Vec<&RefitReport> = reports.iter().filter(|r| r.pilot == pilot).collect();
        if group.is_empty() {
            continue;
        }
        let d = if pilot { dir.join("pilot") } else { dir.to_path_buf() };
        handover::private_files::create_dir(&d).with_context(|| format!("cannot create {}", d.display()))?;
        handover::private_files::write_csv(
            &d.join("measured_fit.csv"),
            group.iter().flat_map(|r| r.rows.iter().cloned()),
        )?;
    }
    Ok(())
}
