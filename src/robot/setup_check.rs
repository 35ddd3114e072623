//! `handover robot-check`: a lab's ROS 2 setup checked without moving anything. The console's
//! side joins the domain with no endpoints of its own, waits for discovery, and says, for each
//! topic the console would use, how many endpoints on the other side could exchange messages
//! with it, or why none can ([`super::discovery`]).

use std::time::Duration;

use super::discovery::{
    Endpoint, Side, announcements, diagnose, interfaces, matching, matching_peers, peers, reached_via,
};
use super::ros2::{ConsoleEndpoints, start_node};
use super::{Domain, RobotSettings};
use ros2_client::dds::rustdds::RTPSEntity;

/// One topic of the console's, as discovery found its other side.
#[derive(Clone, Debug, PartialEq)]
pub struct TopicCheck {
    pub topic: String,
    pub ros_type: &'static str,
    pub side: Side,
    /// Endpoints on the other side that match.
    pub matching: usize,
    /// Why none does (when none does).
    pub problem: Option<String>,
    /// Whether a session needs it (the trial topic is for robots that want it).
    pub required: bool,
    /// Where the matching endpoints are, from this machine (`ADDRESS via INTERFACE`).
    pub found_on: Vec<String>,
}

/// What `robot-check` checks: the robot's topics, the measuring system's, or both.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Checked {
    pub robot: bool,
    pub measure: bool,
}

/// The console's endpoints, each with whether a session needs it: the robot's topics, the
/// arm's, or both.
fn console_endpoints(settings: &RobotSettings, checked: Checked) -> Vec<(Endpoint, bool)> {
    let e = ConsoleEndpoints::of(&settings.ros2);
    let mut all = Vec::new();
    if checked.robot {
        all.extend([(e.pose, true), (e.trial, false), (e.status, true)]);
    }
    if checked.measure {
        all.push((e.joint_states, true));
    }
    all
}

/// What `robot-check` found.
#[derive(Clone, Debug)]
pub struct SetupReport {
    pub domain: Domain,
    pub checks: Vec<TopicCheck>,
    /// Where other participants' announcements came from (`ADDRESS via INTERFACE`, `this
    /// machine`), on any interface, whatever `ros2.networks` allows.
    pub heard_on: Vec<String>,
    /// Local addresses of the interfaces those announcements came in on that
    /// `ros2.networks` leaves out (none when it allows every network).
    pub excluded: Vec<std::net::IpAddr>,
}

/// Joins the settings' domain, waits `wait` for discovery, and checks every topic.
pub fn check_setup(settings: &RobotSettings, checked: Checked, wait: Duration) -> Result<SetupReport, String> {
    let domain = settings.ros2.domain().map_err(|e| e.to_string())?;
    // Where each participant's announcements come from, heard while discovery runs.
    let listener = std::thread::spawn(move || announcements(domain.id, wait));
    let started = start_node(&settings.ros2, "handover_check")?;
    let heard = listener.join().unwrap_or_default();
    let local = interfaces();
    let checks = console_endpoints(settings, checked)
        .into_iter()
        .map(|(ours, required)| {
            let others = peers(&started.participant, ours.side);
            let addresses: Vec<_> = matching_peers(&ours, &others)
                .flat_map(|p| heard.get(&p.participant).into_iter().flatten().copied())
                .collect();
            TopicCheck {
                matching: matching(&ours, &others),
                problem: diagnose(&ours, &others, started.domain),
                found_on: reached_via(&addresses, &local),
                topic: ours.topic,
                ros_type: ours.ros_type,
                side: ours.side,
                required,
            }
        })
        .collect();
    let own = started.participant.guid().prefix;
    let others: Vec<std::net::IpAddr> = heard
        .iter()
        .filter(|(p, _)| p.as_slice() != own.as_ref())
        .flat_map(|(_, sources)| sources.iter().copied())
        .collect();
    let networks = &settings.ros2.networks;
    let mut excluded: Vec<std::net::IpAddr> = local
        .iter()
        .filter(|i| !networks.is_empty() && !networks.contains(&i.address) && !i.address.is_loopback())
        .filter(|i| others.iter().any(|&ip| i.reaches(ip) && !local.iter().any(|l| l.address == ip)))
        .map(|i| i.address)
        .collect();
    excluded.dedup();
    Ok(SetupReport { domain: started.domain, checks, heard_on: reached_via(&others, &local), excluded })
}
