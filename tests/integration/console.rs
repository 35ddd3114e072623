//! The console without a terminal: every screen as a snapshot at 100×30, and whole
//! sessions driven by key events through the app, with and without a robot.
//!
//! Its length: one test per way a session is driven (keys, failures, resume, the robot),
//! sharing the console's setup and snapshot helpers.

use crate::support::tmpdir;

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

use handover::protocol::{DEFAULT_PROTOCOL, Study};
use handover::record::read_log;
use handover::session::VoidReason;
use handover::study_dir::StudyDirs;
use handover::tui::app::Overlay;
use handover::tui::app::Screen;
use handover::tui::{App, AppConfig, render};
use ratatui::Terminal;
use ratatui::backend::TestBackend;
use ratatui::crossterm::event::{KeyCode, KeyEvent, KeyModifiers};

pub(crate) const T0: u64 = 1_800_000_000_000_000_000;

pub(crate) fn config(dir: &Path, simulate: bool) -> AppConfig {
    let mut v: serde_json::Value = serde_json::from_str(DEFAULT_PROTOCOL).unwrap();
    v["learning"]["particles"] = 300.into();
    let text = v.to_string();
    let study = Arc::new(Study::from_json(&text, "small").unwrap());
    AppConfig {
        study,
        protocol_text: text,
        dirs: StudyDirs::resolve(Some(dir), None, None),
        participant: "new".into(),
        simulate,
        pilot: false,
        pilot_body: Default::default(),
        practice: false,
        pace: Duration::ZERO,
        seed: Some(1),
        tap: None,
    }
}

/// A console on the test protocol as `edit` changes it.
fn app_with_protocol(dir: &Path, edit: impl FnOnce(&mut serde_json::Value)) -> App {
    let mut cfg = config(dir, false);
    let mut v: serde_json::Value = serde_json::from_str(&cfg.protocol_text).unwrap();
    edit(&mut v);
    cfg.protocol_text = v.to_string();
    cfg.study = Arc::new(Study::from_json(&cfg.protocol_text, "edited").unwrap());
    let mut a = App::new(cfg);
    a.tick(T0);
    a
}

pub(crate) fn app(dir: &Path) -> App {
    let mut a = App::new(config(dir, false));
    a.tick(T0);
    a
}

pub(crate) fn press(app: &mut App, code: KeyCode) {
    app.key(KeyEvent::new(code, KeyModifiers::NONE));
    app.wait_idle();
}

pub(crate) fn keys(app: &mut App, s: &str) {
    for c in s.chars() {
        press(app, KeyCode::Char(c));
    }
}

/// The screen as text, drawn 65 s after the clock's start.
pub(crate) fn screen(app: &mut App, width: u16, height: u16) -> String {
    let now = app.now_ns;
    app.now_ns = T0 + 65_000_000_000;
    let mut t = Terminal::new(TestBackend::new(width, height)).unwrap();
    t.draw(|f| render(app, f)).unwrap();
    app.now_ns = now;
    t.backend().to_string()
}

/// The sizes every screen is drawn at: the smallest the console accepts, a common one and a
/// large one.
const SIZES: [(u16, u16); 3] = [(80, 24), (100, 30), (160, 45)];

/// A screen at every size, one snapshot holding the three.
fn at_sizes(app: &mut App) -> String {
    SIZES.iter().map(|&(w, h)| format!("{w}×{h}\n{}", screen(app, w, h))).collect::<Vec<_>>().join("\n")
}

macro_rules! snap {
    ($name:expr, $app:expr) => {{
        let text = at_sizes($app);
        insta::with_settings!({filters => vec![
            (r"p-[a-z0-9]{8}", "p-XXXXXXXX"),
            (r"\d{8}T\d{6}Z(-\d+)?", "TIME"),

        ]}, {
            insta::assert_snapshot!($name, text);
        });
    }};
}

/// Presents and records the first offered grip of `n` trials.
/// Answers questionnaire items in turn: each key, then Enter to move on.
pub(crate) fn answer(app: &mut App, answers: &str) {
    past_transition(app);
    for c in answers.chars() {
        keys(app, &c.to_string());
        press(app, KeyCode::Enter);
    }
}

/// Confirms the transition screen between phases, if one is shown.
pub(crate) fn past_transition(app: &mut App) {
    if app.transition().is_some() {
        press(app, KeyCode::Enter);
    }
}

fn trials(app: &mut App, n: usize, grip: char) {
    for _ in 0..n {
        past_transition(app);
        press(app, KeyCode::Enter);
        keys(app, &grip.to_string());
    }
}

/// Every line of the operator's instruction is on screen whole, at the smallest size.
fn assert_full_instruction(app: &mut App) {
    let text = screen(app, 80, 24);
    for needle in [
        "position     x ",
        "of the object's centre",
        "orientation  roll ",
        "yaw ",
        "frame        participant's",
        "z up",
        "left, right  always the participant's",
    ] {
        assert!(text.contains(needle), "'{needle}' is not on the 80×24 screen:\n{text}");
    }
}

#[test]
fn every_screen_at_three_sizes() {
    // A fixed directory, so that the log path on screen has the same length every run.
    let dir = PathBuf::from("target/console-snapshots");
    let _ = std::fs::remove_dir_all(&dir);
    let mut a = app(&dir);
    snap!("setup", &mut a);
    press(&mut a, KeyCode::Enter);
    snap!("trial_present", &mut a);
    assert_full_instruction(&mut a);
    // Joints are numbered as every table and output numbers them: q*1 … q*7.
    for (w, h) in [(100, 30), (160, 45)] {
        let s = screen(&mut a, w, h);
        assert!(s.contains("q*1 ") && s.contains("q*7 ") && !s.contains("q*0"), "{s}");
    }
    press(&mut a, KeyCode::Enter);
    snap!("trial_grasp", &mut a);
    // Presented, on a short screen: the object and the pose, and the rows to the history.
    let presented = screen(&mut a, 80, 24);
    assert!(presented.contains("pose         ") && !presented.contains("orientation"), "{presented}");
    keys(&mut a, "2");
    snap!("trial_after_grasp", &mut a);
    keys(&mut a, "?");
    snap!("help", &mut a);
    press(&mut a, KeyCode::Esc);
    keys(&mut a, "x");
    snap!("void_reason", &mut a);
    keys(&mut a, "4");
    keys(&mut a, "fire alarm");
    snap!("void_detail", &mut a);
    press(&mut a, KeyCode::Esc);
    keys(&mut a, "n");
    keys(&mut a, "water break");
    snap!("note_editor", &mut a);
    press(&mut a, KeyCode::Esc);
    keys(&mut a, "p");
    snap!("paused", &mut a);
    keys(&mut a, "p");
    keys(&mut a, "q");
    snap!("confirm_quit", &mut a);
    keys(&mut a, "a");
    snap!("abort_reason", &mut a);
    press(&mut a, KeyCode::Esc);
    a.overlay = Some(Overlay::WriteFailed { message: "No space left on device (os error 28)".into(), last_event: 3 });
    snap!("write_failed", &mut a);
    a.overlay = None;
    trials(&mut a, 4, '1');
    snap!("transition_between_programs", &mut a);
    trials(&mut a, 5, '1');
    snap!("transition_before_test", &mut a);
    past_transition(&mut a);
    snap!("test_phase", &mut a);
    assert_full_instruction(&mut a);
    trials(&mut a, 16, '2');
    snap!("transition_before_questionnaire", &mut a);
    past_transition(&mut a);
    snap!("questionnaire", &mut a);
    // A key of another questionnaire screen says where it acts (it is not in the footer).
    let events = a.session().unwrap().event_count();
    keys(&mut a, "a");
    assert!(a.status.starts_with("a and b answer the forced choice, after the statements: 1–5"), "{}", a.status);
    assert_eq!(a.session().unwrap().event_count(), events);
    keys(&mut a, "4");
    snap!("questionnaire_answered", &mut a);
    press(&mut a, KeyCode::Enter);
    snap!("questionnaire_second_item", &mut a);
    keys(&mut a, "h");
    snap!("participant_statement", &mut a);
    answer(&mut a, "3524153");
    snap!("participant_forced_choice", &mut a);
    answer(&mut a, "a");
    snap!("participant_hand_back", &mut a);
    a.key(KeyEvent::new(KeyCode::Char('e'), KeyModifiers::CONTROL));
    snap!("questionnaire_review", &mut a);
    keys(&mut a, "3");
    assert!(a.status.starts_with("This is the review: ← goes back to a statement"), "{}", a.status);
    press(&mut a, KeyCode::Left);
    snap!("forced_choice", &mut a);
    keys(&mut a, "3");
    assert!(a.status.starts_with("This is the forced choice: a or b answers it"), "{}", a.status);
    press(&mut a, KeyCode::Right);
    press(&mut a, KeyCode::Enter);
    a.wait_idle();
    snap!("summary", &mut a);
    let small = screen(&mut a, 70, 20);
    assert!(small.contains("Terminal too small") && small.contains("need 80×24, have 70×20"), "{small}");
    insta::assert_snapshot!("too_small", small);
}

#[test]
fn a_whole_session_by_keys_logs_26_responses() {
    let dir = tmpdir("whole");
    let mut a = app(&dir);
    press(&mut a, KeyCode::Enter);
    let mut grip = '1';
    for _ in 0..26 {
        past_transition(&mut a);
        press(&mut a, KeyCode::Enter);
        keys(&mut a, &grip.to_string());
        grip = if grip == '1' { '2' } else { '1' };
    }
    answer(&mut a, "45342512b");
    press(&mut a, KeyCode::Enter);
    a.wait_idle();
    let Screen::Summary(view) = &a.screen else { panic!("expected the summary screen") };
    assert!(view.completed);
    let path = view.log_path.clone();
    let log = read_log(&path).unwrap();
    assert!(log.finished);
    let count = |t: &str| log.messages.iter().filter(|m| m.topic == t).count();
    assert_eq!(count("/trial/response"), 26);
    assert_eq!(count("/questionnaire/likert"), 8);
    assert_eq!(count("/questionnaire/choice"), 1);
    assert!(!log.start.pilot);
    // A participant record was created for the new id, with no name in it.
    let rec =
        std::fs::read_to_string(dir.join("participants").join(format!("{}.json", log.start.participant))).unwrap();
    assert!(rec.contains("\"slot\": 0") && !rec.contains("name"));
    check_with_reference_reader(&path, 26);
    keys(&mut a, "q");
    assert!(a.quit);
}

/// After a key, the loop waits up to half a frame for the key's work before it draws
/// (`App::await_reports`): a grip's update is taken as soon as the worker reports it, and
/// with nothing under way the wait returns at once.
#[test]
fn a_key_s_work_is_taken_as_soon_as_it_is_done() {
    let dir = tmpdir("await");
    let mut a = app(&dir);
    press(&mut a, KeyCode::Enter);
    press(&mut a, KeyCode::Enter);
    let before = a.screen_mode();
    a.key(KeyEvent::new(KeyCode::Char('1'), KeyModifiers::NONE));
    assert!(a.busy(), "the grip is with the worker");
    let t = std::time::Instant::now();
    assert!(a.await_reports(Duration::from_secs(60)), "its report came");
    assert!(t.elapsed() < Duration::from_secs(30), "taken when it came, not at the end of the wait");
    assert!(!a.busy());
    assert_ne!(a.screen_mode(), before, "the next trial awaits its presentation");
    let t = std::time::Instant::now();
    assert!(!a.await_reports(Duration::from_secs(60)), "nothing under way");
    assert!(t.elapsed() < Duration::from_secs(1));
}

/// A number answers the statement shown and stays there (a double press changes the answer,
/// never answers the next one); Enter on an unanswered statement asks before skipping it.
#[test]
fn a_double_press_answers_one_statement_and_enter_asks_before_skipping() {
    let dir = tmpdir("questionnaire");
    let mut a = app(&dir);
    press(&mut a, KeyCode::Enter);
    trials(&mut a, 26, '1');
    past_transition(&mut a);
    keys(&mut a, "44");
    a.wait_idle();
    assert_eq!(a.cursor, 0);
    assert_eq!(a.session().unwrap().likert_answers().len(), 1);
    let s = screen(&mut a, 100, 30);
    assert!(s.contains("statement 1/8") && s.contains("← answered"), "{s}");
    keys(&mut a, "2");
    a.wait_idle();
    assert_eq!(a.session().unwrap().likert_answers().values().copied().collect::<Vec<_>>(), vec![2]);
    press(&mut a, KeyCode::Enter);
    assert_eq!(a.cursor, 1);
    // Unanswered: the first Enter asks, the second skips.
    press(&mut a, KeyCode::Enter);
    assert_eq!(a.cursor, 1);
    let s = screen(&mut a, 100, 30);
    assert!(s.contains("Statement 2 of 8 has no answer"), "{s}");
    press(&mut a, KeyCode::Enter);
    assert_eq!(a.cursor, 2);
    // Asking is for that statement only: answering elsewhere and coming back asks again.
    press(&mut a, KeyCode::Enter);
    keys(&mut a, "3");
    press(&mut a, KeyCode::Enter);
    assert_eq!(a.cursor, 3);
    assert_eq!(a.session().unwrap().likert_answers().len(), 2);
}

/// The reference Python reader (`../shared/tools/check_mcap.py`), when CI provides it
/// through HANDOVER_PYTHON (a Python with `mcap` and `jsonschema`).
fn check_with_reference_reader(path: &Path, responses: usize) {
    let Ok(python) = std::env::var("HANDOVER_PYTHON") else {
        crate::support::missing("HANDOVER_PYTHON, a Python with mcap and jsonschema for the reference reader");
        return;
    };
    let out = std::process::Command::new(python)
        .arg("../shared/tools/check_mcap.py")
        .arg(format!("--expect=/trial/response={responses}"))
        .arg("--expect=/questionnaire/likert=8")
        .arg("--expect=/questionnaire/choice=1")
        .arg(path)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
}

#[test]
fn undo_and_void_by_keys() {
    let dir = tmpdir("undo");
    let mut a = app(&dir);
    press(&mut a, KeyCode::Enter);
    trials(&mut a, 1, '1');
    keys(&mut a, "u");
    let s = a.session().unwrap();
    assert_eq!(s.trials().len(), 0, "the grasp is taken back");
    assert!(matches!(s.prompt(), handover::session::Prompt::Grasp(_)));
    keys(&mut a, "2");
    press(&mut a, KeyCode::Enter);
    keys(&mut a, "x3");
    let s = a.session().unwrap();
    assert!(
        matches!(s.prompt(), handover::session::Prompt::Present(v) if v.trial == 2),
        "the voided trial is repeated"
    );
    keys(&mut a, "u");
    assert!(a.status.contains("Nothing to undo"), "{}", a.status);
    // Keys typed while the app is busy wait their turn.
    a.key(KeyEvent::new(KeyCode::Enter, KeyModifiers::NONE));
    a.key(KeyEvent::new(KeyCode::Char('1'), KeyModifiers::NONE));
    a.key(KeyEvent::new(KeyCode::Enter, KeyModifiers::NONE));
    a.key(KeyEvent::new(KeyCode::Char('2'), KeyModifiers::NONE));
    a.wait_idle();
    assert_eq!(a.session().unwrap().trials().len(), 3);
    keys(&mut a, "qy");
    assert!(a.quit);
    assert!(a.exit_message.as_deref().unwrap_or("").contains("handover resume"));
}

/// A void says so, stays in the phase's history with its reason, and "other" asks what
/// happened (the detail is logged).
#[test]
fn a_void_is_confirmed_kept_in_the_history_and_other_asks_why() {
    let dir = tmpdir("void");
    let mut a = app(&dir);
    press(&mut a, KeyCode::Enter);
    trials(&mut a, 1, '1');
    press(&mut a, KeyCode::Enter);
    keys(&mut a, "x1");
    a.wait_idle();
    assert_eq!(a.status, "Trial 2 voided (object dropped): it is repeated");
    press(&mut a, KeyCode::Enter);
    keys(&mut a, "x4");
    assert!(matches!(a.overlay, Some(Overlay::VoidDetail(_))), "{:?}", a.overlay);
    press(&mut a, KeyCode::Enter);
    assert!(a.status.contains("Say what happened"), "{}", a.status);
    keys(&mut a, "fire alarm");
    press(&mut a, KeyCode::Enter);
    a.wait_idle();
    assert!(a.overlay.is_none());
    let voids = a.session().unwrap().voids().to_vec();
    assert_eq!(voids.len(), 2);
    assert_eq!((voids[1].reason, voids[1].detail.as_str()), (VoidReason::Other, "fire alarm"));
    let s = screen(&mut a, 160, 45);
    assert!(s.contains("voided: object dropped") && s.contains("voided: other — fire alarm"), "{s}");
    // The digit before the object is presented says what to do first.
    keys(&mut a, "1");
    assert!(a.status.starts_with("Press Enter when the robot holds the object there first"), "{}", a.status);
}

/// A study whose participants are registered but which has no logs yet is not new: the
/// setup screen does not say counterbalancing starts afresh; with neither folder it does.
#[test]
fn only_a_study_with_no_folders_is_called_new() {
    let dir = tmpdir("newfolders");
    let mut a = App::new(AppConfig { participant: "new".into(), ..config(&dir, false) });
    a.tick(T0);
    assert!(screen(&mut a, 100, 30).contains("counterbalancing starts afresh"));
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_handover"))
        .args(["participant", "new", "--study-dir", dir.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(out.status.success() && !dir.join("logs").exists());
    let mut a = App::new(AppConfig { participant: "new".into(), ..config(&dir, false) });
    a.tick(T0);
    let s = screen(&mut a, 100, 30);
    assert!(!s.contains("counterbalancing starts afresh") && s.contains("1 registered"), "{s}");
}

/// A participant id with no record is one clear state: not "existing record", no start
/// offered; Enter does not start it.
#[test]
fn an_id_without_a_record_offers_no_start() {
    let dir = tmpdir("norecord");
    let mut a = App::new(AppConfig { participant: "p-NOSUCH01".into(), ..config(&dir, false) });
    a.tick(T0);
    let s = screen(&mut a, 100, 30);
    assert!(s.contains("p-NOSUCH01 (cannot be used: see above)") && s.contains("Cannot start"), "{s}");
    assert!(s.contains("The session cannot start: e enters another participant id"), "{s}");
    assert!(!s.contains("existing record") && !s.contains("Press Enter to start"), "{s}");
    press(&mut a, KeyCode::Enter);
    assert!(matches!(a.screen, Screen::Setup), "no session started");
}

#[test]
fn aborting_ends_the_session_for_good() {
    let dir = tmpdir("abort");
    let mut a = app(&dir);
    press(&mut a, KeyCode::Enter);
    trials(&mut a, 2, '1');
    // `q` then `a` asks once more, for a reason; Esc goes back, and no reason is no abort.
    keys(&mut a, "qa");
    assert!(matches!(a.overlay, Some(Overlay::AbortReason(_))), "{:?}", a.overlay);
    press(&mut a, KeyCode::Esc);
    assert!(matches!(a.screen, Screen::Session) && a.overlay.is_none());
    keys(&mut a, "qa");
    press(&mut a, KeyCode::Enter);
    assert!(matches!(a.screen, Screen::Session), "an empty reason does not abort");
    keys(&mut a, "participant withdrew");
    press(&mut a, KeyCode::Enter);
    a.wait_idle();
    let Screen::Summary(view) = &a.screen else { panic!("expected the summary screen") };
    assert!(!view.completed);
    let log = read_log(&view.log_path).unwrap();
    let end = log.messages.iter().find(|m| m.topic == "/session/end").unwrap();
    assert_eq!(end.value["status"], "aborted");
    assert_eq!(end.value["reason"], "participant withdrew");
}

#[test]
fn keys_are_ignored_while_the_terminal_is_too_small() {
    let dir = tmpdir("hidden");
    let mut a = app(&dir);
    press(&mut a, KeyCode::Enter);
    a.visible = false;
    press(&mut a, KeyCode::Enter);
    press(&mut a, KeyCode::Char('1'));
    assert!(a.session().unwrap().trials().is_empty(), "no grasp recorded behind a hidden screen");
    a.visible = true;
    press(&mut a, KeyCode::Enter);
    press(&mut a, KeyCode::Char('1'));
    assert_eq!(a.session().unwrap().trials().len(), 1);
}

#[test]
fn a_rehearsal_with_a_simulated_participant_is_flagged_pilot() {
    let dir = tmpdir("simulate");
    let mut a = App::new(config(&dir, true));
    a.tick(T0);
    press(&mut a, KeyCode::Enter);
    for i in 0..200 {
        a.tick(T0 + i);
        a.wait_idle();
        if matches!(a.screen, Screen::Summary(_)) {
            break;
        }
    }
    let Screen::Summary(view) = &a.screen else { panic!("the simulated participant finishes the session") };
    let log = read_log(&view.log_path).unwrap();
    assert!(log.start.pilot && log.start.participant.starts_with("pilot-"));
    assert!(!dir.join("participants").exists(), "rehearsals never touch participants/");
}

#[test]
fn an_existing_participant_s_body_height_scales_the_arm() {
    let dir = tmpdir("height");
    let rec = handover::participant::ParticipantRecord {
        id: "p-tall0001".into(),
        slot: 1,
        created_at: "2026-11-22T00:00:00Z".into(),
        body_height_m: Some(1.85),
        handedness: None,
        withdrawn_at: None,
    };
    rec.create(&dir.join("participants")).unwrap();
    let mut cfg = config(&dir, false);
    cfg.participant = "p-tall0001".into();
    let mut a = App::new(cfg);
    a.tick(T0);
    press(&mut a, KeyCode::Enter);
    let s = a.session().unwrap();
    assert_eq!(s.start().slot, 1, "the record's slot");
    assert!((s.study().arm.upper_arm - 0.186 * 1.85).abs() < 1e-12);
    trials(&mut a, 1, '1');
    keys(&mut a, "qy");
    let log = read_log(&handover::record::mcap_files(&dir.join("logs"))[0]).unwrap();
    let replayed = handover::record::study_of(&log).unwrap();
    assert!((replayed.arm.upper_arm - 0.186 * 1.85).abs() < 1e-12, "the log holds the protocol as run");
    assert_eq!(replayed.sha256, log.start.protocol_sha256);
}

/// The robot operator's screen (`handover follow`) drawn at `w`×`h`.
pub(crate) fn draw_follow(view: &handover::tui::follow::FollowView, w: u16, h: u16) -> String {
    let mut t = Terminal::new(TestBackend::new(w, h)).unwrap();
    t.draw(|f| handover::tui::follow::render(view, f)).unwrap();
    t.backend().to_string()
}

/// The label of the query prompted now, as the protocol writes it.
fn q_label(a: &App) -> String {
    let s = a.session().unwrap();
    match s.prompt() {
        handover::session::Prompt::Present(v) | handover::session::Prompt::Grasp(v) => {
            s.query(v.query).query.label.clone()
        }
        p => panic!("{p:?}"),
    }
}

#[test]
fn a_left_handed_short_participant_gets_mirrored_scaled_poses_named_from_both_sides() {
    let dir = tmpdir("left");
    let rec = handover::participant::ParticipantRecord {
        id: "p-left0001".into(),
        slot: 0,
        created_at: "2026-11-22T00:00:00Z".into(),
        body_height_m: Some(1.55),
        handedness: Some(handover::kinematics::Hand::Left),
        withdrawn_at: None,
    };
    rec.create(&dir.join("participants")).unwrap();
    let mut cfg = config(&dir, false);
    cfg.participant = "p-left0001".into();
    let mut a = App::new(cfg);
    a.tick(T0);
    let setup = screen(&mut a, 100, 30);
    assert!(setup.contains("Hand: the participant's LEFT hand (on your right, facing them)"), "{setup}");
    assert!(setup.contains("poses ×0.886 of the protocol's 1.75 m body"), "{setup}");
    press(&mut a, KeyCode::Enter);
    let s = a.session().unwrap();
    assert_eq!(s.study().arm.side, handover::kinematics::Hand::Left);
    let trial = screen(&mut a, 100, 30);
    assert!(
        trial.contains("frame        participant's left shoulder") && trial.contains("LEFT hand (on your right"),
        "{trial}"
    );
    // The protocol's labels are written for a right hand: mirrored, their "left" is the
    // participant's right, so the screen names poses and grips as the participant has them.
    assert!(trial.contains("left, right  the participant's (protocol labels mirrored, colours kept)"), "{trial}");
    let label = handover::kinematics::Hand::Left.experienced(&q_label(&a));
    assert!(trial.contains(&format!("pose         {label}")), "{trial}");
    assert!(
        trial.contains("Right grip (blue)") && trial.contains("Left grip (red)"),
        "grips named as they are: {trial}"
    );
    // The pose shown is the protocol's, scaled by the reach (1.55 / 1.75) and mirrored (y negated).
    let handover::session::Prompt::Present(view) = a.session().unwrap().prompt() else { panic!("a trial is prompted") };
    let q = a.session().unwrap().query(view.query).clone();
    let [x, y, z] = q.query.pose.position;
    let k = 1.55 / 1.75;
    let [cx, cy, cz] = q.pose.position;
    assert!((cx - x * k).abs() < 1e-9 && (cy + y * k).abs() < 1e-9 && (cz - z * k).abs() < 1e-9, "{:?}", q.pose);
    assert!(trial.contains(&format!("x {cx:+.3}  y {cy:+.3}  z {cz:+.3} m")), "{trial}");
    trials(&mut a, 1, '1');
    keys(&mut a, "qy");
    let log = read_log(&handover::record::mcap_files(&dir.join("logs"))[0]).unwrap();
    let replayed = handover::record::study_of(&log).unwrap();
    assert_eq!(replayed.arm.side, handover::kinematics::Hand::Left, "the log holds the protocol as run");
    assert_eq!(replayed.query(&q.query.id).unwrap().pose, q.pose);
}

#[test]
fn a_withdrawn_participant_gets_no_new_session() {
    let dir = tmpdir("withdrawn");
    let rec = handover::participant::ParticipantRecord {
        id: "p-gone0001".into(),
        slot: 0,
        created_at: "2026-11-22T00:00:00Z".into(),
        body_height_m: None,
        handedness: None,
        withdrawn_at: Some("2026-11-23T00:00:00Z".into()),
    };
    rec.create(&dir.join("participants")).unwrap();
    let mut cfg = config(&dir, false);
    cfg.participant = "p-gone0001".into();
    let mut a = App::new(cfg);
    a.tick(T0);
    press(&mut a, KeyCode::Enter);
    assert!(a.session().is_none(), "no session started");
    assert!(a.status.contains("withdrew"), "{}", a.status);
    assert!(handover::record::mcap_files(&dir.join("logs")).is_empty(), "no log written");
}

/// A console with a robot reached through a program (`--robot-command`) that runs `body`.
fn app_with_robot(dir: &Path, body: &str, settings: &str) -> App {
    use std::os::unix::fs::PermissionsExt;
    let program = dir.join("robot.sh");
    std::fs::write(&program, format!("#!/bin/sh\ncat > /dev/null\n{body}\n")).unwrap();
    std::fs::set_permissions(&program, std::fs::Permissions::from_mode(0o755)).unwrap();
    let settings = handover::robot::RobotSettings::from_json(settings, "lab.json").unwrap();
    let robot = handover::robot::Robot::new(settings, |tx, s| {
        Ok(Box::new(handover::robot::hook::CommandHook::new(program.clone(), tx, s)?))
    })
    .unwrap();
    let mut a = App::new(config(dir, false)).with_robot(Some(robot));
    a.tick(T0);
    a
}

/// Ticks the console until the robot's last report for this trial is `state`.
fn until_robot(app: &mut App, state: handover::session::RobotState) {
    let t = std::time::Instant::now();
    loop {
        app.tick(T0);
        app.wait_idle();
        if app.session().and_then(|s| s.robot()).and_then(|r| r.last.as_ref()).is_some_and(|(s, _)| *s == state) {
            return;
        }
        assert!(t.elapsed() < Duration::from_secs(10), "the robot never said {state:?}");
        std::thread::sleep(Duration::from_millis(20));
    }
}

fn mode_is_grasp(app: &App) -> bool {
    matches!(app.session().map(|s| s.prompt()), Some(handover::session::Prompt::Grasp(_)))
}

#[test]
fn the_operator_sends_the_pose_to_the_robot_and_confirms_it() {
    use handover::session::RobotState;
    let dir = tmpdir("robot-ok");
    let mut a = app_with_robot(&dir, "exit 0", "{}");
    let setup = screen(&mut a, 100, 30);
    assert!(setup.contains("robot.sh (presented on the operator's Enter)"), "{setup}");
    press(&mut a, KeyCode::Enter);
    let text = screen(&mut a, 100, 30);
    assert!(text.contains("robot        not sent yet: s sends the pose"), "{text}");
    assert!(text.contains(" s  send to robot "), "the footer offers it: {text}");
    keys(&mut a, "s");
    until_robot(&mut a, RobotState::AtPose);
    let text = screen(&mut a, 100, 30);
    assert!(text.contains("robot        at_pose (attempt 1, "), "with the seconds it took: {text}");
    // With the robot's line too the instruction is whole at the smallest size.
    assert_full_instruction(&mut a);
    let small = screen(&mut a, 80, 24);
    assert!(small.contains("robot        at_pose (attempt 1, ") && small.contains("1  Left grip"), "{small}");
    // The robot operator's screen shows the robot's status from the log.
    let mut view =
        handover::tui::follow::FollowView::new(handover::record::Follower::open(&a.log_path().unwrap()).unwrap());
    view.tick(handover::dryrun::now_ns());
    let mut t = Terminal::new(TestBackend::new(80, 24)).unwrap();
    t.draw(|f| handover::tui::follow::render(&view, f)).unwrap();
    let followed = t.backend().to_string();
    assert!(followed.contains("robot        at_pose (attempt 1, "), "{followed}");
    assert!(!mode_is_grasp(&a), "the operator confirms (present_on: operator)");
    press(&mut a, KeyCode::Enter);
    assert!(mode_is_grasp(&a));
    keys(&mut a, "1");
    // With present_on at_pose, the robot's answer presents the query.
    let dir = tmpdir("robot-auto");
    let mut a = app_with_robot(&dir, "exit 0", r#"{"present_on": "at_pose"}"#);
    press(&mut a, KeyCode::Enter);
    keys(&mut a, "s");
    let t = std::time::Instant::now();
    while !mode_is_grasp(&a) {
        assert!(t.elapsed() < Duration::from_secs(10), "never presented");
        a.tick(T0);
        a.wait_idle();
        std::thread::sleep(Duration::from_millis(20));
    }
    let log = read_log(&a.log_path().unwrap()).unwrap();
    let names: Vec<&str> = log.events.iter().map(|e| e.event.name()).collect();
    assert_eq!(names, ["robot command", "robot report", "query presented"]);
}

#[test]
fn a_robot_failure_is_shown_and_the_operator_resends_voids_or_goes_on_by_hand() {
    use handover::session::{Event, RobotState};
    let dir = tmpdir("robot-fail");
    let mut a = app_with_robot(&dir, "echo 'joint 4 at its limit' >&2\nexit 2", "{}");
    press(&mut a, KeyCode::Enter);
    keys(&mut a, "s");
    until_robot(&mut a, RobotState::Failed);
    assert!(a.status.contains("The robot reported failed (exit status 2: joint 4 at its limit)"), "{}", a.status);
    let text = screen(&mut a, 100, 30);
    assert!(text.contains("robot        failed (attempt 1, "), "{text}");
    assert!(text.contains("The robot reported failed (exit status 2: joint 4 at its limit)"), "{text}");
    // Re-send: a second attempt, which fails too.
    keys(&mut a, "s");
    until_robot(&mut a, RobotState::Failed);
    assert_eq!(a.session().unwrap().robot().unwrap().attempts, 2);
    // Void it as a robot fault: the trial starts over, nothing presented.
    keys(&mut a, "x2");
    assert!(a.session().unwrap().robot().is_none());
    assert!(!mode_is_grasp(&a));
    // Or go on by hand: Enter presents as without a robot.
    press(&mut a, KeyCode::Enter);
    assert!(mode_is_grasp(&a));
    let log = read_log(&a.log_path().unwrap()).unwrap();
    let void = log.events.iter().find_map(|e| match &e.event {
        Event::TrialVoided { reason, .. } => Some(*reason),
        _ => None,
    });
    assert_eq!(void, Some(handover::session::VoidReason::RobotFault));
    let commands = log.events.iter().filter(|e| matches!(e.event, Event::RobotCommanded { .. })).count();
    assert_eq!(commands, 2);
}

#[test]
fn a_robot_that_does_not_answer_times_out() {
    use handover::session::RobotState;
    let dir = tmpdir("robot-hang");
    let mut a = app_with_robot(&dir, "sleep 600", r#"{"timeout_s": 1}"#);
    press(&mut a, KeyCode::Enter);
    keys(&mut a, "s");
    let text = screen(&mut a, 100, 30);
    assert!(text.contains("sent (attempt 1"), "{text}");
    until_robot(&mut a, RobotState::Timeout);
    assert!(a.status.contains("The robot reported timeout (no answer within 1 s)"), "{}", a.status);
    assert!(!a.robot().unwrap().busy());
}

/// The default protocol observing the measured arm with noise `sigma_deg` per joint.
fn measured_config(dir: &Path, simulate: bool, sigma_deg: f64) -> AppConfig {
    let mut c = config(dir, simulate);
    let mut v: serde_json::Value = serde_json::from_str(&c.protocol_text).unwrap();
    v["learning"]["observation"] = "measured".into();
    v["learning"]["measurement"] = serde_json::json!({ "sigma_deg": vec![sigma_deg; 7] });
    c.protocol_text = v.to_string();
    c.study = Arc::new(Study::from_json(&c.protocol_text, "measured").unwrap());
    c
}

#[test]
fn a_rehearsal_says_when_the_measured_arm_implies_another_grip_than_the_key() {
    let dir = tmpdir("measured-rehearsal");
    // 40° of noise: some measurements lie nearer the other grip's configurations.
    let mut a = App::new(measured_config(&dir, true, 40.0));
    a.tick(T0);
    press(&mut a, KeyCode::Enter);
    let mut said = None;
    for i in 0..200 {
        a.tick(T0 + i);
        a.wait_idle();
        if a.status.contains("The measured arm is nearest") {
            said = Some(a.status.clone());
            break;
        }
    }
    let said = said.expect("a disagreement within the session");
    let t = a.session().unwrap().trials().last().unwrap().clone();
    let g = t.measured.as_ref().expect("the rehearsal measures every grasp");
    assert!(!g.agrees(t.region), "{said}");
    assert!(said.contains("the belief learned from the measurement"), "{said}");
}

#[test]
fn a_measured_protocol_without_a_measuring_system_learns_from_the_handle_and_says_so() {
    let dir = tmpdir("measured");
    let mut a = App::new(measured_config(&dir, false, 5.0));
    a.tick(T0);
    let setup = screen(&mut a, 160, 40);
    assert!(setup.contains("Arm measurement: none (--measure ros2"), "{setup}");
    press(&mut a, KeyCode::Enter);
    trials(&mut a, 1, '1');
    assert!(a.status.contains("No arm sample in the 0.5 s before the grasp"), "{}", a.status);
    let t = &a.session().unwrap().trials()[0];
    assert!(t.measured.is_none());
    // Every event is on disk before the console goes on.
    let log = read_log(&a.log_path().unwrap()).unwrap();
    let response = log.messages.iter().find(|m| m.topic == "/trial/response").unwrap();
    assert_eq!(response.value["learned_from"], "region", "{:?}", response.value);
}

/// Between Program A and B, before the test and before the questionnaire the console stops
/// on the protocol's text until the experimenter confirms; grip keys there say why they do
/// nothing; a protocol's own text is shown with the programs' labels.
#[test]
fn transitions_wait_for_the_experimenter_with_the_protocol_s_text() {
    let dir = tmpdir("transitions");
    let transitions = serde_json::json!({
        "between_programs": "Say: {done} has finished and {next} starts.",
        "before_test": "Say: now the test.",
        "before_questionnaire": "Say: now the statements."
    });
    let mut a = app_with_protocol(&dir, |v| v["session"]["transitions"] = transitions);
    press(&mut a, KeyCode::Enter);
    assert_eq!(a.transition(), None, "the first program starts at once");
    trials(&mut a, 5, '1');
    assert_eq!(a.transition(), Some(handover::session::Transition::Program(1)));
    let s = screen(&mut a, 80, 24);
    assert!(s.contains("Say: Program A has finished and Program B starts.") && s.contains("Program B is next"), "{s}");
    keys(&mut a, "1");
    assert!(a.status.starts_with("Tell the participant what comes next"), "{}", a.status);
    let before = a.session().unwrap().trials().len();
    press(&mut a, KeyCode::Enter);
    assert_eq!(a.transition(), None);
    assert_eq!(a.session().unwrap().trials().len(), before, "confirming records nothing");
    assert!(a.status.starts_with("Program B begins"), "{}", a.status);
    trials(&mut a, 5, '2');
    assert_eq!(a.transition(), Some(handover::session::Transition::Test));
    assert!(screen(&mut a, 80, 24).contains("Say: now the test."));
    trials(&mut a, 16, '1');
    assert_eq!(a.transition(), Some(handover::session::Transition::Questionnaire));
    assert!(screen(&mut a, 80, 24).contains("Say: now the statements."));
    press(&mut a, KeyCode::Enter);
    assert_eq!(a.mode(), handover::tui::keys::Mode::Questionnaire);
    // A protocol whose text names an unknown placeholder is refused, naming the field.
    let mut v: serde_json::Value = serde_json::from_str(&a.config.protocol_text).unwrap();
    v["session"]["transitions"]["before_test"] = "now {program}".into();
    let err = Study::from_json(&v.to_string(), "bad.json").unwrap_err().to_string();
    assert!(err.contains("session.transitions.before_test") && err.contains("no placeholder"), "{err}");
}

/// A transition's confirmation is an event in the log: the robot operator's screen shows
/// no pose until it is given, a resumed console does not ask again once it was, `u` on the
/// transition screen takes back the phase's last grasp and says which, and an undo across a
/// confirmed transition says the participant must be told again (the transition returns).
#[test]
fn a_transition_is_logged_and_the_follower_waits_for_it() {
    use handover::record::Follower;
    use handover::session::Transition;
    use handover::tui::follow::FollowView;
    let dir = tmpdir("transition-log");
    let mut a = app(&dir);
    press(&mut a, KeyCode::Enter);
    let path = a.log_path().unwrap();
    let mut view = FollowView::new(Follower::open(&path).unwrap());
    let draw = |view: &FollowView| draw_follow(view, 80, 24);
    trials(&mut a, 5, '1');
    assert_eq!(a.transition(), Some(Transition::Program(1)));
    view.tick(T0 + 1);
    let s = draw(&view);
    assert!(s.contains("Between phases") && s.contains("do not move the robot yet") && !s.contains("(query "), "{s}");
    // u on the transition screen: the screen says what it undoes, the status that it did.
    assert!(screen(&mut a, 80, 24).contains("u undoes the grasp of Program A, trial 5"));
    keys(&mut a, "u");
    assert!(a.status.starts_with("Undone: the grasp of Program A, trial 5"), "{}", a.status);
    assert_eq!(a.transition(), None);
    keys(&mut a, "2");
    assert_eq!(a.transition(), Some(Transition::Program(1)));
    press(&mut a, KeyCode::Enter);
    assert_eq!(a.transition(), None);
    view.tick(T0 + 2);
    assert!(draw(&view).contains("(query "), "the pose once confirmed:\n{}", draw(&view));
    let log = read_log(&path).unwrap();
    let confirmations: Vec<_> = log.messages.iter().filter(|m| m.topic == "/session/transition").collect();
    assert_eq!(confirmations.len(), 1);
    assert_eq!(confirmations[0].value["transition"], "program");
    assert_eq!(confirmations[0].value["program"], "B");
    // Back across the confirmed transition: said, and the transition is asked again.
    keys(&mut a, "u");
    assert!(a.status.contains("back to Program A: tell the participant"), "{}", a.status);
    keys(&mut a, "1");
    assert_eq!(a.transition(), Some(Transition::Program(1)));
    press(&mut a, KeyCode::Enter);
    // Resumed after the confirmation: the console goes on without asking again.
    keys(&mut a, "qy");
    drop(a);
    let log = read_log(&path).unwrap();
    let mut r = App::resume(config(&dir, false), &log).unwrap();
    r.wait_idle();
    assert_eq!(r.transition(), None);
    assert_eq!(r.mode(), handover::tui::keys::Mode::Present);
    keys(&mut r, "qy");
}

/// One session per participant at a time: a participant with an unfinished session gets no
/// second one (the setup says so, with the whole command that continues it), and the quit
/// message prints that command too, with the study's folder.
#[test]
fn an_unfinished_session_is_continued_not_doubled() {
    let dir = tmpdir("unfinished");
    let mut a = app(&dir);
    press(&mut a, KeyCode::Enter);
    trials(&mut a, 2, '1');
    let id = a.session().unwrap().start().participant.clone();
    keys(&mut a, "qy");
    let command = format!("handover resume --participant {id} --study-dir {}", dir.display());
    let message = a.exit_message.clone().unwrap_or_default();
    assert!(message.contains(&command), "{message}");
    drop(a);
    let mut cfg = config(&dir, false);
    cfg.participant = id.clone();
    let mut b = App::new(cfg);
    b.tick(T0);
    let error = b.plan.as_ref().and_then(|p| p.error.clone()).unwrap_or_default();
    assert!(error.contains("has an unfinished session") && error.contains(&command), "{error}");
    press(&mut b, KeyCode::Enter);
    assert!(b.session().is_none(), "no second session");
    assert_eq!(handover::record::mcap_files(&dir.join("logs")).len(), 1);
}

/// `run --pilot`: a real person in a pilot gets a `pilot-` id and no participant record; the
/// log is flagged pilot (the header says so), so analysis reports it apart and the
/// counterbalancing never counts it; it is resumed by its log.
#[test]
fn a_pilot_with_a_real_person_is_kept_apart() {
    let dir = tmpdir("pilot");
    let mut a = App::new(AppConfig { pilot: true, ..config(&dir, false) });
    a.tick(T0);
    let setup = screen(&mut a, 100, 30);
    assert!(
        setup.contains("(pilot with a person: no record, logged as pilot)") && !setup.contains("existing record"),
        "{setup}"
    );
    press(&mut a, KeyCode::Enter);
    let start = a.session().unwrap().start().clone();
    assert!(start.pilot && start.participant.starts_with("pilot-"), "{start:?}");
    assert!(screen(&mut a, 80, 24).contains("[PILOT]"));
    trials(&mut a, 26, '1');
    past_transition(&mut a);
    assert!(!dir.join("participants").exists() || std::fs::read_dir(dir.join("participants")).unwrap().count() == 0);
    keys(&mut a, "qy");
    let message = a.exit_message.clone().unwrap_or_default();
    assert!(message.contains("handover resume ") && message.contains(".mcap"), "by its log: {message}");
    let counts = handover::counterbalance::completed_per_slot(&dir.join("logs"), &dir.join("participants"), 2);
    assert_eq!((counts.completed, counts.waiting), (vec![0, 0], vec![0, 0]));
    // A pilot's body and hand, which no record holds, come from the command line: the
    // protocol is fitted to them as to a participant's.
    let body = handover::protocol::Body { height_m: Some(1.95), hand: handover::kinematics::Hand::Left };
    let mut tall = App::new(AppConfig { pilot: true, pilot_body: body, ..config(&tmpdir("pilot-body"), false) });
    tall.tick(T0);
    let setup = screen(&mut tall, 100, 30);
    assert!(setup.contains("Hand: the participant's LEFT hand"), "{setup}");
    press(&mut tall, KeyCode::Enter);
    let study = tall.session().unwrap().study();
    assert_eq!(study.arm.side, handover::kinematics::Hand::Left);
    assert!(study.pose_scale() > 1.05, "poses scaled to 1.95 m: ×{}", study.pose_scale());
    // A pilot or a rehearsal never runs under a registered participant's id.
    for args in [
        &["run", "--pilot", "--simulated-participant"][..],
        &["run", "--pilot", "--participant", "p-abcdefgh"],
        &["run", "--simulated-participant", "--participant", "p-abcdefgh"],
        // A body on the command line is a pilot's only (a participant's is in their record).
        &["run", "--body-height", "1.8"],
        &["run", "--pilot", "--body-height", "3"],
    ] {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_handover")).args(args).output().unwrap();
        assert_eq!(out.status.code(), Some(2), "{args:?}");
    }
}

/// `run --practice`: a rehearsal in which the simulated participant only chooses; the
/// status line says what they did and which key records it, nothing moves by itself, and
/// an operator who presses what it says runs the whole session to its end.
#[test]
fn a_practice_rehearsal_waits_for_the_operator_s_keys() {
    use handover::session::Prompt;
    let dir = tmpdir("practice");
    let mut a = App::new(AppConfig { practice: true, ..config(&dir, true) });
    a.tick(T0);
    press(&mut a, KeyCode::Enter);
    for k in 1..20 {
        a.tick(T0 + k * 1_000_000_000);
    }
    assert!(matches!(a.session().unwrap().prompt(), Prompt::Present(ref v) if v.trial == 1), "nothing moves by itself");
    let key_in = |hint: &str| -> char {
        let after = hint.split("press ").nth(1).expect("the hint names a key");
        after.chars().next().unwrap()
    };
    let mut hinted = 0;
    for _ in 0..400 {
        if a.transition().is_some() {
            press(&mut a, KeyCode::Enter);
            continue;
        }
        match a.session().unwrap().prompt() {
            Prompt::Present(_) => press(&mut a, KeyCode::Enter),
            Prompt::Grasp(_) => {
                let hint = a.practice_hint().expect("the participant's grip is said");
                assert!(screen(&mut a, 80, 24).contains("Practice: the participant took the"), "on the status line");
                keys(&mut a, &key_in(&hint).to_string());
                hinted += 1;
            }
            Prompt::Likert { .. } | Prompt::ForcedChoice => {
                let hint = a.practice_hint().expect("the participant's answer is said");
                keys(&mut a, &key_in(&hint).to_string());
                press(&mut a, KeyCode::Enter);
                hinted += 1;
            }
            Prompt::Finish => press(&mut a, KeyCode::Enter),
            Prompt::Done { completed } => {
                assert!(completed);
                break;
            }
            Prompt::Paused => panic!("not paused"),
        }
    }
    assert!(matches!(a.session().map(|s| s.prompt()), Some(Prompt::Done { completed: true }) | None));
    assert_eq!(hinted, 26 + 8 + 1, "every grasp and answer was the operator's key");
    let log = read_log(&handover::record::mcap_files(&dir.join("logs"))[0]).unwrap();
    assert!(log.start.pilot && log.start.simulated_truth.is_some());
}

/// At 80×24 the history has room for a few rows: the earliest give way, and its title
/// counts them, so nothing is cut without a word.
#[test]
fn the_history_says_how_many_earlier_trials_it_hides() {
    let dir = tmpdir("history");
    let mut a = app(&dir);
    press(&mut a, KeyCode::Enter);
    trials(&mut a, 4, '1');
    let s = screen(&mut a, 80, 24);
    let title = s.lines().find(|l| l.contains("History of this phase")).expect("the history panel");
    assert!(title.contains("earlier"), "{s}");
    assert!(!screen(&mut a, 160, 45).contains(" earlier "), "all four fit when tall");
    // Once the object is presented, a short screen keeps the object and the pose and gives
    // the history the rows: all four trials at 80×24, the full instruction when tall.
    press(&mut a, KeyCode::Enter);
    let s = screen(&mut a, 80, 24);
    let history: Vec<&str> = s.lines().skip_while(|l| !l.contains("History of this phase")).collect();
    let rows = history
        .iter()
        .filter(|l| l.trim_start_matches('"').strip_prefix('│').is_some_and(|r| r.starts_with(char::is_numeric)))
        .count();
    assert_eq!(rows, 4, "{s}");
    assert!(!s.contains(" earlier ") && !s.contains("orientation") && s.contains("pose "), "{s}");
    assert!(screen(&mut a, 160, 45).contains("orientation"), "the full instruction when tall");
}

/// The questionnaire handed to the participant: one statement, nothing that un-blinds, only
/// the answering keys act (no quit, note, pause or help; Ctrl+C included), Enter at the end
/// asks for the keyboard back instead of finishing, and Ctrl+E gives it back.
#[test]
fn the_participant_answers_blinded_and_hands_back() {
    let dir = tmpdir("participant");
    let mut a = app(&dir);
    press(&mut a, KeyCode::Enter);
    trials(&mut a, 26, '1');
    past_transition(&mut a);
    keys(&mut a, "h");
    assert!(a.participant_mode);
    for (w, h) in SIZES {
        let s = screen(&mut a, w, h);
        for secret in ["active", "passive", "Belief", "slot", "participant p-", "bike-handover", "PILOT", "Ctrl"] {
            assert!(!s.contains(secret), "'{secret}' is on the participant's screen:\n{s}");
        }
        assert!(s.contains("Statement 1 of 8"), "{s}");
    }
    for c in ['q', '?', 'n', 'p', 'x'] {
        keys(&mut a, &c.to_string());
        assert!(a.overlay.is_none() && !a.quit, "{c} opens nothing");
    }
    a.key(KeyEvent::new(KeyCode::Char('c'), KeyModifiers::CONTROL));
    a.wait_idle();
    assert!(a.overlay.is_none() && !a.quit, "Ctrl+C does not quit in the participant's hands");
    answer(&mut a, "45342512b");
    assert_eq!(a.session().unwrap().likert_answers().len(), 8);
    assert_eq!(a.session().unwrap().forced_choice(), Some(1));
    press(&mut a, KeyCode::Enter);
    assert!(matches!(a.screen, Screen::Session), "the participant cannot finish the session");
    assert!(screen(&mut a, 80, 24).contains("hand the keyboard back to the experimenter"));
    a.key(KeyEvent::new(KeyCode::Char('e'), KeyModifiers::CONTROL));
    assert!(!a.participant_mode);
    assert!(screen(&mut a, 80, 24).contains("participant p-"), "the experimenter's header is back");
    press(&mut a, KeyCode::Enter);
    a.wait_idle();
    assert!(matches!(a.screen, Screen::Summary(_)));
}

/// The help fits 120×35 whole, and at 80×24 scrolls to its last line.
#[test]
fn the_help_fits_or_scrolls_to_its_end() {
    let dir = tmpdir("help");
    let mut a = app(&dir);
    press(&mut a, KeyCode::Enter);
    // After a grasp the help lists undo too: its longest.
    trials(&mut a, 1, '1');
    keys(&mut a, "?");
    let big = screen(&mut a, 120, 35);
    assert!(big.contains("Keys (Esc closes)") && big.contains("type an existing participant id"), "{big}");
    let small = screen(&mut a, 80, 24);
    assert!(small.contains("↑/↓ scroll") && !small.contains("type an existing participant id"), "{small}");
    for _ in 0..40 {
        press(&mut a, KeyCode::Down);
    }
    let end = screen(&mut a, 80, 24);
    assert!(end.contains("type an existing participant id"), "{end}");
    press(&mut a, KeyCode::Esc);
    assert!(a.overlay.is_none());
}

/// A resumed session keeps its clock from the logged start, and its status line is whole.
#[test]
fn a_resumed_session_shows_its_elapsed_time_and_whole_status() {
    let dir = tmpdir("resumed");
    let mut a = app(&dir);
    press(&mut a, KeyCode::Enter);
    trials(&mut a, 2, '1');
    keys(&mut a, "qy");
    drop(a);
    let path = handover::record::mcap_files(&dir.join("logs"))[0].clone();
    let log = read_log(&path).unwrap();
    let mut r = App::resume(config(&dir, false), &log).unwrap();
    let started = chrono::DateTime::parse_from_rfc3339(&log.start.started_at).unwrap();
    r.tick(started.timestamp_nanos_opt().unwrap() as u64 + 3_725_000_000_000);
    let mut t = Terminal::new(TestBackend::new(80, 24)).unwrap();
    t.draw(|f| render(&r, f)).unwrap();
    let s = t.backend().to_string();
    assert!(s.contains("elapsed 1:02:05"), "{s}");
    let name = path.file_name().unwrap().to_string_lossy().to_string();
    let flat: String = s.lines().map(|l| l.trim_matches('"').trim_end()).collect::<Vec<_>>().join("");
    assert!(flat.contains(&format!("Resumed {name} after")), "the status is whole:\n{s}");
    keys(&mut r, "qy");
}

/// The robot operator's screen (`handover follow`) reads the log the console writes: the
/// current instruction whole at every size, brought up to date as the log grows, and carried
/// into the continuation when the session is resumed; it writes nothing.
#[test]
fn follow_shows_the_current_instruction_from_the_live_log() {
    use handover::record::Follower;
    use handover::tui::follow::FollowView;
    let dir = PathBuf::from("target/console-follow");
    let _ = std::fs::remove_dir_all(&dir);
    let mut a = app(&dir);
    press(&mut a, KeyCode::Enter);
    let path = a.log_path().unwrap();
    let mut view = FollowView::new(Follower::open(&path).unwrap());
    let draw = draw_follow;
    view.tick(T0);
    let query_now = |a: &App| match a.session().unwrap().prompt() {
        handover::session::Prompt::Present(v) | handover::session::Prompt::Grasp(v) => {
            a.session().unwrap().query(v.query).query.id.clone()
        }
        p => panic!("{p:?}"),
    };
    let first = query_now(&a);
    let text = SIZES.iter().map(|&(w, h)| format!("{w}×{h}\n{}", draw(&view, w, h))).collect::<Vec<_>>().join("\n");
    insta::with_settings!({filters => vec![
        (r"p-[a-z0-9]{8}", "p-XXXXXXXX"),
        (r"\d{8}T\d{6}Z(-\d+)?", "TIME"),
        (r"last event \d+ s ago", "last event N s ago"),
    ]}, {
        insta::assert_snapshot!("follow", text);
    });
    for (w, h) in SIZES {
        let s = draw(&view, w, h);
        assert!(
            s.contains(&format!("(query {first})")) && s.contains("of the object's centre") && s.contains("z up"),
            "{s}"
        );
    }
    let before = std::fs::read(&path).unwrap();
    // Two trials on: the follower catches up.
    trials(&mut a, 2, '1');
    let third = query_now(&a);
    view.tick(T0 + 1);
    assert_eq!(view.follower.session().event_count(), a.session().unwrap().event_count());
    assert!(draw(&view, 80, 24).contains(&format!("(query {third})")));
    press(&mut a, KeyCode::Enter);
    view.tick(T0 + 2);
    assert!(draw(&view, 80, 24).contains("The participant is taking the object."));
    // Quit and resume: the follower says so, then follows the continuation.
    keys(&mut a, "qy");
    drop(a);
    view.tick(T0 + 3);
    // As after a kill: no pose and no "taking the object" once no console runs the session.
    let s = draw(&view, 80, 24);
    assert!(
        s.contains("THE CONSOLE LEFT THE SESSION — do not move the robot.") && s.contains("handover resume"),
        "{s}"
    );
    assert!(!s.contains("(query ") && !s.contains("taking the object"), "{s}");
    let log = read_log(&path).unwrap();
    let mut r = App::resume(config(&dir, false), &log).unwrap();
    r.wait_idle();
    view.tick(T0 + 4);
    assert_eq!(view.follower.path(), &r.log_path().unwrap());
    keys(&mut r, "1");
    view.tick(T0 + 5);
    assert_eq!(view.follower.session().event_count(), r.session().unwrap().event_count());
    assert!(std::fs::read(&path).unwrap().starts_with(&before), "the follower wrote nothing");
    keys(&mut r, "qy");
}

/// A continuation copies the interrupted log's events one synced event at a time before
/// anything new: caught half-copied it shows an earlier trial's pose, so the robot
/// operator's screen stays on the interrupted log until the continuation holds them all.
#[test]
fn follow_moves_to_a_continuation_only_once_it_holds_every_earlier_event() {
    use handover::record::{Follower, RecordedSession, continuation_path, study_of};
    use handover::session::Session;
    use handover::tui::follow::FollowView;
    let dir = tmpdir("follow-half-copied");
    let mut a = app(&dir);
    press(&mut a, KeyCode::Enter);
    trials(&mut a, 3, '1');
    let path = a.log_path().unwrap();
    keys(&mut a, "qy");
    drop(a);
    let old = read_log(&path).unwrap();
    let mut view = FollowView::new(Follower::open(&path).unwrap());
    view.tick(T0);
    let before = draw_follow(&view, 80, 24);
    assert!(before.contains("trial 4/"), "{before}");
    // A continuation with the first two events copied so far (a resume caught mid-copy).
    let study = Arc::new(study_of(&old).unwrap());
    let mut start = old.start.clone();
    start.resumed_from = Some(path.file_name().unwrap().to_string_lossy().into_owned());
    let next = continuation_path(&old, chrono::Utc::now() + chrono::TimeDelta::hours(1));
    let session = Session::new(study, start).unwrap();
    let mut half = RecordedSession::create(&next, &old.protocol_text, session, old.start_time_ns).unwrap();
    for e in &old.events[..2] {
        half.submit(e.clone()).unwrap();
    }
    view.tick(T0 + 1);
    assert_eq!(view.follower.path(), &path, "a half-copied continuation is not followed");
    let s = draw_follow(&view, 80, 24);
    assert!(s.contains("trial 4/") && !s.contains("trial 2/"), "{s}");
    // Every event copied: the follower moves to it (closed here, as no console holds it).
    for e in &old.events[2..] {
        half.submit(e.clone()).unwrap();
    }
    half.finish().unwrap();
    view.tick(T0 + 2);
    assert_eq!(view.follower.path(), &next);
    let s = draw_follow(&view, 80, 24);
    assert!(s.contains("trial 4/") && s.contains(&*next.file_name().unwrap().to_string_lossy()), "{s}");
}

/// A protocol's long pose label wraps inside the instruction, which grows for it: at 80×24
/// every other line of the instruction is still on screen whole.
#[test]
fn a_long_pose_label_wraps_and_the_instruction_stays_whole() {
    let dir = tmpdir("long-label");
    let long = "Handlebars held at chest height and turned to the participant's left, as a rider would take them from a stand beside the bicycle, end";
    let mut a = app_with_protocol(&dir, |v| {
        for q in v["training_menu"].as_array_mut().unwrap() {
            q["label"] = long.into();
        }
    });
    press(&mut a, KeyCode::Enter);
    assert_full_instruction(&mut a);
    let s = screen(&mut a, 80, 24);
    assert!(s.contains("beside the bicycle, end") && s.contains("Press Enter when the robot holds"), "{s}");
}

/// A long statement in the participant's hands wraps and leaves the scale and the hint on
/// screen at 80×24.
#[test]
fn a_long_statement_keeps_its_scale_on_the_participant_s_screen() {
    let dir = tmpdir("long-statement");
    let long = "When {program} handed me the bicycle handlebars or the lock, I could take them without bending, reaching far or turning my wrist in a way that felt awkward, and I would be happy to take objects from it in the same way again tomorrow, end";
    let mut a = app_with_protocol(&dir, |v| {
        for (k, item) in v["questionnaire"]["items"].as_array_mut().unwrap().iter_mut().enumerate() {
            item["statement"] = format!("{long} {k}").into();
        }
    });
    press(&mut a, KeyCode::Enter);
    trials(&mut a, 26, '1');
    past_transition(&mut a);
    keys(&mut a, "h");
    let s = screen(&mut a, 80, 24);
    for needle in ["again tomorrow, end ", "Strongly disagree", "Strongly agree", "Press a number to answer"] {
        assert!(s.contains(needle), "'{needle}':\n{s}");
    }
}
