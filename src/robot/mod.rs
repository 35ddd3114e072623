//! The robot in the loop: what a command says ([`RobotCommand`]), the links that carry it
//! (ROS 2 topics, [`ros2`]; a program per command, [`hook`]) and the [`Robot`] that sends
//! commands, collects what the link reports and times a command out. The session logs both
//! sides as events (`/robot/command`, `/robot/status`); the operator keeps the last word.

pub mod discovery;
pub mod hook;
pub mod joint_states;
pub mod ros2;
mod settings;
pub mod setup_check;

use std::sync::mpsc::{Receiver, Sender, channel};
use std::time::{Duration, Instant};

use nalgebra::UnitQuaternion;
use serde::Serialize;

pub use settings::{
    BaseFrame, Domain, FieldProblem, MAX_DOMAIN_ID, PresentOn, RobotSettings, Ros2Settings, SettingsError,
    TopicNameError, validate_topic,
};

use crate::session::{Event, Phase, Prompt, RobotLinkKind, RobotState, SentPose, Session};

/// A grip offered at a query.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Grip {
    pub id: String,
    pub label: String,
}

/// A quaternion as `geometry_msgs/msg/Quaternion` names its parts.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Xyzw {
    pub x: f64,
    pub y: f64,
    pub z: f64,
    pub w: f64,
}

/// One command: the trial and the object's pose, as a program's standard input and the ROS 2
/// trial message carry it (JSON).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RobotCommand {
    /// Its id: when it was issued, `SEC.NANOSEC` since the Unix epoch, which is also the
    /// pose message's `header.stamp` ([`CommandId`]). Every publication of the command carries
    /// the same id; each status names the id it answers.
    pub command: String,
    /// The same instant (ns since the Unix epoch).
    #[serde(skip)]
    pub issued_ns: u64,
    pub phase: Phase,
    /// 1-based within the run (training) or the test phase.
    pub trial: usize,
    /// 1 for the trial's first command, 2… for re-sends.
    pub attempt: u32,
    pub query: String,
    /// The pose's name.
    pub label: String,
    pub object: String,
    pub grips: Vec<Grip>,
    pub frame: String,
    /// The object's centre (m).
    pub position: [f64; 3],
    pub orientation: Xyzw,
    /// The same orientation as roll, pitch, yaw (degrees; R = Rz(yaw) Ry(pitch) Rx(roll)).
    pub rpy_deg: [f64; 3],
}

impl RobotCommand {
    /// The pose as the log records it.
    pub fn sent_pose(&self) -> SentPose {
        let o = self.orientation;
        SentPose { frame: self.frame.clone(), position: self.position, orientation: [o.x, o.y, o.z, o.w] }
    }

    /// The event that logs it.
    pub fn event(&self, link: RobotLinkKind) -> Event {
        Event::RobotCommanded {
            query: self.query.clone(),
            link,
            pose: self.sent_pose(),
            command: Some(self.command.clone()),
        }
    }

    /// A report on this command.
    pub fn report(&self, state: RobotState, detail: impl Into<String>) -> Report {
        Report {
            query: self.query.clone(),
            command: Some(self.command.clone()),
            state,
            detail: detail.into(),
            stale: false,
        }
    }
}

/// Command ids: the instant a command is issued, `SEC.NANOSEC` since the Unix epoch. An
/// action's goal id in ROS 2 is a UUID; this id is the command's `header.stamp`, so that a
/// robot node can name the command from the pose message alone with standard types. Ids
/// increase within a process (two commands in one nanosecond get consecutive ones).
pub struct CommandId;

impl CommandId {
    /// A new id, and its instant in ns.
    pub fn issue() -> (String, u64) {
        use std::sync::atomic::{AtomicU64, Ordering};
        static LAST: AtomicU64 = AtomicU64::new(0);
        let now = crate::now_ns();
        let ns = match LAST.fetch_update(Ordering::SeqCst, Ordering::SeqCst, |last| Some(now.max(last + 1))) {
            Ok(last) | Err(last) => now.max(last + 1),
        };
        (Self::text(ns), ns)
    }

    /// The id of the instant `ns`.
    pub fn text(ns: u64) -> String {
        format!("{}.{:09}", ns / 1_000_000_000, ns % 1_000_000_000)
    }
}

/// The command for the query the session waits to have presented (none when it waits for
/// something else): its commanded pose, in the base frame when the lab gave one.
pub fn command_for(session: &Session, settings: &RobotSettings) -> Option<RobotCommand> {
    let Prompt::Present(view) = session.prompt() else { return None };
    let q = session.query(view.query);
    let object = session.study().object(q);
    let mut pose = q.pose.to_isometry();
    if let Some(base) = &settings.base_frame {
        pose = base.base_from_shoulder() * pose;
    }
    let rotation: UnitQuaternion<f64> = pose.rotation;
    let (r, p, y) = rotation.euler_angles();
    let attempt = session.robot().filter(|t| t.query == q.query.id).map_or(0, |t| t.attempts) + 1;
    let (command, issued_ns) = CommandId::issue();
    Some(RobotCommand {
        command,
        issued_ns,
        phase: view.phase,
        trial: view.trial,
        attempt,
        query: q.query.id.clone(),
        label: q.query.label.clone(),
        object: object.id.clone(),
        grips: q
            .regions
            .iter()
            .map(|&r| Grip { id: object.regions[r].id.clone(), label: object.regions[r].label.clone() })
            .collect(),
        frame: settings.frame_id().to_string(),
        position: [pose.translation.x, pose.translation.y, pose.translation.z],
        orientation: Xyzw { x: rotation.i, y: rotation.j, z: rotation.k, w: rotation.w },
        rpy_deg: [r, p, y].map(f64::to_degrees),
    })
}

/// What a link heard about a command.
#[derive(Clone, Debug, PartialEq)]
pub struct Report {
    /// The query of the command it answers (stale: of the command it names, else of the last
    /// command sent).
    pub query: String,
    /// The id of the command it answers, or (stale) names.
    pub command: Option<String>,
    pub state: RobotState,
    pub detail: String,
    /// It answers another command than the one under way, or cannot be told to answer it.
    pub stale: bool,
}

impl Report {
    /// The event that logs it.
    pub fn event(&self) -> Event {
        Event::RobotReported {
            query: self.query.clone(),
            state: self.state,
            detail: self.detail.clone(),
            command: self.command.clone(),
            stale: self.stale,
        }
    }

    /// Whether it is the final answer to `command`.
    pub fn ends(&self, command: &RobotCommand) -> bool {
        !self.stale && self.state.is_final() && self.command.as_deref() == Some(command.command.as_str())
    }
}

/// A way of reaching the robot. Reports arrive on the channel the link was made with.
pub trait Link: Send {
    fn kind(&self) -> RobotLinkKind;
    /// Starts carrying out `command` (a command under way is abandoned).
    fn send(&mut self, command: &RobotCommand) -> Result<(), String>;
    /// The command under way timed out: stop working on it.
    fn cancel(&mut self) {}
    /// Where it is connected, for the screen (`ros2 domain 0`, the program's name).
    fn describe(&self) -> String;
    /// Why the robot cannot be hearing or answering, when the link can tell (nobody
    /// subscribed, another message type, incompatible QoS).
    fn diagnose(&self) -> Option<String> {
        None
    }
}

/// A command under way.
#[derive(Clone, Debug)]
struct Pending {
    query: String,
    command: String,
    sent: Instant,
}

/// The robot as the console and dry runs see it: a link, its reports, and the timeout.
pub struct Robot {
    link: Box<dyn Link>,
    reports: Receiver<Report>,
    pending: Option<Pending>,
    /// How long the last command took to its final report.
    last_took: Option<Duration>,
    pub settings: RobotSettings,
}

impl Robot {
    /// A robot reached through the link that `make` builds with a report channel.
    pub fn new(
        settings: RobotSettings,
        make: impl FnOnce(Sender<Report>, &RobotSettings) -> Result<Box<dyn Link>, String>,
    ) -> Result<Self, String> {
        let (tx, reports) = channel();
        let link = make(tx, &settings)?;
        Ok(Self { link, reports, pending: None, last_took: None, settings })
    }

    pub fn kind(&self) -> RobotLinkKind {
        self.link.kind()
    }

    pub fn describe(&self) -> String {
        self.link.describe()
    }

    /// Sends a command (logged before: see [`RobotCommand::event`]).
    pub fn send(&mut self, command: &RobotCommand) -> Result<(), String> {
        self.pending =
            Some(Pending { query: command.query.clone(), command: command.command.clone(), sent: Instant::now() });
        self.last_took = None;
        self.link.send(command)
    }

    /// Whether a command is waiting for its final report.
    pub fn busy(&self) -> bool {
        self.pending.is_some()
    }

    /// How long the command under way has taken, or the last one took.
    pub fn elapsed(&self) -> Option<Duration> {
        self.pending.as_ref().map(|p| p.sent.elapsed()).or(self.last_took)
    }

    /// The next report, waiting at most `wait`; a command past its time is reported as a
    /// timeout (and the link told to give it up). A report on any command but the one under
    /// way is stale, whatever the link made of it.
    pub fn next_report(&mut self, wait: Duration) -> Option<Report> {
        let deadline = self.pending.as_ref().map(|p| p.sent + self.settings.timeout());
        let wait = deadline.map_or(wait, |d| wait.min(d.saturating_duration_since(Instant::now())));
        let got = if wait.is_zero() { self.reports.try_recv().ok() } else { self.reports.recv_timeout(wait).ok() };
        if let Some(mut report) = got {
            let under_way = self.pending.as_ref().map(|p| p.command.as_str());
            if report.command.as_deref() != under_way || under_way.is_none() {
                report.stale = true;
            }
            if !report.stale
                && report.state.is_final()
                && let Some(p) = self.pending.take()
            {
                self.last_took = Some(p.sent.elapsed());
            }
            return Some(report);
        }
        match (&self.pending, deadline) {
            (Some(p), Some(d)) if Instant::now() >= d => {
                let mut detail = format!("no answer within {} s", self.settings.timeout_s);
                if let Some(why) = self.link.diagnose() {
                    detail = format!("{why} (no answer within {} s)", self.settings.timeout_s);
                }
                let report = Report {
                    query: p.query.clone(),
                    command: Some(p.command.clone()),
                    state: RobotState::Timeout,
                    detail,
                    stale: false,
                };
                self.last_took = Some(p.sent.elapsed());
                self.pending = None;
                self.link.cancel();
                Some(report)
            }
            _ => None,
        }
    }
}

/// A robot's status message, read.
#[derive(Clone, Debug, PartialEq)]
pub struct Status {
    pub state: RobotState,
    /// The command it names (none: a bare status).
    pub command: Option<String>,
    /// The robot's words beyond the state and the id (a failure's reason; the whole text of
    /// a status that is none of the states).
    pub detail: String,
}

/// The text a robot's status message carries: `STATE [ID][: WHY]`, STATE one of `moving`,
/// `at_pose`, `failed`, ID the command's id ([`CommandId`]), WHY a failure's reason (`failed
/// 1765130000.123456789: no IK solution`). Anything else is `other`, with the text as the
/// detail; a text beginning `failed` is a failure whatever follows.
pub fn parse_status(text: &str) -> Status {
    let text = text.trim();
    let clean = |t: &str| t.chars().filter(|c| !c.is_control()).take(500).collect::<String>();
    let other = || {
        let mut detail = clean(text);
        if detail.is_empty() {
            detail = "(empty status)".into();
        }
        let state = if text.starts_with("failed") { RobotState::Failed } else { RobotState::Other };
        Status { state, command: None, detail }
    };
    let (word, rest) = text.split_once([' ', ':']).map_or((text, ""), |(w, _)| (w, &text[w.len()..]));
    let state = match word {
        "moving" => RobotState::Moving,
        "at_pose" => RobotState::AtPose,
        "failed" => RobotState::Failed,
        _ => return other(),
    };
    // The id, if the next word is one.
    let (command, rest) = match rest.strip_prefix(' ').map(|r| r.trim_start()) {
        Some(r) => {
            let id = r.split([' ', ':']).next().unwrap_or("");
            if crate::session::validate_command_id(id).is_ok() {
                (Some(id.to_string()), &r[id.len()..])
            } else {
                (None, rest)
            }
        }
        None => (None, rest),
    };
    match (state, rest.trim()) {
        (_, "") => Status { state, command, detail: String::new() },
        (RobotState::Failed, why) => {
            let why = why.strip_prefix(':').unwrap_or(why).trim();
            Status { state, command, detail: clean(&format!("failed: {why}")) }
        }
        _ => other(),
    }
}

#[cfg(test)]
mod tests;
