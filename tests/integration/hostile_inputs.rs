//! Every file the program reads is untrusted. This suite mutates logs (truncation, byte
//! flips, edited fields, foreign MCAP), protocols, `score` inputs and participant records,
//! runs the real binary on each under a memory limit, and asserts: exit 0, 1 or 2, with a
//! message naming the file; never a panic; never a write outside the case's own folder;
//! within the time and memory budgets below.
//!
//! Its length: one test per untrusted input (protocol, log, participant record, JSON), each
//! with its many hostile cases.

use crate::support::tmpdir;

use std::collections::BTreeSet;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use handover::protocol::{DEFAULT_PROTOCOL, Study};
use handover::record::read_log;
use rand::{RngExt, SeedableRng};

/// The budgets every case runs under: address space and wall time of one command.
const MEMORY_KIB: u64 = 3 << 20;
const SECONDS: u64 = 60;

struct Run {
    code: i32,
    stdout: String,
    stderr: String,
}

/// The binary under `ulimit -v` (an allocation over the budget fails and aborts, which
/// the exit-status check below would catch) and killed after the time budget (a hang shows
/// as exit 137, not a test that never ends), in `cwd`.
fn run_in(cwd: &Path, args: &[&str]) -> Run {
    let mut script = format!("ulimit -v {MEMORY_KIB}; exec timeout -s KILL {SECONDS} \"$0\"");
    for i in 1..=args.len() {
        script.push_str(&format!(" \"${i}\""));
    }
    let t0 = Instant::now();
    let out = Command::new("sh")
        .arg("-c")
        .arg(&script)
        .arg(env!("CARGO_BIN_EXE_handover"))
        .args(args)
        .current_dir(cwd)
        .stdin(Stdio::null())
        .output()
        .unwrap();
    assert!(t0.elapsed() < Duration::from_secs(SECONDS), "{args:?} took {:?}", t0.elapsed());
    Run {
        code: out.status.code().unwrap_or(-1),
        stdout: String::from_utf8_lossy(&out.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
    }
}

/// The contract for one hostile case.
fn assert_contained(r: &Run, what: &str, file_hint: &str) {
    assert!(matches!(r.code, 0..=2), "{what}: exit {} (a crash or an abort)\n{}", r.code, r.stderr);
    assert!(!r.stderr.contains("panicked"), "{what}: panicked\n{}", r.stderr);
    if r.code != 0 {
        assert!(r.stderr.contains(file_hint), "{what}: the message names the file ({file_hint}):\n{}", r.stderr);
    }
}

/// Every file and folder below `dir`.
fn tree(dir: &Path) -> BTreeSet<PathBuf> {
    let mut out = BTreeSet::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).into_iter().flatten().flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p.clone());
            }
            out.insert(p);
        }
    }
    out
}

fn example_score() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/examples/score.json")
}

fn small_protocol_text() -> String {
    let mut v: serde_json::Value = serde_json::from_str(DEFAULT_PROTOCOL).unwrap();
    v["learning"]["particles"] = 150.into();
    v["session"]["trials_per_condition"] = 2.into();
    v.to_string()
}

/// One finished dry-run log of the small protocol, made in `dir`.
fn base_log(dir: &Path) -> PathBuf {
    let proto = dir.join("small.json");
    std::fs::write(&proto, small_protocol_text()).unwrap();
    let r = run_in(dir, &["dry-run", "--protocol", "small.json", "--seed", "9", "--logs", "logs"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    handover::record::mcap_files(&dir.join("logs")).pop().unwrap()
}

/// Runs `analyze --verify` and `resume --dry-run` on a hostile log in a folder of its own,
/// and checks the contract; returns the two exit statuses.
fn try_log(root: &Path, name: &str, bytes: &[u8]) -> (i32, i32) {
    let case = root.join(name);
    let inside = case.join("logs").join("p-case");
    std::fs::create_dir_all(&inside).unwrap();
    let file = inside.join("case.mcap");
    std::fs::write(&file, bytes).unwrap();
    let before_outside = tree(root).into_iter().filter(|p| !p.starts_with(&case)).collect::<BTreeSet<_>>();
    let verify = run_in(&case, &["analyze", "--alpha-particles", "300", "--verify", "logs/p-case/case.mcap"]);
    assert_contained(&verify, &format!("{name}: analyze --verify"), "case.mcap");
    let resume = run_in(&case, &["resume", "--no-console", "logs/p-case/case.mcap"]);
    assert_contained(&resume, &format!("{name}: resume --dry-run"), "case.mcap");
    // The follower reads the log first, then wants a terminal (none here): a bad log is
    // named, a good one gets as far as asking for a terminal; never a crash.
    let follow = run_in(&case, &["follow", "logs/p-case/case.mcap"]);
    assert_eq!(follow.code, 2, "{name}: follow\n{}", follow.stderr);
    assert!(
        !follow.stderr.contains("panicked")
            && (follow.stderr.contains("case.mcap") || follow.stderr.contains("interactive terminal")),
        "{name}: follow\n{}",
        follow.stderr
    );
    // Writes stay beside the log: nothing appears outside the case's log folder.
    let after = tree(root);
    for p in &after {
        if !p.starts_with(&case) {
            assert!(before_outside.contains(p), "{name}: wrote outside its folder: {}", p.display());
        } else {
            assert!(p.starts_with(&inside) || *p == case.join("logs") || *p == case, "{name}: {}", p.display());
        }
    }
    (verify.code, resume.code)
}

#[test]
fn hostile_logs_are_refused_or_read_and_never_escape_their_folder() {
    let root = tmpdir("logs");
    let base = base_log(&root);
    let good = std::fs::read(&base).unwrap();
    let log = read_log(&base).unwrap();
    assert!(log.finished && log.integrity.is_empty(), "{:?}", log.integrity);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
    let mut cases: Vec<(String, Vec<u8>)> = Vec::new();
    // Truncations at 30 offsets (a crash at any byte).
    for k in 0..30 {
        let at = rng.random_range(0..good.len());
        cases.push((format!("truncated-{k}-at-{at}"), good[..at].to_vec()));
    }
    // Single byte flips at 40 offsets.
    for k in 0..40 {
        let at = rng.random_range(0..good.len());
        let mut b = good.clone();
        b[at] ^= 1 << rng.random_range(0..8);
        cases.push((format!("flip-{k}-at-{at}"), b));
    }
    // Edited fields (same length, so the file still parses): ids that are paths.
    let participant = log.start.participant.clone();
    let text_edits = [
        (participant.as_str(), "../../etc/../x"),
        (log.start.session_id.as_str(), "../../../../../.."),
        ("\"slot\":1", "\"slot\":7"),
        ("\"slot\":0", "\"slot\":7"),
        ("\"pilot\":true", "\"pilot\":null"),
    ];
    for (k, (from, to)) in text_edits.iter().enumerate() {
        let to = &to[..to.len().min(from.len())];
        let to = format!("{to:-<width$}", width = from.len());
        let edited = replace_all(&good, from.as_bytes(), to.as_bytes());
        if edited != good {
            cases.push((format!("edited-{k}"), edited));
        }
    }
    // Not MCAP at all, an empty file, and a foreign MCAP file.
    cases.push(("empty".into(), Vec::new()));
    cases.push(("json".into(), b"{\"not\": \"a log\"}".to_vec()));
    cases.push(("foreign".into(), foreign_mcap()));
    let mut codes = std::collections::BTreeMap::new();
    for (name, bytes) in &cases {
        let c = try_log(&root, name, bytes);
        *codes.entry(c).or_insert(0) += 1;
    }
    eprintln!("{} hostile logs: (verify, resume) exit statuses {codes:?}", cases.len());
    // A path in an id is refused outright.
    let edited = replace_all(
        &good,
        participant.as_bytes(),
        format!("{:-<w$}", "../../etc/../x", w = participant.len()).as_bytes(),
    );
    let (verify, resume) = try_log(&root, "path-in-id", &edited);
    assert_eq!((verify, resume), (1, 2), "a participant id that is a path fails verify and resume");
    // A flipped byte inside a schema is caught by --verify (CRC and schema check).
    let at = find(&good, b"\"$schema\"").unwrap() + 3;
    let mut flipped = good.clone();
    flipped[at] ^= 1;
    assert_eq!(try_log(&root, "schema-flip", &flipped).0, 1);
    std::fs::remove_dir_all(&root).unwrap();
}

fn find(hay: &[u8], needle: &[u8]) -> Option<usize> {
    hay.windows(needle.len()).position(|w| w == needle)
}

fn replace_all(hay: &[u8], from: &[u8], to: &[u8]) -> Vec<u8> {
    assert_eq!(from.len(), to.len());
    let mut out = hay.to_vec();
    let mut i = 0;
    while let Some(k) = find(&out[i..], from) {
        out[i + k..i + k + from.len()].copy_from_slice(to);
        i += k + from.len();
    }
    out
}

/// A valid MCAP file that is not a session log (another program's topics).
fn foreign_mcap() -> Vec<u8> {
    let mut w = mcap::Writer::new(std::io::Cursor::new(Vec::new())).unwrap();
    let s = w.add_schema("x", "jsonschema", b"{}").unwrap();
    let c = w.add_channel(s, "/camera", "json", &Default::default()).unwrap();
    let h = mcap::records::MessageHeader { channel_id: c, sequence: 1, log_time: 1, publish_time: 1 };
    w.write_to_known_channel(&h, b"{}").unwrap();
    w.finish().unwrap();
    w.into_inner().into_inner()
}

#[test]
fn a_new_logs_folder_is_owner_only() {
    use std::os::unix::fs::PermissionsExt;
    let root = tmpdir("modes");
    std::fs::write(root.join("small.json"), small_protocol_text()).unwrap();
    let r = run_in(&root, &["dry-run", "--protocol", "small.json", "--study-dir", "study"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    for p in [root.join("study"), root.join("study/logs")] {
        let mode = std::fs::metadata(&p).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, 0o700, "{}", p.display());
    }
    for p in tree(&root.join("study")) {
        let mode = std::fs::metadata(&p).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, if p.is_dir() { 0o700 } else { 0o600 }, "{}", p.display());
    }
    std::fs::remove_dir_all(&root).unwrap();
}

/// The JSON paths of every value in `v` that `pick` picks.
fn paths_where(
    v: &serde_json::Value,
    pick: fn(&serde_json::Value) -> bool,
    path: &mut Vec<String>,
    out: &mut Vec<Vec<String>>,
) {
    if pick(v) {
        out.push(path.clone());
    }
    let children: Vec<(String, &serde_json::Value)> = match v {
        serde_json::Value::Array(a) => a.iter().enumerate().map(|(i, x)| (i.to_string(), x)).collect(),
        serde_json::Value::Object(o) => o.iter().map(|(k, x)| (k.clone(), x)).collect(),
        _ => Vec::new(),
    };
    for (key, x) in children {
        path.push(key);
        paths_where(x, pick, path, out);
        path.pop();
    }
}

fn at_path<'a>(v: &'a mut serde_json::Value, path: &[String]) -> &'a mut serde_json::Value {
    path.iter().fold(v, |v, k| match v {
        serde_json::Value::Array(a) => &mut a[k.parse::<usize>().unwrap()],
        other => &mut other[k.as_str()],
    })
}

/// The error of a protocol that must be refused.
fn refusal(v: &serde_json::Value) -> String {
    match Study::from_json(&v.to_string(), "p.json") {
        Ok(_) => panic!("accepted"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn hostile_protocols_are_refused_with_the_field_or_run() {
    let base: serde_json::Value = serde_json::from_str(DEFAULT_PROTOCOL).unwrap();
    let mut paths = Vec::new();
    paths_where(&base, serde_json::Value::is_number, &mut Vec::new(), &mut paths);
    let hostile = [1e308, -1e308, 1e-9, 0.0, -1.0, 1e9, 3.5];
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(12);
    let (mut refused, mut accepted) = (0, 0);
    // Known hostile values (a huge bound, a huge prior, a tiny step), then 120 random
    // (number, value) mutations.
    let mut cases: Vec<(Vec<String>, f64)> = vec![
        (vec!["objects", "0", "regions", "0", "tsr", "Bw", "5", "1"].into_iter().map(String::from).collect(), 1e308),
        (vec!["learning", "prior", "q_star_deg", "0", "max"].into_iter().map(String::from).collect(), 1e308),
        (vec!["discretisation", "swivel_step_deg"].into_iter().map(String::from).collect(), 1e-9),
        (vec!["discretisation", "resolution", "translation_m"].into_iter().map(String::from).collect(), 1e-9),
        (vec!["session", "trials_per_condition"].into_iter().map(String::from).collect(), 1e9),
        (vec!["learning", "particles"].into_iter().map(String::from).collect(), 1e9),
    ];
    for _ in 0..120 {
        let p = paths[rng.random_range(0..paths.len())].clone();
        cases.push((p, hostile[rng.random_range(0..hostile.len())]));
    }
    for (path, value) in &cases {
        let mut v = base.clone();
        *at_path(&mut v, path) = serde_json::json!(value);
        if path.last().is_some_and(|k| k == "particles" || k == "trials_per_condition" || k == "grid_boxes")
            && *value >= 0.0
        {
            *at_path(&mut v, path) = serde_json::json!(*value as u64);
        }
        let text = v.to_string();
        let t0 = Instant::now();
        let result = std::panic::catch_unwind(|| match Study::from_json(&text, "hostile.json") {
            Ok(study) => {
                handover::session::check_runs(std::sync::Arc::new(study)).map(|()| true).map_err(|e| e.to_string())
            }
            Err(e) => {
                assert!(e.to_string().starts_with("hostile.json: invalid protocol"), "{e}");
                Ok(false)
            }
        });
        let field = path.join(".");
        let outcome = result.unwrap_or_else(|_| panic!("{field} = {value}: panicked"));
        assert!(t0.elapsed() < Duration::from_secs(20), "{field} = {value}: took {:?}", t0.elapsed());
        match outcome {
            Ok(true) => accepted += 1,
            Ok(false) => refused += 1,
            Err(e) => panic!("{field} = {value}: accepted by validation but does not run: {e}"),
        }
    }
    eprintln!("{} hostile protocols: {refused} refused, {accepted} accepted and run", cases.len());
    // Each hostile edit is refused, naming its field and (for work) the budget.
    type Edit = (&'static str, fn(&mut serde_json::Value), &'static str);
    let edits: [Edit; 4] = [
        (
            "objects[0].regions[0].tsr.Bw[5]",
            |v| v["objects"][0]["regions"][0]["tsr"]["Bw"][5][1] = 1e308.into(),
            "expected min ≤ max within",
        ),
        ("learning.prior.q_star_deg[0]", |v| v["learning"]["prior"]["q_star_deg"][0]["max"] = 1e308.into(), "outside"),
        ("discretisation.swivel_step_deg", |v| v["discretisation"]["swivel_step_deg"] = 1e-9.into(), "degrees from 1"),
        (
            "discretisation.resolution.translation_m",
            |v| v["discretisation"]["resolution"]["translation_m"] = 1e-9.into(),
            "m from 0.001",
        ),
    ];
    for (path, edit, words) in edits {
        let mut v = base.clone();
        edit(&mut v);
        let e = refusal(&v);
        assert!(e.contains(path) && e.contains(words), "{path}: {e}");
    }
    let mut v = base.clone();
    v["session"]["trials_per_condition"] = serde_json::json!(1_000_000_000u64);
    let e = refusal(&v);
    assert!(e.contains("session.trials_per_condition") && e.contains("200"), "{e}");
    // Steps that are each legal but together imply too much work: refused by the budget,
    // before any inverse kinematics is done.
    let mut v = base.clone();
    v["discretisation"]["resolution"]["translation_m"] = serde_json::json!(0.001);
    v["discretisation"]["resolution"]["rotation_deg"] = serde_json::json!(1.0);
    v["discretisation"]["swivel_step_deg"] = serde_json::json!(1.0);
    let t0 = Instant::now();
    let e = refusal(&v);
    assert!(e.contains("inverse-kinematics evaluations") && e.contains("over the budget"), "{e}");
    assert!(t0.elapsed() < Duration::from_secs(2), "refused before the work: {:?}", t0.elapsed());
}

#[test]
fn hostile_score_inputs_exit_2_naming_the_field() {
    let dir = tmpdir("score");
    let base: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(example_score()).unwrap()).unwrap();
    type Case = (&'static str, fn(&mut serde_json::Value), &'static str);
    let cases: Vec<Case> = vec![
        ("huge-q-star", |v| v["particles"][0]["q_star"][0] = 1e308.into(), "particles[0]"),
        ("negative-w", |v| v["particles"][1]["w"][0] = (-1.0).into(), "particles[1].w[0]"),
        ("huge-config", |v| v["menu"][0]["configs"][0][0] = 1e300.into(), "alpha × cost"),
        ("zero-alpha", |v| v["alpha"] = 0.0.into(), "alpha"),
        ("no-menu", |v| v["menu"] = serde_json::json!([]), "menu"),
        ("bad-observation", |v| v["observation"]["config"] = 99.into(), "observation"),
        ("huge-dim", |v| v["particles"][0]["q_star"] = serde_json::json!(vec![0.0; 100]), "q_star"),
    ];
    for (name, edit, field) in &cases {
        let mut v = base.clone();
        edit(&mut v);
        let f = dir.join(format!("{name}.json"));
        std::fs::write(&f, v.to_string()).unwrap();
        let r = run_in(&dir, &["research", "score", f.to_str().unwrap()]);
        assert_eq!(r.code, 2, "{name}: {}{}", r.stdout, r.stderr);
        assert!(r.stderr.contains(&format!("{name}.json")) && r.stderr.contains(field), "{name}: {}", r.stderr);
        assert!(!r.stdout.contains("null"), "{name}: no undefined number is printed");
    }
    // An endless input is refused, not read forever: a device is not a regular file.
    let r = run_in(&dir, &["research", "score", "/dev/zero"]);
    assert_eq!(r.code, 2, "{}", r.stderr);
    assert!(r.stderr.contains("/dev/zero") && r.stderr.contains("a device"), "{}", r.stderr);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn hostile_participant_records_are_refused_naming_the_field() {
    let dir = tmpdir("records");
    let parts = dir.join("participants");
    std::fs::create_dir_all(&parts).unwrap();
    let good = serde_json::json!({"id": "p-abc", "slot": 1, "created_at": "2026-11-22T10:00:00Z"});
    let cases: Vec<(&str, String, &str)> = vec![
        (
            "slot",
            serde_json::json!({"id": "p-abc", "slot": 7, "created_at": "2026-11-22T10:00:00Z"}).to_string(),
            "slot",
        ),
        ("time", serde_json::json!({"id": "p-abc", "slot": 0, "created_at": "yesterday"}).to_string(), "created_at"),
        (
            "height",
            serde_json::json!({"id": "p-abc", "slot": 0, "created_at": "2026-11-22T10:00:00Z", "body_height_m": 9.0})
                .to_string(),
            "body_height_m",
        ),
        (
            "other-id",
            serde_json::json!({"id": "p-xyz", "slot": 0, "created_at": "2026-11-22T10:00:00Z"}).to_string(),
            "id",
        ),
        ("name", format!("{{\"name\": \"Ada\", {}", &good.to_string()[1..]), "name"),
        ("empty", String::new(), "p-abc.json"),
        ("huge", format!("{{\"id\": \"{}\"}}", "x".repeat(100_000)), "bytes"),
    ];
    for (name, text, field) in &cases {
        std::fs::write(parts.join("p-abc.json"), text).unwrap();
        let r = run_in(&dir, &["participant", "show", "p-abc"]);
        assert_eq!(r.code, 2, "{name}: {}", r.stdout);
        assert!(r.stderr.contains("p-abc.json") && r.stderr.contains(field), "{name}: {}", r.stderr);
        // The console refuses it before it starts, too.
        let r = run_in(&dir, &["run", "--participant", "p-abc"]);
        assert_eq!(r.code, 2, "{name}: run");
    }
    std::fs::write(parts.join("p-abc.json"), good.to_string()).unwrap();
    let r = run_in(&dir, &["participant", "show", "p-abc"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_closed_standard_output_ends_every_command_quietly() {
    let dir = tmpdir("pipe");
    std::fs::write(dir.join("small.json"), small_protocol_text()).unwrap();
    let parts = dir.join("participants");
    std::fs::create_dir_all(&parts).unwrap();
    std::fs::write(
        parts.join("p-abc.json"),
        serde_json::json!({"id": "p-abc", "slot": 1, "created_at": "2026-11-22T10:00:00Z"}).to_string(),
    )
    .unwrap();
    for args in [
        vec!["participant", "show", "p-abc"],
        vec!["feasible", "--protocol", "small.json"],
        vec!["protocol", "check", "small.json"],
        vec!["research", "score", example_score().to_str().unwrap()],
    ] {
        let mut child = Command::new(env!("CARGO_BIN_EXE_handover"))
            .args(&args)
            .current_dir(&dir)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        // The reader goes away at once, as `| head -0` does.
        drop(child.stdout.take());
        let mut err = String::new();
        child.stderr.take().unwrap().read_to_string(&mut err).unwrap();
        let status = child.wait().unwrap();
        assert!(!err.contains("panicked") && !err.contains("Broken pipe"), "{args:?}: {err}");
        assert!(matches!(status.code(), Some(0 | 2)), "{args:?}: {status:?} {err}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A finished log with any one byte changed is flagged: it does not read, or reads as damaged
/// (`integrity`, which `analyze --verify` reports), or reads as not finished; never as the
/// intact log it was. Every byte of a small finished log, in memory.
#[test]
fn every_one_byte_change_of_a_finished_log_is_flagged() {
    let dir = tmpdir("flips");
    let path = base_log(&dir);
    let bytes = std::fs::read(&path).unwrap();
    let intact = handover::record::read_log_bytes(&path, &bytes).unwrap();
    assert!(intact.finished && intact.integrity.is_empty(), "{:?}", intact.integrity);
    let mut unflagged = Vec::new();
    let mut flipped = bytes.clone();
    for at in 0..bytes.len() {
        flipped[at] ^= 0xFF;
        // The bytes' structure and CRCs first (cheap); the whole read only if they pass.
        let flagged = !handover::record::integrity_problems(&flipped).is_empty()
            || match handover::record::read_log_bytes(&path, &flipped) {
                Err(_) => true,
                Ok(log) => !log.integrity.is_empty() || !log.finished || log.cut_tail,
            };
        if !flagged {
            unflagged.push(at);
        }
        flipped[at] = bytes[at];
    }
    assert!(
        unflagged.is_empty(),
        "{} of {} one-byte changes pass as intact, at {:?}",
        unflagged.len(),
        bytes.len(),
        &unflagged[..unflagged.len().min(20)]
    );
    // A finished log with anything after its end, and one whose records stop before its footer.
    let mut padded = bytes.clone();
    padded.extend(std::iter::repeat_n(0u8, 4096));
    let e = handover::record::read_log_bytes(&path, &padded).unwrap_err().to_string();
    assert!(e.contains("4096 bytes follow its footer"), "{e}");
    let summary = mcap::Summary::read(&bytes).unwrap().unwrap();
    let second = summary.chunk_indexes[1].chunk_start_offset as usize;
    let mut short = bytes.clone();
    short[second + 1] ^= 0x01; // the second event's chunk length
    let e = handover::record::read_log_bytes(&path, &short).unwrap_err().to_string();
    assert!(e.contains("damaged") && e.contains("before its data end"), "{e}");
    std::fs::remove_dir_all(dir).unwrap();
}

/// One dry run of `text` (a protocol accepted by `Study::from_json`), read back: the reader
/// must accept every log a protocol `protocol check` accepts gives.
fn log_of_accepted(dir: &Path, name: &str, text: &str) {
    let study = std::sync::Arc::new(Study::from_json(text, name).unwrap());
    let p = handover::dryrun::plan(&study, 1, 0, None, "2026-11-22T00:00:00Z".into());
    let session = handover::session::Session::new(std::sync::Arc::clone(&study), p.start.clone()).unwrap();
    let path = dir.join(format!("{name}.mcap"));
    let mut rec = handover::record::RecordedSession::create(&path, text, session, handover::dryrun::now_ns()).unwrap();
    handover::dryrun::drive(&mut rec, &p.participant, Duration::ZERO).unwrap();
    rec.finish().unwrap();
    let read =
        read_log(&path).unwrap_or_else(|e| panic!("{name}: the protocol was accepted but its log is refused: {e}"));
    assert!(read.finished, "{name}");
}

/// Protocol texts follow one rule, in bytes, from `protocol check` to the log reader: what the
/// check refuses is named (control characters escaped on the terminal), and every protocol it
/// accepts — named cases at the limits and random texts around them — gives a readable log.
#[test]
fn protocol_texts_follow_one_rule_from_check_to_log() {
    let dir = tmpdir("texts");
    let base: serde_json::Value = serde_json::from_str(&small_protocol_text()).unwrap();
    let with = |path: &[&str], value: &str| {
        let mut v = base.clone();
        let mut at = &mut v;
        for k in path {
            at = match k.parse::<usize>() {
                Ok(i) => &mut at[i],
                Err(_) => &mut at[*k],
            };
        }
        *at = value.into();
        v.to_string()
    };
    let check = |name: &str, text: &str| {
        let file = dir.join(format!("{name}.json"));
        std::fs::write(&file, text).unwrap();
        run_in(&dir, &["protocol", "check", file.to_str().unwrap()])
    };
    let refused: Vec<(&str, String, &str)> = vec![
        ("tab-in-name", with(&["name"], "bike\thandover"), "U+0009"),
        ("umlauts-300-bytes", with(&["name"], &"ü".repeat(150)), "300 bytes"),
        ("label-122-bytes", with(&["session", "program_labels", "0"], &"ü".repeat(61)), "122 bytes"),
        ("osc-in-object-label", with(&["objects", "0", "label"], "\u{1b}]0;x\u{7}bars"), "U+001B"),
        ("clear-in-statement", with(&["questionnaire", "items", "0", "statement"], "\u{1b}[2J"), "U+001B"),
        ("query-id-path", with(&["training_menu", "0", "id"], "../../../../x"), "is not an id"),
        ("query-id-absolute", with(&["test_set", "0", "id"], "/tmp/x"), "is not an id"),
        ("second-document", format!("{}\n{{}}", small_protocol_text()), "nothing after"),
        ("byte-order-mark", format!("\u{feff}{}", small_protocol_text()), "byte-order mark"),
    ];
    for (name, text, why) in &refused {
        let r = check(name, text);
        assert_eq!(r.code, 2, "{name}: refused\n{}", r.stderr);
        assert!(r.stderr.contains(why), "{name}: says {why}\n{}", r.stderr);
        assert!(!r.stderr.contains('\u{1b}') && !r.stderr.contains('\u{7}'), "{name}: no raw control character");
    }
    let accepted = [
        ("umlauts-200-bytes", with(&["name"], &"ü".repeat(100))),
        ("label-100-bytes", with(&["session", "program_labels", "0"], &"ü".repeat(50))),
        ("lines-in-description", with(&["description"], "first line\nsecond line")),
    ];
    for (name, text) in &accepted {
        let r = check(name, text);
        assert_eq!(r.code, 0, "{name}: accepted\n{}", r.stderr);
        log_of_accepted(&dir, name, text);
    }
    // Random texts around the limits, from an alphabet of ASCII, two- to four-byte characters
    // and control characters: whatever the validator accepts, the reader accepts.
    let alphabet = ['a', 'Z', '7', ' ', '-', 'ü', '€', '𝄞', '\t', '\n', '\u{1b}', '\u{85}', '\u{7f}'];
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(33);
    let (mut tried, mut ok) = (0, 0);
    for case in 0..24 {
        let field: &[&str] = match case % 3 {
            0 => &["name"],
            1 => &["session", "program_labels", "1"],
            _ => &["objects", "1", "label"],
        };
        let len = rng.random_range(1..=70usize);
        let clean = rng.random_bool(0.6);
        let s: String = (0..len)
            .map(|_| {
                let n = if clean { 8 } else { alphabet.len() };
                alphabet[rng.random_range(0..n)]
            })
            .collect();
        let text = with(field, s.trim());
        if s.trim().is_empty() {
            continue;
        }
        tried += 1;
        if Study::from_json(&text, "random").is_ok() {
            ok += 1;
            log_of_accepted(&dir, &format!("random-{case}"), &text);
        }
    }
    assert!(ok > 3 && ok < tried, "both outcomes were tried: {ok} of {tried} accepted");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Makes a FIFO (named pipe) at `path`.
fn mkfifo(path: &Path) {
    let st = Command::new("mkfifo").arg(path).status().unwrap();
    assert!(st.success(), "mkfifo {}", path.display());
}

#[test]
fn fifos_and_link_loops_are_refused_without_waiting() {
    let dir = tmpdir("fifos");
    let log_dir = dir.join("logs").join("p-abc");
    std::fs::create_dir_all(&log_dir).unwrap();
    mkfifo(&log_dir.join("session.mcap"));
    std::fs::create_dir_all(dir.join("participants")).unwrap();
    mkfifo(&dir.join("participants").join("p-abc.json"));
    mkfifo(&dir.join("protocol.json"));
    // Each names the FIFO at once (no writer ever opens these pipes) and exits 2; `analyze`
    // skips it as it skips any file that is not a log, and exits 1.
    let cases: &[(&[&str], &str, i32)] = &[
        (&["analyze", "logs/p-abc/session.mcap"], "session.mcap", 1),
        (&["resume", "--no-console", "logs/p-abc/session.mcap"], "session.mcap", 2),
        (&["follow", "logs/p-abc/session.mcap"], "session.mcap", 2),
        (&["protocol", "check", "protocol.json"], "protocol.json", 2),
        (&["dry-run", "--protocol", "protocol.json"], "protocol.json", 2),
        (&["participant", "show", "p-abc"], "p-abc.json", 2),
        (&["participant", "withdraw", "p-abc"], "p-abc.json", 2),
    ];
    for (args, name, code) in cases {
        let t0 = Instant::now();
        let r = run_in(&dir, args);
        assert_eq!(r.code, *code, "{args:?}: {}", r.stderr);
        assert!(r.stderr.contains(name) && r.stderr.contains("FIFO"), "{args:?}: {}", r.stderr);
        assert!(t0.elapsed() < Duration::from_secs(10), "{args:?} waited {:?}", t0.elapsed());
    }
    // A folder walk passes a FIFO by, and does not follow a link that loops back: one
    // real log beside them is found once, with no warning per level of the loop.
    let real = base_log(&dir);
    std::os::unix::fs::symlink("..", log_dir.join("loop")).unwrap();
    std::os::unix::fs::symlink(dir.join("logs"), dir.join("logs").join("again")).unwrap();
    let r = run_in(&dir, &["analyze", "--alpha-particles", "300", "logs"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert!(r.stderr.lines().count() < 5, "a warnings flood:\n{}", r.stderr);
    let sessions = r.stdout.lines().filter(|l| l.contains(real.file_stem().unwrap().to_str().unwrap())).count();
    assert!(sessions <= 1, "the log was found through a link:\n{}", r.stdout);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The default protocol in the three shapes its sections take: as shipped; with a
/// `population` (each learned component's mean mid-range, sd a sixth of it); learning from
/// the measured arm (`learning.measurement`).
fn protocol_shapes() -> Vec<(&'static str, serde_json::Value)> {
    let base: serde_json::Value = serde_json::from_str(DEFAULT_PROTOCOL).unwrap();
    let mut with_population = base.clone();
    let spreads = |field: &str| -> serde_json::Value {
        base["learning"]["prior"][field]
            .as_array()
            .unwrap()
            .iter()
            .map(|c| match (c["min"].as_f64(), c["max"].as_f64()) {
                (Some(lo), Some(hi)) => serde_json::json!({"mean": (lo + hi) / 2.0, "sd": (hi - lo) / 6.0}),
                _ => serde_json::json!({"mean": c["value"].as_f64().unwrap_or(0.0), "sd": 0.0}),
            })
            .collect()
    };
    with_population["population"] = serde_json::json!({"q_star_deg": spreads("q_star_deg"), "w": spreads("w")});
    let mut measured = base.clone();
    measured["learning"]["observation"] = "measured".into();
    measured["learning"]["measurement"] = serde_json::json!({"sigma_deg": vec![3.0; 7]});
    vec![("as shipped", base), ("with a population", with_population), ("measured", measured)]
}

/// A protocol's sections take one entry per joint, per region, per query: every array of
/// the protocol in each of its shapes lengthened by one (its last entry again), shortened by
/// one, and emptied is refused naming a field, or accepted and runs; never a panic.
#[test]
fn every_array_of_a_protocol_lengthened_shortened_or_emptied_is_refused_or_runs() {
    let (mut refused, mut accepted) = (0, 0);
    for (shape, base) in protocol_shapes() {
        assert!(Study::from_json(&base.to_string(), "shape.json").is_ok(), "{shape}: the base is valid");
        let mut paths = Vec::new();
        paths_where(&base, serde_json::Value::is_array, &mut Vec::new(), &mut paths);
        for path in &paths {
            type Edit = (&'static str, fn(&mut Vec<serde_json::Value>));
            let edits: [Edit; 3] = [
                ("lengthened", |a| {
                    let last = a.last().cloned().unwrap_or(serde_json::json!(0));
                    a.push(last)
                }),
                ("shortened", |a| {
                    a.pop();
                }),
                ("emptied", |a| a.clear()),
            ];
            for (what, edit) in edits {
                let mut v = base.clone();
                edit(at_path(&mut v, path).as_array_mut().unwrap());
                let text = v.to_string();
                let field = format!("{shape}: {} {what}", path.join("."));
                let result = std::panic::catch_unwind(|| match Study::from_json(&text, "hostile.json") {
                    Ok(study) => {
                        let study = std::sync::Arc::new(study);
                        // What dry runs and plans draw people from.
                        let _ = study.population().draw(1, 0);
                        handover::session::check_runs(study).map(|()| true).map_err(|e| e.to_string())
                    }
                    Err(e) => {
                        let e = e.to_string();
                        assert!(e.starts_with("hostile.json: invalid protocol") && e.contains("  - "), "{e}");
                        Ok(false)
                    }
                });
                match result.unwrap_or_else(|_| panic!("{field}: panicked")) {
                    Ok(true) => accepted += 1,
                    Ok(false) => refused += 1,
                    Err(e) => panic!("{field}: accepted by validation but does not run: {e}"),
                }
            }
        }
    }
    eprintln!(
        "{} protocols with an array's length changed: {refused} refused, {accepted} accepted and run",
        refused + accepted
    );
    assert!(refused > 0 && accepted > 0);
}

/// A log's protocol `text` in place of the one it embeds: the log rewritten record by record
/// (its messages, metadata and other attachments as they were), so that only the protocol
/// is wrong and every CRC is right.
fn with_embedded_protocol(log: &[u8], text: &str) -> Vec<u8> {
    let summary = mcap::Summary::read(log).unwrap().expect("a summary");
    let profile = match mcap::read::LinearReader::new(log).unwrap().next() {
        Some(Ok(mcap::records::Record::Header(h))) => h.profile,
        other => panic!("no header: {other:?}"),
    };
    let options = mcap::WriteOptions::new().profile(profile);
    let mut w = options.create(std::io::Cursor::new(Vec::new())).unwrap();
    for m in mcap::MessageStream::new(log).unwrap() {
        w.write(&m.unwrap()).unwrap();
    }
    for index in &summary.attachment_indexes {
        let mut a = mcap::read::attachment(log, index).unwrap();
        if a.name == "protocol.json" {
            a.data = std::borrow::Cow::Owned(text.as_bytes().to_vec());
        }
        w.attach(&a).unwrap();
    }
    for index in &summary.metadata_indexes {
        w.write_metadata(&mcap::read::metadata(log, index).unwrap()).unwrap();
    }
    w.finish().unwrap();
    w.into_inner().into_inner()
}

/// A protocol no command accepts, embedded in a log: `analyze` skips the log, naming it,
/// and analyses the rest; `resume` and `follow` refuse it naming it (exit 2). And the same
/// protocol's prior or population as a file for `protocol with`: refused, exit 2. Cases: a
/// prior's 8th joint (q* and w), a population's 8th, a prior's mean outside its range.
#[test]
fn a_protocol_no_command_accepts_is_named_wherever_it_comes_from() {
    let root = tmpdir("embedded-protocol");
    let base = base_log(&root);
    let good = std::fs::read(&base).unwrap();
    let r = run_in(&root, &["dry-run", "--protocol", "small.json", "--seed", "10", "--logs", "other"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let other = std::fs::read(handover::record::mcap_files(&root.join("other")).pop().unwrap()).unwrap();
    let small: serde_json::Value = serde_json::from_str(&small_protocol_text()).unwrap();
    let population = protocol_shapes().remove(1).1["population"].clone();
    type Edit = (&'static str, fn(&mut serde_json::Value), &'static str);
    let cases: [Edit; 4] = [
        ("prior-q-8", |v| push_last(&mut v["learning"]["prior"]["q_star_deg"]), "learning.prior.q_star_deg"),
        ("prior-w-8", |v| push_last(&mut v["learning"]["prior"]["w"]), "learning.prior.w"),
        ("population-8", |v| push_last(&mut v["population"]["q_star_deg"]), "population.q_star_deg"),
        (
            "mean-outside",
            |v| {
                v["learning"]["prior"]["q_star_deg"][1] =
                    serde_json::json!({"kind": "gaussian", "mean": 300.0, "sd": 10.0, "min": -10.0, "max": 60.0})
            },
            "mean 300 lies outside",
        ),
    ];
    for (name, edit, words) in cases {
        let mut v = small.clone();
        v["population"] = population.clone();
        edit(&mut v);
        let (verify, resume) = try_log(&root, name, &with_embedded_protocol(&good, &v.to_string()));
        assert_eq!((verify, resume), (1, 2), "{name}");
        // Beside a good log (another session), the bad one is skipped by name and the good
        // one analysed.
        let case = root.join(format!("{name}-beside"));
        std::fs::create_dir_all(case.join("logs/p-good")).unwrap();
        std::fs::write(case.join("logs/p-good/good.mcap"), &other).unwrap();
        std::fs::create_dir_all(case.join("logs/p-bad")).unwrap();
        std::fs::write(case.join("logs/p-bad/bad.mcap"), with_embedded_protocol(&good, &v.to_string())).unwrap();
        let r = run_in(&case, &["analyze", "logs", "--alpha-particles", "300", "--out", "results"]);
        assert_eq!(r.code, 1, "{name}: {}", r.stderr);
        assert!(r.stderr.contains("skipped") && r.stderr.contains("bad.mcap"), "{name}: {}", r.stderr);
        assert!(!r.stderr.contains("good.mcap"), "{name}: {}", r.stderr);
        assert!(case.join("results/pilot/sessions.csv").exists(), "{name}: the good log is analysed");
        // The section as a file for `protocol with`.
        let (field, section) = if name.starts_with("population") {
            ("--population-file", &v["population"])
        } else {
            ("--prior-file", &v["learning"]["prior"])
        };
        std::fs::write(case.join("section.json"), section.to_string()).unwrap();
        let r = run_in(&case, &["protocol", "with", field, "section.json", "--out", "next"]);
        assert_eq!(r.code, 2, "{name}: protocol with\n{}", r.stderr);
        assert!(r.stderr.contains("section.json") && r.stderr.contains(words), "{name}: {}", r.stderr);
    }
    std::fs::remove_dir_all(&root).unwrap();
}

fn push_last(v: &mut serde_json::Value) {
    let a = v.as_array_mut().unwrap();
    let last = a.last().cloned().unwrap();
    a.push(last);
}
