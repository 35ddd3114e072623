//! What DDS discovery knows about the other side of one of the console's topics, in words:
//! nobody there, someone there with another message type, or someone there whose QoS cannot
//! match the console's. DDS itself says none of this to either side (a mismatched pair simply
//! never exchanges data), so a robot that never answers, or a measuring system that is never
//! heard, is explained from the discovery database.

use std::net::IpAddr;

use ros2_client::dds::rustdds::qos::QosPolicyId;
use ros2_client::dds::rustdds::{DomainParticipant, QosPolicies, RTPSEntity, policy};

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
    /// Its participant's GUID prefix.
    pub participant: [u8; 12],
}

/// A GUID prefix's bytes.
fn prefix_bytes(prefix: &(impl AsRef<[u8]> + ?Sized)) -> [u8; 12] {
    let mut out = [0; 12];
    let b = prefix.as_ref();
    out[..b.len().min(12)].copy_from_slice(&b[..b.len().min(12)]);
    out
}

/// The UDP port of a domain's discovery multicast (SPDP: RTPS 2.x's PB + DG × domain).
pub fn discovery_port(domain: u16) -> u16 {
    7400 + 250 * domain
}

/// The group discovery announcements are multicast to.
const DISCOVERY_GROUP: std::net::Ipv4Addr = std::net::Ipv4Addr::new(239, 255, 0, 1);

/// Listens for `wait` to the participants' discovery announcements multicast in `domain`
/// (on every IPv4 interface, beside the DDS participant's own socket) and says where each
/// participant's came from: GUID prefix → source addresses. Empty if the port cannot be
/// shared.
#[cfg(unix)]
pub fn announcements(domain: u16, wait: std::time::Duration) -> std::collections::HashMap<[u8; 12], Vec<IpAddr>> {
    use std::os::fd::FromRawFd;
    let mut heard: std::collections::HashMap<[u8; 12], Vec<IpAddr>> = Default::default();
    // SAFETY: a socket made here and handed to UdpSocket, which owns and closes it; the
    // options are plain ints.
    let socket = unsafe {
        let fd = libc::socket(libc::AF_INET, libc::SOCK_DGRAM | libc::SOCK_CLOEXEC, 0);
        if fd < 0 {
            return heard;
        }
        let socket = std::net::UdpSocket::from_raw_fd(fd);
        let one: libc::c_int = 1;
        for option in [libc::SO_REUSEADDR, libc::SO_REUSEPORT] {
            let p = (&raw const one).cast::<libc::c_void>();
            libc::setsockopt(fd, libc::SOL_SOCKET, option, p, size_of::<libc::c_int>() as libc::socklen_t);
        }
        let addr = libc::sockaddr_in {
            sin_family: libc::AF_INET as libc::sa_family_t,
            sin_port: discovery_port(domain).to_be(),
            sin_addr: libc::in_addr { s_addr: 0 },
            sin_zero: [0; 8],
        };
        let p = (&raw const addr).cast::<libc::sockaddr>();
        if libc::bind(fd, p, size_of::<libc::sockaddr_in>() as libc::socklen_t) != 0 {
            return heard;
        }
        socket
    };
    for i in interfaces() {
        if let IpAddr::V4(v4) = i.address {
            let _ = socket.join_multicast_v4(&DISCOVERY_GROUP, &v4);
        }
    }
    let deadline = std::time::Instant::now() + wait;
    let mut buf = [0u8; 2048];
    while let Some(left) = deadline.checked_duration_since(std::time::Instant::now()).filter(|d| !d.is_zero()) {
        let _ = socket.set_read_timeout(Some(left.min(std::time::Duration::from_millis(100))));
        // An RTPS message: "RTPS", version, vendor, then the sender's GUID prefix.
        if let Ok((n, from)) = socket.recv_from(&mut buf)
            && n >= 20
            && &buf[..4] == b"RTPS"
        {
            let prefix = prefix_bytes(&buf[8..20]);
            let sources = heard.entry(prefix).or_default();
            if !sources.contains(&from.ip()) {
                sources.push(from.ip());
            }
        }
    }
    heard
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
/// `participant` has discovered them; its own (discovery lists them too) are left out.
pub fn peers(participant: &DomainParticipant, side: Side) -> Vec<Peer> {
    let own = participant.guid().prefix;
    let of = |g: &ros2_client::dds::rustdds::GUID| prefix_bytes(&g.prefix);
    match side {
        Side::Publishes => participant
            .discovered_readers()
            .into_iter()
            .filter(|r| r.reader_proxy.remote_reader_guid.prefix != own)
            .map(|r| Peer {
                dds_topic: r.subscription_topic_data.topic_name().clone(),
                dds_type: r.subscription_topic_data.type_name().clone(),
                qos: r.subscription_topic_data.qos(),
                participant: of(&r.reader_proxy.remote_reader_guid),
            })
            .collect(),
        Side::Subscribes => participant
            .discovered_writers()
            .into_iter()
            .filter(|w| w.writer_proxy.remote_writer_guid.prefix != own)
            .map(|w| Peer {
                dds_topic: w.publication_topic_data.topic_name.clone(),
                dds_type: w.publication_topic_data.type_name.clone(),
                qos: w.publication_topic_data.qos(),
                participant: of(&w.writer_proxy.remote_writer_guid),
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
    matching_peers(ours, peers).count()
}

/// The endpoints among `peers` that can exchange messages with `ours`.
pub fn matching_peers<'a>(ours: &'a Endpoint, peers: &'a [Peer]) -> impl Iterator<Item = &'a Peer> {
    let topic = dds_topic(&ours.topic);
    peers.iter().filter(move |p| p.dds_topic == topic && problem(ours, p).is_none())
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

/// One of this machine's network interfaces: its name, an address and the prefix length.
#[derive(Clone, Debug, PartialEq)]
pub struct Interface {
    pub name: String,
    pub address: IpAddr,
    pub prefix: u8,
}

impl Interface {
    /// Whether `ip` is on this interface's network (or is its own address).
    pub fn reaches(&self, ip: IpAddr) -> bool {
        let bits = |a: IpAddr| match a {
            IpAddr::V4(v) => (u128::from(u32::from(v)), 32),
            IpAddr::V6(v) => (u128::from(v), 128),
        };
        let ((ours, len), (theirs, len2)) = (bits(self.address), bits(ip));
        if len != len2 || self.prefix > len {
            return false;
        }
        let shift = u32::from(len - self.prefix);
        shift >= 128 || (ours >> shift) == (theirs >> shift)
    }
}

/// This machine's interfaces with an IP address (getifaddrs).
#[cfg(unix)]
pub fn interfaces() -> Vec<Interface> {
    let mut out = Vec::new();
    let mut list: *mut libc::ifaddrs = std::ptr::null_mut();
    // SAFETY: getifaddrs fills `list` with a linked list that is freed below; every pointer
    // read is checked for null and read only while the list lives.
    unsafe {
        if libc::getifaddrs(&mut list) != 0 {
            return out;
        }
        let mut at = list;
        while !at.is_null() {
            let a = &*at;
            at = a.ifa_next;
            if a.ifa_addr.is_null() || a.ifa_name.is_null() {
                continue;
            }
            let ip = |sa: *const libc::sockaddr| -> Option<IpAddr> {
                if sa.is_null() {
                    return None;
                }
                match i32::from((*sa).sa_family) {
                    libc::AF_INET => {
                        let v = &*(sa.cast::<libc::sockaddr_in>());
                        Some(IpAddr::from(u32::from_be(v.sin_addr.s_addr).to_be_bytes()))
                    }
                    libc::AF_INET6 => Some(IpAddr::from((*(sa.cast::<libc::sockaddr_in6>())).sin6_addr.s6_addr)),
                    _ => None,
                }
            };
            let Some(address) = ip(a.ifa_addr) else { continue };
            let prefix = ip(a.ifa_netmask).map_or(0, |m| match m {
                IpAddr::V4(v) => u32::from(v).count_ones() as u8,
                IpAddr::V6(v) => u128::from(v).count_ones() as u8,
            });
            let name = std::ffi::CStr::from_ptr(a.ifa_name).to_string_lossy().into_owned();
            out.push(Interface { name, address, prefix });
        }
        libc::freeifaddrs(list);
    }
    out
}

/// Where an endpoint at `addresses` is reached from this machine: `ADDRESS via INTERFACE`
/// for each address on one of `interfaces`' networks (the endpoint's own machine: `on this
/// machine`), each once.
pub fn reached_via(addresses: &[IpAddr], interfaces: &[Interface]) -> Vec<String> {
    let mut out: Vec<String> = addresses
        .iter()
        .filter_map(|&ip| {
            if interfaces.iter().any(|i| i.address == ip) || ip.is_loopback() {
                return Some("this machine".to_string());
            }
            let via = interfaces.iter().find(|i| !i.address.is_loopback() && i.reaches(ip))?;
            Some(format!("{ip} via {} ({}/{})", via.name, via.address, via.prefix))
        })
        .collect();
    out.sort();
    out.dedup();
    out
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
        Peer { dds_topic: topic.into(), dds_type: ty.into(), qos: q, participant: [0; 12] }
    }

    const POSE: &str = "geometry_msgs::msg::dds_::PoseStamped_";
    const DOMAIN: Domain = Domain { id: 7, from: "ROS_DOMAIN_ID" };

    #[test]
    fn a_peer_is_placed_on_the_interface_whose_network_holds_it() {
        let iface = |name: &str, a: &str, prefix| Interface { name: name.into(), address: a.parse().unwrap(), prefix };
        let ifaces = [iface("lo", "127.0.0.1", 8), iface("wlan0", "192.168.1.20", 24), iface("eth1", "10.20.0.1", 16)];
        let ip = |a: &str| a.parse::<IpAddr>().unwrap();
        assert_eq!(reached_via(&[ip("10.20.3.4")], &ifaces), ["10.20.3.4 via eth1 (10.20.0.1/16)"]);
        assert_eq!(
            reached_via(&[ip("192.168.1.7"), ip("10.21.0.1")], &ifaces),
            ["192.168.1.7 via wlan0 (192.168.1.20/24)"]
        );
        assert_eq!(reached_via(&[ip("192.168.1.20"), ip("127.0.0.1")], &ifaces), ["this machine"]);
        assert!(reached_via(&[ip("172.16.0.1"), ip("fe80::1")], &ifaces).is_empty());
        assert!(iface("any", "0.0.0.0", 0).reaches(ip("8.8.8.8")));
        assert!(!iface("v4", "10.0.0.1", 8).reaches(ip("::1")));
        // This machine has a loopback at least.
        assert!(interfaces().iter().any(|i| i.address.is_loopback()), "{:?}", interfaces());
    }

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
