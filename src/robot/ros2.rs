//! The robot over ROS 2, with no ROS install: `ros2-client` on RustDDS (pure Rust DDS).
//! Each command is published as a `std_msgs/msg/String` (the command's JSON) on the trial
//! topic and a `geometry_msgs/msg/PoseStamped` on the pose topic; the robot's
//! `std_msgs/msg/String` statuses (`moving`, `at_pose`, `failed`) come back on the status
//! topic. QoS is the ROS 2 default (reliable, volatile, keep last 10), which a stock
//! `rclpy`/`rclcpp` node and `ros2 topic pub` match.
//!
//! A pose is not lost to DDS discovery: it is published once the robot's subscription is
//! matched (or after `resend_s` without one), and again every `resend_s` until the robot
//! answers. Statuses carry no command id: one is taken to answer the command under way.

use std::sync::mpsc::{Receiver, RecvTimeoutError, Sender, channel};
use std::time::{Duration, Instant};

use ros2_client::dds::rustdds::DomainParticipantBuilder;
use ros2_client::dds::{Context, Node, Publisher, Subscription};
use ros2_client::qos::{Durability, History, WhenFull};
use ros2_client::{MessageTypeName, Name, NodeName, NodeOptions, QosProfile};
use serde::{Deserialize, Serialize};

use super::{Link, Report, RobotCommand, RobotSettings, Ros2Settings, parse_status};
use crate::session::RobotLinkKind;

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
    /// The command's pose, stamped now.
    pub fn of(command: &RobotCommand) -> Self {
        let now = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).unwrap_or_default();
        let [x, y, z] = command.position;
        let o = command.orientation;
        Self {
            header: Header {
                stamp: Time { sec: i32::try_from(now.as_secs()).unwrap_or(i32::MAX), nanosec: now.subsec_nanos() },
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

/// The ROS 2 link: a thread that owns the DDS participant.
pub struct Ros2Link {
    jobs: Sender<Job>,
    description: String,
}

/// The ROS 2 default QoS (`rclpy`'s and `ros2 topic pub`'s): reliable, volatile, keep last 10.
fn default_qos() -> QosProfile {
    QosProfile::publisher_default()
        .reliability_reliable(WhenFull::DEFAULT)
        .durability(Durability::Volatile)
        .history(History::KeepLast { depth: 10 })
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
pub(super) fn start_node(r: &Ros2Settings, node_name: &str) -> Result<Node, String> {
    let mut builder = DomainParticipantBuilder::new(r.domain_id);
    if !r.networks.is_empty() {
        builder = builder.with_only_networks(r.networks.clone());
    }
    let participant = builder.build().map_err(|e| format!("ROS 2 DDS participant: {e}"))?;
    let context = Context::from_domain_participant(participant).map_err(|e| format!("ROS 2 context: {e}"))?;
    let name = NodeName::new("/", node_name).map_err(|e| format!("ROS 2 node name: {e}"))?;
    let mut node =
        context.new_node(name, NodeOptions::new().enable_rosout(false)).map_err(|e| format!("ROS 2 node: {e:?}"))?;
    let spinner = node.spinner().map_err(|e| format!("ROS 2 spinner: {e}"))?;
    std::thread::spawn(move || {
        let _ = futures::executor::block_on(spinner.spin());
    });
    Ok(node)
}

/// A topic of a ROS 2 message type with the default QoS.
pub(super) fn topic(
    node: &mut Node,
    name: &str,
    package: &str,
    ty: &str,
) -> Result<ros2_client::dds::rustdds::Topic, String> {
    let n = Name::parse(name).map_err(|e| format!("ROS 2 topic {name}: {e}"))?;
    node.create_topic(&n, MessageTypeName::new(package, ty), &default_qos())
        .map_err(|e| format!("ROS 2 topic {name}: {e}"))
}

fn endpoints(settings: &RobotSettings) -> Result<Endpoints, String> {
    let r = &settings.ros2;
    let mut node = start_node(r, "handover_console")?;
    let pose_topic = topic(&mut node, &r.pose_topic, "geometry_msgs", "PoseStamped")?;
    let trial_topic = topic(&mut node, &r.trial_topic, "std_msgs", "String")?;
    let status_topic = topic(&mut node, &r.status_topic, "std_msgs", "String")?;
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
        let (ready_tx, ready) = channel::<Result<(), String>>();
        let settings = settings.clone();
        let description = format!(
            "ros2 domain {} → {} (status {})",
            settings.ros2.domain_id, settings.ros2.pose_topic, settings.ros2.status_topic
        );
        std::thread::spawn(move || match endpoints(&settings) {
            Ok(e) => {
                let _ = ready_tx.send(Ok(()));
                serve(e, &settings, &job_rx, &reports);
            }
            Err(why) => {
                let _ = ready_tx.send(Err(why));
            }
        });
        ready.recv().map_err(|_| "the ROS 2 thread stopped".to_string())??;
        Ok(Self { jobs, description })
    }
}

/// A command being delivered.
struct Delivery {
    command: RobotCommand,
    since: Instant,
    last_sent: Option<Instant>,
    answered: bool,
}

/// The ROS 2 thread: publishes commands, re-sends until answered, forwards statuses.
fn serve(e: Endpoints, settings: &RobotSettings, jobs: &Receiver<Job>, reports: &Sender<Report>) {
    let resend = Duration::from_secs_f64(settings.ros2.resend_s);
    let mut current: Option<Delivery> = None;
    let mut last_query: Option<String> = None;
    loop {
        match jobs.recv_timeout(Duration::from_millis(10)) {
            Ok(Job::Send(command)) => {
                last_query = Some(command.query.clone());
                current = Some(Delivery { command: *command, since: Instant::now(), last_sent: None, answered: false });
            }
            Ok(Job::Cancel) => current = None,
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => return,
        }
        if let Some(d) = current.as_mut().filter(|d| !d.answered) {
            let due = match d.last_sent {
                None => e.pose.get_subscription_count(&e.node) > 0 || d.since.elapsed() >= resend,
                Some(t) => t.elapsed() >= resend,
            };
            if due {
                let json = serde_json::to_string(&d.command).unwrap_or_default();
                let _ = e.trial.publish(json);
                let _ = e.pose.publish(PoseStamped::of(&d.command));
                d.last_sent = Some(Instant::now());
            }
        }
        while let Ok(Some((text, _))) = e.status.take() {
            // A status before any command is about nothing the session knows.
            let Some(query) = last_query.clone() else { continue };
            let (state, detail) = parse_status(&text);
            if let Some(d) = current.as_mut() {
                d.answered = true;
                if state.is_final() {
                    current = None;
                }
            }
            if reports.send(Report { query, state, detail }).is_err() {
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
}
