//! What DDS discovery knows about the other side of one of the console's topics, in words:
//! nobody there, someone there with another message type, or someone there whose QoS cannot
//! match the console's. DDS itself says none of this to either side (a mismatched pair simply
//! never exchanges data), so a robot that never answers, or a measuring system that is never
//! heard, is explained from the discovery database.

use ros2_client::dds::rustdds::DomainParticipant;
use ros2_client::dds::rustdds::qos::QosPolicyId;
use ros2_client::dds::rustdds::{QosPolicies, policy};

use super::Domain;

/// Which side of the topic the console is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    /// The console publishes; the other side subscribes.
    Publishes,
    /// The console subscribes; the other side publishes.
    Subscribes,
}

/// One of the console's endpoints, as discovery compares it with the others.
#[derive(Clone, Debug)]
pub struct Endpoint {
    /// The ROS 2 topic name (`/handover/target_pose`).
    pub topic: String,
    /// The ROS 2 message type (`geometry_msgs/msg/PoseStamped`).
    pub ros_type: &'static str,
    pub side: Side,
    pub qos: QosPolicies,
}

/// What discovery knows of one endpoint on the other side.
#[derive(Clone, Debug, PartialEq)]
pub struct Peer {
    /// The DDS topic name (`rt/handover/target_pose`).
    pub dds_topic: String,
    /// The DDS type name (`geometry_msgs::msg::dds_::PoseStamped_`).
    pub dds_type: String,
    pub qos: QosPolicies,
}

/// The DDS name of a ROS 2 topic (`/a/b` → `rt/a/b`).
pub(crate) fn dds_topic(ros_topic: &str) -> String {
    format!("rt/{}", ros_topic.trim_start_matches('/'))
}

/// The ROS 2 name of a DDS type (`pkg::msg::dds_::Type_` → `pkg/msg/Type`); other names
/// as they are.
pub fn ros_type(dds_type: &str) -> String {
    match dds_type.split("::").collect::<Vec<_>>().as_slice() {
        [package, kind, "dds_", name] if name.ends_with('_') => {
            format!("{package}/{kind}/{}", &name[..name.len() - 1])
        }
        _ => dds_type.to_string(),
    }
}

/// The ROS 2 name of a DDS topic (`rt/a/b` → `/a/b`); other names as they are.
fn ros_topic(dds_topic: &str) -> String {
    dds_topic.strip_prefix("rt").map_or_else(|| dds_topic.to_string(), str::to_string)
}

/// The endpoints on the other side of a topic of the console's, on any topic, as
/// `participant` has discovered them (its own are not among them).
pub fn peers(participant: &DomainParticipant, side: Side) -> Vec<Peer> {
    match side {
        Side::Publishes => participant
            .discovered_readers()
            .into_iter()
            .map(|r| Peer {
                dds_topic: r.subscription_topic_data.topic_name().clone(),
                dds_type: r.subscription_topic_data.type_name().clone(),
                qos: r.subscription_topic_data.qos(),
            })
            .collect(),
        Side::Subscribes => participant
            .discovered_writers()
            .into_iter()
            .map(|w| Peer {
                dds_topic: w.publication_topic_data.topic_name.clone(),
                dds_type: w.publication_topic_data.type_name.clone(),
                qos: w.publication_topic_data.qos(),
            })
            .collect(),
    }
}

/// A QoS policy's value on one side, as `ros2 topic info -v` words it.
fn policy_value(qos: &QosPolicies, id: QosPolicyId) -> String {
    match id {
        QosPolicyId::Reliability => match qos.reliability() {
            Some(policy::Reliability::BestEffort) => "BEST_EFFORT".into(),
            Some(policy::Reliability::Reliable { .. }) => "RELIABLE".into(),
            None => "BEST_EFFORT (unstated)".into(),
        },
        QosPolicyId::Durability => match qos.durability() {
            Some(policy::Durability::Volatile) | None => "VOLATILE".into(),
            Some(policy::Durability::TransientLocal) => "TRANSIENT_LOCAL".into(),
            Some(policy::Durability::Transient) => "TRANSIENT".into(),
            Some(policy::Durability::Persistent) => "PERSISTENT".into(),
        },
        other => format!("{other:?}"),
    }
}

/// Why `peer` (on `ours`' topic) cannot exchange messages with `ours`, or `None` when it can.
fn problem(ours: &Endpoint, peer: &Peer) -> Option<String> {
    let they = match ours.side {
        Side::Publishes => "subscriber",
        Side::Subscribes => "publisher",
    };
    let theirs = ros_type(&peer.dds_type);
    if theirs != ours.ros_type {
        return Some(format!("a {they} of {} takes {theirs}, not {}", ours.topic, ours.ros_type));
    }
    let (offered, requested) = match ours.side {
        Side::Publishes => (&ours.qos, &peer.qos),
        Side::Subscribes => (&peer.qos, &ours.qos),
    };
    offered.compliance_failure_wrt(requested).map(|id| {
        format!(
            "a {they} of {} cannot match the console's QoS: {} {} offered, {} requested",
            ours.topic,
            format!("{id:?}").to_uppercase(),
            policy_value(offered, id),
            policy_value(requested, id),
        )
    })
}

/// How many of `peers` can exchange messages with `ours`.
pub fn matching(ours: &Endpoint, peers: &[Peer]) -> usize {
    let topic = dds_topic(&ours.topic);
    peers.iter().filter(|p| p.dds_topic == topic && problem(ours, p).is_none()).count()
}

/// Why the other side of `ours` cannot be heard, or `None` when discovery shows a matching
/// endpoint there. `peers` is what discovery knows (see [`peers`]).
pub fn diagnose(ours: &Endpoint, peers: &[Peer], domain: Domain) -> Option<String> {
    let topic = dds_topic(&ours.topic);
    let on_topic: Vec<&Peer> = peers.iter().filter(|p| p.dds_topic == topic).collect();
    let (they, verb) = match ours.side {
        Side::Publishes => ("subscriber", "subscribes to"),
        Side::Subscribes => ("publisher", "publishes"),
    };
    if on_topic.is_empty() {
        let mut why = format!("nobody {verb} {} in ROS 2 {domain}", ours.topic);
        let mut elsewhere: Vec<String> =
            peers.iter().filter(|p| ros_type(&p.dds_type) == ours.ros_type).map(|p| ros_topic(&p.dds_topic)).collect();
        elsewhere.sort();
        elsewhere.dedup();
        if !elsewhere.is_empty() {
            elsewhere.truncate(5);
            why += &format!(" ({} {they}s seen on {})", ours.ros_type, elsewhere.join(", "));
        }
        return Some(why);
    }
    let mut problems = Vec::new();
    for p in &on_topic {
        match problem(ours, p) {
            None => return None,
            Some(why) => problems.push(why),
        }
    }
    problems.dedup();
    Some(problems.join("; "))
}

#[cfg(test)]
mod tests {
    use ros2_client::dds::rustdds::QosPolicyBuilder;

    use super::*;

    fn qos(reliable: bool, transient: bool) -> QosPolicies {
        QosPolicyBuilder::new()
            .reliability(if reliable {
                policy::Reliability::Reliable { max_blocking_time: ros2_client::dds::rustdds::Duration::ZERO }
            } else {
                policy::Reliability::BestEffort
            })
            .durability(if transient { policy::Durability::TransientLocal } else { policy::Durability::Volatile })
            .build()
    }

    fn peer(topic: &str, ty: &str, q: QosPolicies) -> Peer {
        Peer { dds_topic: topic.into(), dds_type: ty.into(), qos: q }
    }

    const POSE: &str = "geometry_msgs::msg::dds_::PoseStamped_";
    const DOMAIN: Domain = Domain { id: 7, from: "ROS_DOMAIN_ID" };

    #[test]
    fn names_are_mapped_between_ros2_and_dds() {
        assert_eq!(dds_topic("/handover/target_pose"), "rt/handover/target_pose");
        assert_eq!(ros_type(POSE), "geometry_msgs/msg/PoseStamped");
        assert_eq!(ros_type("std_msgs::msg::dds_::String_"), "std_msgs/msg/String");
        assert_eq!(ros_type("Foo"), "Foo");
        assert_eq!(ros_topic("rt/a/b"), "/a/b");
    }

    #[test]
    fn each_mismatch_is_said_in_words() {
        let ours = Endpoint {
            topic: "/handover/target_pose".into(),
            ros_type: "geometry_msgs/msg/PoseStamped",
            side: Side::Publishes,
            qos: qos(true, false),
        };
        // Nobody, with the same type seen on another topic.
        let other = peer("rt/robot/goal", POSE, qos(true, false));
        assert_eq!(
            diagnose(&ours, std::slice::from_ref(&other), DOMAIN).unwrap(),
            "nobody subscribes to /handover/target_pose in ROS 2 domain 7 (ROS_DOMAIN_ID) \
             (geometry_msgs/msg/PoseStamped subscribers seen on /robot/goal)"
        );
        // Another type.
        let wrong = peer("rt/handover/target_pose", "std_msgs::msg::dds_::String_", qos(true, false));
        assert_eq!(
            diagnose(&ours, std::slice::from_ref(&wrong), DOMAIN).unwrap(),
            "a subscriber of /handover/target_pose takes std_msgs/msg/String, not geometry_msgs/msg/PoseStamped"
        );
        // A durability the console does not offer.
        let latched = peer("rt/handover/target_pose", POSE, qos(true, true));
        let why = diagnose(&ours, &[latched], DOMAIN).unwrap();
        assert!(why.contains("DURABILITY VOLATILE offered, TRANSIENT_LOCAL requested"), "{why}");
        // One matching subscriber is enough, whatever else is there; best effort matches reliable.
        assert_eq!(diagnose(&ours, &[wrong, peer("rt/handover/target_pose", POSE, qos(false, false))], DOMAIN), None);

        // The console subscribing reliably to a best-effort publisher.
        let status = Endpoint {
            topic: "/handover/robot_status".into(),
            ros_type: "std_msgs/msg/String",
            side: Side::Subscribes,
            qos: qos(true, false),
        };
        let sensor = peer("rt/handover/robot_status", "std_msgs::msg::dds_::String_", qos(false, false));
        let why = diagnose(&status, &[sensor], DOMAIN).unwrap();
        assert!(why.contains("a publisher of /handover/robot_status cannot match"), "{why}");
        assert!(why.contains("RELIABILITY BEST_EFFORT offered, RELIABLE requested"), "{why}");
        assert_eq!(
            diagnose(&status, &[], DOMAIN).unwrap(),
            "nobody publishes /handover/robot_status in ROS 2 domain 7 (ROS_DOMAIN_ID)"
        );
    }
}
