"""A measuring system for the ROS 2 interop tests (rclpy): sensor_msgs/msg/JointState at
--rate Hz on --topic, with the QoS measuring systems use (--qos sensor: rclpy's
qos_profile_sensor_data, best effort) or the ROS 2 default (--qos default: reliable).

Each message names the joints of --names in that order plus one no protocol maps, as capture
systems add; joint i of message k is at --positions[i] + 0.001 sin(0.37 k + i) rad, so every
sample differs. It is stamped with this machine's clock, and every sample published is
written to --out as one JSON line (stamp in ns, positions in --names' order, as repr floats,
which read back to the same float64 bits). Prints "ready" once the publisher exists.
"""

import argparse
import json
import math
import time

import rclpy
from rclpy.node import Node
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import JointState


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--topic", default="/handover/participant/joint_states")
    ap.add_argument("--names", required=True, help="comma-separated joint names, in publishing order")
    ap.add_argument("--positions", required=True, help="comma-separated angles (rad), one per name")
    ap.add_argument("--qos", choices=["sensor", "default"], default="sensor")
    ap.add_argument("--rate", type=float, default=100.0)
    ap.add_argument("--out", required=True)
    args = ap.parse_args()
    names = args.names.split(",")
    base = [float(v) for v in args.positions.split(",")]
    rclpy.init()
    node = Node("handover_test_mocap")
    qos = qos_profile_sensor_data if args.qos == "sensor" else 10
    publisher = node.create_publisher(JointState, args.topic, qos)
    out = open(args.out, "a", encoding="utf-8")
    print("ready", flush=True)
    try:
        publish(args, node, publisher, out, names, base)
    except KeyboardInterrupt:
        pass  # SIGINT: the node ends and DDS releases its shared memory
    node.destroy_node()
    rclpy.try_shutdown()


def publish(args, node, publisher, out, names, base) -> None:
    k = 0
    while True:
        positions = [b + 0.001 * math.sin(0.37 * k + i) for i, b in enumerate(base)]
        now = time.time_ns()
        m = JointState()
        m.header.stamp.sec = now // 1_000_000_000
        m.header.stamp.nanosec = now % 1_000_000_000
        m.header.frame_id = "mocap"
        m.name = names + ["unmapped_marker"]
        m.position = positions + [0.0]
        publisher.publish(m)
        out.write(json.dumps({"stamp_ns": now, "position": positions}) + "\n")
        out.flush()
        k += 1
        time.sleep(1.0 / args.rate)


if __name__ == "__main__":
    main()
