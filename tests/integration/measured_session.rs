//! A study with `measured` observations, as a lab runs it: dry runs that measure the arm,
//! logs that replay and verify bit for bit, and the measurement in `/trial/response`.

use crate::support::{handover, tmpdir};

use std::path::{Path, PathBuf};
use std::process::Command;

use handover::record::read_log;
use handover::session::{Event, MeasurementSource};

/// The default protocol observing the measured arm with noise `sigma_deg` on every joint.
fn measured_protocol(dir: &Path, sigma_deg: f64) -> PathBuf {
    let mut v: serde_json::Value = serde_json::from_str(handover::protocol::DEFAULT_PROTOCOL).unwrap();
    v["learning"]["particles"] = 300.into();
    v["learning"]["observation"] = "measured".into();
    let names = handover::kinematics::JOINT_NAMES;
    v["learning"]["measurement"] =
        serde_json::json!({ "sigma_deg": vec![sigma_deg; 7], "joint_names": names, "window_s": 0.5 });
    let p = dir.join("measured.json");
    std::fs::write(&p, v.to_string()).unwrap();
    p
}

/// A dry run of `protocol` logging to `logs`, with `extra` options; asserts it succeeded.
fn dry_run(protocol: &Path, logs: &Path, extra: &[&str]) {
    let mut args = vec!["dry-run", "--protocol", protocol.to_str().unwrap(), "--logs", logs.to_str().unwrap()];
    args.extend(extra);
    let (code, _, err) = handover(&args);
    assert_eq!(code, 0, "{err}");
}

fn responses(path: &Path) -> Vec<serde_json::Value> {
    read_log(path).unwrap().messages.into_iter().filter(|m| m.topic == "/trial/response").map(|m| m.value).collect()
}

#[test]
fn a_measured_dry_run_logs_every_measurement_and_verifies_bit_for_bit() {
    let dir = tmpdir("dry");
    let protocol = measured_protocol(&dir, 3.0);
    let logs = dir.join("logs");
    dry_run(&protocol, &logs, &["--participants", "2"]);
    let files = handover::record::mcap_files(&logs);
    assert_eq!(files.len(), 2);
    let log = read_log(&files[0]).unwrap();
    let grasps: Vec<_> = log
        .events
        .iter()
        .filter_map(|s| match &s.event {
            Event::GraspRecorded { measured, .. } => Some(measured.clone()),
            _ => None,
        })
        .collect();
    assert_eq!(grasps.len(), 26);
    for m in &grasps {
        let m = m.as_ref().expect("a dry run measures every grasp");
        assert_eq!((m.q_rad.len(), m.source), (7, MeasurementSource::Simulated));
    }
    let rs = responses(&files[0]);
    assert_eq!(rs.len(), 26);
    let mut agree = 0;
    for r in &rs {
        assert_eq!(r["learned_from"], "measured", "{r}");
        assert_eq!(r["measured"]["q_rad"].as_array().unwrap().len(), 7);
        if r["measured"]["agrees"] == true {
            assert_eq!(r["measured"]["implied_region"], r["region"]);
            agree += 1;
        }
    }
    // With 3° of noise the nearest configuration nearly always lies in the grip taken.
    assert!(agree >= 23, "{agree} of 26 agree");

    // Replaying every event recomputes every derived value exactly.
    let (code, _, err) = handover(&["analyze", "--alpha-particles", "300", logs.to_str().unwrap(), "--verify"]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("every derived value matches"), "{err}");

    // A derived number of the measurement edited (same length) is found.
    let mut bytes = std::fs::read(&files[0]).unwrap();
    let key = b"\"nearest_config_index\":";
    let at = (0..bytes.len() - key.len())
        .find(|&i| &bytes[i..i + key.len()] == key && bytes[i + key.len()].is_ascii_digit())
        .unwrap()
        + key.len();
    bytes[at] = if bytes[at] == b'1' { b'2' } else { b'1' };
    std::fs::write(&files[0], &bytes).unwrap();
    let (code, _, err) = handover(&["analyze", "--alpha-particles", "300", logs.to_str().unwrap(), "--verify"]);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("/trial/response") && err.contains("nearest_config_index"), "{err}");

    if let Ok(python) = std::env::var("HANDOVER_PYTHON") {
        let out = Command::new(python)
            .arg("../shared/tools/check_mcap.py")
            .arg("--expect=/trial/response=26")
            .arg(&files[1])
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
    } else {
        crate::support::missing("HANDOVER_PYTHON (a Python with mcap and jsonschema for check_mcap.py)");
    }
}

#[test]
fn a_protocol_measuring_badly_is_refused_naming_the_field() {
    let dir = tmpdir("bad");
    let base: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(measured_protocol(&dir, 5.0)).unwrap()).unwrap();
    use serde_json::json;
    // (JSON pointer, new value or none to remove it, the field the error names)
    let cases = [
        ("/learning/measurement", None, "learning.measurement"),
        ("/learning/measurement/sigma_deg", Some(json!([5, 5])), "sigma_deg"),
        ("/learning/measurement/sigma_deg/3", Some(json!(0.0)), "sigma_deg[3]"),
        ("/learning/measurement/sigma_deg/0", Some(json!(90)), "sigma_deg[0]"),
        ("/learning/measurement/window_s", Some(json!(60)), "window_s"),
        ("/learning/measurement/joint_names", Some(json!(["a", "b", "c", "d", "e", "f", "a"])), "joint_names[6]"),
        ("/learning/measurement/joint_names", Some(json!(["a b", "b", "c", "d", "e", "f", "g"])), "joint_names[0]"),
        ("/learning/observation", Some(json!("region")), "learning.measurement"),
    ];
    for (pointer, value, field) in cases {
        let mut v = base.clone();
        match value {
            Some(value) => *v.pointer_mut(pointer).unwrap_or_else(|| panic!("{pointer}")) = value,
            None => {
                v["learning"].as_object_mut().unwrap().remove("measurement");
            }
        }
        let p = dir.join("edited.json");
        std::fs::write(&p, v.to_string()).unwrap();
        let (code, out, err) = handover(&["protocol", "check", p.to_str().unwrap()]);
        assert_eq!(code, 2, "{field}: {out}{err}");
        assert!(format!("{out}{err}").contains(field), "{field}: {out}{err}");
    }
}

/// Writes a measurements CSV with one sample per grasp of `log` (at the grasp's time, the
/// logged measurement), in degrees or radians, with an extra column a capture system might
/// add; `keep` picks the grasps that get a sample.
fn measurements_csv(log: &Path, path: &Path, degrees: bool, keep: impl Fn(usize) -> bool) {
    let contents = read_log(log).unwrap();
    let mut w = csv::Writer::from_path(path).unwrap();
    let mut header = vec!["time".to_string(), "frame".to_string()];
    let unit = if degrees { "deg" } else { "rad" };
    header.extend(handover::kinematics::JOINT_NAMES.iter().map(|j| format!("{j}_{unit}")));
    w.write_record(&header).unwrap();
    let grasps = contents.events.iter().filter_map(|s| match &s.event {
        Event::GraspRecorded { measured: Some(m), .. } => Some((s.time_ns, m.q_rad.clone())),
        _ => None,
    });
    for (k, (t, q)) in grasps.enumerate().filter(|(k, _)| keep(*k)) {
        let time = chrono::DateTime::from_timestamp_nanos(t as i64).to_rfc3339_opts(chrono::SecondsFormat::Nanos, true);
        let mut row = vec![time, k.to_string()];
        row.extend(q.iter().map(|v| if degrees { v.to_degrees() } else { *v }.to_string()));
        w.write_record(&row).unwrap();
    }
    w.flush().unwrap();
}

/// One dry run of the measured protocol (σ = 4°): its logs folder and its log.
fn one_measured_session(dir: &Path) -> (PathBuf, PathBuf) {
    let logs = dir.join("logs");
    dry_run(&measured_protocol(dir, 4.0), &logs, &[]);
    let log = handover::record::mcap_files(&logs).remove(0);
    (logs, log)
}

#[test]
fn measurements_from_a_file_refit_a_session_beside_its_logged_fit() {
    let dir = tmpdir("posthoc");
    let (logs, log) = one_measured_session(&dir);
    let all = dir.join("all.csv");
    measurements_csv(&log, &all, false, |_| true);
    let out = dir.join("out");
    let (code, stdout, err) = handover(&[
        "analyze",
        "--alpha-particles",
        "50",
        logs.to_str().unwrap(),
        "--measurements",
        all.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(stdout.contains("MEASURED RE-FIT") && stdout.contains("26 of 26 grasps measured"), "{stdout}");
    // The same measurements from a file give the live session's fit, bit for bit: both fits
    // side by side.
    let mut r = csv::Reader::from_path(out.join("pilot/measured_fit.csv")).unwrap();
    let rows: Vec<csv::StringRecord> = r.records().map(|x| x.unwrap()).collect();
    let h = r.headers().unwrap().clone();
    let col = |name: &str| h.iter().position(|c| c == name).unwrap();
    assert_eq!(rows.len(), 2 * 2 * 2 * 7, "2 programs × 2 fits × (q*, w) × 7 joints");
    for row in rows.iter().filter(|x| &x[col("fit")] == "logged") {
        let twin = rows
            .iter()
            .find(|x| {
                &x[col("fit")] == "measured"
                    && x[col("program")] == row[col("program")]
                    && x[col("parameter")] == row[col("parameter")]
                    && x[col("joint")] == row[col("joint")]
            })
            .unwrap();
        for c in ["mean", "ci_low", "ci_high", "ess"] {
            assert_eq!(row[col(c)], twin[col(c)], "{row:?} vs {twin:?}");
        }
        assert_eq!(&row[col("observation")], "measured");
    }

    // Samples for every other grasp: the rest learn from the region.
    let half = dir.join("half.csv");
    measurements_csv(&log, &half, true, |k| k % 2 == 0);
    let (code, stdout, err) = handover(&[
        "analyze",
        "--alpha-particles",
        "50",
        logs.to_str().unwrap(),
        "--measurements",
        half.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(stdout.contains("13 of 26 grasps measured"), "{stdout}");

    // Bad files and options are refused, naming the row and column (exit 2).
    let text = std::fs::read_to_string(&all).unwrap();
    let mut lines: Vec<&str> = text.lines().collect();
    lines.swap(2, 3);
    let unordered = dir.join("unordered.csv");
    std::fs::write(&unordered, lines.join("\n")).unwrap();
    let renamed = dir.join("renamed.csv");
    std::fs::write(&renamed, text.replace("elbow_flexion_rad", "elbow_rad")).unwrap();
    let garbled = dir.join("garbled.csv");
    std::fs::write(&garbled, text.replacen(",0,", ",0,x", 1)).unwrap();
    for (args, says) in [
        (vec!["--measurements", unordered.to_str().unwrap()], "row 4, column 'time'"),
        (vec!["--measurements", renamed.to_str().unwrap()], "'elbow_flexion_rad'"),
        (vec!["--measurements", garbled.to_str().unwrap()], "row 2, column 'shoulder_flexion_rad'"),
        (vec!["--measurements", all.to_str().unwrap(), "--sigma-deg", "1,2"], "--sigma-deg has 2 values"),
        (vec!["--sigma-deg", "3"], "are for --measurements"),
    ] {
        let mut a = vec!["analyze", logs.to_str().unwrap()];
        a.extend(args);
        let (code, _, err) = handover(&a);
        assert_eq!(code, 2, "{a:?}: {err}");
        assert!(err.contains(says), "{a:?}: {err}");
    }
}

/// The C3D points (Vicon's angle outputs) and components the model's joints are read from.
const C3D_JOINTS: [(&str, usize); 7] = [
    ("RShoulderAngles", 0),
    ("RShoulderAngles", 1),
    ("RShoulderAngles", 2),
    ("RElbowAngles", 0),
    ("RElbowAngles", 2),
    ("RWristAngles", 0),
    ("RWristAngles", 1),
];

#[test]
fn a_c3d_file_of_joint_angles_refits_as_the_same_samples_in_a_csv() {
    let dir = tmpdir("c3d");
    let (logs, log) = one_measured_session(&dir);
    let grasps: Vec<(u64, Vec<f64>)> = read_log(&log)
        .unwrap()
        .events
        .iter()
        .filter_map(|s| match &s.event {
            Event::GraspRecorded { measured: Some(m), .. } => Some((s.time_ns, m.q_rad.clone())),
            _ => None,
        })
        .collect();
    // 10 frames a second from a second before the first grasp; the last frame at or before
    // each grasp holds its angles (degrees, as C3D's f32 has them), every other frame is invalid.
    let start = grasps[0].0 - 1_000_000_000;
    let frames = ((grasps.last().unwrap().0 - start) / 100_000_000 + 10) as usize;
    let labels = ["RShoulderAngles", "RElbowAngles", "RWristAngles"];
    let invalid = c3dio::MarkerPoint { point: [0.0; 3], residual: -1.0, cameras: [false; 7] };
    let mut cells = vec![invalid; frames * labels.len()];
    let mut csv_rows = Vec::new();
    for (t, q) in &grasps {
        let k = ((t - start) / 100_000_000) as usize;
        for (d, (label, axis)) in C3D_JOINTS.iter().enumerate() {
            let p = labels.iter().position(|l| l == label).unwrap();
            let cell = &mut cells[k * labels.len() + p];
            cell.residual = 0.0;
            cell.point[*axis] = q[d].to_degrees() as f32;
        }
        let angles: Vec<f64> = C3D_JOINTS
            .iter()
            .map(|(label, axis)| {
                f64::from(cells[k * labels.len() + labels.iter().position(|l| l == label).unwrap()].point[*axis])
            })
            .collect();
        csv_rows.push((start + k as u64 * 100_000_000, angles));
    }
    let mut c3d = c3dio::C3d::new();
    // The groups the writer writes parameters into.
    for group in ["POINT", "ANALOG", "EVENT", "EVENT_CONTEXT", "FORCE_PLATFORM", "MANUFACTURER", "SEG"] {
        c3d.parameters.insert_group(group, String::new());
    }
    c3d.points.labels = labels.iter().map(|l| l.to_string()).collect();
    c3d.points.descriptions = labels.iter().map(|_| String::new()).collect();
    c3d.points.units = ['d', 'e', 'g', ' '];
    c3d.points.frame_rate = 10.0;
    c3d.points.scale_factor = 1.0;
    c3d.points.first_frame = 1;
    c3d.points.last_frame = frames as u16;
    c3d.points.points = grid::Grid::from_vec(cells, labels.len());
    let c3d_path = dir.join("capture.c3d");
    c3d.write_path(c3d_path.clone()).unwrap();
    let names: Vec<String> = C3D_JOINTS.iter().map(|(l, a)| format!("{l}.{}", ["x", "y", "z"][*a])).collect();
    let csv_path = dir.join("capture.csv");
    let mut w = csv::Writer::from_path(&csv_path).unwrap();
    let mut header = vec!["time".to_string()];
    header.extend(names.iter().map(|n| format!("{n}_deg")));
    w.write_record(&header).unwrap();
    for (t, angles) in &csv_rows {
        let mut row = vec![format!("{}.{:09}", t / 1_000_000_000, t % 1_000_000_000)];
        row.extend(angles.iter().map(|a| a.to_string()));
        w.write_record(&row).unwrap();
    }
    w.flush().unwrap();

    let start_text =
        chrono::DateTime::from_timestamp_nanos(start as i64).to_rfc3339_opts(chrono::SecondsFormat::Nanos, true);
    let refit = |file: &Path, extra: &[&str], out: &str| {
        let mut args = vec!["analyze", "--alpha-particles", "50", logs.to_str().unwrap()];
        let out = dir.join(out);
        let joint_names = names.join(",");
        args.extend(["--measurements", file.to_str().unwrap(), "--joint-names", &joint_names]);
        args.extend(["--out", out.to_str().unwrap()]);
        args.extend(extra);
        let (code, stdout, err) = handover(&args);
        assert_eq!(code, 0, "{err}");
        assert!(stdout.contains("26 of 26 grasps measured"), "{stdout}");
        std::fs::read_to_string(out.join("pilot/measured_fit.csv")).unwrap()
    };
    let from_c3d = refit(&c3d_path, &["--c3d-start", &start_text], "out-c3d");
    let from_csv = refit(&csv_path, &[], "out-csv");
    assert_eq!(from_c3d, from_csv, "the same samples give the same fits");

    // A C3D file without its start time, or with a name the file has no point for, is refused.
    for (extra, says) in [
        (vec![], "needs --c3d-start"),
        (vec!["--c3d-start", &start_text, "--joint-names", "a.x,b.x,c.x,d.x,e.x,f.x,g.x"], "no point labelled 'a'"),
    ] {
        let mut args = vec!["analyze", logs.to_str().unwrap(), "--measurements", c3d_path.to_str().unwrap()];
        args.extend(extra.iter().copied());
        let (code, _, err) = handover(&args);
        assert_eq!(code, 2, "{err}");
        assert!(err.contains(says), "{err}");
    }
    // A file that only says it is one is refused, not read.
    let fake = dir.join("fake.c3d");
    std::fs::write(&fake, [0u8; 2048]).unwrap();
    let (code, _, err) = handover(&[
        "analyze",
        logs.to_str().unwrap(),
        "--measurements",
        fake.to_str().unwrap(),
        "--c3d-start",
        &start_text,
        "--joint-names",
        &names.join(","),
    ]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("not a C3D file the reader can take"), "{err}");
    hostile_c3d_files_are_refused(&dir, &logs, &c3d_path, &start_text, &names.join(","));
}

/// C3D files edited or cut: every one is read or refused by the library without a panic
/// escaping or an allocation beyond the budget, and through the command line they exit 2
/// naming the file, with no panic message on the terminal.
fn hostile_c3d_files_are_refused(dir: &Path, logs: &Path, good: &Path, start: &str, joint_names: &str) {
    use handover::analysis::MeasurementSeries;
    let bytes = std::fs::read(good).unwrap();
    let names: Vec<String> = joint_names.split(',').map(String::from).collect();
    let analyze = |file: &Path| {
        handover(&[
            "analyze",
            "--alpha-particles",
            "50",
            logs.to_str().unwrap(),
            "--measurements",
            file.to_str().unwrap(),
            "--c3d-start",
            start,
            "--joint-names",
            joint_names,
        ])
    };
    // Cut anywhere from 10 % to 99 %: refused as cut short, never read as a shorter capture.
    for percent in [10, 25, 50, 75, 90, 95, 99] {
        let cut = dir.join(format!("cut-{percent}.c3d"));
        std::fs::write(&cut, &bytes[..bytes.len() * percent / 100]).unwrap();
        let (code, _, err) = analyze(&cut);
        assert_eq!(code, 2, "cut at {percent} %: {err}");
        assert!(err.contains(&format!("cut-{percent}.c3d")), "{err}");
    }
    // A header claiming 10,000 points × 65,535 frames in a small file: refused before any
    // allocation (the reader would take 15 GB).
    let mut huge = bytes.clone();
    huge[2..4].copy_from_slice(&10_000u16.to_le_bytes());
    huge[8..10].copy_from_slice(&65_535u16.to_le_bytes());
    let huge_path = dir.join("huge.c3d");
    std::fs::write(&huge_path, &huge).unwrap();
    let (code, _, err) = analyze(&huge_path);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("over the budget"), "{err}");
    // Every byte of the header and the parameter section set to 0x00, 0xFF and one more:
    // read or refused, in the library; the refusals the parser itself raised (its panics)
    // are tried through the command line, whose terminal must show no panic.
    let (mut tried, mut refused, mut parser_refusals) = (0, 0, Vec::new());
    for at in 0..bytes.len().min(1536) {
        for value in [0x00, 0xff, bytes[at].wrapping_add(1)] {
            if value == bytes[at] {
                continue;
            }
            let mut b = bytes.clone();
            b[at] = value;
            let f = dir.join("edited.c3d");
            std::fs::write(&f, &b).unwrap();
            tried += 1;
            if let Err(e) = MeasurementSeries::read_c3d(&f, &names, 0) {
                refused += 1;
                if e.to_string().contains("could not parse it") && parser_refusals.len() < 3 {
                    parser_refusals.push(b);
                }
            }
        }
    }
    eprintln!("C3D edits: {tried} tried, {refused} refused ({} by the parser), the rest read", parser_refusals.len());
    for (i, b) in parser_refusals.iter().enumerate() {
        let f = dir.join(format!("parser-{i}.c3d"));
        std::fs::write(&f, b).unwrap();
        let (code, _, err) = analyze(&f);
        assert_eq!(code, 2, "{err}");
        assert!(!err.contains("panicked"), "no panic message: {err}");
    }
}

/// Resample-move (`learning.moves`) in a measured session: the moves are part of the
/// session's derived values, so its log replays bit for bit, and they change the belief.
#[test]
fn a_session_with_moves_verifies_bit_for_bit_and_learns_otherwise_than_with_jitter() {
    let dir = tmpdir("moves");
    let jitter = measured_protocol(&dir, 5.0);
    let mut v: serde_json::Value = serde_json::from_slice(&std::fs::read(&jitter).unwrap()).unwrap();
    v["learning"]["moves"] = 3.into();
    let moves = dir.join("moves.json");
    std::fs::write(&moves, v.to_string()).unwrap();
    let mut means = Vec::new();
    for (protocol, name) in [(&jitter, "jitter"), (&moves, "moves")] {
        let logs = dir.join(name);
        dry_run(protocol, &logs, &["--seed", "5"]);
        let (code, _, err) = handover(&["analyze", "--alpha-particles", "300", logs.to_str().unwrap(), "--verify"]);
        assert_eq!(code, 0, "{err}");
        assert!(err.contains("every derived value matches"), "{err}");
        let files = handover::record::mcap_files(&logs);
        let log = read_log(&files[0]).unwrap();
        let beliefs: Vec<serde_json::Value> =
            log.messages.into_iter().filter(|m| m.topic.starts_with("/belief/")).map(|m| m.value).collect();
        assert!(beliefs.len() >= 10, "{} beliefs", beliefs.len());
        if name == "moves" {
            // Resampled after every update, then moved: every belief is equally weighted.
            for b in &beliefs {
                let ess = b["ess"].as_f64().unwrap();
                assert!((ess - 300.0).abs() < 1e-9, "{b}");
            }
        }
        means.push(beliefs.iter().map(|b| b["mean"].to_string()).collect::<Vec<_>>());
    }
    assert_eq!(means[0][0], means[1][0], "the same prior draw");
    assert_ne!(means[0].last(), means[1].last(), "moves change what is learned");
}
