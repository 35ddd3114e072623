//! The setup screen: protocol, participant, blinded order, seed, log path.

use ratatui::Frame;
use ratatui::layout::Rect;
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Paragraph, Wrap};

use crate::tui::app::App;
use crate::tui::theme;

pub fn render(app: &App, frame: &mut Frame, area: Rect) {
    let study = &app.config.study;
    let p = &study.protocol;
    let can_start = app.plan.as_ref().is_some_and(|p| p.error.is_none());
    // What to do comes first: the rest may be cut on a small terminal, never this.
    let mut lines = vec![Line::from(Span::styled(
        if can_start {
            "Press Enter to start the session."
        } else if app.config.simulate {
            "The session cannot start; q quits."
        } else {
            "The session cannot start: e enters another participant id ('new' for a new one), q quits."
        },
        if can_start { theme::instruction() } else { theme::warning() },
    ))];
    if let Some(e) = app.plan.as_ref().and_then(|p| p.error.as_ref()) {
        lines.push(Line::from(Span::styled(format!("Cannot start: {e}"), theme::warning())));
    }
    match &app.plan {
        Some(plan) => {
            let who = if plan.simulated.is_some() {
                format!("{} (simulated participant — rehearsal, logged as pilot)", plan.start.participant)
            } else if plan.new_record.is_some() {
                format!("{} (new; created when the session starts)", plan.start.participant)
            } else if plan.error.is_some() {
                format!("{} (cannot be used: see above)", plan.start.participant)
            } else if plan.start.pilot {
                format!("{} (pilot with a person: no record, logged as pilot)", plan.start.participant)
            } else {
                format!("{} (existing record)", plan.start.participant)
            };
            lines.push(Line::from(vec![Span::styled("Participant: ", theme::title()), Span::raw(who)]));
            let s = &plan.study;
            lines.push(Line::from(vec![
                Span::styled("Hand: ", theme::title()),
                Span::raw(format!("the participant's {}", theme::hand_sides(s.arm.side))),
            ]));
            lines.push(Line::from(format!(
                "  arm {:.2} + {:.2} + {:.2} m (upper arm, forearm, hand); poses ×{:.3}{}",
                s.arm.upper_arm,
                s.arm.forearm,
                s.arm.hand,
                s.pose_scale(),
                s.protocol
                    .pose_scaling
                    .map_or(String::new(), |p| format!(" of the protocol's {} m body", p.reference_body_height_m))
            )));
            let order: Vec<String> = (plan.start.condition_order.iter().enumerate())
                .map(|(i, c)| format!("{} = {}", plan.start.program_labels[i], c.name()))
                .collect();
            lines.push(Line::from(vec![
                Span::styled(
                    format!("Order (slot {}; the experimenter's view only): ", plan.start.slot),
                    theme::title(),
                ),
                Span::raw(order.join(", ")),
            ]));
            lines
                .push(Line::from(vec![Span::styled("Seed: ", theme::title()), Span::raw(plan.start.seed.to_string())]));
            lines.push(Line::from(vec![
                Span::styled("Log: ", theme::title()),
                Span::raw(plan.log_path.display().to_string()),
            ]));
            lines.push(Line::from(vec![
                Span::styled("Study folders: ", theme::title()),
                Span::styled(plan.folders.clone(), if plan.new_folders { theme::warning() } else { theme::dim() }),
            ]));
            if let Some(balance) = &plan.balance {
                lines.push(Line::from(vec![Span::styled("Study: ", theme::title()), Span::raw(balance.clone())]));
            }
            if plan.new_folders {
                lines.push(Line::from(Span::styled(
                    "  New study folders: counterbalancing starts afresh. Is this the study directory you meant?",
                    theme::warning(),
                )));
            }
        }
        None => lines.push(Line::from("No plan")),
    }
    let robot = app.robot().map_or_else(
        || "none: the operator commands it by hand".to_string(),
        |r| format!("{} (presented on {})", r.describe(), r.settings.present_on.name()),
    );
    lines.push(Line::from(vec![Span::styled("Robot: ", theme::title()), Span::raw(robot)]));
    if app.config.study.protocol.learning.observation == crate::protocol::ObservationModel::Measured {
        let measuring = match (app.arm(), app.config.simulate) {
            (Some(arm), _) => arm.describe(),
            (None, true) => "simulated: the participant's configuration with the protocol's noise".to_string(),
            (None, false) => "none (--measure ros2 subscribes to a measuring system): every grasp learns from the handle taken, logged as the fallback".to_string(),
        };
        lines.push(Line::from(vec![Span::styled("Arm measurement: ", theme::title()), Span::raw(measuring)]));
    }
    lines.push(Line::from(vec![Span::styled("Protocol: ", theme::title()), Span::raw(p.name.clone())]));
    lines.push(Line::from(format!(
        "  {} training queries, {} test queries; {} training trials per program; {} particles, α = {}",
        study.training.len(),
        study.test.len(),
        p.session.trials_per_condition,
        p.learning.particles,
        p.learning.alpha
    )));
    // The description takes the rows left, cut with an ellipsis when it does not fit.
    let width = area.width.saturating_sub(2) as usize;
    let left = (area.height.saturating_sub(2) as usize).saturating_sub(super::rows_of(&lines, width));
    if left > 0 {
        let description = super::clip_wrapped(&p.description, width.saturating_sub(2), left);
        lines.push(Line::from(format!("  {description}")));
    }
    frame.render_widget(
        Paragraph::new(lines).wrap(Wrap { trim: false }).block(Block::bordered().title(" Setup ")),
        area,
    );
}
