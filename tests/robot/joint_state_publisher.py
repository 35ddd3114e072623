"""A stand-in measuring system for the ROS 2 interop test: an independent DDS implementation
(Cyclone DDS, through its Python binding) publishing sensor_msgs/msg/JointState on the ROS 2
wire, with no ROS install.

It publishes --rate messages a second on --topic for --seconds: the joints of --names (in
that order, plus one joint no protocol maps, as capture systems add), at --positions (rad),
stamped with this machine's clock. It prints "ready" once the writer exists.
"""

import argparse
import sys
import time

from cyclonedds.core import Policy, Qos
from cyclonedds.domain import DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.topic import Topic
from cyclonedds.util import duration

from ros2_types import Header, JointState, Time, dds_name


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--topic", default="/handover/participant/joint_states")
    ap.add_argument("--names", required=True, help="comma-separated joint names, in publishing order")
    ap.add_argument("--positions", required=True, help="comma-separated angles (rad), one per name")
    ap.add_argument("--rate", type=float, default=100.0)
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--domain", type=int, default=0)
    args = ap.parse_args()
    names = args.names.split(",") + ["unmapped_marker"]
    positions = [float(v) for v in args.positions.split(",")] + [0.0]

    qos = Qos(
        Policy.Reliability.Reliable(duration(seconds=1)),
        Policy.Durability.Volatile,
        Policy.History.KeepLast(10),
    )
    dp = DomainParticipant(args.domain)
    writer = DataWriter(dp, Topic(dp, dds_name(args.topic), JointState), qos=qos)
    print("ready", flush=True)
    end = time.monotonic() + args.seconds
    while time.monotonic() < end:
        now = time.time_ns()
        stamp = Time(sec=now // 1_000_000_000, nanosec=now % 1_000_000_000)
        writer.write(
            JointState(
                header=Header(stamp=stamp, frame_id="mocap"),
                name=names,
                position=positions,
                velocity=[],
                effort=[],
            )
        )
        time.sleep(1.0 / args.rate)
    return 0


if __name__ == "__main__":
    sys.exit(main())
