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

/// The belief panel's narrowest useful width: a side column narrower than this puts the
/// instruction on top, at the whole width.
const SIDE_MIN_WIDTH: u16 = 40;

/// The belief panel's width with short names (component, prior, mean, interval).
const BELIEF_COMPACT_WIDTH: u16 = 34;

/// A grip's label as this session's participant experiences it (their left, their right).
pub fn grip_label(session: &Session, label: &str) -> String {
    session.study().arm.side.experienced(label)
}

/// The grasp panel's width: its widest line (key, label, id) and its borders.
fn grasp_width(session: &Session, v: &TrialView) -> u16 {
    let q = session.query(v.query);
    let object = session.study().object(q);
    let widest = q.regions.iter().map(|&r| {
        4 + grip_label(session, &object.regions[r].label).chars().count() + 2 + object.regions[r].id.chars().count()
    });
    (widest.chain([theme::GRASP.chars().count()]).max().unwrap_or(0) + 2) as u16
}

pub fn render(app: &App, frame: &mut Frame, area: Rect) {
    let Some(session) = app.session() else { return };
    let (view, awaiting_grasp) = match session.prompt() {
        Prompt::Present(v) => (v, false),
        Prompt::Grasp(v) => (v, true),
        _ => return,
    };
    // The instruction has priority: its panel is as wide and tall as its lines, at every size
    // the console accepts; the grasp, history and belief share what is left. Once the object
    // is presented, where the robot holds it matters no more: on a short screen the panel
    // keeps the object and the pose, and the history gets the rows.
    let detail = !awaiting_grasp || area.height >= DETAILED_HEIGHT;
    let lines = instruction_lines(session, &view, awaiting_grasp, detail, robot_line(app, session));
    let instr_w = lines.iter().map(Line::width).max().unwrap_or(0) as u16 + 2;
    let side_by_side = area.width >= instr_w + SIDE_MIN_WIDTH;
    // Stacked, a line longer than the screen (a long label) wraps: the panel grows for it.
    let wrap_w = if side_by_side { instr_w } else { area.width };
    let instr_h = super::rows_of(&lines, wrap_w.saturating_sub(2) as usize) as u16 + 2;
    let grasp_h = session.query(view.query).regions.len() as u16 + 3;
    let (instr, grasp, history, side) = if side_by_side {
        let left_w = instr_w.max(area.width * 58 / 100);
        let [left, right] = Layout::horizontal([Constraint::Length(left_w), Constraint::Min(0)]).areas(area);
        let [instr, grasp, history] =
            Layout::vertical([Constraint::Length(instr_h), Constraint::Length(grasp_h), Constraint::Min(3)])
                .areas(left);
        (instr, grasp, history, right)
    } else {
        let [instr, rest] = Layout::vertical([Constraint::Length(instr_h), Constraint::Min(0)]).areas(area);
        // The grips are keyed from: their column is as wide as their lines (the belief keeps
        // at least its compact width).
        let grasp_w =
            grasp_width(session, &view).max(area.width / 2).min(area.width.saturating_sub(BELIEF_COMPACT_WIDTH));
        let [left, right] = Layout::horizontal([Constraint::Length(grasp_w), Constraint::Min(0)]).areas(rest);
        let [grasp, history] = Layout::vertical([Constraint::Length(grasp_h), Constraint::Min(3)]).areas(left);
        (instr, grasp, history, right)
    };
    frame.render_widget(
        Paragraph::new(lines).wrap(Wrap { trim: false }).block(Block::bordered().title(phase_title(session, &view))),
        instr,
    );
    grasp_prompt(session, &view, awaiting_grasp, frame, grasp);
    history_panel(session, &view, frame, history);
    if view.phase == Phase::Training {
        belief_panel(app, session, view.program.unwrap_or(0), frame, side);
    } else {
        let text = vec![
            Line::from("Test phase: no learning."),
            Line::from("Each object at each test pose once,"),
            Line::from("in this participant's shuffled order."),
        ];
        frame.render_widget(
            Paragraph::new(text).wrap(Wrap { trim: false }).block(Block::bordered().title(" Test ")),
            side,
        );
    }
}

pub fn phase_title(session: &Session, v: &TrialView) -> String {
    match v.program {
        Some(p) => format!(" Training · {} · trial {}/{} ", session.start().program_labels[p], v.trial, v.of),
        None => format!(" Test · trial {}/{} ", v.trial, v.of),
    }
}

/// What the robot is doing about this trial (none without a robot).
fn robot_line(app: &App, session: &Session) -> Option<Line<'static>> {
    let robot = app.robot()?;
    Some(robot_status(session, robot.elapsed(), "not sent yet: s sends the pose"))
}

/// The robot's line of the instruction: what was sent and last reported, `unsent` before
/// anything is sent; `since` the time since it was sent, when known.
pub fn robot_status(session: &Session, since: Option<std::time::Duration>, unsent: &str) -> Line<'static> {
    let (text, style) = match session.robot() {
        None => (unsent.to_string(), theme::key()),
        Some(t) => {
            let secs = since.map_or(String::new(), |d| format!(", {:.1} s", d.as_secs_f64()));
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

/// The height from which a presented trial keeps its instruction in full.
const DETAILED_HEIGHT: u16 = 34;

/// The robot operator's instruction: the object and the pose, and with `detail` where (the
/// object's centre, in the participant's shoulder frame) and how it is turned, whose hand and
/// whose left. Shared by the console and `handover follow`.
pub fn instruction_lines(
    session: &Session,
    v: &TrialView,
    done: bool,
    detail: bool,
    robot: Option<Line<'static>>,
) -> Vec<Line<'static>> {
    let q = session.query(v.query);
    let object = session.study().object(q);
    let [x, y, z] = q.pose.position;
    let [r, p, yaw] = q.pose.rpy_deg;
    let side = session.study().arm.side;
    let mut lines = vec![
        Line::from(Span::styled(theme::PRESENT, if done { theme::dim() } else { theme::instruction() })),
        Line::from(vec![
            Span::styled(format!("  {}", object.label), theme::title()),
            Span::raw(format!("  (query {})", q.query.id)),
        ]),
        Line::from(format!("  pose         {}", side.experienced(&q.query.label))),
    ];
    if detail {
        lines.extend([
            Line::from(format!("  position     x {x:+.3}  y {y:+.3}  z {z:+.3} m, of the object's centre")),
            Line::from(format!("  orientation  roll {r:+.1}°  pitch {p:+.1}°  yaw {yaw:+.1}°")),
            Line::from(format!("  frame        {}", theme::frame_of(side))),
            Line::from(format!("  hand         {}", theme::hand_sides(side))),
            Line::from(format!("  left, right  {}", theme::whose_left(side))),
        ]);
    }
    lines.extend(robot);
    lines.push(Line::from(Span::styled(
        if done { "Presented." } else { theme::PRESENT_DONE },
        if done { theme::dim() } else { theme::instruction() },
    )));
    lines
}

fn grasp_prompt(session: &Session, v: &TrialView, active: bool, frame: &mut Frame, area: Rect) {
    let q = session.query(v.query);
    let object = session.study().object(q);
    let mut lines =
        vec![Line::from(Span::styled(theme::GRASP, if active { theme::instruction() } else { theme::dim() }))];
    for (k, &r) in q.regions.iter().enumerate() {
        lines.push(Line::from(vec![
            Span::styled(format!(" {} ", k + 1), if active { theme::key() } else { theme::dim() }),
            Span::raw(format!(" {}  ", grip_label(session, &object.regions[r].label))),
            Span::styled(object.regions[r].id.clone(), theme::dim()),
        ]));
    }
    frame.render_widget(Paragraph::new(lines).block(Block::bordered().title(" Grasp ")), area);
}

/// The phase's trials so far, each voided presentation (with its reason) before the trial it
/// was repeated as.
fn history_panel(session: &Session, v: &TrialView, frame: &mut Frame, area: Rect) {
    // Narrow: the grip (or the void's reason) only; the query's id needs the width.
    let with_query = area.width >= 62;
    // The last column: the panel less its borders, the other columns and their spacing.
    let what_w = (area.width as usize).saturating_sub(2 + 3 + 1 + if with_query { 22 + 1 } else { 0 });
    let row = |trial: usize, query: &str, what: String| {
        let mut cells = vec![trial.to_string()];
        if with_query {
            cells.push(super::fit(query, 22));
        }
        cells.push(super::fit(&what, what_w));
        Row::new(cells)
    };
    let mut rows: Vec<(usize, usize, Row)> = session
        .trials()
        .iter()
        .filter(|t| t.phase == v.phase && t.run == v.program)
        .map(|t| {
            let q = session.query(t.query);
            let region = grip_label(session, &session.study().object(q).regions[q.regions[t.region]].label);
            (t.trial, 1, row(t.trial, &q.query.id, region))
        })
        .collect();
    rows.extend(session.voids().iter().filter(|x| x.phase == v.phase && x.run == v.program).map(|x| {
        let q = session.query(x.query);
        let why = if x.detail.is_empty() {
            format!("voided: {}", x.reason.label())
        } else {
            format!("voided: {} — {}", x.reason.label(), x.detail)
        };
        (x.trial, 0, row(x.trial, &q.query.id, why).style(theme::dim()))
    }));
    // Stable: voids of a trial in the order they happened, before the trial's grasp.
    rows.sort_by_key(|(trial, kind, _)| (*trial, *kind));
    let n = rows.len();
    let skip = n.saturating_sub(area.height.saturating_sub(3) as usize);
    let (widths, header) = if with_query {
        (vec![Constraint::Length(3), Constraint::Length(22), Constraint::Fill(1)], vec!["#", "query", "grip taken"])
    } else {
        (vec![Constraint::Length(3), Constraint::Fill(1)], vec!["#", "grip taken"])
    };
    // The rows that do not fit are the earliest; the title counts them.
    let title = match skip {
        0 => " History of this phase ".to_string(),
        n => format!(" History of this phase · {n} earlier "),
    };
    let title = super::fit(&title, (area.width as usize).saturating_sub(2));
    let table = Table::new(rows.into_iter().skip(skip).map(|(_, _, row)| row), widths)
        .header(Row::new(header).style(theme::title()))
        .block(Block::bordered().title(title));
    frame.render_widget(table, area);
}

/// Pairs of learned components shown by the particle view (Tab cycles).
fn joint_pairs(free: &[usize]) -> Vec<(usize, usize)> {
    if free.len() < 2 {
        return vec![(free.first().copied().unwrap_or(0), free.first().copied().unwrap_or(0))];
    }
    free.chunks(2).map(|c| if c.len() == 2 { (c[0], c[1]) } else { (free[0], c[0]) }).collect()
}

/// A component of λ as every screen and table numbers it: q*1 … q*7, w1 … w7 (1-based).
fn component_name(c: usize) -> String {
    if c < 7 { format!("q*{} {}", c + 1, JOINT_NAMES[c]) } else { format!("w{} {}", c - 6, JOINT_NAMES[c - 7]) }
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
    let last = learner.entropies.last().copied().unwrap_or(0.0);
    let inner_h = area.height.saturating_sub(2);
    let inner_w = area.width.saturating_sub(2);
    // A short panel gives up the sparkline (the entropy goes to the bottom border), then the
    // particles, then the table's last rows (counted there); a narrow one names the
    // components by their symbol only.
    let n_rows = free.len().min(7);
    let rows_wanted = n_rows as u16 + 1;
    let spark_h = if inner_h >= rows_wanted + 3 + 4 { 3 } else { 0 };
    let table_h = rows_wanted.min(inner_h.saturating_sub(spark_h));
    let shown_rows = (table_h as usize).saturating_sub(1).min(n_rows);
    let mut bottom = if spark_h == 0 { format!(" entropy {last:.2} nats ") } else { String::new() };
    if shown_rows < n_rows {
        let hidden = n_rows - shown_rows;
        bottom.push_str(&format!("· {hidden} {} hidden ", if hidden == 1 { "row" } else { "rows" }));
    }
    let room = (area.width as usize).saturating_sub(2);
    let outer = Block::bordered().title(super::fit(&block_title, room)).title_bottom(super::fit(&bottom, room));
    let inner = outer.inner(area);
    frame.render_widget(outer, area);
    let [spark_area, table_area, canvas_area] =
        Layout::vertical([Constraint::Length(spark_h), Constraint::Length(table_h), Constraint::Min(0)]).areas(inner);
    if spark_h > 0 {
        let scale = 1000.0;
        let data: Vec<u64> = learner.entropies.iter().map(|h| (h * scale).max(0.0) as u64).collect();
        frame.render_widget(
            Sparkline::default()
                .data(&data)
                .style(Style::new().fg(Color::Magenta))
                .block(Block::new().title(format!("entropy per iteration (now {last:.2} nats)"))),
            spark_area,
        );
    }
    let compact = inner_w < 44;
    // The posterior mean and its 90 % credible interval against the prior's range.
    let summary = &learner.summary;
    let (mean, low, high) = (summary.mean.to_vec(), summary.ci_low.to_vec(), summary.ci_high.to_vec());
    let rows: Vec<Row> = free
        .iter()
        .take(shown_rows)
        .map(|&c| {
            let (lo, hi) = supports[c];
            Row::new(vec![
                if compact { short(c) } else { component_name(c) },
                format!("{:.0}…{:.0}", shown(c, lo), shown(c, hi)),
                format!("{:+.1}", shown(c, mean[c])),
                format!("{:.0}…{:.0}", shown(c, low[c]), shown(c, high[c])),
            ])
        })
        .collect();
    let name_w = if compact { Constraint::Length(4) } else { Constraint::Min(14) };
    frame.render_widget(
        Table::new(rows, [name_w, Constraint::Length(9), Constraint::Length(6), Constraint::Length(9)]).header(
            Row::new(vec![if compact { "λ" } else { "learned (q*: deg)" }, "prior", "mean", "90% CI"])
                .style(theme::title()),
        ),
        table_area,
    );
    if canvas_area.height < 4 {
        return;
    }
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
    if c < 7 { format!("q*{}", c + 1) } else { format!("w{}", c - 6) }
}
