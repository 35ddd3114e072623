//! Rendering: each screen reads the app's state and draws; nothing here changes state.

mod overlays;
mod questionnaire;
mod setup;
mod summary;
mod trial;

use ratatui::Frame;
use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::text::{Line, Span};
use ratatui::widgets::Paragraph;

use super::app::{App, Overlay, Screen};
use super::theme;
use crate::session::Prompt;

/// Draws the whole console.
pub fn render(app: &App, frame: &mut Frame) {
    let area = frame.area();
    if area.width < theme::MIN_WIDTH || area.height < theme::MIN_HEIGHT {
        overlays::too_small(frame, area);
        return;
    }
    let [top, body, status, keys] =
        Layout::vertical([Constraint::Length(1), Constraint::Min(0), Constraint::Length(1), Constraint::Length(1)])
            .areas(area);
    header(app, frame, top);
    match &app.screen {
        Screen::Setup => setup::render(app, frame, body),
        Screen::Summary(view) => summary::render(app, view, frame, body),
        Screen::Session => match app.session().map(|s| s.prompt()) {
            Some(Prompt::Present(_) | Prompt::Grasp(_)) => trial::render(app, frame, body),
            Some(Prompt::Paused) => overlays::paused(app, frame, body),
            Some(Prompt::Done { .. }) | None => overlays::finishing(frame, body),
            Some(_) => questionnaire::render(app, frame, body),
        },
    }
    let msg = if app.busy() { theme::COMPUTING.to_string() } else { app.status.clone() };
    frame.render_widget(Paragraph::new(Line::from(Span::styled(msg, theme::instruction()))), status);
    frame.render_widget(Paragraph::new(key_hints(app)), keys);
    match &app.overlay {
        Some(Overlay::Help) => overlays::help(app, frame, area),
        Some(Overlay::ConfirmQuit) => overlays::confirm_quit(app, frame, area),
        Some(Overlay::VoidReason) => overlays::void_reason(frame, area),
        Some(Overlay::Note(text)) => overlays::line_editor(frame, area, "Note (Enter saves, Esc cancels)", text),
        Some(Overlay::ParticipantId(text)) => {
            overlays::line_editor(frame, area, "Participant id, or 'new' (Enter confirms, Esc cancels)", text)
        }
        Some(Overlay::AbortReason(text)) => overlays::line_editor(
            frame,
            area,
            "End the session for good? Reason (e.g. participant withdrew); Enter ends it, Esc goes back",
            text,
        ),
        Some(Overlay::VoidDetail(text)) => overlays::line_editor(
            frame,
            area,
            "Void as other: what happened? (Enter voids the trial, Esc goes back)",
            text,
        ),
        Some(Overlay::WriteFailed { message, last_event }) => overlays::write_failed(frame, area, message, *last_event),
        None => {}
    }
}

fn header(app: &App, frame: &mut Frame, area: Rect) {
    let mut spans = vec![Span::styled(format!(" {} ", theme::APP), theme::title())];
    spans.push(Span::raw(format!("— {} ", app.config.study.protocol.name)));
    if let Some(s) = app.session() {
        spans.push(Span::raw(format!("— participant {} ", s.start().participant)));
        if s.start().pilot {
            spans.push(Span::styled("[PILOT] ", theme::warning()));
        }
    }
    if let Some(t0) = app.session_started_ns {
        let secs = app.now_ns.saturating_sub(t0) / 1_000_000_000;
        spans.push(Span::raw(format!("— elapsed {:02}:{:02}", secs / 60, secs % 60)));
    }
    frame.render_widget(Paragraph::new(Line::from(spans)), area);
}

fn hint<'a>(k: &'a str, what: &'a str) -> [Span<'a>; 2] {
    [Span::styled(format!(" {k} "), theme::key()), Span::raw(format!(" {what}  "))]
}

fn key_hints(app: &App) -> Line<'static> {
    let pairs = super::keys::hints(app.mode(), app.counts());
    Line::from(
        pairs
            .iter()
            .flat_map(|(k, w)| hint(k, w))
            .map(|s| Span::styled(s.content.into_owned(), s.style))
            .collect::<Vec<_>>(),
    )
}
