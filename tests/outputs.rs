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
fn dictionary() -> BTreeMap<String, Vec<(String, String)>> {
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
        "boolean" => value == "true" || value == "false",
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
                let report = handover::robot::Report { query: command.query.clone(), state, detail: String::new() };
                submit(&mut rec, report.event());
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
            &["--measurements", &s(&dir.join("mocap.csv")), "--sigma-deg", "5"][..],
        ]
        .concat(),
    );
    handover(
        &[
            &["observations", "--scenarios", "planar2", "--seeds", "2", "--sigmas-deg", "5"][..],
            &["--out", &s(&dir.join("observations"))][..],
            &sim[..],
        ]
        .concat(),
    );
    handover(&[&["simulate", "planar2", "--seeds", "2", "--out", &s(&dir.join("sim"))][..], &sim[..]].concat());
    handover(&[&["simulate", "two-sets", "--out", &s(&dir.join("two"))][..], &sim[..]].concat());
    handover(
        &[
            &["front", "--scenarios", "planar2", "--learn", "q-star", "--seeds", "2", "--betas", "0.1"][..],
            &["--epsilons", "0.25", "--out", &s(&dir.join("front"))][..],
            &sim[..],
        ]
        .concat(),
    );
    handover(&["plan", "--participants", "2,3", "--studies", "2", "--out", &s(&dir.join("plan"))]);
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
    for folder in ["analyze/pilot", "sim", "two", "front", "observations", "plan"] {
        for path in csv_files(&dir.join(folder)) {
            let name = path.file_name().unwrap().to_string_lossy().into_owned();
            let rows = check_csv(&path, &name, &dict);
            *checked.entry(name).or_default() += rows;
        }
    }
    checked.insert("feasible.csv".into(), check_csv(&dir.join("feasible.csv"), "feasible.csv", &dict));
    let undocumented: Vec<_> = dict.keys().filter(|k| !checked.contains_key(*k)).collect();
    assert!(undocumented.is_empty(), "documented but not written: {undocumented:?}");
    for (name, rows) in &checked {
        assert!(*rows > 0, "{name} has no rows");
    }
    // The trial that was voided after an undo, and the note, are in the tables.
    let trials = std::fs::read_to_string(dir.join("analyze/pilot/trials.csv")).unwrap();
    assert!(trials.contains(",undone,") && trials.contains(",voided,"), "{trials}");
    assert!(trials.contains("other,\"phone rang, 2 min\""), "{trials}");
    let robot = std::fs::read_to_string(dir.join("analyze/pilot/robot.csv")).unwrap();
    assert!(robot.contains(",1,ros2,shoulder,") && robot.contains(",at_pose,"), "{robot}");
    let notes = std::fs::read_to_string(dir.join("analyze/pilot/notes.csv")).unwrap();
    assert!(notes.contains("\"asked to repeat, \"\"twice\"\"\""), "{notes}");
    let _ = std::fs::remove_dir_all(&dir);
}
