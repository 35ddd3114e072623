//! Dialogs and whole-screen states: help, quit, void reason, line editor, pause, too small.

use ratatui::Frame;
use ratatui::layout::{Constraint, Flex, Layout, Rect};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Clear, Paragraph, Wrap};

use crate::session::Transition;
use crate::session::VoidReason;
use crate::tui::app::App;
use crate::tui::keys::Mode;
use crate::tui::theme;

fn centred(area: Rect, width: u16, height: u16) -> Rect {
    let [v] = Layout::vertical([Constraint::Length(height.min(area.height))]).flex(Flex::Center).areas(area);
    let [h] = Layout::horizontal([Constraint::Length(width.min(area.width))]).flex(Flex::Center).areas(v);
    h
}

fn dialog(frame: &mut Frame, area: Rect, title: &str, lines: Vec<Line>, width: u16) {
    let inner = width.min(area.width).saturating_sub(2).max(1) as usize;
    let height = super::rows_of(&lines, inner);
    let r = centred(area, width, height as u16 + 2);
    frame.render_widget(Clear, r);
    frame.render_widget(
        Paragraph::new(lines).wrap(Wrap { trim: false }).block(Block::bordered().title(title.to_string())),
        r,
    );
}

/// The keys, the section of the screen below first; it scrolls (↑/↓) when taller than the
/// terminal.
pub fn help(app: &App, frame: &mut Frame, area: Rect) {
    let mut sections = crate::tui::keys::help(app.counts());
    let first = match app.screen_mode() {
        Mode::Questionnaire | Mode::Participant => "Questionnaire",
        Mode::Setup => "Setup",
        _ => "Trials",
    };
    sections.sort_by_key(|(heading, _)| *heading != first);
    let mut lines: Vec<Line> = Vec::new();
    for (heading, keys) in sections {
        lines.push(Line::from(Span::styled(heading.to_string(), theme::title())));
        for (k, w) in keys {
            lines.push(Line::from(vec![Span::styled(format!(" {k:<6} "), theme::key()), Span::raw(format!(" {w}"))]));
        }
    }
    let width = lines.iter().map(Line::width).max().unwrap_or(0) as u16 + 2;
    let r = centred(area, width, lines.len() as u16 + 2);
    let visible = r.height.saturating_sub(2);
    let overflow = (lines.len() as u16).saturating_sub(visible);
    let offset = app.help_scroll.min(overflow);
    let title = if overflow > 0 {
        format!(" Keys ({}–{} of {}; ↑/↓ scroll, Esc closes) ", offset + 1, offset + visible, lines.len())
    } else {
        " Keys (Esc closes) ".to_string()
    };
    frame.render_widget(Clear, r);
    frame.render_widget(Paragraph::new(lines).scroll((offset, 0)).block(Block::bordered().title(title)), r);
}

/// Between phases: what to tell the participant, from the protocol; Enter goes on.
pub fn transition(app: &App, frame: &mut Frame, area: Rect) {
    let Some(stage) = app.transition() else { return };
    let heading = match stage {
        Transition::Program(k) => {
            app.session().map_or(String::new(), |s| format!("{} is next", s.start().program_labels[k]))
        }
        Transition::Test => "The test phase is next".into(),
        Transition::Questionnaire => "The questionnaire is next".into(),
    };
    let mut lines = vec![
        Line::from(Span::styled(heading, theme::title())),
        Line::from(""),
        Line::from(Span::styled(app.transition_text(stage), theme::instruction())),
        Line::from(""),
        Line::from("Press Enter once the participant has been told."),
    ];
    if let Some(what) = app.undoable() {
        lines.push(Line::from(format!("u undoes {what} if it was recorded wrong (before telling them).")));
    }
    frame.render_widget(
        Paragraph::new(lines).wrap(Wrap { trim: false }).block(Block::bordered().title(" Between phases ")),
        area,
    );
}

pub fn confirm_quit(app: &App, frame: &mut Frame, area: Rect) {
    let resumable = app.session().is_some();
    let mut lines = vec![Line::from(Span::styled("Quit the console?", theme::instruction()))];
    if resumable {
        lines.push(Line::from("Everything recorded is on disk; the session can be resumed with"));
        let command = app.log_path().map_or_else(|| "handover resume <log>".into(), |p| app.resume_command(&p));
        lines.push(Line::from(crate::text::printable(&command).into_owned()));
    }
    lines.push(Line::from(if resumable {
        "y: quit   n: stay   a: abort the session for good"
    } else {
        "y: quit   n: stay"
    }));
    dialog(frame, area, " Quit ", lines, 70);
}

pub fn void_reason(frame: &mut Frame, area: Rect) {
    let mut lines = vec![Line::from("Why is this trial void? (it will be repeated)")];
    for (k, r) in VoidReason::ALL.iter().enumerate() {
        lines.push(Line::from(vec![
            Span::styled(format!(" {} ", k + 1), theme::key()),
            Span::raw(format!(" {}", r.label())),
        ]));
    }
    dialog(frame, area, " Void the trial ", lines, 56);
}

pub fn line_editor(frame: &mut Frame, area: Rect, title: &str, text: &str) {
    let lines = vec![Line::from(vec![Span::raw(text.to_string()), Span::styled("▏", theme::instruction())])];
    dialog(frame, area, &format!(" {title} "), lines, 76);
}

pub fn paused(app: &App, frame: &mut Frame, area: Rect) {
    let notes = app.session().map_or(0, |s| s.notes().len());
    let lines = vec![
        Line::from(Span::styled(theme::PAUSED, theme::warning())),
        Line::from(""),
        Line::from("The session is paused: nothing is presented or recorded."),
        Line::from(format!("Notes so far: {notes} (n adds one)")),
    ];
    frame.render_widget(Paragraph::new(lines).block(Block::bordered().title(" Paused ")), area);
}

pub fn finishing(frame: &mut Frame, area: Rect) {
    frame.render_widget(
        Paragraph::new(vec![Line::from(theme::COMPUTING), Line::from("Finishing the log and computing the summary.")])
            .block(Block::bordered().title(" Summary ")),
        area,
    );
}

pub fn too_small(frame: &mut Frame, area: Rect) {
    let text = vec![
        Line::from(Span::styled("Terminal too small", theme::warning())),
        Line::from(format!("need {}×{}, have {}×{}", theme::MIN_WIDTH, theme::MIN_HEIGHT, area.width, area.height)),
        Line::from("Enlarge the window; nothing is lost. Keys are ignored until then."),
    ];
    frame.render_widget(Paragraph::new(text).wrap(Wrap { trim: false }), area);
}

/// The log could not be written: a blocking dialog until the write is retried.
pub fn write_failed(frame: &mut Frame, area: Rect, message: &str, last_event: usize) {
    let lines = vec![
        Line::from(Span::styled("The log could not be written.", theme::warning())),
        Line::from(message.to_string()),
        Line::from(""),
        Line::from(format!("Nothing after event {last_event} is recorded, and nothing moves on until it is.")),
        Line::from("Free space (or fix the disk), then press r to retry; q quits and leaves the session resumable."),
    ];
    dialog(frame, area, " Log write failed ", lines, 78);
}
