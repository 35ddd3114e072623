//! One rule for the texts a protocol or a log carries (checked by the protocol's validator,
//! by the session before it logs a start and by the log reader, so that every protocol
//! `protocol check` accepts gives a log the reader accepts), the rule for ids that can become
//! file names, and how any text from a file is printed on a terminal.

use std::borrow::Cow;

/// The most bytes of a name, id or label (a protocol's name, an object's label, …).
pub const NAME_BYTES: usize = 200;
/// The most bytes of a description, statement, question or transition text.
pub const LONG_BYTES: usize = 4000;
/// The most bytes of a program label (the blinded name of a condition).
pub const PROGRAM_LABEL_BYTES: usize = 100;
/// The most bytes of an id in a protocol (objects, regions, queries, questionnaire items).
pub const ID_BYTES: usize = 64;

/// Why a text breaks the rule; its message completes "FIELD …" ("name has 300 bytes, …").
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum TextProblem {
    #[error("has {bytes} bytes, expected at most {max} bytes of UTF-8 text")]
    TooLong { bytes: usize, max: usize },
    #[error(
        "has the control character U+{code:04X} at byte {at}, expected printable text{}",
        if *newlines { " (line breaks allowed)" } else { "" }
    )]
    Control { code: u32, at: usize, newlines: bool },
    #[error(
        "'{shown}' is not an id: expected 1 to {ID_BYTES} characters from A–Z, a–z, 0–9, '-' and '_', starting with a letter or digit"
    )]
    NotAnId { shown: String },
}

/// Checks a label: at most `max` bytes (UTF-8, as stored) and no control character (no
/// tab, newline, escape or other C0/C1 code), so it fits a log and prints on one line.
pub fn check_label(v: &str, max: usize) -> Result<(), TextProblem> {
    if v.len() > max {
        return Err(TextProblem::TooLong { bytes: v.len(), max });
    }
    check_no_control(v, false)
}

/// Checks a long text: at most `max` bytes, control characters other than a line break
/// refused.
pub fn check_long(v: &str, max: usize) -> Result<(), TextProblem> {
    if v.len() > max {
        return Err(TextProblem::TooLong { bytes: v.len(), max });
    }
    check_no_control(v, true)
}

fn check_no_control(v: &str, newlines: bool) -> Result<(), TextProblem> {
    match v.char_indices().find(|&(_, c)| c.is_control() && !(newlines && c == '\n')) {
        Some((at, c)) => Err(TextProblem::Control { code: c as u32, at, newlines }),
        None => Ok(()),
    }
}

/// Checks an id that can become a file name (a query's plot, a CSV key): 1 to
/// [`ID_BYTES`] characters from A–Z, a–z, 0–9, '-' and '_', starting with a letter or a digit
/// — no dots, slashes or spaces, so never a path.
pub fn check_id(v: &str) -> Result<(), TextProblem> {
    let ok = (1..=ID_BYTES).contains(&v.len())
        && v.as_bytes()[0].is_ascii_alphanumeric()
        && v.bytes().all(|b| b.is_ascii_alphanumeric() || matches!(b, b'-' | b'_'));
    if ok { Ok(()) } else { Err(TextProblem::NotAnId { shown: printable(v).into_owned() }) }
}

/// A text as it may be printed on a terminal: every control character (an escape sequence's
/// ESC, a bell, a carriage return, a tab) is shown escaped (`\u{1b}`), so nothing from a file
/// can move the cursor, retitle the window or clear the screen. Other characters are kept.
pub fn printable(v: &str) -> Cow<'_, str> {
    if !v.chars().any(char::is_control) {
        return Cow::Borrowed(v);
    }
    let mut out = String::with_capacity(v.len() + 8);
    for c in v.chars() {
        if c.is_control() {
            out.extend(c.escape_default());
        } else {
            out.push(c);
        }
    }
    Cow::Owned(out)
}

/// [`printable`], keeping line breaks (for multi-line messages such as a list of problems).
pub fn printable_lines(v: &str) -> Cow<'_, str> {
    if !v.chars().any(|c| c.is_control() && c != '\n') {
        return Cow::Borrowed(v);
    }
    Cow::Owned(v.split('\n').map(|l| printable(l).into_owned()).collect::<Vec<_>>().join("\n"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_are_counted_in_bytes_and_refuse_control_characters() {
        assert!(check_label(&"ü".repeat(100), 200).is_ok());
        let e = check_label(&"ü".repeat(150), 200).unwrap_err();
        assert_eq!(e, TextProblem::TooLong { bytes: 300, max: 200 });
        assert!(e.to_string().contains("300 bytes"), "{e}");
        let e = check_label("a\tb", 200).unwrap_err();
        assert!(e.to_string().contains("U+0009 at byte 1"), "{e}");
        assert!(check_label("line\nbreak", 200).is_err());
        assert!(check_long("line\nbreak", 200).is_ok());
        assert!(check_long("\u{1b}]0;x\u{7}", 200).is_err());
        assert!(check_label("\u{85}", 200).is_err(), "C1 controls too");
    }

    #[test]
    fn ids_never_make_a_path() {
        for ok in ["u-lock", "test_bars_1", "A9"] {
            assert!(check_id(ok).is_ok(), "{ok}");
        }
        for bad in ["", "../../x", "/abs", "a b", "a.b", "-x", "_x", "ü", &"x".repeat(65)] {
            assert!(check_id(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn control_characters_are_escaped_for_the_terminal() {
        assert_eq!(printable("plain ü"), "plain ü");
        assert_eq!(printable("\u{1b}]0;x\u{7}"), "\\u{1b}]0;x\\u{7}");
        assert_eq!(printable("\u{1b}[2J"), "\\u{1b}[2J");
        assert_eq!(printable_lines("a\nb\u{1b}"), "a\nb\\u{1b}");
    }
}
