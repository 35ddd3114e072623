//! End to end: the real binary in a real terminal (tmux): start a session, record grasps,
//! undo one, void one, answer the questionnaire, and check the screen and the log.

use crate::support::small_protocol;

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

use handover::record::{mcap_files, read_log};

/// Runs tmux on the server of session `name`. Every session has a server of its own
/// (`-L name`): tests run in parallel, and a shared server exits when its last session is
/// killed, racing another test's `new-session` into a session that never starts.
fn tmux(name: &str, args: &[&str]) -> String {
    let out = Command::new("tmux").args(["-L", name]).args(args).output().expect("tmux runs");
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn has_tmux() -> bool {
    Command::new("tmux").arg("-V").output().is_ok_and(|o| o.status.success())
}

/// A detached tmux session on its own server, killed with its server (and the server's
/// socket file, which tmux leaves behind) when dropped.
struct Session {
    name: String,
    socket: String,
}

impl Session {
    /// Starts `cmd` in a `cols`×`rows` terminal; fails naming tmux's error if it does not start.
    fn start(name: &str, cols: u16, rows: u16, cmd: &str) -> Session {
        let (cols, rows) = (cols.to_string(), rows.to_string());
        let out = Command::new("tmux")
            .args(["-L", name, "new-session", "-d", "-s", name, "-x", &cols, "-y", &rows, cmd])
            .output()
            .expect("tmux runs");
        assert!(out.status.success(), "tmux new-session {name}: {}", String::from_utf8_lossy(&out.stderr));
        let socket = tmux(name, &["display-message", "-p", "-t", name, "#{socket_path}"]).trim().to_string();
        Session { name: name.to_string(), socket }
    }
}

impl Drop for Session {
    fn drop(&mut self) {
        tmux(&self.name, &["kill-server"]);
        if !self.socket.is_empty() {
            let _ = std::fs::remove_file(&self.socket);
        }
    }
}

fn send(name: &str, keys: &[&str]) {
    for k in keys {
        tmux(name, &["send-keys", "-t", name, k]);
        std::thread::sleep(Duration::from_millis(40));
    }
}

fn wait_for(name: &str, text: &str) -> String {
    let t0 = Instant::now();
    loop {
        let screen = tmux(name, &["capture-pane", "-t", name, "-p"]);
        if screen.contains(text) {
            return screen;
        }
        if t0.elapsed() > Duration::from_secs(60) {
            let alive = tmux(name, &["list-panes", "-t", name, "-F", "#{pane_dead} #{pane_current_command}"]);
            panic!("'{text}' never appeared in {name} (pane: '{}'); the screen:\n{screen}", alive.trim());
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// What the operator's instruction said for one trial, read off the screen.
struct Shown {
    query: String,
    position: String,
    orientation: String,
    /// The grasp panel's lines ("1  Left grip (blue)  left-grip").
    grips: Vec<String>,
}

/// Reads the whole instruction off a trial screen: the query's id and the full position,
/// orientation, frame and whose-left lines (none of them cut at 80 columns).
fn instruction_on(screen: &str) -> Shown {
    let line = |start: &str| -> String {
        let l = screen.lines().find(|l| l.contains(start)).unwrap_or_else(|| panic!("no '{start}' line:\n{screen}"));
        l.trim_matches('│').trim().to_string()
    };
    let object = line("(query ");
    let query = object.split("(query ").nth(1).and_then(|r| r.split(')').next()).unwrap().to_string();
    let position = line("position     x ");
    assert!(position.ends_with("m, of the object's centre"), "cut: '{position}'");
    let orientation = line("orientation  roll ");
    assert!(orientation.contains("yaw ") && orientation.ends_with('°'), "cut: '{orientation}'");
    assert!(line("frame        participant's").ends_with("y to their left, z up"), "{screen}");
    assert!(line("left, right ").ends_with("as they face the robot"), "{screen}");
    let grips = (1..=9)
        .map_while(|k| {
            let key = format!("│ {k}  ");
            let l = screen.lines().find(|l| l.starts_with(&key))?;
            Some(l.split('│').nth(1)?.trim().to_string())
        })
        .collect();
    Shown { query, position, orientation, grips }
}

/// A whole session at the smallest size the console accepts (80×24), driven by keys as an
/// experimenter would: every trial's full instruction is read off the screen (and checked
/// against the log's study afterwards), a grasp is undone and a trial voided, each
/// transition is confirmed, and the questionnaire is handed to the participant and back.
#[test]
fn the_console_runs_a_session_in_a_real_terminal() {
    if !has_tmux() {
        crate::support::missing("tmux");
        return;
    }
    let dir = std::env::temp_dir().join(format!("handover-tmux-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let proto = small_protocol(&dir);
    let name = format!("handover-e2e-{}", std::process::id());
    let cmd = format!(
        "{} run --protocol {} --logs {} --participants-dir {} --seed 5; sleep 30",
        env!("CARGO_BIN_EXE_handover"),
        proto.display(),
        dir.join("logs").display(),
        dir.join("participants").display()
    );
    let _guard = Session::start(&name, 80, 24, &cmd);
    wait_for(&name, "Press Enter to start the session.");
    send(&name, &["Enter"]);
    let mut shown = Vec::new();
    // Trial 1: present, take grip 1, undo it, take grip 2 instead.
    shown.push(instruction_on(&wait_for(&name, "Training · Program A · trial 1/5")));
    send(&name, &["Enter", "1"]);
    wait_for(&name, "trial 2/5");
    send(&name, &["u"]);
    let screen = wait_for(&name, "Training · Program A · trial 1/5");
    assert!(screen.contains("Presented."), "the undone trial awaits its grasp again:\n{screen}");
    send(&name, &["2"]);
    // Trial 2: present, then void it (robot fault); it is repeated.
    shown.push(instruction_on(&wait_for(&name, "trial 2/5")));
    send(&name, &["Enter", "x"]);
    wait_for(&name, "Why is this trial void?");
    send(&name, &["2"]);
    wait_for(&name, "Trial 2 voided (robot fault)");
    // Every other trial: wait for its screen, read the instruction, present, grasp; the
    // transitions between the phases are confirmed.
    let mut phases = vec![("Training · Program A", 5, 2)];
    phases.push(("Training · Program B", 5, 1));
    phases.push(("Test", 16, 1));
    for (k, (phase, of, first)) in phases.into_iter().enumerate() {
        if k > 0 {
            wait_for(&name, "Press Enter once the participant has been told.");
            send(&name, &["Enter"]);
        }
        for trial in first..=of {
            let screen = wait_for(&name, &format!("{phase} · trial {trial}/{of}"));
            shown.push(instruction_on(&screen));
            send(&name, &["Enter", if trial % 2 == 0 { "1" } else { "2" }]);
        }
    }
    wait_for(&name, "The questionnaire is next");
    send(&name, &["Enter"]);
    wait_for(&name, "statement 1/8");
    // The participant answers: each number confirmed with Enter (a number alone does not
    // move on); Enter at the end asks for the keyboard back; Ctrl+E takes it back.
    send(&name, &["h"]);
    wait_for(&name, "Statement 1 of 8");
    for answer in ["4", "4", "3", "5", "2", "4", "3", "3", "b"] {
        send(&name, &[answer, "Enter"]);
    }
    wait_for(&name, "Please hand the keyboard back to the experimenter");
    send(&name, &["C-e"]);
    let screen = wait_for(&name, "Press Enter to finish the session");
    assert!(screen.contains("8 of 8 statements answered") && screen.contains("forced choice: Program B"), "{screen}");
    send(&name, &["Enter"]);
    let screen = wait_for(&name, "Session complete.");
    assert!(screen.contains("Program A = "), "{screen}");
    send(&name, &["q"]);
    std::thread::sleep(Duration::from_millis(300));
    let logs = mcap_files(&dir.join("logs"));
    assert_eq!(logs.len(), 1);
    let log = read_log(&logs[0]).unwrap();
    assert!(log.finished);
    let count = |t: &str| log.messages.iter().filter(|m| m.topic == t).count();
    assert_eq!(count("/trial/undo"), 1);
    assert_eq!(count("/trial/void"), 1);
    assert_eq!(count("/trial/response"), 27, "26 kept and the one undone");
    assert_eq!(count("/questionnaire/likert"), 8);
    assert_eq!(count("/questionnaire/choice"), 1);
    let end = log.messages.iter().find(|m| m.topic == "/session/end").unwrap();
    assert_eq!(end.value["status"], "completed");
    // What the screen said is the pose the session ran, for every one of the 27 screens.
    assert_eq!(shown.len(), 27, "26 trials and the voided one");
    let study = handover::record::study_of(&log).unwrap();
    for s in &shown {
        let q = study.training.iter().chain(&study.test).find(|q| q.query.id == s.query).expect("a query of the study");
        let [x, y, z] = q.pose.position;
        let [r, p, w] = q.pose.rpy_deg;
        assert!(s.position.contains(&format!("x {x:+.3}  y {y:+.3}  z {z:+.3} m")), "{}: {}", s.query, s.position);
        assert!(s.orientation.contains(&format!("roll {r:+.1}°  pitch {p:+.1}°  yaw {w:+.1}°")), "{}", s.orientation);
        // Each grip offered, whole: its key, the protocol's label and the id the CSVs use.
        let object = &study.protocol.objects[q.object];
        let expected: Vec<String> = (q.regions.iter().enumerate())
            .map(|(k, &r)| format!("{}  {}  {}", k + 1, object.regions[r].label, object.regions[r].id))
            .collect();
        assert_eq!(s.grips, expected, "{}", s.query);
    }
    let _ = std::fs::remove_dir_all(dir);
}

/// The command line of a console whose exit status and terminal modes afterwards are
/// written to `status` (the shell prints `stty -a` after the console returns).
fn console_cmd(dir: &Path, proto: &Path, extra: &str, status: &Path) -> String {
    format!(
        "{} run --protocol {} --study-dir {} {extra}; echo \"exit=$?\" > {}; stty -a >> {}; sleep 30",
        env!("CARGO_BIN_EXE_handover"),
        proto.display(),
        dir.display(),
        status.display(),
        status.display()
    )
}

fn wait_file(path: &Path) -> String {
    let t0 = Instant::now();
    loop {
        if let Ok(s) = std::fs::read_to_string(path)
            && s.contains("icanon")
        {
            return s;
        }
        assert!(t0.elapsed() < Duration::from_secs(30), "{} never written", path.display());
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// Waits until a process has exited (a console must not outlive its terminal).
fn wait_gone(pid: &str) {
    let t0 = Instant::now();
    while Path::new(&format!("/proc/{pid}")).exists()
        && !std::fs::read_to_string(format!("/proc/{pid}/stat")).unwrap_or_default().contains(") Z")
    {
        assert!(t0.elapsed() < Duration::from_secs(10), "process {pid} outlived its terminal");
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// The console's own process id (the child of the tmux pane's shell).
fn console_pid(name: &str) -> String {
    let shell = tmux(name, &["display-message", "-p", "-t", name, "#{pane_pid}"]).trim().to_string();
    let out = Command::new("pgrep").args(["-P", &shell]).output().expect("pgrep runs");
    String::from_utf8_lossy(&out.stdout).lines().next().expect("the console runs").trim().to_string()
}

#[test]
fn signals_restore_the_terminal_and_leave_the_session_resumable() {
    if !has_tmux() {
        crate::support::missing("tmux");
        return;
    }
    let dir = std::env::temp_dir().join(format!("handover-signal-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let proto = small_protocol(&dir);
    for (k, (signal, number)) in
        [("TERM", 15), ("HUP", 1), ("INT", 2), ("QUIT", 3), ("USR1", 10), ("ALRM", 14)].into_iter().enumerate()
    {
        let status = dir.join(format!("status-{signal}"));
        let name = format!("handover-sig-{}-{k}", std::process::id());
        let _guard = Session::start(&name, 100, 30, &console_cmd(&dir, &proto, "--seed 5", &status));
        wait_for(&name, "Press Enter to start the session.");
        send(&name, &["Enter"]);
        wait_for(&name, "trial 1/5");
        send(&name, &["Enter", "1"]);
        wait_for(&name, "trial 2/5");
        let pid = console_pid(&name);
        // A second console for the same participant is refused while this one runs.
        if k == 0 {
            let logs = mcap_files(&dir.join("logs"));
            let participant = read_log(&logs[0]).unwrap().start.participant;
            let second = format!("{name}-2");
            let status2 = dir.join("status-second");
            let extra = format!("--participant {participant}");
            let g2 = Session::start(&second, 100, 30, &console_cmd(&dir, &proto, &extra, &status2));
            wait_for(&second, "Press Enter to start the session.");
            send(&second, &["Enter"]);
            let screen = wait_for(&second, "already has a live session");
            assert!(screen.contains(&format!("process {pid}")), "says who holds it:\n{screen}");
            // Its window is closed: the console goes with its terminal.
            let second_pid = console_pid(&second);
            drop(g2);
            wait_gone(&second_pid);
        }
        Command::new("kill").args([&format!("-{signal}"), &pid]).status().unwrap();
        let after = wait_file(&status);
        assert!(after.contains(&format!("exit={}", 128 + number)), "SIG{signal}: {after}");
        assert!(after.contains(" icanon") && after.contains(" echo"), "SIG{signal}: the terminal is restored: {after}");
    }
    // Every interrupted session is whole on disk and resumable: one grasp each.
    let logs = mcap_files(&dir.join("logs"));
    assert_eq!(logs.len(), 6, "{logs:?}");
    for l in &logs {
        let log = read_log(l).unwrap();
        assert!(log.finished && !log.cut_tail, "{}", l.display());
        assert_eq!(log.messages.iter().filter(|m| m.topic == "/trial/response").count(), 1);
    }
    let _ = std::fs::remove_dir_all(dir);
}

/// The robot operator's screen in a second terminal: `handover follow` on the log the
/// console is writing shows the console's current query, whole at 80×24, and moves on with
/// it; q leaves it without touching the session.
#[test]
fn follow_in_a_second_terminal_tracks_the_console() {
    if !has_tmux() {
        crate::support::missing("tmux");
        return;
    }
    let dir = std::env::temp_dir().join(format!("handover-follow-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let proto = small_protocol(&dir);
    let console = format!("handover-follow-console-{}", std::process::id());
    let cmd = format!(
        "{} run --protocol {} --study-dir {} --seed 5; sleep 30",
        env!("CARGO_BIN_EXE_handover"),
        proto.display(),
        dir.display()
    );
    let _g1 = Session::start(&console, 80, 24, &cmd);
    wait_for(&console, "Press Enter to start the session.");
    send(&console, &["Enter"]);
    let query_of = |screen: &str| -> String {
        let l = screen.lines().find(|l| l.contains("(query ")).expect("a query on screen");
        l.split("(query ").nth(1).and_then(|r| r.split(')').next()).unwrap().to_string()
    };
    let first = query_of(&wait_for(&console, "trial 1/5"));
    let log = mcap_files(&dir.join("logs")).pop().expect("the console's log");
    let follower = format!("handover-follow-reader-{}", std::process::id());
    let fcmd = format!("{} follow {}; echo \"exit=$?\"; sleep 30", env!("CARGO_BIN_EXE_handover"), log.display());
    let _g2 = Session::start(&follower, 80, 24, &fcmd);
    let screen = wait_for(&follower, &format!("(query {first})"));
    assert!(screen.contains("of the object's centre") && screen.contains("read-only"), "{screen}");
    send(&console, &["Enter"]);
    wait_for(&follower, "The participant is taking the object.");
    send(&console, &["1"]);
    let second = query_of(&wait_for(&console, "trial 2/5"));
    let screen = wait_for(&follower, "Training · Program A · trial 2/5");
    assert!(screen.contains(&format!("(query {second})")), "{screen}");
    send(&follower, &["q"]);
    wait_for(&follower, "exit=0");
    // The console goes on unaffected.
    send(&console, &["Enter", "2"]);
    wait_for(&console, "trial 3/5");
    send(&console, &["q", "y"]);
    wait_for(&console, "handover resume");
    let _ = std::fs::remove_dir_all(dir);
}

/// The robot operator never sees a stale pose: when the console is killed (`kill -9`, no
/// word in the log), `handover follow` says the console is lost and shows no pose; when
/// the session is resumed it follows the continuation and shows the resumed console's trial.
#[test]
fn follow_says_when_the_console_is_lost_and_follows_its_resumption() {
    if !has_tmux() {
        crate::support::missing("tmux");
        return;
    }
    let dir = std::env::temp_dir().join(format!("handover-follow-lost-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let proto = small_protocol(&dir);
    let console = format!("handover-lost-console-{}", std::process::id());
    let bin = env!("CARGO_BIN_EXE_handover");
    let cmd = format!("{bin} run --protocol {} --study-dir {} --seed 5; sleep 30", proto.display(), dir.display());
    let _g1 = Session::start(&console, 80, 24, &cmd);
    wait_for(&console, "Press Enter to start the session.");
    send(&console, &["Enter"]);
    wait_for(&console, "trial 1/5");
    send(&console, &["Enter", "1"]);
    wait_for(&console, "trial 2/5");
    let log = mcap_files(&dir.join("logs")).pop().expect("the console's log");
    let follower = format!("handover-lost-reader-{}", std::process::id());
    let fcmd = format!("{bin} follow {}; sleep 30", log.display());
    let _g2 = Session::start(&follower, 80, 24, &fcmd);
    wait_for(&follower, "trial 2/5");
    let pid = console_pid(&console);
    Command::new("kill").args(["-9", &pid]).status().unwrap();
    let screen = wait_for(&follower, "THE CONSOLE HAS STOPPED");
    assert!(screen.contains("Console lost") && !screen.contains("(query "), "no pose once lost:\n{screen}");
    // The session is resumed in another terminal: the follower moves to the continuation.
    let resumer = format!("handover-lost-resume-{}", std::process::id());
    let rcmd = format!("{bin} resume {}; sleep 30", log.display());
    let _g3 = Session::start(&resumer, 80, 24, &rcmd);
    wait_for(&resumer, "trial 2/5");
    let continuation = mcap_files(&dir.join("logs")).into_iter().find(|p| *p != log).expect("a continuation");
    let name = continuation.file_name().unwrap().to_string_lossy().into_owned();
    let screen = wait_for(&follower, &name);
    assert!(screen.contains("trial 2/5") && !screen.contains("Console lost"), "{screen}");
    send(&resumer, &["Enter", "2"]);
    wait_for(&resumer, "trial 3/5");
    wait_for(&follower, "trial 3/5");
    send(&resumer, &["q", "y"]);
    wait_for(&resumer, "handover resume");
    let _ = std::fs::remove_dir_all(dir);
}

/// A left-handed 1.95 m participant at the smallest size (80×24), in a real terminal: every
/// line of each trial's instruction is on screen whole (the mirrored whose-left line included,
/// and "Press Enter when the robot holds the object there."), and the grips are named as the
/// participant has them (the protocol's "Left grip (blue)" is their "Right grip (blue)").
#[test]
fn a_left_handed_tall_participant_gets_the_whole_instruction_at_80_by_24() {
    if !has_tmux() {
        crate::support::missing("tmux");
        return;
    }
    let dir = std::env::temp_dir().join(format!("handover-tmux-left-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let proto = small_protocol(&dir);
    let study = dir.join("study");
    let (code, out, err) = crate::support::handover(&[
        "participant",
        "new",
        "--study-dir",
        study.to_str().unwrap(),
        "--body-height",
        "1.95",
        "--handedness",
        "left",
    ]);
    assert_eq!(code, 0, "{err}");
    let id = out.split_whitespace().find(|w| w.starts_with("p-")).expect("the new id is printed").to_string();
    let name = format!("handover-left-{}", std::process::id());
    let cmd = format!(
        "{} run --protocol {} --study-dir {} --participant {id} --seed 3; sleep 30",
        env!("CARGO_BIN_EXE_handover"),
        proto.display(),
        study.display()
    );
    let _guard = Session::start(&name, 80, 24, &cmd);
    wait_for(&name, "Press Enter to start the session.");
    send(&name, &["Enter"]);
    for trial in 1..=3 {
        let screen = wait_for(&name, &format!("trial {trial}/5"));
        let lines: Vec<&str> = screen.lines().map(|l| l.trim_matches('│').trim()).collect();
        for needle in [
            "frame        participant's left shoulder: x ahead, y to their left, z up",
            "hand         LEFT hand (on your right, facing them)",
            "left, right  the participant's (protocol labels mirrored, colours kept)",
            "Press Enter when the robot holds the object there.",
            "Which grip did the participant take?",
        ] {
            assert!(lines.iter().any(|l| l.starts_with(needle)), "trial {trial}: '{needle}' is not whole:\n{screen}");
        }
        assert!(
            lines.iter().any(|l| l.starts_with("position     x ") && l.ends_with("m, of the object's centre")),
            "trial {trial}: the position is cut:\n{screen}"
        );
        // Each offered grip: blue is the participant's right, red their left.
        for l in lines.iter().filter(|l| l.contains("grip (")) {
            assert!(
                (l.contains("Right") && l.contains("(blue)")) || (l.contains("Left") && l.contains("(red)")),
                "trial {trial}: a grip named as the protocol's right hand has it: '{l}'\n{screen}"
            );
        }
        send(&name, &["Enter", "1"]);
    }
    send(&name, &["q", "y"]);
    wait_for(&name, "handover resume");
    let _ = std::fs::remove_dir_all(&dir);
}
