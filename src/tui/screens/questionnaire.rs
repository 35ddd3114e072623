//! The questionnaire: one statement at a time, every point labelled; then the forced choice.

use ratatui::Frame;
use ratatui::layout::Rect;
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Paragraph, Wrap};

use crate::session::{Prompt, Session, program_letter};
use crate::tui::app::App;
use crate::tui::theme;

pub fn render(app: &App, frame: &mut Frame, area: Rect) {
    let Some(s) = app.session() else { return };
    let q = &s.study().protocol.questionnaire;
    let order = s.likert_order();
    let n = order.len();
    let labels = &s.start().program_labels;
    let mut lines = Vec::new();
    let title;
    if app.cursor < n {
        let (program, item) = order[app.cursor];
        let label = &labels[program];
        title = format!(" Questionnaire · statement {}/{} · about {} ", app.cursor + 1, n, label);
        lines.push(Line::from(Span::styled(format!("About {label}:"), theme::title())));
        lines.push(Line::from(""));
        lines.push(Line::from(Span::styled(
            format!("  “{}”", q.items[item].statement.replace("{program}", label)),
            theme::instruction(),
        )));
        lines.push(Line::from(""));
        lines.extend(scale_lines(s, program, item, "← answered"));
    } else if app.cursor == n {
        title = " Questionnaire · forced choice ".to_string();
        lines.push(Line::from(Span::styled(format!("  “{}”", q.forced_choice), theme::instruction())));
        lines.push(Line::from(""));
        lines.extend(choice_lines(s, "← chosen"));
    } else {
        title = " Questionnaire · review ".to_string();
        let answered = s.likert_answers().len();
        lines.push(Line::from(format!("{answered} of {n} statements answered.")));
        for &(program, item) in &order {
            let v = s.likert_answers().get(&(program, item));
            lines.push(Line::from(format!(
                "  Program {} · {:<18} {}",
                program_letter(program),
                q.items[item].id,
                v.map_or("—".to_string(), |v| v.to_string())
            )));
        }
        lines.push(Line::from(format!(
            "  forced choice: {}",
            s.forced_choice().map_or("—".to_string(), |p| labels[p].clone())
        )));
        lines.push(Line::from(""));
        lines.push(Line::from(Span::styled(
            if s.prompt() == Prompt::Finish {
                "Press Enter to finish the session (← to change an answer)."
            } else {
                "Some answers are missing: use ← / → to reach them."
            },
            theme::instruction(),
        )));
    }
    frame.render_widget(Paragraph::new(lines).wrap(Wrap { trim: false }).block(Block::bordered().title(title)), area);
}

/// The questionnaire in the participant's hands: one statement, large and centred, its
/// scale, and nothing else (no condition, no belief, no setup); at the end, a request to
/// hand the keyboard back.
pub fn render_participant(app: &App, frame: &mut Frame, area: Rect) {
    let Some(s) = app.session() else { return };
    let q = &s.study().protocol.questionnaire;
    let order = s.likert_order();
    let n = order.len();
    let labels = &s.start().program_labels;
    let mut lines = Vec::new();
    let hint;
    if app.cursor < n {
        let (program, item) = order[app.cursor];
        lines.push(Line::from(Span::styled(format!("Statement {} of {n}", app.cursor + 1), theme::dim())));
        lines.push(Line::from(""));
        lines.push(Line::from(Span::styled(
            q.items[item].statement.replace("{program}", &labels[program]),
            theme::instruction(),
        )));
        lines.push(Line::from(""));
        lines.extend(scale_lines(s, program, item, "← your answer"));
        hint = "Press a number to answer, then Enter for the next statement (← goes back).";
    } else if app.cursor == n {
        lines.push(Line::from(Span::styled("Last question", theme::dim())));
        lines.push(Line::from(""));
        lines.push(Line::from(Span::styled(q.forced_choice.clone(), theme::instruction())));
        lines.push(Line::from(""));
        lines.extend(choice_lines(s, "← your answer"));
        hint = "Press a or b to answer, then Enter (← goes back).";
    } else if s.prompt() == Prompt::Finish {
        lines.push(Line::from(Span::styled(theme::HAND_BACK, theme::instruction())));
        hint = "";
    } else {
        lines.push(Line::from(Span::styled("Some questions have no answer yet.", theme::instruction())));
        hint = "Press ← to go back to them.";
    }
    if !hint.is_empty() {
        lines.push(Line::from(""));
        lines.push(Line::from(hint));
    }
    let outer = Block::bordered().title(" Questionnaire ");
    let inner = outer.inner(area);
    frame.render_widget(outer, area);
    // A readable column in the middle, the text starting a third of the way down.
    let width = inner.width.min(72);
    let x = inner.x + (inner.width - width) / 2;
    let lines = super::spaced(lines, inner.height as usize * 3 / 4, width as usize);
    let rows = super::rows_of(&lines, width as usize) as u16;
    let top = (inner.height / 4).min(inner.height.saturating_sub(rows + 1));
    let column = Rect { x, y: inner.y + top, width, height: inner.height - top };
    frame.render_widget(Paragraph::new(lines).wrap(Wrap { trim: false }), column);
}

/// The scale's points for a statement, its answer marked.
fn scale_lines(s: &Session, program: usize, item: usize, mark: &str) -> Vec<Line<'static>> {
    let answer = s.likert_answers().get(&(program, item)).copied();
    let scale = &s.study().protocol.questionnaire.scale;
    scale
        .iter()
        .enumerate()
        .map(|(k, p)| option_line(&(k + 1).to_string(), &p.label, answer == Some(p.value), mark))
        .collect()
}

/// The forced choice's programs (keys a, b, …), the choice marked.
fn choice_lines(s: &Session, mark: &str) -> Vec<Line<'static>> {
    let labels = &s.start().program_labels;
    (labels.iter().enumerate())
        .map(|(p, label)| option_line(&program_letter(p).to_lowercase(), label, s.forced_choice() == Some(p), mark))
        .collect()
}

fn option_line(key: &str, label: &str, chosen: bool, mark: &str) -> Line<'static> {
    Line::from(vec![
        Span::styled(format!(" {key} "), if chosen { theme::selected() } else { theme::key() }),
        Span::raw(format!("  {label}{}", if chosen { format!("   {mark}") } else { String::new() })),
    ])
}
