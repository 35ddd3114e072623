//! The questionnaire: one statement at a time, every point labelled; then the forced choice.

use ratatui::Frame;
use ratatui::layout::Rect;
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Paragraph, Wrap};

use crate::session::{Prompt, program_letter};
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
        let answer = s.likert_answers().get(&(program, item)).copied();
        for (k, p) in q.scale.iter().enumerate() {
            let chosen = answer == Some(p.value);
            lines.push(Line::from(vec![
                Span::styled(format!(" {} ", k + 1), if chosen { theme::selected() } else { theme::key() }),
                Span::raw(format!(" {}{}", p.label, if chosen { "   ← answered" } else { "" })),
            ]));
        }
    } else if app.cursor == n {
        title = " Questionnaire · forced choice ".to_string();
        lines.push(Line::from(Span::styled(format!("  “{}”", q.forced_choice), theme::instruction())));
        lines.push(Line::from(""));
        for (p, label) in labels.iter().enumerate() {
            let chosen = s.forced_choice() == Some(p);
            let key = if p == 0 { "a" } else { "b" };
            lines.push(Line::from(vec![
                Span::styled(format!(" {key} "), if chosen { theme::selected() } else { theme::key() }),
                Span::raw(format!(" {label}{}", if chosen { "   ← chosen" } else { "" })),
            ]));
        }
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
