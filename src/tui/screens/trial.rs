//! The trial screen: the robot operator's instruction, the grasp prompt, the phase's
//! history, and (in training) the belief.

use ratatui::Frame;
use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::style::{Color, Style};
use ratatui::symbols::Marker;
use ratatui::text::{Line, Span};
use ratatui::widgets::canvas::{Canvas, Points};
use ratatui::widgets::{Block, Paragraph, Row, Sparkline, Table, Wrap};

use crate::kinematics::JOINT_NAMES;
use crate::session::{Phase, Prompt, RobotState, Session, TrialView};
use crate::tui::app::App;
use crate::tui::theme;

pub fn render(app: &App, frame: &mut Frame, area: Rect) {
    let Some(session) = app.session() else { return };
    let (view, awaiting_grasp) = match session.prompt() {
        Prompt::Present(v) => (v, false),
        Prompt::Grasp(v) => (v, true),
        _ => return,
    };
    let [left, right] = Layout::horizontal([Constraint::Percentage(58), Constraint::Percentage(42)]).areas(area);
    let [instr, grasp, history] =
        Layout::vertical([Constraint::Length(11), Constraint::Length(6), Constraint::Min(3)]).areas(left);
    instruction(session, &view, awaiting_grasp, robot_line(app, session), frame, instr);
    grasp_prompt(session, &view, awaiting_grasp, frame, grasp);
    history_panel(session, &view, frame, history);
    if view.phase == Phase::Training {
        belief_panel(app, session, view.program.unwrap_or(0), frame, right);
    } else {
        let text = vec![
            Line::from("Test phase: no learning."),
            Line::from("Each object at each test pose once,"),
            Line::from("in this participant's shuffled order."),
        ];
        frame.render_widget(Paragraph::new(text).block(Block::bordered().title(" Test ")), right);
    }
}

fn phase_title(session: &Session, v: &TrialView) -> String {
    match v.program {
        Some(p) => format!(" Training · {} · trial {}/{} ", session.start().program_labels[p], v.trial, v.of),
        None => format!(" Test · trial {}/{} ", v.trial, v.of),
    }
}

/// What the robot is doing about this trial (a blank line without a robot).
fn robot_line(app: &App, session: &Session) -> Line<'static> {
    let Some(robot) = app.robot() else { return Line::from("") };
    let (text, style) = match session.robot() {
        None => ("not sent yet: s sends the pose".to_string(), theme::key()),
        Some(t) => {
            let secs = robot.elapsed().map_or(String::new(), |d| format!(", {:.1} s", d.as_secs_f64()));
            match &t.last {
                None => (format!("sent (attempt {}{secs}), no answer yet", t.attempts), Style::default()),
                // The detail is in the status line: this line keeps to the panel's width.
                Some((state, _)) => {
                    let style = match state {
                        RobotState::Failed | RobotState::Timeout => theme::warning(),
                        _ => Style::default(),
                    };
                    (format!("{} (attempt {}{secs})", state.name(), t.attempts), style)
                }
            }
        }
    };
    Line::from(vec![Span::raw("  robot        "), Span::styled(text, style)])
}

fn instruction(session: &Session, v: &TrialView, done: bool, robot: Line<'static>, frame: &mut Frame, area: Rect) {
    let q = session.query(v.query);
    let object = session.study().object(q);
    let [x, y, z] = q.pose.position;
    let [r, p, yaw] = q.pose.rpy_deg;
    let side = session.study().arm.side;
    let lines = vec![
        Line::from(Span::styled(theme::PRESENT, if done { theme::dim() } else { theme::instruction() })),
        Line::from(vec![
            Span::styled(format!("  {}", object.label), theme::title()),
            Span::raw(format!("  (query {})", q.query.id)),
        ]),
        Line::from(format!("  pose: {}", q.query.label)),
        Line::from(format!("  position     x {x:+.3}  y {y:+.3}  z {z:+.3} m")),
        Line::from(format!("  orientation  roll {r:+.1}°  pitch {p:+.1}°  yaw {yaw:+.1}°")),
        Line::from(format!("  frame        {} shoulder (x forward, y left, z up)", side.name())),
        Line::from(format!("  hand         {}", theme::hand_sides(side))),
        robot,
        Line::from(Span::styled(
            if done { "Presented." } else { theme::PRESENT_DONE },
            if done { theme::dim() } else { theme::instruction() },
        )),
    ];
    frame.render_widget(
        Paragraph::new(lines).wrap(Wrap { trim: false }).block(Block::bordered().title(phase_title(session, v))),
        area,
    );
}

fn grasp_prompt(session: &Session, v: &TrialView, active: bool, frame: &mut Frame, area: Rect) {
    let q = session.query(v.query);
    let object = session.study().object(q);
    let mut lines =
        vec![Line::from(Span::styled(theme::GRASP, if active { theme::instruction() } else { theme::dim() }))];
    for (k, &r) in q.regions.iter().enumerate() {
        lines.push(Line::from(vec![
            Span::styled(format!(" {} ", k + 1), if active { theme::key() } else { theme::dim() }),
            Span::raw(format!(" {}", object.regions[r].label)),
        ]));
    }
    frame.render_widget(Paragraph::new(lines).block(Block::bordered().title(" Grasp ")), area);
}

/// The phase's trials so far, each voided presentation (with its reason) before the trial it
/// was repeated as.
fn history_panel(session: &Session, v: &TrialView, frame: &mut Frame, area: Rect) {
    let mut rows: Vec<(usize, usize, Row)> = session
        .trials()
        .iter()
        .filter(|t| t.phase == v.phase && t.run == v.program)
        .map(|t| {
            let q = session.query(t.query);
            let region = &session.study().object(q).regions[q.regions[t.region]].label;
            (t.trial, 1, Row::new(vec![t.trial.to_string(), q.query.id.clone(), region.clone()]))
        })
        .collect();
    rows.extend(session.voids().iter().filter(|x| x.phase == v.phase && x.run == v.program).map(|x| {
        let q = session.query(x.query);
        let why = if x.detail.is_empty() {
            format!("voided: {}", x.reason.label())
        } else {
            format!("voided: {} — {}", x.reason.label(), x.detail)
        };
        (x.trial, 0, Row::new(vec![x.trial.to_string(), q.query.id.clone(), why]).style(theme::dim()))
    }));
    // Stable: voids of a trial in the order they happened, before the trial's grasp.
    rows.sort_by_key(|(trial, kind, _)| (*trial, *kind));
    let n = rows.len();
    let skip = n.saturating_sub(area.height.saturating_sub(3) as usize);
    let table = Table::new(
        rows.into_iter().skip(skip).map(|(_, _, row)| row),
        [Constraint::Length(4), Constraint::Length(22), Constraint::Min(10)],
    )
    .header(Row::new(vec!["#", "query", "grip taken"]).style(theme::title()))
    .block(Block::bordered().title(" History of this phase "));
    frame.render_widget(table, area);
}

/// Pairs of learned components shown by the particle view (Tab cycles).
fn joint_pairs(free: &[usize]) -> Vec<(usize, usize)> {
    if free.len() < 2 {
        return vec![(free.first().copied().unwrap_or(0), free.first().copied().unwrap_or(0))];
    }
    free.chunks(2).map(|c| if c.len() == 2 { (c[0], c[1]) } else { (free[0], c[0]) }).collect()
}

fn component_name(c: usize) -> String {
    if c < 7 { format!("q*{} {}", c, JOINT_NAMES[c]) } else { format!("w{} {}", c - 7, JOINT_NAMES[c - 7]) }
}

fn shown(c: usize, v: f64) -> f64 {
    if c < 7 { v.to_degrees() } else { v }
}

fn belief_panel(app: &App, session: &Session, run: usize, frame: &mut Frame, area: Rect) {
    let learner = &session.learners()[run];
    let belief = &learner.belief;
    let supports = belief.support();
    let free = belief.free().to_vec();
    let block_title = format!(" Belief · {} · iteration {} ", session.start().program_labels[run], learner.iteration);
    let outer = Block::bordered().title(block_title);
    let inner = outer.inner(area);
    frame.render_widget(outer, area);
    let [spark_area, table_area, canvas_area] =
        Layout::vertical([Constraint::Length(3), Constraint::Length(free.len().min(7) as u16 + 1), Constraint::Min(4)])
            .areas(inner);
    let scale = 1000.0;
    let data: Vec<u64> = learner.entropies.iter().map(|h| (h * scale).max(0.0) as u64).collect();
    let last = learner.entropies.last().copied().unwrap_or(0.0);
    frame.render_widget(
        Sparkline::default()
            .data(&data)
            .style(Style::new().fg(Color::Magenta))
            .block(Block::new().title(format!("entropy per iteration (now {last:.2} nats)"))),
        spark_area,
    );
    // The posterior mean and its 90 % credible interval against the prior's range.
    let summary = &learner.summary;
    let (mean, low, high) = (summary.mean.to_vec(), summary.ci_low.to_vec(), summary.ci_high.to_vec());
    let rows: Vec<Row> = free
        .iter()
        .take(7)
        .map(|&c| {
            let (lo, hi) = supports[c];
            Row::new(vec![
                component_name(c),
                format!("{:.0}…{:.0}", shown(c, lo), shown(c, hi)),
                format!("{:+.1}", shown(c, mean[c])),
                format!("{:.0}…{:.0}", shown(c, low[c]), shown(c, high[c])),
            ])
        })
        .collect();
    frame.render_widget(
        Table::new(rows, [Constraint::Min(14), Constraint::Length(9), Constraint::Length(6), Constraint::Length(9)])
            .header(Row::new(vec!["learned (deg)", "prior", "mean", "90% CI"]).style(theme::title())),
        table_area,
    );
    let pairs = joint_pairs(&free);
    let (a, b) = pairs[app.joint_pair % pairs.len()];
    let pts: Vec<(f64, f64)> =
        (0..belief.len()).map(|i| (shown(a, belief.particle(i)[a]), shown(b, belief.particle(i)[b]))).collect();
    let (xa, xb) = (shown(a, supports[a].0), shown(a, supports[a].1));
    let (ya, yb) = (shown(b, supports[b].0), shown(b, supports[b].1));
    let canvas = Canvas::default()
        .block(Block::new().title(format!("particles: {} × {} (Tab)", short(a), short(b))))
        .marker(Marker::Braille)
        .x_bounds([xa, xb])
        .y_bounds([ya, yb])
        .paint(move |ctx| {
            ctx.draw(&Points { coords: &pts, color: Color::Cyan });
        });
    frame.render_widget(canvas, canvas_area);
}

fn short(c: usize) -> String {
    if c < 7 { format!("q*{c}") } else { format!("w{}", c - 7) }
}
