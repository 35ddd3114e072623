"""A stand-in robot for the ROS 2 interop tests: an independent DDS implementation (Cyclone
DDS, through its Python binding) speaking the ROS 2 wire types, with no ROS install.

It subscribes to the handover pose (geometry_msgs/msg/PoseStamped) and trial
(std_msgs/msg/String) topics, records every message it receives as one JSON line in --out,
and answers each pose on the status topic (std_msgs/msg/String) as --answer says:
`at_pose` ("moving", then "at_pose"), `failed` ("moving", then "failed"), or `silent`
(nothing, so that the console times out). It stops after --seconds.
"""

import argparse
import json
import sys
import time

from cyclonedds.core import Policy, Qos
from cyclonedds.domain import DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

from ros2_types import PoseStamped, String, dds_name


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--answer", choices=["at_pose", "failed", "silent"], default="at_pose")
    ap.add_argument("--out", required=True, help="JSON lines of everything received")
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--domain", type=int, default=0)
    ap.add_argument("--pose-topic", default="/handover/target_pose")
    ap.add_argument("--trial-topic", default="/handover/trial")
    ap.add_argument("--status-topic", default="/handover/robot_status")
    args = ap.parse_args()

    # The ROS 2 default QoS: reliable, volatile, keep last 10.
    qos = Qos(
        Policy.Reliability.Reliable(duration(seconds=1)),
        Policy.Durability.Volatile,
        Policy.History.KeepLast(10),
    )
    dp = DomainParticipant(args.domain)
    poses = DataReader(dp, Topic(dp, dds_name(args.pose_topic), PoseStamped), qos=qos)
    trials = DataReader(dp, Topic(dp, dds_name(args.trial_topic), String), qos=qos)
    status = DataWriter(dp, Topic(dp, dds_name(args.status_topic), String), qos=qos)

    end = time.monotonic() + args.seconds
    with open(args.out, "a", encoding="utf-8") as out:
        print("ready", flush=True)
        while time.monotonic() < end:
            for m in trials.take(N=10):
                out.write(json.dumps({"topic": args.trial_topic, "t": time.time(), "trial": json.loads(m.data)}) + "\n")
                out.flush()
            for m in poses.take(N=10):
                p, o = m.pose.position, m.pose.orientation
                out.write(
                    json.dumps(
                        {
                            "topic": args.pose_topic,
                            "t": time.time(),
                            "frame_id": m.header.frame_id,
                            "stamp": [m.header.stamp.sec, m.header.stamp.nanosec],
                            "position": [p.x, p.y, p.z],
                            "orientation": [o.x, o.y, o.z, o.w],
                        }
                    )
                    + "\n"
                )
                out.flush()
                if args.answer == "silent":
                    continue
                status.write(String(data="moving"))
                time.sleep(0.05)
                status.write(String(data=args.answer))
            time.sleep(0.005)
    return 0


if __name__ == "__main__":
    sys.exit(main())
