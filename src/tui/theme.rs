//! Colours, styles, the terminal's least size and the instruction texts every screen shares
//! (status-line messages are written where their event is handled).

use ratatui::style::{Color, Modifier, Style};

pub const MIN_WIDTH: u16 = 80;
pub const MIN_HEIGHT: u16 = 24;

pub fn title() -> Style {
    Style::new().fg(Color::Cyan).add_modifier(Modifier::BOLD)
}

pub fn instruction() -> Style {
    Style::new().fg(Color::Yellow).add_modifier(Modifier::BOLD)
}

pub fn key() -> Style {
    Style::new().fg(Color::Black).bg(Color::Gray)
}

pub fn dim() -> Style {
    Style::new().fg(Color::DarkGray)
}

pub fn selected() -> Style {
    Style::new().fg(Color::Black).bg(Color::Green).add_modifier(Modifier::BOLD)
}

pub fn warning() -> Style {
    Style::new().fg(Color::Red).add_modifier(Modifier::BOLD)
}

pub const APP: &str = "handover";
pub const PRESENT: &str = "ROBOT OPERATOR — command the robot to hand over:";
pub const PRESENT_DONE: &str = "Press Enter when the robot holds the object there.";
pub const FOLLOW_PRESENT_DONE: &str = "Tell the experimenter when the robot holds the object there.";
pub const GRASP: &str = "Which grip did the participant take?";
pub const COMPUTING: &str = "computing…";
pub const HAND_BACK: &str = "Thank you. Please hand the keyboard back to the experimenter.";
pub const PAUSED: &str = "PAUSED — press p to resume";

/// Whose left and right the screen's labels mean: always the participant's. The protocol
/// writes its poses and labels for a right hand; a left hand's poses are mirrored
/// (docs/kinematics.md), so the screens name them as this participant experiences them
/// ([`crate::kinematics::Hand::experienced`]), and the grips keep their colours.
pub fn whose_left(hand: crate::kinematics::Hand) -> &'static str {
    match hand {
        crate::kinematics::Hand::Right => "always the participant's, as they face the robot",
        crate::kinematics::Hand::Left => "the participant's (protocol labels mirrored, colours kept)",
    }
}

/// The frame a pose is written in: the participant's shoulder, their axes.
pub fn frame_of(hand: crate::kinematics::Hand) -> String {
    format!("participant's {} shoulder: x ahead, y to their left, z up", hand.name())
}

/// The participant's hand that takes the objects, named from both people's views: the
/// operator faces the participant, so the participant's right is on the operator's left.
pub fn hand_sides(hand: crate::kinematics::Hand) -> String {
    format!("{} hand (on your {}, facing them)", hand.name().to_uppercase(), hand.other().name())
}
