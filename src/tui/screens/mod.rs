//! Rendering: each screen reads the app's state and draws; nothing here changes state.

mod overlays;
mod questionnaire;
mod setup;
mod summary;
pub(super) mod trial;

use ratatui::Frame;
use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Paragraph, Wrap};

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
    let msg = match (app.busy(), app.practice_hint()) {
        (true, _) => theme::COMPUTING.to_string(),
        (false, Some(hint)) if app.status.is_empty() => hint,
        (false, Some(hint)) => format!("{hint} · {}", app.status),
        (false, None) => app.status.clone(),
    };
    // A long message takes a second line rather than being cut.
    let status_h = if Line::from(msg.as_str()).width() > area.width as usize { 2 } else { 1 };
    let [top, body, status, keys] = Layout::vertical([
        Constraint::Length(1),
        Constraint::Min(0),
        Constraint::Length(status_h),
        Constraint::Length(1),
    ])
    .areas(area);
    header(app, frame, top);
    match &app.screen {
        Screen::Setup => setup::render(app, frame, body),
        Screen::Summary(view) => summary::render(app, view, frame, body),
        Screen::Session if app.transition().is_some() => overlays::transition(app, frame, body),
        Screen::Session if app.participant_mode => questionnaire::render_participant(app, frame, body),
        Screen::Session => match app.session().map(|s| s.prompt()) {
            Some(Prompt::Present(_) | Prompt::Grasp(_)) => trial::render(app, frame, body),
            Some(Prompt::Paused) => overlays::paused(app, frame, body),
            Some(Prompt::Done { .. }) | None => overlays::finishing(frame, body),
            Some(_) => questionnaire::render(app, frame, body),
        },
    }
    frame.render_widget(
        Paragraph::new(Line::from(Span::styled(msg, theme::instruction()))).wrap(Wrap { trim: false }),
        status,
    );
    frame.render_widget(Paragraph::new(key_hints(app, area.width)), keys);
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

/// The header: who, whether it is a rehearsal, how long the session has run (from its
/// logged start, so a resumed session keeps its clock), and the protocol (cut first).
/// Lines spaced out by blank lines when `rows` rows of `width` columns have room for them
/// (wrapped): large text for someone reading from a distance (the participant, the robot
/// operator).
pub(crate) fn spaced(lines: Vec<Line<'static>>, rows: usize, width: usize) -> Vec<Line<'static>> {
    if rows_of(&lines, width) + lines.len() <= rows {
        lines.into_iter().flat_map(|l| [l, Line::from("")]).collect()
    } else {
        lines
    }
}

/// A text cut to `width` columns, with an ellipsis where it was cut: a cut is never silent.
pub(crate) fn fit(text: &str, width: usize) -> String {
    if text.chars().count() <= width {
        return text.to_string();
    }
    let mut out: String = text.chars().take(width.saturating_sub(1)).collect();
    if width > 0 {
        out.push('…');
    }
    out
}

/// A text word-wrapped at `width` columns into at most `rows` rows, the last ending in an
/// ellipsis when the text goes on.
pub(crate) fn clip_wrapped(text: &str, width: usize, rows: usize) -> String {
    let width = width.max(1);
    let mut lines: Vec<String> = Vec::new();
    let mut current = String::new();
    for word in text.split(' ') {
        let candidate = if current.is_empty() { word.to_string() } else { format!("{current} {word}") };
        if candidate.chars().count() <= width || current.is_empty() {
            current = candidate;
        } else {
            lines.push(std::mem::take(&mut current));
            current = word.to_string();
        }
    }
    lines.push(current);
    if lines.len() <= rows {
        return text.to_string();
    }
    lines.truncate(rows);
    if let Some(last) = lines.last_mut() {
        *last = fit(&format!("{last} …"), width);
        if !last.ends_with('…') {
            last.push('…');
        }
    }
    lines.join(" ")
}

/// The rows lines take when word-wrapped at `width` columns, counted by the paragraph that
/// draws them (ratatui's own word wrapper, untrimmed as every screen draws it), so a panel
/// sized by it always holds its lines.
pub(crate) fn rows_of(lines: &[Line], width: usize) -> usize {
    let width = u16::try_from(width.max(1)).unwrap_or(u16::MAX);
    Paragraph::new(lines.to_vec()).wrap(Wrap { trim: false }).line_count(width)
}

fn header(app: &App, frame: &mut Frame, area: Rect) {
    let mut spans = vec![Span::styled(format!(" {} ", theme::APP), theme::title())];
    if app.participant_mode {
        spans.push(Span::raw("— questionnaire"));
        frame.render_widget(Paragraph::new(Line::from(spans)), area);
        return;
    }
    if let Some(s) = app.session() {
        spans.push(Span::raw(format!("— participant {} ", s.start().participant)));
        if s.start().pilot {
            spans.push(Span::styled("[PILOT] ", theme::warning()));
        }
    }
    if let Some(t0) = app.session_started_ns {
        let secs = app.now_ns.saturating_sub(t0) / 1_000_000_000;
        let clock = if secs >= 3600 {
            format!("{}:{:02}:{:02}", secs / 3600, secs / 60 % 60, secs % 60)
        } else {
            format!("{:02}:{:02}", secs / 60, secs % 60)
        };
        spans.push(Span::raw(format!("— elapsed {clock} ")));
    }
    spans.push(Span::raw(format!("— {}", app.config.study.protocol.name)));
    frame.render_widget(Paragraph::new(Line::from(spans)), area);
}

/// Footer hints that give way first when the footer does not fit, most dispensable first
/// (never the keys that answer the screen shown: the choice is listed only where it acts).
const DISPENSABLE: [&str; 4] = ["joints", "move", "pause", "note"];

/// The footer: the keys that act now, spaced out when they fit, packed when not, and at the
/// narrowest the most dispensable dropped, then the last ones (help and quit are always
/// listed).
fn key_hints(app: &App, width: u16) -> Line<'static> {
    // The participant who has answered everything only hands the keyboard back.
    if app.participant_done() {
        return Line::default();
    }
    let pairs = super::keys::hints(app.mode(), app.counts());
    let build = |pairs: &[(String, &'static str)], gap: &str| -> Line<'static> {
        Line::from(
            pairs
                .iter()
                .flat_map(|(k, w)| [Span::styled(format!(" {k} "), theme::key()), Span::raw(format!(" {w}{gap}"))])
                .collect::<Vec<_>>(),
        )
    };
    let mut pairs = pairs;
    let wide = build(&pairs, "  ");
    if wide.width() <= width as usize {
        return wide;
    }
    loop {
        let packed = build(&pairs, "");
        if packed.width() <= width as usize || pairs.len() <= 1 {
            return packed;
        }
        let dispensable = DISPENSABLE.iter().find_map(|d| pairs.iter().position(|(_, w)| w == d));
        match dispensable.or_else(|| pairs.iter().rposition(|(k, _)| k != "?" && k != "q")) {
            Some(i) => {
                pairs.remove(i);
            }
            None => return packed,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{clip_wrapped, fit};

    #[test]
    fn a_cut_text_ends_in_an_ellipsis() {
        assert_eq!(fit("participant sneezed", 19), "participant sneezed");
        assert_eq!(fit("participant sneezed", 12), "participant…");
        assert_eq!(fit("· 3 more when taller ", 10).chars().count(), 10);
        let text = "The user study of Bestick et al.: bicycle handlebars and a U-lock, each with two grips";
        assert_eq!(clip_wrapped(text, 40, 5), text);
        let two = clip_wrapped(text, 40, 2);
        assert!(two.ends_with('…') && two.chars().count() <= 80, "{two}");
    }
}
