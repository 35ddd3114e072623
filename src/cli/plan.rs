//! `handover plan`: the power of a protocol's study at several sizes, from whole simulated
//! studies (`src/plan.rs`).

use super::figures::FigureArgs;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use anyhow::Result;
use clap::Args;
use handover::analysis::SEED_MEASURES;
use handover::experiment::ShardManifest;
use handover::output_dir;
use handover::plan::{
    ObjectShareRow, PowerRow, SIGNIFICANCE, StudyObjectRow, StudyRow, object_share_rows, participant, power,
    session_in_memory, session_seconds, simulate_study, study_rows, study_seed,
};
use handover::plot::{PowerSeries, power_plot};
use handover::protocol::Study;
use handover::record::{RecordedSession, new_log_path};
use handover::session::Session;
use handover::study_dir::ParticipantLock;
use rayon::prelude::*;

use super::input::{PopulationArg, bad, count, load_protocol};
use super::simulate::write_csv;

/// Simulated sessions a plan may run (studies × the largest size): the work budget.
pub const MAX_SESSIONS: usize = 200_000;
/// The largest study size planned for.
pub const MAX_PARTICIPANTS: usize = 1000;

/// Plan a study before recruiting: how many participants does the protocol need to find its
/// effect? For each size N, `--studies` whole studies of N simulated participants (drawn from
/// the protocol's `population` section, or its default) are run through the session's own
/// code, counterbalanced as the protocol says, kept in memory, and analysed as `analyze`
/// analyses logs: per training iteration, the two conditions' paired difference in test
/// log-likelihood and in distance to the truth (two-sided Wilcoxon signed-rank over the
/// participants), and the objects each condition offered. The power is the share of studies
/// with p < .05, with its 95 % Wilson interval.
///
/// Studies are nested: study k of N participants is the first N of study k's participants,
/// so every size is planned on the same people.
///
/// Writes: a table on stdout; with --out DIR, studies.csv, study_objects.csv, power.csv,
/// objects.csv and power.svg (docs/outputs.md). With --shard K/N only studies.csv,
/// study_objects.csv and shard.json, for --merge.
#[derive(Debug, Args)]
pub struct PlanArgs {
    /// Protocol (default: the embedded protocols/bike-handover.json).
    #[arg(long, value_name = "FILE")]
    protocol: Option<PathBuf>,
    /// Study sizes to plan for, comma-separated (participants, each 2 to 1000).
    #[arg(long, alias = "participants", value_delimiter = ',', default_value = "5,10,20,40")]
    sizes: Vec<usize>,
    /// Simulated studies per size.
    #[arg(long, default_value_t = 200, value_parser = count(1))]
    studies: usize,
    /// Seed of the whole plan (studies, bodies, λ, answers); the same seed gives
    /// byte-identical files for any --threads and any sharding.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Output folder for the CSVs and the figure.
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Worker threads [default: all cores]; the numbers do not depend on it.
    #[arg(long, value_parser = count(1))]
    threads: Option<usize>,
    /// Also write the first simulated study's sessions (at the largest size) as pilot logs,
    /// LOGS/<id>/<id>_<UTC time>.mcap, so that `analyze LOGS` shows the same study.
    #[arg(long, value_name = "LOGS")]
    keep_logs: Option<PathBuf>,
    /// Run only shard K of N (0-based) of the studies, as one task of a batch scheduler's job
    /// array: writes the shard's rows and DIR/shard.json (--out DIR), to be joined by --merge.
    #[arg(long, value_name = "K/N", conflicts_with_all = ["merge", "keep_logs"])]
    shard: Option<String>,
    /// Join the shard directories of this same command (the same options, each run with
    /// --shard) into exactly what the whole run writes to --out, without running anything.
    #[arg(long, value_name = "DIR", num_args = 1.., conflicts_with = "shard")]
    merge: Vec<PathBuf>,
    /// Whom the simulated participants' λ are drawn from: `protocol` (its `population`
    /// section, or its default), `prior` (the robot's own prior: people as varied as the
    /// robot allows) or a population file (a protocol's `population` section, as `analyze
    /// --fit-population` writes it from a pilot).
    #[arg(long, default_value = "protocol")]
    population: PopulationArg,
    #[command(flatten)]
    figures: FigureArgs,
}

/// The checked sizes (each 2 to [`MAX_PARTICIPANTS`], no repeats, the work within budget):
/// the largest.
fn check(a: &PlanArgs) -> Result<usize> {
    for &n in &a.sizes {
        if !(2..=MAX_PARTICIPANTS).contains(&n) {
            return Err(bad(format!(
                "--sizes has {n}, expected sizes from 2 (a paired test needs pairs) to {MAX_PARTICIPANTS}"
            )));
        }
    }
    let mut sorted = a.sizes.clone();
    sorted.sort_unstable();
    sorted.dedup();
    if sorted.len() != a.sizes.len() {
        return Err(bad("--sizes names a size twice"));
    }
    let Some(&largest) = sorted.last() else {
        return Err(bad("--sizes is empty, expected sizes such as 5,10,20,40"));
    };
    let sessions = a.studies.saturating_mul(largest);
    if sessions > MAX_SESSIONS {
        return Err(bad(format!(
            "--studies × the largest --sizes = {sessions} simulated sessions, over the budget of {MAX_SESSIONS}"
        )));
    }
    Ok(largest)
}

/// What a shard of a plan writes, and its merge reads.
const SHARD_FILES: [&str; 2] = ["studies.csv", "study_objects.csv"];

pub fn run(args: PlanArgs) -> Result<()> {
    args.figures.check()?;
    let largest = check(&args)?;
    let (text, study) = load_protocol(args.protocol.as_deref())?;
    let (text, study) = args.population.apply(text, study)?;
    let from_prior = args.population == PopulationArg::Prior;
    let (pool, threads) = super::progress::worker_pool(args.threads)?;
    let fingerprint = format!(
        "plan protocol {} sizes {:?} studies {} seed {}{}",
        study.sha256,
        args.sizes,
        args.studies,
        args.seed,
        if from_prior { " people from the prior" } else { "" }
    );
    let shard = args.shard.as_deref().map(super::shards::parse_shard).transpose()?;
    // The folder is this run's (its options, and the shard): another run's is refused, a
    // rerun of this one replaces its files.
    let run_id = match shard {
        Some((k, n)) => format!("{fingerprint}; shard {k}/{n}"),
        None => fingerprint.clone(),
    };
    for dir in args.out.iter() {
        output_dir::prepare(dir, "plan", Some(&run_id), &[]).map_err(super::input::output_dir_error)?;
    }
    let started = Instant::now();
    if shard.is_some() && args.out.is_none() {
        return Err(bad("--shard needs --out DIR for the shard's files"));
    }
    let (rows, objects, shards) = if args.merge.is_empty() {
        let indices: Vec<usize> = match shard {
            Some((k, n)) => (0..args.studies).filter(|s| s % n == k).collect(),
            None => (0..args.studies).collect(),
        };
        let (rows, objects) = run_studies(&pool, &text, &study, &args, &indices, largest)?;
        (rows, objects, None)
    } else {
        let (rows, objects, manifests) = merge_shards(&args, &fingerprint, &study)?;
        (rows, objects, Some(manifests))
    };
    if let (Some((k, n)), Some(dir)) = (shard, &args.out) {
        write_csv(&dir.join("studies.csv"), &rows)?;
        write_csv(&dir.join("study_objects.csv"), &objects)?;
        let seconds = started.elapsed().as_secs_f64();
        let manifest = super::shards::manifest(dir, fingerprint, (k, n), rows.len(), &SHARD_FILES, seconds, threads)?;
        super::shards::write_manifest(dir, &manifest)?;
        output_dir::finish(dir, "plan", Some(&run_id), &[])?;
        errln!(
            "shard {k}/{n}: {} rows in {:.1} s; wrote {}/studies.csv, study_objects.csv and shard.json",
            rows.len(),
            started.elapsed().as_secs_f64(),
            dir.display()
        );
        return Ok(());
    }
    let seconds = started.elapsed().as_secs_f64();
    let timing = match &shards {
        None => super::timing(seconds, threads),
        Some(manifests) => super::shards::merged_timing(manifests, seconds),
    };
    let powers = power(&rows);
    let shares = object_share_rows(&objects);
    // The stated duration of one session, from the first study's first participant.
    let (p_text, fitted, p) = participant(&text, &study, study_seed(args.seed, 0), 0, from_prior, &Default::default())
        .map_err(anyhow::Error::msg)?;
    let log = session_in_memory(p_text, fitted, &p).map_err(anyhow::Error::msg)?;
    print_table(&study, &args, &powers, &shares, session_seconds(&log), log.events.len(), &timing)?;
    if let Some(logs) = &args.keep_logs {
        keep_logs(&text, &study, args.seed, largest, from_prior, logs)?;
    }
    if let Some(dir) = &args.out {
        write_csv(&dir.join("studies.csv"), &rows)?;
        write_csv(&dir.join("study_objects.csv"), &objects)?;
        write_csv(&dir.join("power.csv"), &powers)?;
        write_csv(&dir.join("objects.csv"), &shares)?;
        plot(&dir.join("power.svg"), &study, &args, &powers)?;
        output_dir::finish(dir, "plan", Some(&run_id), &[])?;
        errln!(
            "wrote {}/{{studies,study_objects,power,objects}}.csv and {}",
            dir.display(),
            args.figures.style().file_names("power")
        );
    }
    Ok(())
}

/// The given studies, each simulated once at the largest size and measured at every size,
/// in parallel (the rows do not depend on the number of threads), in study order.
fn run_studies(
    pool: &rayon::ThreadPool,
    text: &str,
    study: &Study,
    args: &PlanArgs,
    indices: &[usize],
    largest: usize,
) -> Result<(Vec<StudyRow>, Vec<StudyObjectRow>)> {
    let bar = super::progress::bar("plan", (indices.len() * largest) as u64, "simulated sessions");
    let object_ids: Vec<String> = study.protocol.objects.iter().map(|o| o.id.clone()).collect();
    let bodies = handover::plan::FittedBodies::default();
    let per_study: Vec<_> = pool.install(|| {
        indices
            .par_iter()
            .map(|&k| {
                let sessions = simulate_study(
                    text,
                    study,
                    args.seed,
                    k,
                    largest,
                    args.population == PopulationArg::Prior,
                    &bodies,
                )?;
                bar.inc(largest as u64);
                Ok::<_, handover::plan::PlanError>(study_rows(k, &sessions, &args.sizes, &object_ids))
            })
            .collect::<Result<Vec<_>, _>>()
    })?;
    bar.finish_and_clear();
    let (rows, objects): (Vec<_>, Vec<_>) = per_study.into_iter().unzip();
    Ok((rows.concat(), objects.concat()))
}

/// The rows of every shard of this plan, checked and in the whole run's order.
/// The shards' rows in the whole plan's order, and their manifests.
fn merge_shards(
    args: &PlanArgs,
    fingerprint: &str,
    study: &Study,
) -> Result<(Vec<StudyRow>, Vec<StudyObjectRow>, Vec<ShardManifest>)> {
    // Budgets: a study has at most one row per size × measure × iteration (iterations are
    // at most the protocol's trials per condition + 1) and per size × condition × object.
    let per_study = args.sizes.len() * SEED_MEASURES.len() * (handover::protocol::limits::TRIALS_PER_CONDITION + 1);
    let max_rows = args.studies * per_study;
    let max_objects = args.studies * args.sizes.len() * 2 * handover::protocol::limits::OBJECTS;
    let mut rows: Vec<StudyRow> = Vec::new();
    let mut objects: Vec<StudyObjectRow> = Vec::new();
    let mut manifests = Vec::new();
    for (dir, m) in super::shards::checked_shards(&args.merge, fingerprint, &SHARD_FILES)? {
        let shard_rows: Vec<StudyRow> = read_rows(&dir.join("studies.csv"), max_rows)?;
        super::shards::check_rows(dir, "studies.csv", shard_rows.len(), &m)?;
        rows.extend(shard_rows);
        objects.extend(read_rows::<StudyObjectRow>(&dir.join("study_objects.csv"), max_objects)?);
        manifests.push(m);
        if rows.len() > max_rows || objects.len() > max_objects {
            return Err(bad(format!("the shards hold more rows than a plan of {} studies has", args.studies)));
        }
    }
    let size_rank = |n: usize| args.sizes.iter().position(|&p| p == n);
    let measure_rank = |m: &str| SEED_MEASURES.iter().position(|&s| s == m);
    for r in &rows {
        if r.study >= args.studies || size_rank(r.participants).is_none() || measure_rank(&r.measure).is_none() {
            return Err(bad(format!(
                "studies.csv: study {} at {} participants, measure '{}' is not part of this plan",
                r.study, r.participants, r.measure
            )));
        }
    }
    let object_rank = |o: &str| study.protocol.objects.iter().position(|x| x.id == o);
    rows.sort_by_key(|r| (r.study, size_rank(r.participants), measure_rank(&r.measure), r.iteration));
    // Conditions in name order (as a study's rows have them), objects in the protocol's.
    objects.sort_by(|a, b| {
        (a.study, size_rank(a.participants), &a.condition, object_rank(&a.object)).cmp(&(
            b.study,
            size_rank(b.participants),
            &b.condition,
            object_rank(&b.object),
        ))
    });
    Ok((rows, objects, manifests))
}

/// A shard's CSV, at most `max` rows (the plan's own size is the budget).
fn read_rows<T: serde::de::DeserializeOwned>(path: &Path, max: usize) -> Result<Vec<T>> {
    handover::input_file::read_csv_rows(path, max).map_err(bad)
}

/// The first study's sessions written as pilot logs: the same events, stamped the same, as
/// the plan analysed.
fn keep_logs(text: &str, study: &Study, seed: u64, participants: usize, from_prior: bool, logs: &Path) -> Result<()> {
    let s = study_seed(seed, 0);
    let bodies = handover::plan::FittedBodies::default();
    for i in 0..participants {
        let (p_text, fitted, p) = participant(text, study, s, i, from_prior, &bodies).map_err(anyhow::Error::msg)?;
        let log = session_in_memory(p_text.clone(), Arc::clone(&fitted), &p).map_err(anyhow::Error::msg)?;
        let path = new_log_path(logs, &p.start.participant, chrono::Utc::now());
        let _lock = ParticipantLock::acquire(&logs.join(&p.start.participant), &p.start.participant, "plan")?;
        let session = Session::new(fitted, p.start.clone()).map_err(|e| anyhow::anyhow!("{e}"))?;
        let mut rec = RecordedSession::create(&path, &p_text, session, log.start_time_ns)?;
        for event in log.events {
            rec.submit(event)?;
        }
        rec.finish()?;
    }
    errln!("wrote the first study's {participants} sessions as pilot logs under {}", logs.display());
    Ok(())
}

/// The last training iteration in the rows.
fn last_iteration(powers: &[PowerRow]) -> usize {
    powers.iter().map(|r| r.iteration).max().unwrap_or(0)
}

#[allow(clippy::too_many_arguments)]
fn print_table(
    study: &Study,
    args: &PlanArgs,
    powers: &[PowerRow],
    shares: &[ObjectShareRow],
    session_s: f64,
    events: usize,
    timing: &str,
) -> Result<()> {
    let population = match (&args.population, study.protocol.population.is_some()) {
        (PopulationArg::File(path), _) => format!("{}'s", path.display()),
        (PopulationArg::Prior, _) => "the robot's prior as the".to_string(),
        (_, true) => "the protocol's".to_string(),
        _ => "the default".to_string(),
    };
    outln!(
        "plan: {} studies per size, seed {}, {population} population (simulated people's α = {}), {} particles ({})",
        args.studies,
        args.seed,
        study.population().alpha,
        study.protocol.learning.particles,
        timing
    );
    outln!(
        "one session: {events} logged events, {:.0} min at the stated times (8 s to present a pose, 4 s to take, 6 s a statement, 10 s the choice, 2 s anything else)",
        session_s / 60.0
    );
    let last = last_iteration(powers);
    let find = |n: usize, measure: &str| {
        powers.iter().find(|r| r.participants == n && r.measure == measure && r.iteration == last)
    };
    let first = powers.first().map_or("first", |r| r.first.as_str());
    let second = powers.first().map_or("second", |r| r.second.as_str());
    outln!(
        "after {last} training handovers per condition, {first} − {second}; power: share of studies with p < {SIGNIFICANCE} [95 % Wilson interval]; effect: mean over studies [2.5–97.5 % of studies]"
    );
    outln!(
        "{:>12} {:>24} {:>28} {:>24} {:>28} {:>14}",
        "participants",
        "test log-lik: power",
        "effect (nats)",
        "distance: power",
        "effect (deg)",
        "session hours"
    );
    for &n in &args.sizes {
        let cell = |r: Option<&PowerRow>| {
            r.map_or((String::from("—"), String::from("—")), |r| {
                (
                    format!("{:.0} % [{:.0}, {:.0}]", r.power * 100.0, r.power_low * 100.0, r.power_high * 100.0),
                    format!("{:+.2} [{:+.2}, {:+.2}]", r.mean_effect, r.effect_q025, r.effect_q975),
                )
            })
        };
        let (ll_p, ll_e) = cell(find(n, "test_log_likelihood"));
        let (d_p, d_e) = cell(find(n, "distance_to_truth_deg"));
        outln!("{n:>12} {ll_p:>24} {ll_e:>28} {d_p:>24} {d_e:>28} {:>14.1}", n as f64 * session_s / 3600.0);
    }
    let n = args.sizes[0];
    let offered: Vec<String> = shares
        .iter()
        .filter(|s| s.participants == n)
        .map(|s| format!("{} {} {:.0} %", s.condition, s.object, s.mean_share * 100.0))
        .collect();
    outln!("objects offered in training (mean share over studies): {}", offered.join(", "));
    Ok(())
}

fn plot(path: &Path, study: &Study, args: &PlanArgs, powers: &[PowerRow]) -> Result<()> {
    let last = last_iteration(powers);
    let label = |measure: &str| match measure {
        "test_log_likelihood" => "test log-likelihood",
        _ => "distance to the truth",
    };
    let names: Vec<String> = SEED_MEASURES
        .iter()
        .map(|m| {
            let r = powers.iter().find(|r| r.measure == *m);
            let (a, b) = r.map_or(("first", "second"), |r| (r.first.as_str(), r.second.as_str()));
            format!("{} ({a} ≠ {b}), iteration {last}", label(m))
        })
        .collect();
    let series: Vec<PowerSeries> = SEED_MEASURES
        .iter()
        .zip(&names)
        .map(|(m, name)| PowerSeries {
            name,
            points: powers
                .iter()
                .filter(|r| r.measure == *m && r.iteration == last)
                .map(|r| (r.participants as f64, r.power, r.power_low, r.power_high))
                .collect(),
        })
        .collect();
    let title = format!(
        "Power of {} over {} simulated studies per size (two-sided Wilcoxon, p < {SIGNIFICANCE})",
        study.protocol.name, args.studies
    );
    power_plot(path, &args.figures.style(), &title, "95 % Wilson interval", &series)?;
    Ok(())
}
