//! The summary: test log-likelihood per iteration and condition, objects chosen, the log.
//! Only here are the conditions un-blinded.

use ratatui::Frame;
use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Paragraph, Row, Table, Wrap};

use crate::session::program_letter;
use crate::tui::app::{App, SummaryView};
use crate::tui::theme;

pub fn render(_app: &App, view: &SummaryView, frame: &mut Frame, area: Rect) {
    let [top, table_area, objects] =
        Layout::vertical([Constraint::Length(4), Constraint::Length(6), Constraint::Min(3)]).areas(area);
    let mut lines = vec![Line::from(Span::styled(
        if view.completed { "Session complete." } else { "Session aborted." },
        theme::title(),
    ))];
    lines.push(Line::from(format!("Log: {}", view.log_path.display())));
    if let Some(e) = &view.error {
        lines.push(Line::from(Span::styled(format!("Analysis failed: {e}"), theme::warning())));
    }
    frame.render_widget(
        Paragraph::new(lines).wrap(Wrap { trim: false }).block(Block::bordered().title(" Summary ")),
        top,
    );
    let Some(a) = &view.analysis else { return };
    let iterations = a.runs.iter().map(|r| r.test_ll_estimate.len()).max().unwrap_or(0);
    let mut header = vec!["program = condition".to_string()];
    header.extend((0..iterations).map(|i| format!("it {i}")));
    let rows: Vec<Row> = a
        .runs
        .iter()
        .map(|r| {
            let mut cells = vec![format!("{} = {}", a.start.program_labels[r.program], r.condition)];
            cells.extend(r.test_ll_estimate.iter().map(|v| format!("{v:.1}")));
            Row::new(cells)
        })
        .collect();
    // The label column as wide as its longest cell; the iterations share the rest (at
    // least 6 columns each: "-123.4").
    let label_w =
        (a.runs.iter().map(|r| format!("{} = {}", a.start.program_labels[r.program], r.condition).chars().count()))
            .chain(std::iter::once(header[0].chars().count()))
            .max()
            .unwrap_or(0) as u16;
    let mut widths = vec![Constraint::Length(label_w)];
    widths.extend((0..iterations).map(|_| Constraint::Min(6)));
    frame.render_widget(
        Table::new(rows, widths).header(Row::new(header).style(theme::title())).block(
            Block::bordered().title(" Test-set log-likelihood of the posterior mean after each training iteration "),
        ),
        table_area,
    );
    let mut lines = Vec::new();
    for r in &a.runs {
        let objects: Vec<&str> = r.trials.iter().map(|t| t.object.as_str()).collect();
        lines.push(Line::from(format!(
            "Program {} ({}): {}",
            program_letter(r.program),
            r.condition,
            objects.join(", ")
        )));
    }
    frame.render_widget(
        Paragraph::new(lines)
            .wrap(Wrap { trim: false })
            .block(Block::bordered().title(" Objects each condition chose ")),
        objects,
    );
}
