//! Every CSV the program writes, read back with the `csv` crate and checked against the data
//! dictionary `docs/outputs.md`: the header is the documented columns in order, and every
//! value has its column's documented type.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::Arc;
use std::time::Duration;

use handover::dryrun::{drive, now_ns, plan_from};
use handover::protocol::Study;
use handover::record::{RecordedSession, new_log_path};
use handover::session::{Event, Session, Stamped, VoidReason};

/// The binary under umask 000, so that every file and folder it writes must set its own
/// owner-only mode.
fn handover(args: &[&str]) -> std::process::Output {
    let out = Command::new("sh")
        .arg("-c")
        .arg("umask 000; exec \"$0\" \"$@\"")
        .arg(env!("CARGO_BIN_EXE_handover"))
        .args(args)
        .output()
        .unwrap();
    assert!(out.status.success(), "handover {args:?}: {}", String::from_utf8_lossy(&out.stderr));
    out
}

fn mode(p: &Path) -> u32 {
    use std::os::unix::fs::PermissionsExt;
    std::fs::metadata(p).unwrap().permissions().mode() & 0o777
}

/// (file name → [(column, type)]) from the dictionary's tables.
pub(crate) fn dictionary() -> BTreeMap<String, Vec<(String, String)>> {
    let text = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/outputs.md")).unwrap();
    let mut files: BTreeMap<String, Vec<(String, String)>> = BTreeMap::new();
    let mut current = None;
    for line in text.lines() {
        if let Some(h) = line.strip_prefix("### `") {
            let name = h.split('`').next().unwrap().to_string();
            files.insert(name.clone(), Vec::new());
            current = Some(name);
        } else if let (Some(name), Some(row)) = (&current, line.strip_prefix("| `")) {
            let cells: Vec<&str> = row.split('|').map(str::trim).collect();
            let column = cells[0].trim_end_matches('`').to_string();
            files.get_mut(name).unwrap().push((column, cells[1].to_string()));
        }
    }
    files
}

fn check_value(file: &str, column: &str, kind: &str, value: &str) {
    let (kind, optional) = kind.strip_suffix('?').map_or((kind, false), |k| (k, true));
    if value.is_empty() {
        assert!(optional, "{file}: {column} is empty, documented as a required {kind}");
        return;
    }
    let ok = match kind {
        "string" => true,
        "integer" => value.parse::<i64>().is_ok(),
        "number" => value.parse::<f64>().is_ok_and(f64::is_finite),
        "boolean" => value == "TRUE" || value == "FALSE",
        "time" => chrono::DateTime::parse_from_rfc3339(value).is_ok() && value.ends_with('Z'),
        other => panic!("{file}: {column} has the undocumented type {other}"),
    };
    assert!(ok, "{file}: {column} = {value:?} is not a {kind}");
}

fn check_csv(path: &Path, name: &str, dict: &BTreeMap<String, Vec<(String, String)>>) -> usize {
    let columns = dict.get(name).unwrap_or_else(|| panic!("{name} is not in docs/outputs.md"));
    let mut reader = csv::Reader::from_path(path).unwrap();
    let header: Vec<String> = reader.headers().unwrap().iter().map(String::from).collect();
    let documented: Vec<&String> = columns.iter().map(|(c, _)| c).collect();
    assert_eq!(header.iter().collect::<Vec<_>>(), documented, "{}: header vs docs/outputs.md", path.display());
    let mut rows = 0;
    for record in reader.records() {
        let record = record.unwrap();
        assert_eq!(record.len(), columns.len(), "{}: row {rows}", path.display());
        for ((column, kind), value) in columns.iter().zip(record.iter()) {
            check_value(name, column, kind, value);
        }
        rows += 1;
    }
    rows
}

/// The line of docs/outputs.md that says how to read `name` with its documented types, none
/// guessed, in pandas and in R: pandas with every text column `string`, the dtypes an empty
/// field needs (`Int64`, `boolean`), the times parsed and only an empty field missing; readr
/// with the types spelled out (`col_types`) and `na = ""`; read.csv with the text columns
/// named and `na.strings = ""`.
pub(crate) fn read_line(name: &str, columns: &[(String, String)]) -> String {
    let dtypes: Vec<String> = columns
        .iter()
        .filter_map(|(c, k)| match k.as_str() {
            "string" | "string?" => Some(format!("\"{c}\": \"string\"")),
            "integer?" => Some(format!("\"{c}\": \"Int64\"")),
            "boolean?" => Some(format!("\"{c}\": \"boolean\"")),
            _ => None,
        })
        .collect();
    let dates: Vec<String> =
        columns.iter().filter(|(_, k)| k.starts_with("time")).map(|(c, _)| format!("\"{c}\"")).collect();
    let mut pandas = format!("pd.read_csv(\"{name}\"");
    if !dtypes.is_empty() {
        pandas += &format!(", dtype={{{}}}", dtypes.join(", "));
    }
    pandas += ", keep_default_na=False, na_values=[\"\"]";
    if !dates.is_empty() {
        pandas += &format!(", parse_dates=[{}]", dates.join(", "));
    }
    pandas += ")";
    let spec: String = columns
        .iter()
        .map(|(_, k)| match k.trim_end_matches('?') {
            "string" => 'c',
            "integer" | "number" => 'd',
            "boolean" => 'l',
            "time" => 'T',
            other => panic!("{name}: the undocumented type {other}"),
        })
        .collect();
    let readr = format!("readr::read_csv(\"{name}\", col_types = \"{spec}\", na = \"\")");
    let texts: Vec<String> =
        columns.iter().filter(|(_, k)| k.starts_with("string")).map(|(c, _)| format!("{c} = \"character\"")).collect();
    let base = if texts.is_empty() {
        format!("read.csv(\"{name}\", na.strings = \"\")")
    } else {
        format!("read.csv(\"{name}\", na.strings = \"\", colClasses = c({}))", texts.join(", "))
    };
    format!("Read: `{pandas}`; R: `{readr}` or `{base}`.")
}

#[test]
fn the_dictionary_says_how_to_read_every_file() {
    let text = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/outputs.md")).unwrap();
    let missing: Vec<String> = dictionary()
        .iter()
        .map(|(name, columns)| read_line(name, columns))
        .filter(|line| !text.lines().any(|l| l == line))
        .collect();
    assert!(missing.is_empty(), "docs/outputs.md lacks:\n{}", missing.join("\n"));
}

/// The classes R gives a documented type: (read.csv's, readr's). An optional column that is
/// empty throughout reads as logical in both.
fn r_classes(kind: &str) -> (&'static [&'static str], &'static [&'static str]) {
    match kind.trim_end_matches('?') {
        "string" => (&["character"], &["character"]),
        // read.csv gives integer up to 2^31 and numeric beyond; readr reads every number as a double.
        "integer" => (&["integer", "numeric"], &["numeric"]),
        // A column of whole numbers (the shoulder at 0 m) reads as integer with read.csv.
        "number" => (&["numeric", "integer"], &["numeric"]),
        // read.csv reads true/false as text unless told `colClasses = "logical"`, as the
        // dictionary's read lines do.
        "boolean" => (&["logical"], &["logical"]),
        "time" => (&["character"], &["POSIXct"]),
        other => panic!("the undocumented type {other}"),
    }
}

/// A reader's KEPT line (every value kept: counted) or ROWS line (a table without rows, whose
/// columns have no values to type: noted).
fn tally(line: &str, kept: &mut usize, no_rows: &mut Vec<String>) {
    match line.split('\t').collect::<Vec<_>>().as_slice() {
        ["KEPT", file, reader, cells, lost] => {
            assert_eq!(*lost, "0", "{file}: {reader} lost {lost} of {cells} values (or made a value missing)");
            *kept += cells.parse::<usize>().unwrap();
        }
        ["ROWS", file, "0"] => no_rows.push(file.to_string()),
        ["ROWS", _, _] => {}
        _ => panic!("unexpected line from a reader: {line}"),
    }
}

/// A seed column as a reader read it (`;`-joined decimal text) is the file's text exactly.
fn assert_seeds_exact(file: &str, column: &str, values: &str, by: &str) {
    let mut reader = csv::Reader::from_path(file).unwrap();
    let at = reader.headers().unwrap().iter().position(|h| h == column).unwrap();
    let written: Vec<String> = reader.records().map(|r| r.unwrap()[at].to_string()).collect();
    let read: Vec<&str> = values.split(';').collect();
    assert_eq!(read.len(), written.len(), "{file}: {column} as {by} reads it");
    for (r, w) in read.iter().zip(&written) {
        // A format-1 log's seed may be 2^53 or more: docs/outputs.md says to read it as text
        // in R, whose numbers are doubles.
        let beyond_doubles = by == "R" && w.parse::<u64>().is_ok_and(|x| x >= 1 << 53);
        assert!(r == w || beyond_doubles, "{file}: {column} as {by} reads it: {r}, written {w}");
    }
}

/// Reads every file with R's `read.csv` and readr as the dictionary's read lines do
/// (`tests/readers/read_csv_types.R`, with the Rscript of HANDOVER_RSCRIPT, which `.ci/run`
/// sets) and checks each column's class against its documented type, and that seeds read as
/// their exact decimal text, and that every value is kept (only an empty field missing); the
/// cells read, counted. A missing HANDOVER_RSCRIPT fails under CI (`support::missing`).
pub(crate) fn read_with_r(paths: &[PathBuf], dict: &BTreeMap<String, Vec<(String, String)>>) -> usize {
    let Ok(rscript) = std::env::var("HANDOVER_RSCRIPT") else {
        crate::support::missing("HANDOVER_RSCRIPT (R with readr; the CSVs were not read with R)");
        return 0;
    };
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/readers/read_csv_types.R");
    let mut args = Vec::new();
    for path in paths {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let line = read_line(&name, &dict[&name]);
        let calls: Vec<&str> = line.split('`').collect();
        args.push(path.display().to_string());
        args.push(calls[3].to_string());
        args.push(calls[5].to_string());
    }
    let out = Command::new(&rscript).arg(&script).args(&args).output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{rscript}: {}", String::from_utf8_lossy(&out.stderr));
    let mut columns = 0;
    let mut seeds = 0;
    let mut kept = 0;
    let mut no_rows: Vec<String> = Vec::new();
    for line in text.lines() {
        let cells: Vec<&str> = line.split('\t').collect();
        match cells.as_slice() {
            ["PROBLEM", file, what @ ..] => panic!("readr could not parse {file}: {what:?}"),
            ["KEPT" | "ROWS", ..] => tally(line, &mut kept, &mut no_rows),
            ["SEED", file, column, values] => {
                assert_seeds_exact(file, column, values, "R");
                seeds += 1;
            }
            [file, column, base, readr, empty] => {
                let name = Path::new(file).file_name().unwrap().to_string_lossy().into_owned();
                let kind = &dict[&name].iter().find(|(c, _)| c == column).unwrap().1;
                let (bases, readrs) = r_classes(kind);
                let all_empty = *empty == "TRUE" && kind.ends_with('?');
                // A table without rows has no values to type.
                let rowless = no_rows.iter().any(|f| f == file);
                let ok =
                    |classes: &[&str], got: &str| rowless || classes.contains(&got) || (all_empty && got == "logical");
                assert!(ok(bases, base), "{name}: {column} ({kind}) reads as {base} with read.csv");
                assert!(ok(readrs, readr), "{name}: {column} ({kind}) reads as {readr} with readr");
                columns += 1;
            }
            _ => panic!("unexpected line from R: {line}"),
        }
    }
    let documented: usize =
        paths.iter().map(|p| dict[&p.file_name().unwrap().to_string_lossy().into_owned()].len()).sum();
    assert_eq!(columns, documented, "every column of every file read by R");
    assert!(seeds >= 1, "{seeds} seed columns");
    kept
}

/// Whether pandas reads a documented type as `dtype` (an optional column empty throughout
/// reads as float64 whatever it holds).
fn pandas_reads(kind: &str, dtype: &str, all_empty: bool) -> bool {
    // An optional column empty throughout has no values to type: float64, or a time column
    // parsed to a datetime without a zone.
    if all_empty && kind.ends_with('?') && (dtype == "float64" || dtype.starts_with("datetime64[")) {
        return true;
    }
    match kind {
        "string" | "string?" => ["object", "str", "string"].contains(&dtype),
        "integer" => dtype == "int64",
        "integer?" => dtype == "Int64",
        // A column of whole numbers (the shoulder at 0 m) reads as int64.
        "number" | "number?" => dtype == "float64" || dtype == "int64",
        "boolean" => dtype == "bool",
        "boolean?" => dtype == "boolean",
        "time" | "time?" => dtype.starts_with("datetime64[") && dtype.ends_with(", UTC]"),
        other => panic!("the undocumented type {other}"),
    }
}

/// Reads every file with pandas as the dictionary's read lines do
/// (`tests/readers/read_csv_pandas.py`, with HANDOVER_PYTHON, into which `.ci/run` installs
/// pandas) and checks each column's dtype against its documented type, and that seeds read
/// exactly. Without HANDOVER_PYTHON, says so and passes; one without pandas fails.
pub(crate) fn read_with_pandas(paths: &[PathBuf], dict: &BTreeMap<String, Vec<(String, String)>>) -> usize {
    let Ok(python) = std::env::var("HANDOVER_PYTHON") else {
        crate::support::missing("HANDOVER_PYTHON (a Python with pandas; the CSVs were not read with pandas)");
        return 0;
    };
    let has_pandas = Command::new(&python).args(["-c", "import pandas"]).output().is_ok_and(|o| o.status.success());
    assert!(has_pandas, "HANDOVER_PYTHON ({python}) has no pandas: install it there, as .ci/run does");
    let mut args = Vec::new();
    for path in paths {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let line = read_line(&name, &dict[&name]);
        let expression = line.split('`').nth(1).unwrap().to_string();
        args.push(path.display().to_string());
        args.push(expression);
    }
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/readers/read_csv_pandas.py");
    let out = Command::new(&python).arg(&script).args(&args).output().unwrap();
    assert!(out.status.success(), "{python}: {}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8_lossy(&out.stdout);
    let (mut columns, mut seeds, mut kept) = (0, 0, 0);
    let mut no_rows: Vec<String> = Vec::new();
    for line in text.lines() {
        match line.split('\t').collect::<Vec<_>>().as_slice() {
            ["KEPT" | "ROWS", ..] => tally(line, &mut kept, &mut no_rows),
            ["SEED", file, column, values] => {
                assert_seeds_exact(file, column, values, "pandas");
                seeds += 1;
            }
            [file, column, dtype, empty] => {
                let name = Path::new(file).file_name().unwrap().to_string_lossy().into_owned();
                let kind = &dict[&name].iter().find(|(c, _)| c == column).unwrap().1;
                // A table without rows has no values to type.
                let rowless = no_rows.iter().any(|f| f == file);
                assert!(
                    rowless || pandas_reads(kind, dtype, *empty == "True"),
                    "{name}: {column} ({kind}) reads as {dtype}"
                );
                columns += 1;
            }
            _ => panic!("unexpected line from pandas: {line}"),
        }
    }
    let documented: usize =
        paths.iter().map(|p| dict[&p.file_name().unwrap().to_string_lossy().into_owned()].len()).sum();
    assert_eq!(columns, documented, "every column of every file read by pandas");
    assert!(seeds >= 1, "{seeds} seed columns");
    kept
}

/// Two sessions: one as dry runs are, one with a note, an undo and a void.
fn logs(dir: &Path) {
    let mut v: serde_json::Value = serde_json::from_str(handover::protocol::DEFAULT_PROTOCOL).unwrap();
    v["learning"]["particles"] = 300.into();
    let text = v.to_string();
    let study = Arc::new(Study::from_json(&text, "small").unwrap());
    for i in 0..2 {
        let p = plan_from(&study, &study.prior_population(), 5, i, None, "2026-11-22T00:00:00Z".into());
        let session = Session::new(Arc::clone(&study), p.start.clone()).unwrap();
        let path = new_log_path(dir, &p.start.participant, chrono::Utc::now());
        let mut rec = RecordedSession::create(&path, &text, session, now_ns()).unwrap();
        if i == 1 {
            let mut t = now_ns();
            let mut submit = |rec: &mut RecordedSession, event| {
                t += 1_000_000_000;
                rec.submit(Stamped { time_ns: t, event }).unwrap();
            };
            // A robot in the loop for the first trial: its command, then moving and at_pose.
            let command =
                handover::robot::command_for(rec.session(), &handover::robot::RobotSettings::default()).unwrap();
            submit(&mut rec, command.event(handover::session::RobotLinkKind::Ros2));
            for state in [handover::session::RobotState::Moving, handover::session::RobotState::AtPose] {
                submit(&mut rec, command.report(state, "").event());
            }
            for _ in 0..2 {
                let e = p.participant.respond(rec.session()).unwrap();
                submit(&mut rec, e);
            }
            submit(&mut rec, Event::Note { text: "asked to repeat, \"twice\"".into() });
            submit(&mut rec, Event::GraspUndone);
            submit(&mut rec, Event::TrialVoided { reason: VoidReason::Other, detail: "phone rang, 2 min".into() });
        }
        drive(&mut rec, &p.participant, Duration::ZERO).unwrap();
        rec.finish().unwrap();
    }
}

fn csv_files(dir: &Path) -> Vec<PathBuf> {
    let mut out: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "csv"))
        .collect();
    out.sort();
    out
}

#[test]
fn every_csv_matches_the_data_dictionary() {
    let dict = dictionary();
    assert!(dict.len() >= 17, "{:?}", dict.keys());
    let dir = std::env::temp_dir().join(format!("handover-outputs-{}", std::process::id()));
    let sim = ["--trials", "2", "--test-size", "10", "--particles", "100"];
    let _ = std::fs::remove_dir_all(&dir);
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let logs_dir = dir.join("logs");
    logs(&logs_dir);
    // One sample of a motion-capture file, far from every grasp: the re-fit learns from the
    // regions and writes its table all the same.
    let mut columns = vec!["time".to_string()];
    columns.extend(handover::kinematics::JOINT_NAMES.iter().map(|j| format!("{j}_deg")));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("mocap.csv"), format!("{}\n1.0,10,20,30,40,50,60,70\n", columns.join(","))).unwrap();
    handover(
        &[
            &["analyze", "--alpha-particles", "200", &s(&logs_dir), "--out", &s(&dir.join("analyze"))][..],
            &["--measurements", &s(&dir.join("mocap.csv")), "--sigma-deg", "5", "--fit-population"][..],
        ]
        .concat(),
    );
    handover(
        &[
            &["research", "observations", "--scenarios", "planar2", "--seeds", "2", "--sigma-deg", "5"][..],
            &["--out", &s(&dir.join("observations"))][..],
            &sim[..],
        ]
        .concat(),
    );
    handover(
        &[&["research", "simulate", "planar2", "--seeds", "2", "--out", &s(&dir.join("sim"))][..], &sim[..]].concat(),
    );
    handover(&[&["research", "simulate", "two-sets", "--out", &s(&dir.join("two"))][..], &sim[..]].concat());
    handover(
        &[
            &["research", "front", "--scenarios", "planar2", "--learn", "q-star", "--seeds", "2", "--betas", "0.1"][..],
            &["--epsilons", "0.25", "--out", &s(&dir.join("front"))][..],
            &sim[..],
        ]
        .concat(),
    );
    handover(&[
        "plan",
        "--sizes",
        "2,3",
        "--studies",
        "2",
        "--out",
        &s(&dir.join("plan")),
        "--figure-formats",
        "svg,pdf,png",
        "--figure-width",
        "one-column",
    ]);
    for format in ["svg", "pdf", "png"] {
        assert!(dir.join("plan").join(format!("power.{format}")).is_file(), "power.{format}");
    }
    handover(&["feasible", "--query", "lock-low-upright", "--plot", &s(&dir.join("feasible"))]);
    // Under umask 000, every file written is still 0600 and every folder 0700.
    let mut modes = 0;
    for folder in ["analyze", "sim", "two", "front", "observations", "plan", "feasible"] {
        let mut stack = vec![dir.join(folder)];
        while let Some(d) = stack.pop() {
            assert_eq!(mode(&d), 0o700, "{}", d.display());
            for e in std::fs::read_dir(&d).unwrap().flatten() {
                if e.file_type().unwrap().is_dir() {
                    stack.push(e.path());
                } else {
                    assert_eq!(mode(&e.path()), 0o600, "{}", e.path().display());
                    modes += 1;
                }
            }
        }
    }
    assert!(modes >= 30, "{modes} files");
    let feasible = handover(&["feasible", "--format", "csv", "--query", "lock-low-upright"]);
    std::fs::write(dir.join("feasible.csv"), feasible.stdout).unwrap();

    let mut checked: BTreeMap<String, usize> = BTreeMap::new();
    let mut paths = Vec::new();
    for folder in ["analyze/pilot", "sim", "two", "front", "observations", "plan"] {
        for path in csv_files(&dir.join(folder)) {
            let name = path.file_name().unwrap().to_string_lossy().into_owned();
            let rows = check_csv(&path, &name, &dict);
            *checked.entry(name).or_default() += rows;
            paths.push(path);
        }
    }
    checked.insert("feasible.csv".into(), check_csv(&dir.join("feasible.csv"), "feasible.csv", &dict));
    paths.push(dir.join("feasible.csv"));
    read_with_r(&paths, &dict);
    read_with_pandas(&paths, &dict);
    let undocumented: Vec<_> = dict.keys().filter(|k| !checked.contains_key(*k)).collect();
    assert!(undocumented.is_empty(), "documented but not written: {undocumented:?}");
    for (name, rows) in &checked {
        assert!(*rows > 0, "{name} has no rows");
    }
    // Fig. 10's paired differences: the median and the share of participants with the first
    // condition higher, recomputed from the per-session test log-likelihoods.
    let read = |file: &str| {
        let mut r = csv::Reader::from_path(dir.join("analyze/pilot").join(file)).unwrap();
        let head: Vec<String> = r.headers().unwrap().iter().map(String::from).collect();
        let rows: Vec<BTreeMap<String, String>> =
            r.records().map(|x| head.iter().cloned().zip(x.unwrap().iter().map(String::from)).collect()).collect();
        rows
    };
    let lls = read("test_log_likelihood.csv");
    for t in read("fig10_tests.csv") {
        let at = |session: &str, condition: &str| -> f64 {
            lls.iter()
                .find(|r| r["session_id"] == session && r["condition"] == condition && r["iteration"] == t["iteration"])
                .unwrap()["log_likelihood_mean"]
                .parse()
                .unwrap()
        };
        let mut sessions: Vec<&str> = lls.iter().map(|r| r["session_id"].as_str()).collect();
        sessions.dedup();
        let mut d: Vec<f64> = sessions.iter().map(|s| at(s, &t["first"]) - at(s, &t["second"])).collect();
        d.sort_by(f64::total_cmp);
        let median = if d.len() % 2 == 1 { d[d.len() / 2] } else { (d[d.len() / 2 - 1] + d[d.len() / 2]) / 2.0 };
        let share = d.iter().filter(|x| **x > 0.0).count() as f64 / d.len() as f64;
        let got = |c: &str| t[c].parse::<f64>().unwrap();
        assert!((got("median_difference") - median).abs() < 1e-9, "{t:?} vs {d:?}");
        assert_eq!(got("share_first_higher"), share, "{t:?}");
    }
    // The trial that was voided after an undo, and the note, are in the tables.
    let trials = std::fs::read_to_string(dir.join("analyze/pilot/trials.csv")).unwrap();
    assert!(trials.contains(",undone,") && trials.contains(",voided,"), "{trials}");
    assert!(trials.contains("other,\"phone rang, 2 min\""), "{trials}");
    let robot = std::fs::read_to_string(dir.join("analyze/pilot/robot.csv")).unwrap();
    let first = robot.lines().nth(1).unwrap_or_default();
    assert!(first.contains(",ros2,shoulder,") && first.contains(",at_pose,") && first.ends_with(",2,0"), "{robot}");
    let notes = std::fs::read_to_string(dir.join("analyze/pilot/notes.csv")).unwrap();
    assert!(notes.contains("\"asked to repeat, \"\"twice\"\"\""), "{notes}");
    let _ = std::fs::remove_dir_all(&dir);
}
