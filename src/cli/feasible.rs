//! `handover feasible`: the feasible sets of a protocol's queries, as JSON, CSV or plots.

use super::figures::FigureArgs;
use std::io::Write;
use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::{Args, ValueEnum};
use handover::kinematics::{HumanArm, JOINT_NAMES};
use handover::plot::{FigureStyle, PointGroup, ScatterPanel, scatter_grid};
use handover::protocol::{ResolvedQuery, Study};
use serde::Serialize;

use super::input::{bad, load_study};

/// List every feasible arm configuration of a protocol's queries: all IK solutions of all
/// discretised grasps of the offered grip regions, labelled by region.
#[derive(Debug, Args)]
pub struct FeasibleArgs {
    /// Protocol file (default: the embedded protocols/bike-handover.json).
    #[arg(long, value_name = "FILE")]
    protocol: Option<PathBuf>,
    /// Only this query (an id from training_menu or test_set).
    #[arg(long, value_name = "ID")]
    query: Option<String>,
    /// Output on stdout: `table` (per query, its configurations per grip), `json` (nested,
    /// with arm points) or `csv` (one row per configuration: its index in the query's feasible
    /// set — the `config_index` of the logs — region id and label, joint angles in radians,
    /// arm points in metres).
    #[arg(long, value_enum, default_value_t = Format::Table)]
    format: Format,
    /// Also write one SVG per query into DIR: 2-D projections of the feasible set in
    /// configuration space, coloured by region (as the paper's Fig. 5, 6 and 9).
    #[arg(long, value_name = "DIR")]
    plot: Option<PathBuf>,
    #[command(flatten)]
    figures: FigureArgs,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
enum Format {
    Table,
    Json,
    Csv,
}

#[derive(Serialize)]
struct Output<'a> {
    protocol: &'a str,
    upper_arm: f64,
    forearm: f64,
    hand: f64,
    joints: [&'static str; 7],
    limits: Vec<[f64; 2]>,
    queries: Vec<QueryOut<'a>>,
}

#[derive(Serialize)]
struct QueryOut<'a> {
    id: &'a str,
    object: &'a str,
    regions: Vec<&'a str>,
    configs: Vec<ConfigOut<'a>>,
}

#[derive(Serialize)]
struct ConfigOut<'a> {
    region: &'a str,
    q: [f64; 7],
    points: Points,
}

#[derive(Serialize)]
struct Points {
    shoulder: [f64; 3],
    elbow: [f64; 3],
    wrist: [f64; 3],
    hand: [f64; 3],
}

fn points(arm: &HumanArm, q: &[f64; 7]) -> Points {
    let [s, e, w, h] = arm.points(q).map(|p| [p.x, p.y, p.z]);
    Points { shoulder: s, elbow: e, wrist: w, hand: h }
}

fn region_ids<'a>(study: &'a Study, q: &ResolvedQuery) -> Vec<&'a str> {
    let object = study.object(q);
    q.regions.iter().map(|&r| object.regions[r].id.as_str()).collect()
}

pub fn run(args: FeasibleArgs) -> Result<()> {
    args.figures.check()?;
    let study = load_study(args.protocol.as_deref())?;
    let queries: Vec<&ResolvedQuery> = match &args.query {
        Some(id) => vec![study.query(id).ok_or_else(|| {
            let ids: Vec<_> = study.all_queries().map(|q| q.query.id.as_str()).collect();
            bad(format!("--query: unknown query '{id}', expected one of: {}", ids.join(", ")))
        })?],
        None => study.all_queries().collect(),
    };
    let arm = &study.arm;
    let mut stdout = std::io::stdout().lock();
    match args.format {
        Format::Table => {
            drop(stdout);
            print_table(&study, &queries)?;
        }
        Format::Json => {
            let out = Output {
                protocol: &study.protocol.name,
                upper_arm: arm.upper_arm,
                forearm: arm.forearm,
                hand: arm.hand,
                joints: JOINT_NAMES,
                limits: arm.limits.to_vec(),
                queries: queries
                    .iter()
                    .map(|q| {
                        let regions = region_ids(&study, q);
                        QueryOut {
                            id: &q.query.id,
                            object: &q.query.object,
                            configs: q
                                .feasible
                                .configs
                                .iter()
                                .map(|c| ConfigOut { region: regions[c.region], q: c.q, points: points(arm, &c.q) })
                                .collect(),
                            regions,
                        }
                    })
                    .collect(),
            };
            serde_json::to_writer_pretty(&mut stdout, &out)?;
            writeln!(stdout)?;
        }
        Format::Csv => {
            let mut w = csv::Writer::from_writer(&mut stdout);
            let mut header = ["query", "object", "config_index", "region", "region_label"].map(String::from).to_vec();
            header.extend(JOINT_NAMES.iter().map(|n| format!("q_{n}_rad")));
            for p in ["shoulder", "elbow", "wrist", "hand"] {
                header.extend(["x", "y", "z"].iter().map(|a| format!("{p}_{a}_m")));
            }
            w.write_record(&header)?;
            for q in &queries {
                let regions = region_ids(&study, q);
                let object = study.object(q);
                for (k, c) in q.feasible.configs.iter().enumerate() {
                    let mut row = vec![
                        q.query.id.clone(),
                        q.query.object.clone(),
                        k.to_string(),
                        regions[c.region].to_string(),
                        object.regions[q.regions[c.region]].label.clone(),
                    ];
                    row.extend(c.q.iter().map(|v| v.to_string()));
                    for p in arm.points(&c.q) {
                        row.extend([p.x, p.y, p.z].iter().map(|v| v.to_string()));
                    }
                    w.write_record(&row)?;
                }
            }
            w.flush()?;
        }
    }
    if let Some(dir) = &args.plot {
        handover::private_files::create_dir(dir).with_context(|| format!("cannot create {}", dir.display()))?;
        for q in &queries {
            let path = dir.join(format!("{}.svg", q.query.id));
            let style = args.figures.style();
            plot_query(&study, q, &path, &style)?;
            errln!("wrote {}", dir.join(style.file_names(&q.query.id)).display());
        }
    }
    Ok(())
}

/// Per query, its configurations per grip: what a protocol designer reads first.
fn print_table(study: &Study, queries: &[&ResolvedQuery]) -> Result<()> {
    outln!(
        "{}: feasible arm configurations per query (--format json or csv for the configurations)",
        study.protocol.name
    );
    outln!("{:<28} {:<12} {:>14}  per grip", "query", "object", "configurations");
    for q in queries {
        let object = study.object(q);
        let per_grip: Vec<String> = q
            .regions
            .iter()
            .enumerate()
            .map(|(r, &region)| {
                let n = q.feasible.configs.iter().filter(|c| c.region == r).count();
                format!("{} {n}", object.regions[region].id)
            })
            .collect();
        outln!("{:<28} {:<12} {:>14}  {}", q.query.id, q.query.object, q.feasible.configs.len(), per_grip.join(" · "));
    }
    Ok(())
}

/// Joint pairs drawn for each query (indices into the joint order).
const PROJECTIONS: [(usize, usize); 4] = [(0, 1), (0, 2), (3, 4), (5, 6)];

fn plot_query(
    study: &Study,
    q: &ResolvedQuery,
    path: &std::path::Path,
    style: &FigureStyle,
) -> Result<(), handover::plot::PlotError> {
    let object = study.object(q);
    let labels: Vec<String> = q.regions.iter().map(|&r| object.regions[r].label.clone()).collect();
    let axis: Vec<String> = JOINT_NAMES.iter().map(|n| format!("{} (deg)", n.replace('_', " "))).collect();
    let panels: Vec<ScatterPanel> = PROJECTIONS
        .iter()
        .map(|&(a, b)| ScatterPanel {
            x_label: &axis[a],
            y_label: &axis[b],
            groups: labels
                .iter()
                .enumerate()
                .map(|(r, name)| PointGroup {
                    name,
                    points: q
                        .feasible
                        .configs
                        .iter()
                        .filter(|c| c.region == r)
                        .map(|c| (c.q[a].to_degrees(), c.q[b].to_degrees()))
                        .collect(),
                })
                .collect(),
        })
        .collect();
    let title = format!("{}: {} ({} configurations)", q.query.id, object.label, q.feasible.configs.len());
    scatter_grid(path, style, &title, &panels, 2).map(drop)
}
