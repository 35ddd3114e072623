//! Every screen for every participant at every size: a whole session is walked for each hand
//! × body height, and each screen it passes through is drawn at each terminal size (the
//! console's and `handover follow`'s). On each, every line of the instruction, every grip and
//! every key the moment needs must be on screen whole.
//!
//! The expected text is computed here from the protocol's JSON (its labels, poses and
//! regions), the participant's body and the documented mirror (docs/kinematics.md: a left
//! hand's pose has y, roll and yaw negated, its labels' "left" and "right" swapped), not from
//! the console's code.

use crate::console::{T0, answer, config, draw_follow, keys, past_transition, press, screen};
use crate::support::tmpdir;

use handover::kinematics::Hand;
use handover::record::Follower;
use handover::session::Prompt;
use handover::tui::App;
use handover::tui::follow::FollowView;
use nalgebra::{Matrix3, Rotation3, Vector3};
use ratatui::crossterm::event::KeyCode;
use serde_json::Value;
use std::f64::consts::PI;

const HANDS: [Hand; 2] = [Hand::Right, Hand::Left];
const HEIGHTS: [f64; 3] = [1.50, 1.75, 1.95];
/// From the smallest the console accepts up, with the heights at which its layouts change.
const SIZES: [(u16, u16); 8] = [(80, 24), (80, 26), (80, 30), (80, 34), (90, 26), (100, 30), (120, 40), (160, 45)];

/// A screen's text: each row without the backend's quotes.
fn rows(text: &str) -> Vec<String> {
    text.lines().map(|l| l.trim_matches('"').to_string()).collect()
}

/// The text of the panels' first column read as running text: each row's first panel (the
/// part after its first border), joined with spaces and its runs of spaces collapsed, so a
/// line wrapped onto the next row reads whole and a cut line does not.
fn running_text(text: &str) -> String {
    let mut out = String::new();
    for row in rows(text) {
        let first = row.split('│').nth(1).unwrap_or(&row);
        out.push(' ');
        out.push_str(first);
    }
    collapse(&out)
}

fn collapse(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// A protocol label as a participant with this hand has it: a left hand's poses are the
/// mirror image, so its whole words "left" and "right" swap (case kept).
fn experienced(label: &str, hand: Hand) -> String {
    if hand == Hand::Right {
        return label.to_string();
    }
    let swap = |w: &str| match w {
        "left" => "right".to_string(),
        "right" => "left".to_string(),
        "Left" => "Right".to_string(),
        "Right" => "Left".to_string(),
        w => w.to_string(),
    };
    let (mut out, mut word) = (String::new(), String::new());
    for c in label.chars() {
        if c.is_alphanumeric() {
            word.push(c);
        } else {
            out += &swap(&std::mem::take(&mut word));
            out.push(c);
        }
    }
    out + &swap(&word)
}

/// A signed number as an operator reads it: no "-0.000".
fn signed(v: f64, decimals: usize) -> String {
    let s = format!("{v:+.decimals$}");
    if s.trim_start_matches(['-', '+']).chars().all(|c| c == '0' || c == '.') { s.replacen('-', "+", 1) } else { s }
}

/// What the robot operator must read for a query: the protocol's entry, scaled by the body
/// and mirrored for a left hand.
struct Expected {
    lines: Vec<String>,
    grips: Vec<String>,
}

fn expected(protocol: &Value, query_id: &str, offered: &[String], hand: Hand, height: f64) -> Expected {
    let entry = ["training_menu", "test_set"]
        .iter()
        .flat_map(|k| protocol[k].as_array().unwrap())
        .find(|q| q["id"] == query_id)
        .unwrap_or_else(|| panic!("{query_id} is in the protocol"));
    let object = protocol["objects"].as_array().unwrap().iter().find(|o| o["id"] == entry["object"]).unwrap();
    let k = height / protocol["pose_scaling"]["reference_body_height_m"].as_f64().unwrap();
    let f = |v: &Value| v.as_f64().unwrap();
    let p = &entry["pose"]["position"];
    let r = &entry["pose"]["rpy_deg"];
    // A left hand's pose: mirrored in y (M R M with M = diag(1, −1, 1)), then turned half a
    // turn about the object's own z (docs/kinematics.md, "Poses that fit the participant").
    let m = if hand == Hand::Left { -1.0 } else { 1.0 };
    let (x, y, z) = (f(&p[0]) * k, m * f(&p[1]) * k, f(&p[2]) * k);
    let rot = Rotation3::from_euler_angles(f(&r[0]).to_radians(), f(&r[1]).to_radians(), f(&r[2]).to_radians());
    let rot = if hand == Hand::Left {
        let mirror = Matrix3::from_diagonal(&Vector3::new(1.0, -1.0, 1.0));
        Rotation3::from_matrix_unchecked(mirror * rot.matrix() * mirror)
            * Rotation3::from_axis_angle(&Vector3::z_axis(), PI)
    } else {
        rot
    };
    // Angles as the operator reads them, in (−180°, 180°].
    let deg = |a: f64| {
        let d = a.to_degrees();
        if d <= -179.95 { d + 360.0 } else { d }
    };
    let (roll, pitch, yaw) = rot.euler_angles();
    let (roll, pitch, yaw) = (deg(roll), deg(pitch), deg(yaw));
    let (name, other) = if hand == Hand::Left { ("left", "right") } else { ("right", "left") };
    let lines = vec![
        "ROBOT OPERATOR — command the robot to hand over:".to_string(),
        format!("{} (query {query_id})", object["label"].as_str().unwrap()),
        format!("pose {}", experienced(entry["label"].as_str().unwrap(), hand)),
        format!("position x {} y {} z {} m, of the object's centre", signed(x, 3), signed(y, 3), signed(z, 3)),
        format!("orientation roll {}° pitch {}° yaw {}°", signed(roll, 1), signed(pitch, 1), signed(yaw, 1)),
        format!("frame participant's {name} shoulder: x ahead, y to their left, z up"),
        format!("hand {} hand (on your {other}, facing them)", name.to_uppercase()),
        format!(
            "left, right {}",
            if hand == Hand::Left {
                "the participant's (protocol labels mirrored, colours kept)"
            } else {
                "always the participant's, as they face the robot"
            }
        ),
    ];
    let regions = object["regions"].as_array().unwrap();
    let grips = offered
        .iter()
        .enumerate()
        .map(|(i, id)| {
            let region = regions.iter().find(|r| r["id"] == id.as_str()).unwrap();
            format!("{} {} {id}", i + 1, experienced(region["label"].as_str().unwrap(), hand))
        })
        .collect();
    Expected { lines, grips }
}

/// Asserts that `needles` all read whole in `text`'s running text; `what` names the screen.
fn assert_reads(text: &str, needles: &[String], what: &str) {
    let running = running_text(text);
    for n in needles {
        assert!(running.contains(&collapse(n)), "{what}: '{n}' is not whole on the screen:\n{text}");
    }
}

/// The footer (the last row) lists each key with its action.
fn assert_footer(text: &str, keys: &[(&str, &str)], what: &str) {
    let rows = rows(text);
    let footer = collapse(rows.last().unwrap());
    for (key, action) in keys {
        assert!(footer.contains(&format!("{key} {action}")), "{what}: the footer lacks '{key} {action}':\n{text}");
    }
}

/// How many screens were drawn, by kind.
#[derive(Default)]
struct Tally {
    drawn: usize,
    screens: std::collections::BTreeMap<&'static str, usize>,
}

impl Tally {
    /// Draws one screen at every size (none of them refused as too small) and checks it.
    fn each_size(
        &mut self,
        combo: &str,
        kind: &'static str,
        mut draw: impl FnMut(u16, u16) -> String,
        mut check: impl FnMut(&str, &str),
    ) {
        for (w, h) in SIZES {
            let text = draw(w, h);
            assert!(!text.contains("Terminal too small"), "{kind}, {combo} at {w}×{h}: {text}");
            check(&text, &format!("{kind}, {combo}, {w}×{h}"));
            self.drawn += 1;
        }
        *self.screens.entry(kind).or_default() += 1;
    }
}

#[test]
fn every_screen_shows_every_line_for_every_hand_body_and_size() {
    let protocol: Value = serde_json::from_str(&config(std::path::Path::new("."), false).protocol_text).unwrap();
    let mut tally = Tally::default();
    for (n, (&hand, &height)) in HANDS.iter().flat_map(|h| HEIGHTS.iter().map(move |b| (h, b))).enumerate() {
        let dir = tmpdir("combinations");
        let id = format!("p-comb{n:04}");
        handover::participant::ParticipantRecord {
            id: id.clone(),
            slot: n % 2,
            created_at: "2026-12-07T00:00:00Z".into(),
            body_height_m: Some(height),
            handedness: Some(hand),
            withdrawn_at: None,
        }
        .create(&dir.join("participants"))
        .unwrap();
        let mut cfg = config(&dir, false);
        cfg.participant = id;
        let mut a = App::new(cfg);
        a.tick(T0);
        let combo = format!("{} hand, {height} m", hand.name());
        let (name, other) = if hand == Hand::Left { ("LEFT", "right") } else { ("RIGHT", "left") };
        tally.each_size(
            &combo,
            "setup",
            |w, h| screen(&mut a, w, h),
            |text, what| {
                assert_reads(
                    text,
                    &[
                        format!("Hand: the participant's {name} hand (on your {other}, facing them)"),
                        format!("poses ×{:.3} of the protocol's 1.75 m body", height / 1.75),
                        "Press Enter to start the session.".into(),
                    ],
                    what,
                );
                assert_footer(text, &[("Enter", "start"), ("q", "quit")], what);
            },
        );
        press(&mut a, KeyCode::Enter);
        let mut follow = FollowView::new(Follower::open(&a.log_path().unwrap()).unwrap());
        let mut trials = 0;
        loop {
            past_transition(&mut a);
            let session = a.session().unwrap();
            let Prompt::Present(view) = session.prompt() else { break };
            let q = session.query(view.query);
            let object = session.study().object(q);
            let offered: Vec<String> = q.regions.iter().map(|&r| object.regions[r].id.clone()).collect();
            let e = expected(&protocol, &q.query.id, &offered, hand, height);
            let mut present = e.lines.clone();
            present.push("Press Enter when the robot holds the object there.".into());
            present.push("Which grip did the participant take?".into());
            present.extend(e.grips.iter().cloned());
            tally.each_size(
                &combo,
                "trial, present",
                |w, h| screen(&mut a, w, h),
                |text, what| {
                    assert_reads(text, &present, what);
                    assert_footer(text, &[("Enter", "presented"), ("?", "help"), ("q", "quit")], what);
                },
            );
            follow.tick(T0 + trials);
            let mut told = e.lines.clone();
            told.push("Tell the experimenter when the robot holds the object there.".into());
            tally.each_size(
                &combo,
                "follow, present",
                |w, h| draw_follow(&follow, w, h),
                |text, what| assert_reads(text, &told, what),
            );
            press(&mut a, KeyCode::Enter);
            let grips = format!("1–{}", e.grips.len());
            tally.each_size(
                &combo,
                "trial, grasp",
                |w, h| screen(&mut a, w, h),
                |text, what| {
                    // Presented: the object and its pose stay; the rest on a tall screen (40 rows up).
                    let mut needles = e.lines[1..3].to_vec();
                    needles.push("Which grip did the participant take?".into());
                    needles.extend(e.grips.iter().cloned());
                    if text.lines().count() >= 40 {
                        needles.extend(e.lines[3..].iter().cloned());
                    }
                    assert_reads(text, &needles, what);
                    assert_footer(text, &[(grips.as_str(), "grip taken"), ("?", "help"), ("q", "quit")], what);
                },
            );
            keys(&mut a, &((trials % e.grips.len() as u64) + 1).to_string());
            trials += 1;
        }
        assert_eq!(trials, 26, "{combo}: every trial was walked");
        // The questionnaire: each statement with its scale, then the forced choice.
        let scale: Vec<String> = protocol["questionnaire"]["scale"]
            .as_array()
            .unwrap()
            .iter()
            .map(|p| format!("{} {}", p["value"], p["label"].as_str().unwrap()))
            .collect();
        while let Prompt::Likert { .. } = a.session().unwrap().prompt() {
            tally.each_size(
                &combo,
                "questionnaire statement",
                |w, h| screen(&mut a, w, h),
                |text, what| {
                    assert_reads(text, &scale, what);
                    assert_footer(text, &[("1–5", "answer"), ("?", "help"), ("q", "quit")], what);
                },
            );
            answer(&mut a, "4");
        }
        tally.each_size(
            &combo,
            "forced choice",
            |w, h| screen(&mut a, w, h),
            |text, what| {
                assert_footer(text, &[("a/b", "choice"), ("?", "help"), ("q", "quit")], what);
            },
        );
        answer(&mut a, "a");
        press(&mut a, KeyCode::Enter);
        a.wait_idle();
        tally.each_size(
            &combo,
            "summary",
            |w, h| screen(&mut a, w, h),
            |text, what| assert!(text.contains("Summary"), "{what}: {text}"),
        );
    }
    let listed: Vec<String> = tally.screens.iter().map(|(k, v)| format!("{k} {v}")).collect();
    println!(
        "{} hands × {} heights × {} sizes: {} screens drawn and checked ({})",
        HANDS.len(),
        HEIGHTS.len(),
        SIZES.len(),
        tally.drawn,
        listed.join(", ")
    );
    assert_eq!(tally.drawn, HANDS.len() * HEIGHTS.len() * SIZES.len() * (1 + 26 * 3 + 8 + 2));
}
