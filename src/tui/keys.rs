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
}

fn digit(c: char, max: usize) -> Option<usize> {
    let d = c.to_digit(10)? as usize;
    (1..=max).contains(&d).then(|| d - 1)
}

/// The intent of a key press in a mode (None: the key does nothing there).
pub fn action_for(mode: Mode, key: KeyEvent) -> Option<Action> {
    if key.kind == KeyEventKind::Release {
        return None;
    }
    if key.modifiers.contains(KeyModifiers::CONTROL) && key.code == KeyCode::Char('c') {
        return Some(Action::Quit);
    }
    use Action as A;
    use KeyCode as K;
    match mode {
        Mode::LineEdit => match key.code {
            K::Enter => Some(A::Confirm),
            K::Esc => Some(A::Cancel),
            K::Backspace => Some(A::Backspace),
            K::Char(c) => Some(A::Char(c)),
            _ => None,
        },
        Mode::Help => match key.code {
            K::Esc | K::Char('?') | K::Char('q') | K::Enter => Some(A::Cancel),
            _ => None,
        },
        Mode::ConfirmQuit => match key.code {
            K::Char('y') | K::Enter => Some(A::Yes),
            K::Char('n') | K::Esc => Some(A::No),
            K::Char('a') => Some(A::Abort),
            _ => None,
        },
        Mode::WriteFailed => match key.code {
            K::Char('r') => Some(A::Retry),
            K::Char('q') => Some(A::Quit),
            _ => None,
        },
        Mode::VoidReason => match key.code {
            K::Esc => Some(A::Cancel),
            K::Char(c) => digit(c, 4).map(A::VoidReason),
            _ => None,
        },
        _ => {
            let common = match key.code {
                K::Char('?') => Some(A::Help),
                K::Char('q') => Some(A::Quit),
                _ => None,
            };
            if common.is_some() {
                return common;
            }
            match (mode, key.code) {
                (Mode::Setup, K::Enter) => Some(A::Confirm),
                (Mode::Setup, K::Char('e')) => Some(A::EditParticipant),
                (Mode::Summary, K::Enter) => Some(A::Quit),
                (Mode::Paused, K::Char('p')) => Some(A::Pause),
                (Mode::Paused, K::Char('n')) => Some(A::Note),
                (Mode::Present | Mode::Grasp | Mode::Questionnaire, K::Char('p')) => Some(A::Pause),
                (Mode::Present | Mode::Grasp | Mode::Questionnaire, K::Char('n')) => Some(A::Note),
                (Mode::Present | Mode::Grasp, K::Char('x')) => Some(A::Void),
                (Mode::Present | Mode::Grasp, K::Tab) => Some(A::SwitchJoints),
                (Mode::Present, K::Enter) => Some(A::Confirm),
                (Mode::Present, K::Char('u')) => Some(A::Undo),
                (Mode::Grasp, K::Char(c)) => digit(c, 9).map(A::Region),
                (Mode::Questionnaire, K::Char('a')) => Some(A::Choice(0)),
                (Mode::Questionnaire, K::Char('b')) => Some(A::Choice(1)),
                (Mode::Questionnaire, K::Char(c)) => digit(c, 9).map(A::Likert),
                (Mode::Questionnaire, K::Left) => Some(A::Prev),
                (Mode::Questionnaire, K::Right) => Some(A::Next),
                (Mode::Questionnaire, K::Enter) => Some(A::Confirm),
                _ => None,
            }
        }
    }
}

/// The help overlay's lines: key and what it does.
pub const HELP: [(&str, &str); 16] = [
    ("Enter", "confirm / next (robot holds the object; start; finish)"),
    ("1–9", "the grip region taken, in the order listed"),
    ("u", "undo the last recorded grasp (until the next query)"),
    ("x", "void the trial, then choose a reason (it is repeated)"),
    ("n", "add a note (Enter saves, Esc cancels)"),
    ("p", "pause / resume"),
    ("Tab", "switch the joints of the particle view"),
    ("?", "this help"),
    ("q", "quit (asks first; the session can be resumed; or a: abort it for good)"),
    ("Questionnaire", ""),
    ("1–5", "answer the statement"),
    ("← / →", "previous / next statement"),
    ("a / b", "forced choice: Program A / Program B"),
    ("Enter", "next; at the end, finish the session"),
    ("Setup", ""),
    ("e", "type an existing participant id (or 'new')"),
];

#[cfg(test)]
mod tests {
    use super::*;

    fn key(code: KeyCode) -> KeyEvent {
        KeyEvent::new(code, KeyModifiers::NONE)
    }

    #[test]
    fn trial_keys() {
        assert_eq!(action_for(Mode::Present, key(KeyCode::Enter)), Some(Action::Confirm));
        assert_eq!(action_for(Mode::Present, key(KeyCode::Char('u'))), Some(Action::Undo));
        assert_eq!(action_for(Mode::Grasp, key(KeyCode::Char('2'))), Some(Action::Region(1)));
        assert_eq!(action_for(Mode::Grasp, key(KeyCode::Char('0'))), None);
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
}
