//! The robot over ROS 2, with no ROS install: `ros2-client` on RustDDS (pure Rust DDS).
//! Each command is published as a `std_msgs/msg/String` (the command's JSON) on the trial
//! topic and a `geometry_msgs/msg/PoseStamped` on the pose topic; the robot's
//! `std_msgs/msg/String` statuses (`moving`, `at_pose`, `failed`) come back on the status
//! topic. QoS is the ROS 2 default (reliable, volatile, keep last 10), which a stock
//! `rclpy`/`rclcpp` node and `ros2 topic pub` match. The domain is the settings' `domain_id`,
//! else `ROS_DOMAIN_ID`, else 0, as for any ROS 2 node.
//!
//! What the robot is guaranteed: a command's pose (with its trial message) is published when
//! the command is sent if any subscriber of the pose topic is matched, again as soon as
//! another subscriber matches and [`AFTER_MATCH`] after any match until a status comes back
//! (a robot that starts after a recorder is not kept waiting), and every `resend_s` until
//! the robot answers. A volatile subscription gets nothing published before it matched, and
//! discovery is not symmetric: this side can see a subscriber matched before the subscriber
//! has matched this publisher, and what is published in between is lost to it. The
//! publications after a match cover that window. Every publication of a command carries its
//! id (the trial message's `command`, the pose's `header.stamp`), and a status names the id
//! it answers (`at_pose 1765130000.123456789`): a status for any other command is stale
//! ([`Attribution`]). When nothing answers, discovery says why ([`super::discovery`]).

use std::sync::mpsc::{Receiver, RecvTimeoutError, Sender, channel};
use std::time::{Duration, Instant};

use ros2_client::dds::rustdds::{DomainParticipant, DomainParticipantBuilder, QosPolicies};
use ros2_client::dds::{Context, Node, Publisher, Subscription};
use ros2_client::qos::{Durability, History, WhenFull};
use ros2_client::{MessageTypeName, Name, NodeName, NodeOptions, QosProfile};
use serde::{Deserialize, Serialize};

use super::discovery::{Endpoint, Side, diagnose, peers};
use super::{Domain, Link, Report, RobotCommand, RobotSettings, Ros2Settings, Status, parse_status};
use crate::session::{RobotLinkKind, RobotState};

/// `builtin_interfaces/msg/Time`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Time {
    pub sec: i32,
    pub nanosec: u32,
}

/// `std_msgs/msg/Header`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Header {
    pub stamp: Time,
    pub frame_id: String,
}

/// `geometry_msgs/msg/Point`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Point {
    pub x: f64,
    pub y: f64,
    pub z: f64,
}

/// `geometry_msgs/msg/Quaternion`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Quaternion {
    pub x: f64,
    pub y: f64,
    pub z: f64,
    pub w: f64,
}

/// `geometry_msgs/msg/Pose`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    pub position: Point,
    pub orientation: Quaternion,
}

/// `geometry_msgs/msg/PoseStamped`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PoseStamped {
    pub header: Header,
    pub pose: Pose,
}

impl PoseStamped {
    /// The command's pose, stamped with the command's id (when it was issued): every
    /// publication of one command carries the same stamp.
    pub fn of(command: &RobotCommand) -> Self {
        let [x, y, z] = command.position;
        let o = command.orientation;
        let (sec, nanosec) = (command.issued_ns / 1_000_000_000, (command.issued_ns % 1_000_000_000) as u32);
        Self {
            header: Header {
                stamp: Time { sec: i32::try_from(sec).unwrap_or(i32::MAX), nanosec },
                frame_id: command.frame.clone(),
            },
            pose: Pose { position: Point { x, y, z }, orientation: Quaternion { x: o.x, y: o.y, z: o.z, w: o.w } },
        }
    }
}

/// What the console asks of the ROS 2 thread.
enum Job {
    Send(Box<RobotCommand>),
    Cancel,
}

/// The ROS 2 link: a thread that owns the DDS node; the participant, to ask discovery why
/// nothing answers.
pub struct Ros2Link {
    jobs: Sender<Job>,
    description: String,
    participant: DomainParticipant,
    domain: Domain,
    /// The console's pose publisher and status subscription, as discovery compares them.
    endpoints: [Endpoint; 2],
}

/// The ROS 2 default QoS (`rclpy`'s and `ros2 topic pub`'s): reliable, volatile, keep last 10.
pub(super) fn default_qos() -> QosProfile {
    QosProfile::publisher_default()
        .reliability_reliable(WhenFull::DEFAULT)
        .durability(Durability::Volatile)
        .history(History::KeepLast { depth: 10 })
}

/// The QoS a sensor stream is taken with: best effort, which matches both best-effort
/// publishers (rclpy's `qos_profile_sensor_data`, what measuring systems use) and reliable ones.
pub(super) fn sensor_qos() -> QosProfile {
    default_qos().reliability_best_effort()
}

/// A started node, its participant and its domain.
pub(super) struct Started {
    pub node: Node,
    pub participant: DomainParticipant,
    pub domain: Domain,
}

/// The publishers, the subscription and the node that matches them.
struct Endpoints {
    node: Node,
    pose: Publisher<PoseStamped>,
    trial: Publisher<String>,
    status: Subscription<String>,
}

/// A node of its own DDS participant in the settings' domain, on the settings' networks, its
/// spinner (discovery, matching) on a thread of its own.
pub(super) fn start_node(r: &Ros2Settings, node_name: &str) -> Result<Started, String> {
    let domain = r.domain().map_err(|e| e.to_string())?;
    let mut builder = DomainParticipantBuilder::new(domain.id);
    if !r.networks.is_empty() {
        builder = builder.with_only_networks(r.networks.clone());
    }
    let participant = builder.build().map_err(|e| format!("ROS 2 DDS participant: {e}"))?;
    let context = Context::from_domain_participant(participant.clone()).map_err(|e| format!("ROS 2 context: {e}"))?;
    let name = NodeName::new("/", node_name).map_err(|e| format!("ROS 2 node name: {e}"))?;
    let mut node =
        context.new_node(name, NodeOptions::new().enable_rosout(false)).map_err(|e| format!("ROS 2 node: {e:?}"))?;
    let spinner = node.spinner().map_err(|e| format!("ROS 2 spinner: {e}"))?;
    std::thread::spawn(move || {
        let _ = futures::executor::block_on(spinner.spin());
    });
    Ok(Started { node, participant, domain })
}

/// A topic of a ROS 2 message type (`package/msg/ty`) with `qos`.
pub(super) fn topic(
    node: &mut Node,
    name: &str,
    package: &str,
    ty: &str,
    qos: &QosProfile,
) -> Result<ros2_client::dds::rustdds::Topic, String> {
    let n = Name::parse(name).map_err(|e| format!("ROS 2 topic {name}: {e}"))?;
    node.create_topic(&n, MessageTypeName::new(package, ty), qos).map_err(|e| format!("ROS 2 topic {name}: {e}"))
}

/// The console's side of every topic it uses, as discovery compares it with the other side:
/// the pose, trial and status topics (the ROS 2 default QoS) and the arm's joint states
/// (taken best effort). The one list the link, the arm's source and `robot-check` share.
pub(super) struct ConsoleEndpoints {
    pub pose: Endpoint,
    pub trial: Endpoint,
    pub status: Endpoint,
    pub joint_states: Endpoint,
}

impl ConsoleEndpoints {
    pub fn of(r: &Ros2Settings) -> Self {
        let reliable = QosPolicies::from(&default_qos());
        let endpoint = |topic: &str, ros_type, side, qos: &QosPolicies| Endpoint {
            topic: topic.to_string(),
            ros_type,
            side,
            qos: qos.clone(),
        };
        Self {
            pose: endpoint(&r.pose_topic, "geometry_msgs/msg/PoseStamped", Side::Publishes, &reliable),
            trial: endpoint(&r.trial_topic, "std_msgs/msg/String", Side::Publishes, &reliable),
            status: endpoint(&r.status_topic, "std_msgs/msg/String", Side::Subscribes, &reliable),
            joint_states: endpoint(
                &r.joint_states_topic,
                "sensor_msgs/msg/JointState",
                Side::Subscribes,
                &QosPolicies::from(&sensor_qos()),
            ),
        }
    }
}

fn endpoints(mut node: Node, r: &Ros2Settings) -> Result<Endpoints, String> {
    let qos = default_qos();
    let pose_topic = topic(&mut node, &r.pose_topic, "geometry_msgs", "PoseStamped", &qos)?;
    let trial_topic = topic(&mut node, &r.trial_topic, "std_msgs", "String", &qos)?;
    let status_topic = topic(&mut node, &r.status_topic, "std_msgs", "String", &qos)?;
    let pose =
        node.create_publisher(&pose_topic, None).map_err(|e| format!("ROS 2 publisher {}: {e}", r.pose_topic))?;
    let trial =
        node.create_publisher(&trial_topic, None).map_err(|e| format!("ROS 2 publisher {}: {e}", r.trial_topic))?;
    let status = node
        .create_subscription(&status_topic, None)
        .map_err(|e| format!("ROS 2 subscription {}: {e}", r.status_topic))?;
    Ok(Endpoints { node, pose, trial, status })
}

impl Ros2Link {
    /// Joins the DDS domain (on its own thread) and sets up the topics.
    pub fn new(reports: Sender<Report>, settings: &RobotSettings) -> Result<Self, String> {
        let (jobs, job_rx) = channel::<Job>();
        let (ready_tx, ready) = channel::<Result<(DomainParticipant, Domain), String>>();
        let settings = settings.clone();
        let thread_settings = settings.clone();
        std::thread::spawn(move || {
            let settings = thread_settings;
            let started = start_node(&settings.ros2, "handover_console");
            match started.and_then(|s| Ok((s.participant, s.domain, endpoints(s.node, &settings.ros2)?))) {
                Ok((participant, domain, e)) => {
                    let _ = ready_tx.send(Ok((participant, domain)));
                    serve(e, &settings, &job_rx, &reports);
                }
                Err(why) => {
                    let _ = ready_tx.send(Err(why));
                }
            }
        });
        let (participant, domain) = ready.recv().map_err(|_| "the ROS 2 thread stopped".to_string())??;
        let r = &settings.ros2;
        let description = format!("ros2 {domain} → {} (status {})", r.pose_topic, r.status_topic);
        let ConsoleEndpoints { pose, status, .. } = ConsoleEndpoints::of(r);
        Ok(Self { jobs, description, participant, domain, endpoints: [pose, status] })
    }
}

/// A command being delivered.
struct Delivery {
    command: RobotCommand,
    since: Instant,
    last_sent: Option<Instant>,
    /// How often its pose was published.
    publications: u32,
    answered: bool,
}

impl Delivery {
    fn of(command: RobotCommand) -> Self {
        Self { command, since: Instant::now(), last_sent: None, publications: 0, answered: false }
    }
}

/// How many earlier commands a status may name and still be told apart from an unknown one.
const REMEMBERED: usize = 64;

/// What the link makes of the robot's statuses: which command each answers. A status that
/// names the command under way answers it; one that names another is stale. A bare status
/// (a robot node written before statuses named commands) is taken for the command under way
/// only while that cannot be wrong: no earlier command's pose was published more than once,
/// every earlier command was answered, and no state (`moving`, `at_pose`, `failed`) came
/// while none was under way. Once
/// any of that happens, the robot may still be answering an earlier command, and every bare
/// status after it is stale, with the reason.
#[derive(Default)]
struct Attribution {
    /// Earlier commands (id, query), newest last.
    earlier: std::collections::VecDeque<(String, String)>,
    /// Why a bare status can no longer be told to answer the command under way.
    bare_refused: Option<String>,
}

impl Attribution {
    /// The command `d` is over: answered, timed out or replaced.
    fn end(&mut self, d: &Delivery, answered: bool) {
        if self.bare_refused.is_none() {
            if !answered {
                self.bare_refused = Some(format!("command {} got no final answer", d.command.command));
            } else if d.publications > 1 {
                self.bare_refused = Some(format!(
                    "the pose of command {} was published {} times and the robot may still answer the repeats",
                    d.command.command, d.publications
                ));
            }
        }
        self.earlier.push_back((d.command.command.clone(), d.command.query.clone()));
        if self.earlier.len() > REMEMBERED {
            self.earlier.pop_front();
        }
    }

    /// `next` replaces the command under way (none: it is given up).
    fn replace(&mut self, current: &mut Option<Delivery>, next: Option<Delivery>) {
        if let Some(d) = current.take() {
            self.end(&d, false);
        }
        *current = next;
    }

    /// The report a status makes; the command under way is answered by it, and over if it
    /// is final.
    fn heard(&mut self, status: Status, current: &mut Option<Delivery>) -> Report {
        let report = self.report(status, current.as_ref());
        if !report.stale
            && let Some(d) = current.as_mut()
        {
            d.answered = true;
            if report.state.is_final() {
                self.end(d, true);
                *current = None;
            }
        }
        report
    }

    /// The report a status makes, with `current` under way.
    fn report(&mut self, status: Status, current: Option<&Delivery>) -> Report {
        let Status { state, command, detail } = status;
        let last_query =
            || current.map(|d| d.command.query.clone()).or_else(|| self.earlier.back().map(|e| e.1.clone()));
        match (command, current) {
            (Some(id), Some(d)) if id == d.command.command => d.command.report(state, detail),
            (Some(id), _) => {
                let query = self.earlier.iter().find(|e| e.0 == id).map(|e| e.1.clone()).or_else(last_query);
                Report { query: query.unwrap_or_default(), command: Some(id), state, detail, stale: true }
            }
            (None, Some(d)) if self.bare_refused.is_none() => d.command.report(state, detail),
            (None, current) => {
                // An answer while nothing is under way may be a second answer to the last
                // command (an unknown text, such as a heartbeat, answers nothing).
                if current.is_none() && self.bare_refused.is_none() && state != RobotState::Other {
                    self.bare_refused = Some("a status came while no command was under way".into());
                }
                let why = self.bare_refused.clone().unwrap_or_default();
                let said = if detail.is_empty() { state.name().to_string() } else { detail };
                let detail =
                    format!("{said} (names no command, and {why}: the robot must name the command it answers)");
                Report { query: last_query().unwrap_or_default(), command: None, state, detail, stale: true }
            }
        }
    }
}

/// When a command still unanswered is published again after a subscriber of the pose topic
/// matched, counted from the match, until a status comes back: the subscriber may match this
/// publisher only after this side matched it (under load, a second or more), and misses what
/// came before. A status proves the robot has matched; a robot slower than the first of these
/// to say `moving` gets the command twice, as it would at a resend, with the same id.
const AFTER_MATCH: [Duration; 3] = [Duration::from_millis(500), Duration::from_secs(1), Duration::from_secs(3)];

/// Whether a command sent at `since` and last published at `sent` is published now, with
/// `subscribers` matched, the last of them at `matched`: first when anyone subscribes, again
/// at a match and [`AFTER_MATCH`] after it if not published since, and every `resend`.
fn publish_due(
    since: Instant,
    sent: Option<Instant>,
    now: Instant,
    subscribers: usize,
    matched: Option<Instant>,
    resend: Duration,
) -> bool {
    let Some(sent) = sent else {
        return subscribers > 0 || now.duration_since(since) >= resend;
    };
    let checkpoint = matched.and_then(|m| {
        let reached = std::iter::once(Duration::ZERO).chain(AFTER_MATCH).rfind(|&d| m + d <= now)?;
        Some(m + reached)
    });
    checkpoint.is_some_and(|t| sent < t) || now.duration_since(sent) >= resend
}

/// The ROS 2 thread: publishes commands, re-sends until answered, forwards statuses with the
/// command each answers.
fn serve(e: Endpoints, settings: &RobotSettings, jobs: &Receiver<Job>, reports: &Sender<Report>) {
    let resend = Duration::from_secs_f64(settings.ros2.resend_s);
    let mut current: Option<Delivery> = None;
    let mut attribution = Attribution::default();
    // Subscribers of the pose topic matched at the last look, and when one last matched.
    let mut seen = 0;
    let mut matched: Option<Instant> = None;
    loop {
        match jobs.recv_timeout(Duration::from_millis(10)) {
            Ok(Job::Send(command)) => attribution.replace(&mut current, Some(Delivery::of(*command))),
            Ok(Job::Cancel) => attribution.replace(&mut current, None),
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => return,
        }
        let subscribers = e.pose.get_subscription_count(&e.node);
        let now = Instant::now();
        if subscribers > seen {
            matched = Some(now);
        }
        seen = subscribers;
        if let Some(d) = current.as_mut().filter(|d| !d.answered)
            && publish_due(d.since, d.last_sent, now, subscribers, matched, resend)
        {
            let json = serde_json::to_string(&d.command).unwrap_or_default();
            let _ = e.trial.publish(json);
            let _ = e.pose.publish(PoseStamped::of(&d.command));
            d.last_sent = Some(now);
            d.publications += 1;
        }
        while let Ok(Some((text, _))) = e.status.take() {
            // The robot answered, so it has matched this publisher: no window left to cover.
            matched = None;
            let report = attribution.heard(parse_status(&text), &mut current);
            // A status before any command is about nothing the session knows.
            if report.query.is_empty() {
                continue;
            }
            if reports.send(report).is_err() {
                return;
            }
        }
    }
}

impl Link for Ros2Link {
    fn kind(&self) -> RobotLinkKind {
        RobotLinkKind::Ros2
    }

    fn describe(&self) -> String {
        self.description.clone()
    }

    fn send(&mut self, command: &RobotCommand) -> Result<(), String> {
        self.jobs.send(Job::Send(Box::new(command.clone()))).map_err(|_| "the ROS 2 thread stopped".to_string())
    }

    fn cancel(&mut self) {
        let _ = self.jobs.send(Job::Cancel);
    }

    fn diagnose(&self) -> Option<String> {
        let problems: Vec<String> = self
            .endpoints
            .iter()
            .filter_map(|ours| diagnose(ours, &peers(&self.participant, ours.side), self.domain))
            .collect();
        (!problems.is_empty()).then(|| problems.join("; "))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::robot::{CommandId, Xyzw};
    use crate::session::Phase;
    use rand::{RngExt, SeedableRng};

    fn command(k: u64) -> RobotCommand {
        let issued_ns = 1_765_130_000_000_000_000 + k;
        RobotCommand {
            command: CommandId::text(issued_ns),
            issued_ns,
            phase: Phase::Training,
            trial: k as usize,
            attempt: 1,
            query: format!("q{}", k % 3),
            label: String::new(),
            object: String::new(),
            grips: Vec::new(),
            frame: "shoulder".into(),
            position: [0.3, 0.0, 0.0],
            orientation: Xyzw { x: 0.0, y: 0.0, z: 0.0, w: 1.0 },
            rpy_deg: [0.0; 3],
        }
    }

    /// A robot node as the simulation runs it.
    #[derive(Clone, Copy, Debug)]
    struct NodeKind {
        /// Its statuses name the command (else: bare, as nodes before command ids).
        names: bool,
        /// It executes a repeated command once (else: every publication, in turn).
        once: bool,
        /// It says `at_pose` twice.
        twice: bool,
        /// It says `moving` when it starts.
        moving: bool,
    }

    /// What one simulated session showed.
    #[derive(Default, Debug)]
    struct Tally {
        credited: usize,
        stale: usize,
        /// Statuses answering the command under way that were logged stale.
        refused_current: usize,
        commands_ended: usize,
    }

    /// A session of 30 commands against a node of `kind` that executes what it receives in
    /// turn (one at a time, as an rclpy callback blocking on a move does), each move 1–40
    /// steps. With `lossy`, the console publishes an unanswered command again (a resend, a
    /// late match) and times some out. Every status goes through [`Attribution::heard`], as
    /// in [`serve`], and is checked against the command that truly caused it.
    fn simulate(kind: NodeKind, lossy: bool, seed: u64) -> Tally {
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
        let mut attribution = Attribution::default();
        let mut current: Option<Delivery> = None;
        let mut inbox: std::collections::VecDeque<u64> = Default::default();
        let mut busy: Option<(u64, u32)> = None;
        let mut last_started: Option<u64> = None;
        let mut sent = 0;
        let mut tally = Tally::default();
        let hear = |attribution: &mut Attribution,
                    state: RobotState,
                    k: u64,
                    current: &mut Option<Delivery>,
                    tally: &mut Tally| {
            let id = CommandId::text(command(k).issued_ns);
            let text = if kind.names { format!("{} {id}", state.name()) } else { state.name().to_string() };
            let under_way = current.as_ref().map(|d| d.command.command.clone());
            let report = attribution.heard(parse_status(&text), current);
            if report.stale {
                tally.stale += 1;
                tally.refused_current += usize::from(under_way.as_deref() == Some(id.as_str()));
            } else {
                assert_eq!(
                    report.command.as_deref(),
                    Some(id.as_str()),
                    "{kind:?} lossy {lossy} seed {seed}: credited"
                );
                assert_eq!(report.state, state);
                tally.credited += 1;
                tally.commands_ended += usize::from(state.is_final());
            }
        };
        for _ in 0..100_000 {
            if current.is_none() && sent < 30 {
                sent += 1;
                current = Some(Delivery::of(command(sent)));
                current.as_mut().unwrap().publications += 1;
                inbox.push_back(sent);
            } else if let Some(d) = current.as_mut().filter(|d| lossy && !d.answered) {
                if rng.random_bool(0.1) {
                    d.publications += 1;
                    inbox.push_back(d.command.issued_ns - 1_765_130_000_000_000_000);
                } else if rng.random_bool(0.02) {
                    attribution.replace(&mut current, None);
                }
            }
            match busy {
                Some((k, 0)) => {
                    busy = None;
                    let state = if rng.random_bool(0.1) { RobotState::Failed } else { RobotState::AtPose };
                    hear(&mut attribution, state, k, &mut current, &mut tally);
                    if kind.twice {
                        hear(&mut attribution, state, k, &mut current, &mut tally);
                    }
                }
                Some((k, left)) => busy = Some((k, left - 1)),
                None => {
                    if let Some(k) = inbox.pop_front()
                        && !(kind.once && last_started == Some(k))
                    {
                        last_started = Some(k);
                        busy = Some((k, rng.random_range(1..40)));
                        if kind.moving {
                            hear(&mut attribution, RobotState::Moving, k, &mut current, &mut tally);
                        }
                    }
                }
            }
            if sent == 30 && current.is_none() && busy.is_none() && inbox.is_empty() {
                break;
            }
            // A command nothing will answer any more (the node dropped it as a repeat, or its
            // answers were all stale) times out, as the console's would.
            if busy.is_none() && inbox.is_empty() && current.is_some() {
                attribution.replace(&mut current, None);
            }
        }
        tally
    }

    /// No status is ever credited to a command it does not answer, over every kind of node,
    /// reliable and lossy delivery, 25 seeds each (800 sessions, 24 000 commands). A node that
    /// names its commands has every answer to the command under way credited; a bare node
    /// keeps working while it cannot be wrong (reliable delivery, one answer each).
    #[test]
    fn every_status_is_credited_to_the_command_it_answers_or_logged_stale() {
        let mut sessions = 0;
        let (mut credited, mut stale) = (0, 0);
        for bits in 0..16u32 {
            let bit = |i: u32| bits & (1 << i) != 0;
            let kind = NodeKind { names: bit(0), once: bit(1), twice: bit(2), moving: bit(3) };
            for lossy in [false, true] {
                for seed in 0..25 {
                    let t = simulate(kind, lossy, seed);
                    sessions += 1;
                    credited += t.credited;
                    stale += t.stale;
                    if kind.names {
                        assert_eq!(t.refused_current, 0, "{kind:?} lossy {lossy} seed {seed}: {t:?}");
                    }
                    if kind.names && !lossy {
                        assert_eq!(t.commands_ended, 30, "{kind:?} seed {seed}: {t:?}");
                    }
                    if !kind.names && !lossy && !kind.twice {
                        assert_eq!((t.stale, t.commands_ended), (0, 30), "{kind:?} seed {seed}: {t:?}");
                    }
                    if kind.twice && kind.names {
                        assert!(
                            t.stale >= t.commands_ended,
                            "{kind:?} seed {seed}: every second answer is stale: {t:?}"
                        );
                    }
                }
            }
        }
        assert_eq!(sessions, 800);
        eprintln!("{sessions} simulated sessions: {credited} statuses credited, {stale} stale, none misattributed");
        assert!(credited > 20_000 && stale > 1_000, "{credited} credited, {stale} stale");
    }

    /// When a command is published: at once if anyone subscribes, at a later match and
    /// 0.5, 1 and 3 s after it unless published since, and every resend otherwise.
    #[test]
    fn a_command_is_published_again_after_a_subscriber_matches() {
        let t0 = Instant::now();
        let s = |secs: f64| t0 + Duration::from_secs_f64(secs);
        let resend = Duration::from_secs(30);
        // Nobody subscribes: only the resend publishes.
        assert!(!publish_due(t0, None, s(1.0), 0, None, resend));
        assert!(publish_due(t0, None, s(30.0), 0, None, resend));
        // A subscriber matched long before the command: published at once, then at the resend.
        let old = Some(t0 - Duration::from_secs(60));
        assert!(publish_due(t0, None, s(0.0), 1, old, resend));
        assert!(!publish_due(t0, Some(s(0.0)), s(29.0), 1, old, resend));
        assert!(publish_due(t0, Some(s(0.0)), s(30.0), 1, old, resend));
        // A robot matches at 5 s: published then, and at 5.5, 6 and 8 s, each once.
        let m = Some(s(5.0));
        let mut sent = s(0.0);
        let mut published = Vec::new();
        for k in 0..=1500 {
            let now = s(4.0 + k as f64 * 0.01);
            let matched = m.filter(|&m| m <= now);
            if publish_due(t0, Some(sent), now, 1 + usize::from(matched.is_some()), matched, resend) {
                sent = now;
                published.push((now - t0).as_secs_f64());
            }
        }
        let expected = [5.0, 5.5, 6.0, 8.0];
        assert_eq!(published.len(), expected.len(), "{published:?}");
        for (p, e) in published.iter().zip(expected) {
            assert!((p - e).abs() < 0.011, "{published:?}");
        }
    }
}
