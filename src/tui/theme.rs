//! Colours, styles and the console's fixed strings, in one place.

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
/// ([`as_experienced`]), and the grips keep their colours.
pub fn whose_left(hand: crate::kinematics::Hand) -> &'static str {
    match hand {
        crate::kinematics::Hand::Right => "always the participant's, as they face the robot",
        crate::kinematics::Hand::Left => "the participant's (protocol labels mirrored, colours kept)",
    }
}

/// A protocol label (a pose, a grip) as a participant with this hand experiences it: for a
/// left hand, whose poses are mirrored, its words "left" and "right" swapped (case kept);
/// unchanged for a right hand.
pub fn as_experienced(label: &str, hand: crate::kinematics::Hand) -> String {
    if hand == crate::kinematics::Hand::Right {
        return label.to_string();
    }
    let mut out = String::with_capacity(label.len());
    let mut word = String::new();
    let flush = |word: &mut String, out: &mut String| {
        let swapped = match word.as_str() {
            "left" => "right",
            "right" => "left",
            "Left" => "Right",
            "Right" => "Left",
            "LEFT" => "RIGHT",
            "RIGHT" => "LEFT",
            w => w,
        };
        out.push_str(swapped);
        word.clear();
    };
    for c in label.chars() {
        if c.is_alphanumeric() {
            word.push(c);
        } else {
            flush(&mut word, &mut out);
            out.push(c);
        }
    }
    flush(&mut word, &mut out);
    out
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

#[cfg(test)]
mod tests {
    use super::as_experienced;
    use crate::kinematics::Hand;

    #[test]
    fn a_left_hand_has_left_and_right_swapped_in_whole_words() {
        let l = |s: &str| as_experienced(s, Hand::Left);
        assert_eq!(l("Handlebars at chest height, turned left"), "Handlebars at chest height, turned right");
        assert_eq!(l("Left grip (blue)"), "Right grip (blue)");
        assert_eq!(l("RIGHT shackle"), "LEFT shackle");
        assert_eq!(l("leftover, upright, bright"), "leftover, upright, bright");
        assert_eq!(as_experienced("Left grip (blue)", Hand::Right), "Left grip (blue)");
    }
}
