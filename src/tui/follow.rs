//! `handover follow LOG`: a read-only screen for a second terminal (the robot operator's)
//! that follows the live log and shows only what the robot must do now, large, with the
//! robot's status when a robot is in the loop. It reads the log; it never writes or locks.

use std::time::Duration;

use ratatui::Frame;
use ratatui::crossterm::event::{KeyCode, KeyEvent, KeyEventKind};
use ratatui::layout::{Constraint, Layout};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Paragraph, Wrap};

use super::screens::trial::{instruction_lines, phase_title, robot_status};
use super::theme;
use crate::record::Follower;
use crate::session::{Prompt, Session};

/// How often the log is looked at.
pub const POLL: Duration = Duration::from_millis(200);

/// The followed log and what became of the last look at it.
pub struct FollowView {
    pub follower: Follower,
    /// Why the last look failed (the screen keeps the last good state).
    pub error: Option<String>,
    pub now_ns: u64,
    /// Whether the console that holds the participant's session still runs (from the
    /// session lock's holder); `None` when there is nothing to ask.
    pub console: Option<bool>,
}

impl FollowView {
    pub fn new(follower: Follower) -> Self {
        Self { follower, error: None, now_ns: 0, console: None }
    }

    /// Looks at the log again.
    pub fn tick(&mut self, now_ns: u64) {
        self.now_ns = now_ns;
        match self.follower.poll() {
            Ok(_) => self.error = None,
            Err(e) => self.error = Some(e.to_string()),
        }
        self.console = self.follower.path().parent().and_then(crate::study_dir::holder_running);
    }

    /// The console ended without closing its log (a crash, `kill -9`, a power cut): what
    /// the screen shows is no longer what the console has reached.
    pub(crate) fn console_lost(&self) -> bool {
        self.console == Some(false)
            && !self.follower.closed()
            && !matches!(self.follower.session().prompt(), Prompt::Done { .. })
    }
}

/// Whether a key leaves the follower (q, Esc, Ctrl+C).
pub fn quits(k: KeyEvent) -> bool {
    k.kind != KeyEventKind::Release
        && (matches!(k.code, KeyCode::Char('q') | KeyCode::Esc)
            || (k.code == KeyCode::Char('c') && k.modifiers.contains(ratatui::crossterm::event::KeyModifiers::CONTROL)))
}

pub fn render(view: &FollowView, frame: &mut Frame) {
    let area = frame.area();
    let [top, body, status, keys] =
        Layout::vertical([Constraint::Length(1), Constraint::Min(0), Constraint::Length(1), Constraint::Length(1)])
            .areas(area);
    let session = view.follower.session();
    let name = view.follower.path().file_name().map_or(String::new(), |n| n.to_string_lossy().into_owned());
    frame.render_widget(
        Paragraph::new(Line::from(vec![
            Span::styled(format!(" {} follow ", theme::APP), theme::title()),
            Span::raw(format!("— participant {} — read-only", session.start().participant)),
        ])),
        top,
    );
    let (title, lines) = now(view, session);
    // Large: the lines spaced out when the screen has room for it.
    let spaced =
        super::screens::spaced(lines, body.height.saturating_sub(2) as usize, body.width.saturating_sub(2) as usize);
    frame.render_widget(Paragraph::new(spaced).wrap(Wrap { trim: false }).block(Block::bordered().title(title)), body);
    let message = match (&view.error, view.follower.last_event_ns()) {
        (Some(e), _) => Span::styled(format!("Cannot read the log now: {e}"), theme::warning()),
        (None, Some(t)) => {
            Span::raw(format!("Following {name}; last event {} s ago", view.now_ns.saturating_sub(t) / 1_000_000_000))
        }
        (None, None) => Span::raw(format!("Following {name}; no event yet")),
    };
    frame.render_widget(Paragraph::new(Line::from(message)).wrap(Wrap { trim: false }), status);
    frame.render_widget(
        Paragraph::new(Line::from(vec![
            Span::styled(" q ", theme::key()),
            Span::raw(" quit (the session is not affected)"),
        ])),
        keys,
    );
}

/// The panel's title and lines for what the session waits for now.
fn now(view: &FollowView, session: &Session) -> (String, Vec<Line<'static>>) {
    // One rule whenever no console runs the session, whether it was lost (a crash, `kill -9`)
    // or left it (a quit, a signal): no pose, since the last one shown may already be past
    // and no one confirms the next.
    let left = view.follower.closed() && !matches!(session.prompt(), Prompt::Done { .. });
    if view.console_lost() || left {
        let log = view.follower.path().display().to_string();
        let (title, headline) = if left {
            (" Console left ", "THE CONSOLE LEFT THE SESSION — do not move the robot.")
        } else {
            (" Console lost ", "THE CONSOLE HAS STOPPED — do not move the robot.")
        };
        // Where it stopped, without the pose.
        let at = match session.prompt() {
            Prompt::Present(v) | Prompt::Grasp(v) => {
                format!("It stopped at {}; that instruction is no longer current.", phase_title(session, &v).trim())
            }
            _ => "Its last instruction is no longer current.".to_string(),
        };
        return (
            title.into(),
            vec![
                Line::from(Span::styled(headline, theme::warning())),
                Line::from(Span::raw(at)),
                Line::from(Span::raw(format!(
                    "The experimenter resumes the session: handover resume {}",
                    crate::text::printable(&log)
                ))),
                Line::from(Span::raw("This screen follows the continuation as soon as it starts.")),
            ],
        );
    }
    let robot = view.follower.last_robot_command_ns().map(|t| {
        let since = session.robot().map(|_| Duration::from_nanos(view.now_ns.saturating_sub(t)));
        robot_status(session, since, "not sent yet")
    });
    let (title, lines) = match session.prompt() {
        // Until the experimenter has told the participant what comes next, the next pose is
        // not shown: the robot stays where it is.
        Prompt::Present(_) if session.transition().is_some() => (
            " Between phases ".into(),
            vec![
                Line::from(Span::styled("WAIT — do not move the robot yet.", theme::warning())),
                Line::from(Span::raw("The experimenter is telling the participant what comes next;")),
                Line::from(Span::raw("the next pose appears here once they go on.")),
            ],
        ),
        Prompt::Present(v) => {
            let mut lines = instruction_lines(session, &v, false, true, robot);
            // The experimenter confirms it, on the console.
            lines.pop();
            lines.push(Line::from(Span::styled(theme::FOLLOW_PRESENT_DONE, theme::instruction())));
            (phase_title(session, &v), lines)
        }
        Prompt::Grasp(v) => {
            let mut lines = instruction_lines(session, &v, true, true, robot);
            lines.push(Line::from(Span::styled("The participant is taking the object.", theme::instruction())));
            (phase_title(session, &v), lines)
        }
        Prompt::Paused => {
            (" Paused ".into(), vec![Line::from(Span::styled("PAUSED — wait for the experimenter", theme::warning()))])
        }
        Prompt::Likert { .. } | Prompt::ForcedChoice | Prompt::Finish => (
            " Questionnaire ".into(),
            vec![Line::from(Span::styled("The questionnaire: the robot is not needed.", theme::instruction()))],
        ),
        Prompt::Done { completed } => (
            " Over ".into(),
            vec![Line::from(Span::styled(
                if completed { "The session is complete." } else { "The session was ended early." },
                theme::title(),
            ))],
        ),
    };
    (title, lines)
}
