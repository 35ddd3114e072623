//! Every key binding, in one place, as a pure function from (mode, key) to an intent.

use ratatui::crossterm::event::{KeyCode, KeyEvent, KeyEventKind, KeyModifiers};

/// What the keyboard currently drives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    Setup,
    /// A query to present (undo possible right after a grasp).
    Present,
    /// A grasp to record.
    Grasp,
    Questionnaire,
    Paused,
    Summary,
    Help,
    ConfirmQuit,
    VoidReason,
    /// A line editor (a note, the participant id on the setup screen, an abort's reason).
    LineEdit,
    /// The log could not be written: retry or quit.
    WriteFailed,
    /// Between programs, before the test phase and before the questionnaire: what to tell
    /// the participant, confirmed by the experimenter.
    Transition,
    /// The questionnaire handed to the participant: answering keys only, nothing that
    /// un-blinds, and a hand-back key nobody presses by chance.
    Participant,
}

/// An operator's intent.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Action {
    Confirm,
    /// The n-th offered region (0-based) as listed on screen.
    Region(usize),
    Undo,
    Void,
    /// The n-th void reason (0-based) of the reason picker.
    VoidReason(usize),
    Note,
    EditParticipant,
    Pause,
    SwitchJoints,
    Help,
    Quit,
    Yes,
    No,
    /// End the session early for good (the participant withdrew).
    Abort,
    /// A Likert answer: the n-th scale point (0-based).
    Likert(usize),
    Prev,
    Next,
    /// The forced choice: program n (0 = A).
    Choice(usize),
    Char(char),
    Backspace,
    Cancel,
    /// Write the event that failed to be logged again.
    Retry,
    /// Send the waiting query's pose to the robot (again).
    SendRobot,
    /// Scroll the help up or down by a line.
    ScrollUp,
    ScrollDown,
    /// Hand the questionnaire to the participant.
    HandOver,
    /// The experimenter takes the keyboard back.
    HandBack,
}

/// The keys a binding answers to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Keys {
    Char(char),
    Enter,
    Esc,
    Tab,
    Left,
    Right,
    Up,
    Down,
    Backspace,
    /// Control and a letter.
    Ctrl(char),
    /// A digit 1..=n, n the count of what is picked ([`Counts`]).
    Digits(Picked),
    /// Any printable character (a line editor).
    Typed,
    /// A letter that acts only while a robot is connected ([`Counts::robot`]).
    RobotChar(char),
}

/// What a digit picks, whose count bounds the digits that act.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Picked {
    /// The grip regions offered.
    Region,
    /// The Likert scale's points.
    ScalePoint,
    /// The void reasons.
    VoidReason,
}

/// How many of each [`Picked`] there are now.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Counts {
    pub regions: usize,
    pub scale_points: usize,
    pub void_reasons: usize,
    /// Whether a robot is connected (its keys act and are listed).
    pub robot: bool,
    /// Whether there is a grasp to undo (`u` acts and is in the footer).
    pub can_undo: bool,
    /// Whether the particle view with its joints is shown (training trials: Tab acts).
    pub joints: bool,
    /// Where the questionnaire's cursor is: the digits answer a statement, `a`/`b` the
    /// forced choice (and change it from the review).
    pub questionnaire: QuestionnaireAt,
}

/// The questionnaire screen shown.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum QuestionnaireAt {
    #[default]
    Statement,
    ForcedChoice,
    Review,
}

impl Counts {
    fn of(self, p: Picked) -> usize {
        match p {
            Picked::Region => self.regions,
            Picked::ScalePoint => self.scale_points,
            Picked::VoidReason => self.void_reasons,
        }
    }
}

/// What a binding does.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Does {
    Is(Action),
    /// The digit's 0-based index picks.
    Pick(fn(usize) -> Action),
    /// The character typed.
    Type,
}

/// Where the help overlay lists a binding.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Section {
    Trial,
    Questionnaire,
    Setup,
    /// Dialogs and editors (their keys are shown in them and in the footer, not in help).
    Dialog,
}

/// One key binding: the one table the key map, the help overlay and the footer hints are
/// all derived from.
pub(crate) struct Binding {
    pub keys: Keys,
    pub modes: &'static [Mode],
    pub does: Does,
    /// The footer's short text ("" = not in the footer).
    pub hint: &'static str,
    /// The help overlay's text ("" = not in help).
    pub help: &'static str,
    pub section: Section,
}

use Mode as M;
const TRIAL: &[Mode] = &[M::Present, M::Grasp];
const IN_SESSION: &[Mode] = &[M::Present, M::Grasp, M::Questionnaire];
const COMMON: &[Mode] = &[M::Setup, M::Present, M::Grasp, M::Questionnaire, M::Paused, M::Summary, M::Transition];
const ANSWERING: &[Mode] = &[M::Questionnaire, M::Participant];

const fn bind(
    keys: Keys,
    modes: &'static [Mode],
    does: Does,
    hint: &'static str,
    help: &'static str,
    section: Section,
) -> Binding {
    Binding { keys, modes, does, hint, help, section }
}

/// Every key binding, in the order the footer lists them.
pub(crate) const BINDINGS: &[Binding] = &[
    // Dialogs and editors take their keys first.
    bind(Keys::Enter, &[M::LineEdit], Does::Is(Action::Confirm), "save", "", Section::Dialog),
    bind(Keys::Esc, &[M::LineEdit], Does::Is(Action::Cancel), "cancel", "", Section::Dialog),
    bind(Keys::Backspace, &[M::LineEdit], Does::Is(Action::Backspace), "", "", Section::Dialog),
    bind(Keys::Typed, &[M::LineEdit], Does::Type, "", "", Section::Dialog),
    bind(Keys::Esc, &[M::Help], Does::Is(Action::Cancel), "close help", "", Section::Dialog),
    bind(Keys::Char('?'), &[M::Help], Does::Is(Action::Cancel), "", "", Section::Dialog),
    bind(Keys::Char('q'), &[M::Help], Does::Is(Action::Cancel), "", "", Section::Dialog),
    bind(Keys::Enter, &[M::Help], Does::Is(Action::Cancel), "", "", Section::Dialog),
    bind(Keys::Up, &[M::Help], Does::Is(Action::ScrollUp), "scroll", "", Section::Dialog),
    bind(Keys::Down, &[M::Help], Does::Is(Action::ScrollDown), "scroll", "", Section::Dialog),
    bind(Keys::Char('y'), &[M::ConfirmQuit], Does::Is(Action::Yes), "quit", "", Section::Dialog),
    bind(Keys::Enter, &[M::ConfirmQuit], Does::Is(Action::Yes), "", "", Section::Dialog),
    bind(Keys::Char('n'), &[M::ConfirmQuit], Does::Is(Action::No), "stay", "", Section::Dialog),
    bind(Keys::Esc, &[M::ConfirmQuit], Does::Is(Action::No), "", "", Section::Dialog),
    bind(Keys::Char('a'), &[M::ConfirmQuit], Does::Is(Action::Abort), "abort session", "", Section::Dialog),
    bind(Keys::Char('r'), &[M::WriteFailed], Does::Is(Action::Retry), "retry the write", "", Section::Dialog),
    bind(Keys::Char('q'), &[M::WriteFailed], Does::Is(Action::Quit), "quit (resumable)", "", Section::Dialog),
    bind(
        Keys::Digits(Picked::VoidReason),
        &[M::VoidReason],
        Does::Pick(Action::VoidReason),
        "reason",
        "",
        Section::Dialog,
    ),
    bind(Keys::Esc, &[M::VoidReason], Does::Is(Action::Cancel), "cancel", "", Section::Dialog),
    // Setup.
    bind(Keys::Enter, &[M::Setup], Does::Is(Action::Confirm), "start", "start the session", Section::Setup),
    bind(
        Keys::Char('e'),
        &[M::Setup],
        Does::Is(Action::EditParticipant),
        "participant id",
        "type an existing participant id (or 'new')",
        Section::Setup,
    ),
    // Trials.
    bind(
        Keys::RobotChar('s'),
        &[M::Present],
        Does::Is(Action::SendRobot),
        "send to robot",
        "send the pose to the robot (again: a new attempt)",
        Section::Trial,
    ),
    bind(
        Keys::Enter,
        &[M::Present],
        Does::Is(Action::Confirm),
        "presented",
        "the robot holds the object at the pose",
        Section::Trial,
    ),
    bind(
        Keys::Digits(Picked::Region),
        &[M::Grasp],
        Does::Pick(Action::Region),
        "grip taken",
        "the grip region taken, in the order listed",
        Section::Trial,
    ),
    bind(
        Keys::Char('u'),
        &[M::Present, M::Transition],
        Does::Is(Action::Undo),
        "undo",
        "undo the last recorded grasp (until the next query)",
        Section::Trial,
    ),
    bind(
        Keys::Char('x'),
        TRIAL,
        Does::Is(Action::Void),
        "void",
        "void the trial, then choose a reason (it is repeated)",
        Section::Trial,
    ),
    // Transitions.
    bind(
        Keys::Enter,
        &[M::Transition],
        Does::Is(Action::Confirm),
        "told them: go on",
        "between phases: the participant has been told; go on",
        Section::Trial,
    ),
    // The questionnaire.
    bind(
        Keys::Digits(Picked::ScalePoint),
        ANSWERING,
        Does::Pick(Action::Likert),
        "answer",
        "answer the statement",
        Section::Questionnaire,
    ),
    bind(Keys::Left, ANSWERING, Does::Is(Action::Prev), "move", "previous statement", Section::Questionnaire),
    bind(Keys::Right, ANSWERING, Does::Is(Action::Next), "move", "next statement", Section::Questionnaire),
    bind(
        Keys::Char('a'),
        ANSWERING,
        Does::Is(Action::Choice(0)),
        "choice",
        "forced choice: Program A",
        Section::Questionnaire,
    ),
    bind(
        Keys::Char('b'),
        ANSWERING,
        Does::Is(Action::Choice(1)),
        "choice",
        "forced choice: Program B",
        Section::Questionnaire,
    ),
    bind(
        Keys::Enter,
        &[M::Questionnaire],
        Does::Is(Action::Confirm),
        "next/finish",
        "next; at the end, finish the session",
        Section::Questionnaire,
    ),
    bind(Keys::Enter, &[M::Participant], Does::Is(Action::Confirm), "next", "", Section::Dialog),
    bind(
        Keys::Char('h'),
        &[M::Questionnaire],
        Does::Is(Action::HandOver),
        "hand to participant",
        "hand the questionnaire to the participant (large, nothing un-blinds)",
        Section::Questionnaire,
    ),
    bind(
        Keys::Ctrl('e'),
        &[M::Participant],
        Does::Is(Action::HandBack),
        "",
        "the experimenter takes the questionnaire back from the participant",
        Section::Questionnaire,
    ),
    // In a session, and everywhere.
    bind(Keys::Char('p'), &[M::Paused], Does::Is(Action::Pause), "resume", "", Section::Trial),
    bind(
        Keys::Char('n'),
        &[M::Present, M::Grasp, M::Questionnaire, M::Paused, M::Transition],
        Does::Is(Action::Note),
        "note",
        "add a note (Enter saves, Esc cancels)",
        Section::Trial,
    ),
    bind(Keys::Char('p'), IN_SESSION, Does::Is(Action::Pause), "pause", "pause / resume", Section::Trial),
    bind(
        Keys::Tab,
        TRIAL,
        Does::Is(Action::SwitchJoints),
        "joints",
        "switch the joints of the particle view",
        Section::Trial,
    ),
    bind(Keys::Enter, &[M::Summary], Does::Is(Action::Quit), "exit", "", Section::Dialog),
    bind(Keys::Char('?'), COMMON, Does::Is(Action::Help), "help", "this help", Section::Trial),
    bind(
        Keys::Char('q'),
        COMMON,
        Does::Is(Action::Quit),
        "quit",
        "quit (asks first; the session can be resumed, or a ends it for good)",
        Section::Trial,
    ),
];

fn matches(keys: Keys, key: KeyEvent, counts: Counts) -> Option<Option<usize>> {
    let ctrl = key.modifiers.contains(KeyModifiers::CONTROL);
    let code = key.code;
    match (keys, code) {
        (Keys::Char(a), KeyCode::Char(b)) if a == b && !ctrl => Some(None),
        (Keys::Ctrl(a), KeyCode::Char(b)) if a == b && ctrl => Some(None),
        (Keys::RobotChar(a), KeyCode::Char(b)) if a == b && counts.robot => Some(None),
        (Keys::Enter, KeyCode::Enter)
        | (Keys::Esc, KeyCode::Esc)
        | (Keys::Tab, KeyCode::Tab)
        | (Keys::Left, KeyCode::Left)
        | (Keys::Right, KeyCode::Right)
        | (Keys::Up, KeyCode::Up)
        | (Keys::Down, KeyCode::Down)
        | (Keys::Backspace, KeyCode::Backspace) => Some(None),
        (Keys::Typed, KeyCode::Char(_)) if !ctrl => Some(None),
        (Keys::Digits(p), KeyCode::Char(c)) if !ctrl => {
            let d = c.to_digit(10)? as usize;
            (1..=counts.of(p).min(9)).contains(&d).then(|| Some(d - 1))
        }
        _ => None,
    }
}

/// The intent of a key press in a mode (None: the key does nothing there). Digits act only
/// up to the count of what they pick.
pub fn action_for(mode: Mode, key: KeyEvent, counts: Counts) -> Option<Action> {
    if key.kind == KeyEventKind::Release {
        return None;
    }
    // Ctrl+C asks to quit, except in the participant's hands (the experimenter takes the
    // keyboard back first).
    if key.modifiers.contains(KeyModifiers::CONTROL) && key.code == KeyCode::Char('c') && mode != Mode::Participant {
        return Some(Action::Quit);
    }
    BINDINGS.iter().filter(|b| b.modes.contains(&mode)).find_map(|b| {
        let digit = matches(b.keys, key, counts)?;
        Some(match (b.does, digit, key.code) {
            (Does::Is(a), _, _) => a,
            (Does::Pick(f), Some(i), _) => f(i),
            (Does::Type, _, KeyCode::Char(c)) => Action::Char(c),
            _ => return None,
        })
    })
}

/// How a binding's keys are written on screen (`1–4` for digits, with the count now).
pub(crate) fn key_label(keys: Keys, counts: Counts) -> String {
    match keys {
        Keys::Char(c) | Keys::RobotChar(c) => c.to_string(),
        Keys::Enter => "Enter".into(),
        Keys::Esc => "Esc".into(),
        Keys::Tab => "Tab".into(),
        Keys::Left => "←".into(),
        Keys::Right => "→".into(),
        Keys::Up => "↑".into(),
        Keys::Down => "↓".into(),
        Keys::Ctrl(c) => format!("Ctrl+{}", c.to_ascii_uppercase()),
        Keys::Backspace => "Backspace".into(),
        Keys::Typed => "text".into(),
        Keys::Digits(p) => match counts.of(p).min(9) {
            0 | 1 => "1".into(),
            n => format!("1–{n}"),
        },
    }
}

/// Whether a binding can act at all now (a robot's keys need a robot, undo a grasp to undo,
/// Tab the particle view of a training trial).
fn acts(b: &Binding, counts: Counts) -> bool {
    in_help(b, counts)
        && (!matches!(b.does, Does::Is(Action::Undo)) || counts.can_undo)
        && (!matches!(b.does, Does::Is(Action::SwitchJoints)) || counts.joints)
        && (!matches!(b.keys, Keys::Digits(Picked::ScalePoint)) || counts.questionnaire == QuestionnaireAt::Statement)
        && (!matches!(b.does, Does::Is(Action::Choice(_))) || counts.questionnaire != QuestionnaireAt::Statement)
}

/// Whether the help lists a binding: every key of the session, the robot's only with a robot
/// (the help says when a key acts, e.g. undo "until the next query").
fn in_help(b: &Binding, counts: Counts) -> bool {
    !matches!(b.keys, Keys::RobotChar(_)) || counts.robot
}

/// What `u` says when there is no grasp to undo.
pub const NOTHING_TO_UNDO: &str = "Nothing to undo: a grasp can be undone until the next query is presented";

/// What a key that does nothing in the participant's hands says (nothing about the session).
pub(crate) const PARTICIPANT_KEYS: &str =
    "The numbers answer; Enter goes to the next statement; ← and → move between them";

/// Why a key that does nothing now does nothing, for the status line.
pub fn why_not(mode: Mode, key: KeyEvent) -> Option<String> {
    if key.kind == KeyEventKind::Release || key.modifiers.contains(KeyModifiers::CONTROL) {
        return None;
    }
    let name = match key.code {
        KeyCode::Char(c) => c.to_string(),
        KeyCode::Enter => "Enter".into(),
        KeyCode::Esc => "Esc".into(),
        KeyCode::Tab => "Tab".into(),
        KeyCode::Backspace => "Backspace".into(),
        KeyCode::Left => "←".into(),
        KeyCode::Right => "→".into(),
        _ => return None,
    };
    let digit = matches!(key.code, KeyCode::Char(c) if c.is_ascii_digit());
    Some(match (mode, key.code) {
        (Mode::Present, _) if digit => {
            "Press Enter when the robot holds the object there first; then the number of the grip taken".into()
        }
        (Mode::Present | Mode::Grasp, KeyCode::Char('u')) => NOTHING_TO_UNDO.into(),
        (Mode::Paused, _) => format!("{name} does nothing while paused: p resumes the session"),
        (Mode::Participant, _) => PARTICIPANT_KEYS.into(),
        (Mode::Transition, _) => "Tell the participant what comes next (on screen), then press Enter".into(),
        _ => format!("{name} does nothing here (? lists the keys that act now)"),
    })
}

/// Every key press that acts in `mode` now, from the binding table: each digit up to its
/// count, one typed letter for a line editor, Ctrl and a letter, the robot's letters with a
/// robot. What a seeded random operator presses (`tests/integration/log_reader.rs`).
pub fn keys_that_act(mode: Mode, counts: Counts) -> Vec<KeyEvent> {
    let plain = |code| KeyEvent::new(code, KeyModifiers::NONE);
    let mut out: Vec<KeyEvent> = Vec::new();
    for b in BINDINGS.iter().filter(|b| b.modes.contains(&mode) && acts(b, counts)) {
        let presses: Vec<KeyEvent> = match b.keys {
            Keys::Char(c) | Keys::RobotChar(c) => vec![plain(KeyCode::Char(c))],
            Keys::Ctrl(c) => vec![KeyEvent::new(KeyCode::Char(c), KeyModifiers::CONTROL)],
            Keys::Enter => vec![plain(KeyCode::Enter)],
            Keys::Esc => vec![plain(KeyCode::Esc)],
            Keys::Tab => vec![plain(KeyCode::Tab)],
            Keys::Left => vec![plain(KeyCode::Left)],
            Keys::Right => vec![plain(KeyCode::Right)],
            Keys::Up => vec![plain(KeyCode::Up)],
            Keys::Down => vec![plain(KeyCode::Down)],
            Keys::Backspace => vec![plain(KeyCode::Backspace)],
            Keys::Typed => vec![plain(KeyCode::Char('x'))],
            Keys::Digits(p) => (1..=counts.of(p).min(9))
                .filter_map(|d| char::from_digit(d as u32, 10))
                .map(|c| plain(KeyCode::Char(c)))
                .collect(),
        };
        for k in presses {
            // A key bound twice in a mode acts by its first binding.
            if action_for(mode, k, counts).is_some() && !out.contains(&k) {
                out.push(k);
            }
        }
    }
    out
}

/// The footer's hints for a mode: (keys, what), in table order; bindings of one action
/// with the same hint are merged ("←/→").
pub fn hints(mode: Mode, counts: Counts) -> Vec<(String, &'static str)> {
    let mut out: Vec<(String, &'static str)> = Vec::new();
    for b in BINDINGS.iter().filter(|b| b.modes.contains(&mode) && !b.hint.is_empty() && acts(b, counts)) {
        let keys = key_label(b.keys, counts);
        match out.last_mut() {
            Some((k, hint)) if *hint == b.hint => *k = format!("{k}/{keys}"),
            _ => out.push((keys, b.hint)),
        }
    }
    out
}

/// The help overlay's sections: (heading, [(keys, what)]), from the same table.
pub fn help(counts: Counts) -> Vec<(&'static str, Vec<(String, &'static str)>)> {
    [(Section::Trial, "Trials"), (Section::Questionnaire, "Questionnaire"), (Section::Setup, "Setup")]
        .into_iter()
        .map(|(section, heading)| {
            let mut lines: Vec<(String, &'static str)> = Vec::new();
            for b in BINDINGS.iter().filter(|b| b.section == section && !b.help.is_empty() && in_help(b, counts)) {
                let line = (key_label(b.keys, counts), b.help);
                if !lines.contains(&line) {
                    lines.push(line);
                }
            }
            (heading, lines)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn key(code: KeyCode) -> KeyEvent {
        KeyEvent::new(code, KeyModifiers::NONE)
    }

    const COUNTS: Counts = Counts {
        regions: 2,
        scale_points: 5,
        void_reasons: 4,
        robot: false,
        can_undo: true,
        joints: true,
        questionnaire: QuestionnaireAt::Statement,
    };

    fn action_for(mode: Mode, key: KeyEvent) -> Option<Action> {
        super::action_for(mode, key, COUNTS)
    }

    #[test]
    fn trial_keys() {
        assert_eq!(action_for(Mode::Present, key(KeyCode::Enter)), Some(Action::Confirm));
        assert_eq!(action_for(Mode::Present, key(KeyCode::Char('u'))), Some(Action::Undo));
        assert_eq!(action_for(Mode::Grasp, key(KeyCode::Char('2'))), Some(Action::Region(1)));
        assert_eq!(action_for(Mode::Grasp, key(KeyCode::Char('0'))), None);
        assert_eq!(action_for(Mode::Grasp, key(KeyCode::Char('3'))), None, "two regions offered");
        assert_eq!(action_for(Mode::Grasp, key(KeyCode::Enter)), None, "a grasp needs a region");
        assert_eq!(action_for(Mode::Present, key(KeyCode::Char('1'))), None, "no region before the query");
        for m in [Mode::Present, Mode::Grasp] {
            assert_eq!(action_for(m, key(KeyCode::Char('x'))), Some(Action::Void));
            assert_eq!(action_for(m, key(KeyCode::Char('n'))), Some(Action::Note));
            assert_eq!(action_for(m, key(KeyCode::Char('p'))), Some(Action::Pause));
            assert_eq!(action_for(m, key(KeyCode::Tab)), Some(Action::SwitchJoints));
            assert_eq!(action_for(m, key(KeyCode::Char('?'))), Some(Action::Help));
            assert_eq!(action_for(m, key(KeyCode::Char('q'))), Some(Action::Quit));
        }
    }

    #[test]
    fn questionnaire_keys() {
        let q = Mode::Questionnaire;
        assert_eq!(action_for(q, key(KeyCode::Char('5'))), Some(Action::Likert(4)));
        assert_eq!(action_for(q, key(KeyCode::Char('6'))), None, "a 5-point scale");
        assert_eq!(action_for(q, key(KeyCode::Left)), Some(Action::Prev));
        assert_eq!(action_for(q, key(KeyCode::Right)), Some(Action::Next));
        assert_eq!(action_for(q, key(KeyCode::Char('a'))), Some(Action::Choice(0)));
        assert_eq!(action_for(q, key(KeyCode::Char('b'))), Some(Action::Choice(1)));
        assert_eq!(action_for(q, key(KeyCode::Char('u'))), None);
    }

    #[test]
    fn dialogs_and_editors() {
        assert_eq!(action_for(Mode::ConfirmQuit, key(KeyCode::Char('y'))), Some(Action::Yes));
        assert_eq!(action_for(Mode::ConfirmQuit, key(KeyCode::Esc)), Some(Action::No));
        assert_eq!(action_for(Mode::ConfirmQuit, key(KeyCode::Char('a'))), Some(Action::Abort));
        assert_eq!(action_for(Mode::VoidReason, key(KeyCode::Char('3'))), Some(Action::VoidReason(2)));
        assert_eq!(action_for(Mode::VoidReason, key(KeyCode::Char('5'))), None);
        assert_eq!(
            action_for(Mode::LineEdit, key(KeyCode::Char('q'))),
            Some(Action::Char('q')),
            "typing, not quitting"
        );
        assert_eq!(action_for(Mode::LineEdit, key(KeyCode::Enter)), Some(Action::Confirm));
        assert_eq!(action_for(Mode::LineEdit, key(KeyCode::Esc)), Some(Action::Cancel));
        assert_eq!(action_for(Mode::Help, key(KeyCode::Esc)), Some(Action::Cancel));
        assert_eq!(action_for(Mode::Paused, key(KeyCode::Char('p'))), Some(Action::Pause));
        assert_eq!(action_for(Mode::Paused, key(KeyCode::Enter)), None);
        let ctrl_c = KeyEvent::new(KeyCode::Char('c'), KeyModifiers::CONTROL);
        assert_eq!(action_for(Mode::LineEdit, ctrl_c), Some(Action::Quit));
    }

    /// The footer and the help say what the key map does: every hint's keys act in its
    /// mode, and the digits shown are the digits taken.
    #[test]
    fn footer_and_help_are_the_key_map() {
        let modes = [
            Mode::Setup,
            Mode::Present,
            Mode::Grasp,
            Mode::Questionnaire,
            Mode::Paused,
            Mode::Summary,
            Mode::Help,
            Mode::ConfirmQuit,
            Mode::VoidReason,
            Mode::LineEdit,
            Mode::WriteFailed,
            Mode::Transition,
            Mode::Participant,
        ];
        for mode in modes {
            let hints = hints(mode, COUNTS);
            assert!(!hints.is_empty(), "{mode:?} has a footer");
            for b in BINDINGS.iter().filter(|b| b.modes.contains(&mode)) {
                let code = match b.keys {
                    Keys::Char(c) => KeyCode::Char(c),
                    Keys::RobotChar(c) => {
                        let with_robot = Counts { robot: true, ..COUNTS };
                        assert_eq!(super::action_for(mode, key(KeyCode::Char(c)), COUNTS), None, "no robot");
                        assert!(super::action_for(mode, key(KeyCode::Char(c)), with_robot).is_some());
                        assert!(
                            super::hints(mode, with_robot).iter().any(|(k, h)| *k == c.to_string() && *h == b.hint)
                        );
                        assert!(
                            !super::hints(mode, COUNTS).iter().any(|(_, h)| *h == b.hint),
                            "hidden without a robot"
                        );
                        continue;
                    }
                    Keys::Ctrl(c) => {
                        let k = KeyEvent::new(KeyCode::Char(c), KeyModifiers::CONTROL);
                        assert!(action_for(mode, k).is_some(), "{mode:?}: Ctrl+{c} is bound");
                        assert_eq!(action_for(mode, key(KeyCode::Char(c))), None, "{c} alone is not Ctrl+{c}");
                        continue;
                    }
                    Keys::Up => KeyCode::Up,
                    Keys::Down => KeyCode::Down,
                    Keys::Enter => KeyCode::Enter,
                    Keys::Esc => KeyCode::Esc,
                    Keys::Tab => KeyCode::Tab,
                    Keys::Left => KeyCode::Left,
                    Keys::Right => KeyCode::Right,
                    Keys::Backspace => KeyCode::Backspace,
                    Keys::Typed => KeyCode::Char('z'),
                    Keys::Digits(_) => KeyCode::Char('1'),
                };
                assert!(action_for(mode, key(code)).is_some(), "{mode:?}: {:?} is bound", b.keys);
            }
        }
        assert_eq!(hints(Mode::Grasp, COUNTS)[0], ("1–2".to_string(), "grip taken"));
        assert!(hints(Mode::Questionnaire, COUNTS).contains(&("←/→".to_string(), "move")));
        let sections = help(COUNTS);
        let questionnaire = &sections.iter().find(|(h, _)| *h == "Questionnaire").unwrap().1;
        assert!(questionnaire.contains(&("1–5".to_string(), "answer the statement")));
        let with_seven = help(Counts { scale_points: 7, ..COUNTS });
        assert!(with_seven.iter().any(|(_, l)| l.contains(&("1–7".to_string(), "answer the statement"))));
        // `u` is listed only with a grasp to undo.
        assert!(hints(Mode::Present, COUNTS).iter().any(|(k, _)| k == "u"));
        assert!(!hints(Mode::Present, Counts { can_undo: false, ..COUNTS }).iter().any(|(k, _)| k == "u"));
        // The help lists it all the same, saying when it acts; Tab only where the joints are shown.
        let trials = |c: Counts| help(c).into_iter().find(|(h, _)| *h == "Trials").unwrap().1;
        assert!(trials(Counts { can_undo: false, ..COUNTS }).iter().any(|(k, _)| k == "u"));
        assert!(!hints(Mode::Present, Counts { joints: false, ..COUNTS }).iter().any(|(k, _)| k == "Tab"));
    }

    /// In the participant's hands only the answering keys act: no quit (Ctrl+C included),
    /// no help, no note, no pause; Ctrl+E gives the keyboard back; every line of the help
    /// fits the narrowest terminal.
    #[test]
    fn the_participant_answers_and_only_the_experimenter_takes_back() {
        let p = Mode::Participant;
        assert_eq!(action_for(p, key(KeyCode::Char('3'))), Some(Action::Likert(2)));
        assert_eq!(action_for(p, key(KeyCode::Enter)), Some(Action::Confirm));
        assert_eq!(action_for(p, key(KeyCode::Char('b'))), Some(Action::Choice(1)));
        for c in ['q', '?', 'n', 'p', 'h', 'e', 'x', 'u'] {
            assert_eq!(action_for(p, key(KeyCode::Char(c))), None, "{c}");
        }
        assert_eq!(action_for(p, KeyEvent::new(KeyCode::Char('c'), KeyModifiers::CONTROL)), None);
        assert_eq!(action_for(p, KeyEvent::new(KeyCode::Char('e'), KeyModifiers::CONTROL)), Some(Action::HandBack));
        assert_eq!(action_for(Mode::Questionnaire, key(KeyCode::Char('h'))), Some(Action::HandOver));
        assert!(!hints(p, COUNTS).iter().any(|(k, _)| k.contains("Ctrl")), "the footer does not tell the participant");
        assert_eq!(why_not(p, key(KeyCode::Char('q'))).as_deref(), Some(PARTICIPANT_KEYS));
        for (_, lines) in help(Counts { robot: true, ..COUNTS }) {
            for (k, w) in lines {
                assert!(8 + 1 + w.chars().count() <= 78, "{k}: '{w}' is wider than 80 columns' help");
            }
        }
    }

    /// A key that does nothing now says why.
    #[test]
    fn keys_that_do_nothing_say_why() {
        let why = |mode, code| why_not(mode, key(code)).unwrap();
        assert!(
            why(Mode::Present, KeyCode::Char('1'))
                .starts_with("Press Enter when the robot holds the object there first")
        );
        assert!(why(Mode::Grasp, KeyCode::Char('u')).starts_with("Nothing to undo"));
        assert!(why(Mode::Paused, KeyCode::Char('1')).contains("p resumes"));
        assert_eq!(why(Mode::Summary, KeyCode::Char('z')), "z does nothing here (? lists the keys that act now)");
        assert_eq!(why_not(Mode::Grasp, key(KeyCode::F(5))), None);
    }
}
