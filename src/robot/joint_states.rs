//! The participant's arm measured live (`--measure ros2`): a measuring system (motion capture,
//! a body tracker) publishes `sensor_msgs/msg/JointState` on a ROS 2 topic; a thread of its
//! own keeps the last seconds of samples, each mapped to the arm model's joint order by the
//! protocol's `learning.measurement.joint_names`, and a grasp takes its sample by
//! [`ArmMeasurement::pick`]'s rule (the latest at or before the grasp, within the protocol's
//! window), the rule `analyze --measurements` applies to a file of samples.
//!
//! A sample's time is its header stamp (the measuring system's clock, which must be the
//! console's: one machine, or NTP/PTP), or the time it arrived when the stamp is zero. So
//! that a sample stamped before the grasp but still on its way counts, a grasp waits for
//! the first sample stamped after it, at most [`SETTLE`]. The subscription is best effort,
//! which hears best-effort publishers (the sensor-data QoS measuring systems use) and
//! reliable ones alike. Messages that do not name every mapped joint, or whose positions are
//! not finite angles, are counted and dropped.

use std::collections::VecDeque;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use serde::{Deserialize, Serialize};

use ros2_client::dds::rustdds::DomainParticipant;

use super::discovery::{Endpoint, Side, diagnose, peers};
use super::ros2::{ConsoleEndpoints, Header, Started, sensor_qos, start_node, topic};
use super::{Domain, Ros2Settings};
use crate::kinematics::JOINTS;
use crate::now_ns;
use crate::session::{ArmMeasurement, MeasurementSource};

/// `sensor_msgs/msg/JointState`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct JointState {
    pub header: Header,
    pub name: Vec<String>,
    pub position: Vec<f64>,
    pub velocity: Vec<f64>,
    pub effort: Vec<f64>,
}

/// How long samples are kept (s): longer than any window a protocol may state.
const KEEP_S: f64 = 10.0;
/// The most samples kept (1 kHz for the whole of [`KEEP_S`]).
const MAX_SAMPLES: usize = 10_000;
/// The longest a grasp waits for a sample stamped after it (a 20 Hz system's period).
pub(crate) const SETTLE: Duration = Duration::from_millis(50);

/// What the thread has seen.
#[derive(Debug, Default)]
struct Buffer {
    /// (ns since the Unix epoch, angles in the model's order), in arrival order.
    samples: VecDeque<(u64, [f64; JOINTS])>,
    received: u64,
    dropped: u64,
    last_drop: Option<String>,
}

/// A live source of arm measurements.
pub struct JointStateSource {
    buffer: Arc<Mutex<Buffer>>,
    description: String,
    participant: DomainParticipant,
    domain: Domain,
    endpoint: Endpoint,
}

/// The message's angles in the model's order, or why not.
fn map_joints(m: &JointState, joint_names: &[String]) -> Result<[f64; JOINTS], String> {
    if m.position.len() != m.name.len() {
        return Err(format!("{} names but {} positions", m.name.len(), m.position.len()));
    }
    let mut q = [0.0; JOINTS];
    for (d, wanted) in joint_names.iter().enumerate().take(JOINTS) {
        let i = m.name.iter().position(|n| n == wanted).ok_or_else(|| format!("no joint '{wanted}'"))?;
        let v = m.position[i];
        if !(v.is_finite() && v.abs() <= 10.0) {
            return Err(format!("joint '{wanted}' is {v}, expected a finite angle within ±10 rad"));
        }
        q[d] = v;
    }
    Ok(q)
}

impl Buffer {
    fn take(&mut self, m: &JointState, joint_names: &[String], arrived_ns: u64) {
        self.received += 1;
        match map_joints(m, joint_names) {
            Ok(q) => {
                let stamp =
                    u64::try_from(m.header.stamp.sec).unwrap_or(0) * 1_000_000_000 + u64::from(m.header.stamp.nanosec);
                let t = if stamp == 0 { arrived_ns } else { stamp };
                self.samples.push_back((t, q));
                let oldest = arrived_ns.saturating_sub((KEEP_S * 1e9) as u64);
                while self.samples.len() > MAX_SAMPLES || self.samples.front().is_some_and(|(t, _)| *t < oldest) {
                    self.samples.pop_front();
                }
            }
            Err(why) => {
                self.dropped += 1;
                self.last_drop = Some(why);
            }
        }
    }

    fn pick(&self, time_ns: u64, window_s: f64) -> Option<ArmMeasurement> {
        ArmMeasurement::pick(&self.samples, time_ns, window_s, MeasurementSource::Ros2)
    }

    /// Whether a sample stamped after `time_ns` has arrived.
    fn settled(&self, time_ns: u64) -> bool {
        self.samples.iter().rev().any(|(t, _)| *t > time_ns)
    }
}

impl JointStateSource {
    /// Subscribes (on a thread of its own) to the settings' joint-state topic, mapping the
    /// message's joint names to the model's by `joint_names` (one per model joint).
    pub fn new(settings: &Ros2Settings, joint_names: &[String]) -> Result<Self, String> {
        if joint_names.len() != JOINTS {
            return Err(format!("{} joint names, expected {JOINTS}", joint_names.len()));
        }
        let buffer = Arc::new(Mutex::new(Buffer::default()));
        let (ready_tx, ready) = std::sync::mpsc::channel::<Result<(DomainParticipant, Domain), String>>();
        let (thread_settings, names, shared) = (settings.clone(), joint_names.to_vec(), Arc::clone(&buffer));
        std::thread::spawn(move || {
            let settings = thread_settings;
            let subscription = start_node(&settings, "handover_arm").and_then(|started| {
                let Started { mut node, participant, domain } = started;
                let t = topic(&mut node, &settings.joint_states_topic, "sensor_msgs", "JointState", &sensor_qos())?;
                let s = node
                    .create_subscription::<JointState>(&t, None)
                    .map_err(|e| format!("ROS 2 subscription {}: {e}", settings.joint_states_topic))?;
                Ok((node, s, participant, domain))
            });
            let (_node, subscription) = match subscription {
                Ok((node, s, participant, domain)) => {
                    let _ = ready_tx.send(Ok((participant, domain)));
                    (node, s)
                }
                Err(why) => {
                    let _ = ready_tx.send(Err(why));
                    return;
                }
            };
            loop {
                match subscription.take() {
                    Ok(Some((m, _))) => {
                        let Ok(mut b) = shared.lock() else { return };
                        b.take(&m, &names, now_ns());
                    }
                    Ok(None) | Err(_) => {
                        // The source is dropped with the console: stop then.
                        if Arc::strong_count(&shared) == 1 {
                            return;
                        }
                        std::thread::sleep(Duration::from_millis(2));
                    }
                }
            }
        });
        let (participant, domain) = ready.recv().map_err(|_| "the ROS 2 measurement thread stopped".to_string())??;
        let description =
            format!("ros2 {domain} ← {} (sensor_msgs/JointState, best effort)", settings.joint_states_topic);
        let endpoint = ConsoleEndpoints::of(settings).joint_states;
        Ok(Self { buffer, description, participant, domain, endpoint })
    }

    pub fn describe(&self) -> String {
        self.description.clone()
    }

    /// Why the measuring system cannot be heard, when discovery can tell (nobody publishes,
    /// another message type, incompatible QoS).
    pub fn diagnose(&self) -> Option<String> {
        diagnose(&self.endpoint, &peers(&self.participant, Side::Subscribes), self.domain)
    }

    /// The grasp at `time_ns`'s sample ([`ArmMeasurement::pick`]), once a sample stamped
    /// after it has arrived or [`SETTLE`] has passed.
    pub fn at(&self, time_ns: u64, window_s: f64) -> Option<ArmMeasurement> {
        let end = std::time::Instant::now() + SETTLE;
        loop {
            let b = self.buffer.lock().ok()?;
            if b.settled(time_ns) || std::time::Instant::now() >= end {
                return b.pick(time_ns, window_s);
            }
            drop(b);
            std::thread::sleep(Duration::from_millis(1));
        }
    }

    /// Waits until a message has been received, at most `timeout`; whether one was.
    pub fn wait_until_heard(&self, timeout: Duration) -> bool {
        let end = std::time::Instant::now() + timeout;
        loop {
            if self.counts().0 > 0 {
                return true;
            }
            if std::time::Instant::now() >= end {
                return false;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
    }

    /// Messages received and dropped so far, and why the last was dropped.
    pub fn counts(&self) -> (u64, u64, Option<String>) {
        self.buffer.lock().map_or((0, 0, None), |b| (b.received, b.dropped, b.last_drop.clone()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::robot::ros2::Time;

    fn msg(sec: i32, names: &[&str], position: Vec<f64>) -> JointState {
        JointState {
            header: Header { stamp: Time { sec, nanosec: 0 }, frame_id: String::new() },
            name: names.iter().map(|n| n.to_string()).collect(),
            position,
            velocity: vec![],
            effort: vec![],
        }
    }

    #[test]
    fn samples_are_mapped_by_name_and_the_latest_before_the_grasp_is_taken() {
        let names: Vec<String> = (0..7).map(|d| format!("j{d}")).collect();
        let mut b = Buffer::default();
        // Published in another order, with an extra joint.
        let order = ["j6", "extra", "j5", "j4", "j3", "j2", "j1", "j0"];
        let position =
            |base: f64| vec![base + 0.6, 9.0, base + 0.5, base + 0.4, base + 0.3, base + 0.2, base + 0.1, base];
        b.take(&msg(100, &order, position(0.0)), &names, 0);
        b.take(&msg(101, &order, position(1.0)), &names, 0);
        let m = b.pick(100_400_000_000, 0.5).unwrap();
        assert_eq!(m.q_rad, vec![0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6]);
        assert!((m.offset_s + 0.4).abs() < 1e-9 && m.source == MeasurementSource::Ros2);
        // Nearer to the later sample, but that one was not yet taken: the earlier one.
        assert_eq!(b.pick(100_900_000_000, 1.0).unwrap().q_rad[0], 0.0);
        assert!(b.settled(100_900_000_000) && !b.settled(101_000_000_000));
        assert_eq!(b.pick(101_000_000_000, 0.5).unwrap().q_rad[0], 1.0);
        assert!(b.pick(102_000_000_001, 1.0).is_none(), "outside the window");
        assert!(b.pick(99_000_000_000, 1.0).is_none(), "every sample after the grasp");
        // A message without a mapped joint, or with a bad angle, is dropped and counted.
        b.take(&msg(102, &["j0"], vec![0.0]), &names, 0);
        b.take(&msg(102, &order, vec![f64::NAN; 8]), &names, 0);
        assert_eq!((b.received, b.dropped, b.samples.len()), (4, 2, 2));
        assert!(b.last_drop.as_deref().unwrap().contains("'j0' is NaN"), "{:?}", b.last_drop);
    }
}
