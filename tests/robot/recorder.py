"""A recorder node for the ROS 2 interop tests (rclpy): every message on the handover pose,
trial and status topics, one JSON line each in --out, in the order they arrive. Floats are
written as Python's repr, which reads back to the same float64 bits.

It subscribes with the ROS 2 default QoS at depth 100 (so nothing is dropped), prints
"ready" once its subscriptions exist, and spins until SIGINT. A pose's stamp is written as the
command id it carries (`SEC.NANOSEC`).
"""

import argparse
import json

import rclpy
from geometry_msgs.msg import PoseStamped
from rclpy.node import Node
from std_msgs.msg import String

from spin import spin_until_sigint


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--out", required=True)
    args = ap.parse_args()
    rclpy.init()
    node = Node("handover_test_recorder")
    out = open(args.out, "a", encoding="utf-8")

    def write(record: dict) -> None:
        out.write(json.dumps(record) + "\n")
        out.flush()

    def on_pose(m: PoseStamped) -> None:
        p, q = m.pose.position, m.pose.orientation
        write(
            {
                "topic": "pose",
                "stamp": f"{m.header.stamp.sec}.{m.header.stamp.nanosec:09d}",
                "frame_id": m.header.frame_id,
                "position": [p.x, p.y, p.z],
                "orientation": [q.x, q.y, q.z, q.w],
            }
        )

    node.create_subscription(PoseStamped, "/handover/target_pose", on_pose, 100)
    node.create_subscription(String, "/handover/trial", lambda m: write({"topic": "trial", "data": m.data}), 100)
    node.create_subscription(
        String, "/handover/robot_status", lambda m: write({"topic": "status", "data": m.data}), 100
    )
    print("ready", flush=True)
    spin_until_sigint(node)


if __name__ == "__main__":
    main()
