"""A robot node for the ROS 2 interop tests (rclpy) that answers as told, to test what the
console does when a robot fails, says nothing, or cannot be matched.

--answer: `at_pose` ("moving", then "at_pose"), `at_pose_only` (only "at_pose"), `failed`
("moving", then "failed: …"), or `silent` (nothing). It takes every publication in turn and
blocks --move-s seconds on each (a blocking MoveIt call), repeats included; --names names the
command (the pose's stamp) in each status, else statuses are bare (robot nodes written before
command ids); --once takes a repeated command once (as the guide asks); --twice says the final answer twice. --out FILE writes a JSON line per status
it sent: the command it answers and the text. --durability transient_local subscribes to the
pose topic with a QoS the console's volatile publisher cannot match (a latched-topic habit);
--pose-type string subscribes to it with the wrong message type. Prints "ready" once its
endpoints exist.
"""

import argparse
import json
import time

import rclpy
from geometry_msgs.msg import PoseStamped
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import String

from spin import spin_until_sigint


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--answer", choices=["at_pose", "at_pose_only", "failed", "silent"], default="at_pose")
    ap.add_argument("--move-s", type=float, default=0.0)
    ap.add_argument("--names", action="store_true")
    ap.add_argument("--twice", action="store_true")
    ap.add_argument("--once", action="store_true")
    ap.add_argument("--out")
    ap.add_argument("--durability", choices=["volatile", "transient_local"], default="volatile")
    ap.add_argument("--pose-type", choices=["pose", "string"], default="pose")
    args = ap.parse_args()
    rclpy.init()
    node = Node("handover_test_robot")
    status = node.create_publisher(String, "/handover/robot_status", 10)
    durability = {"volatile": DurabilityPolicy.VOLATILE, "transient_local": DurabilityPolicy.TRANSIENT_LOCAL}
    qos = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE, durability=durability[args.durability])

    out = open(args.out, "a", encoding="utf-8") if args.out else None
    taken = set()

    def say(command: str, state: str, why: str = "") -> None:
        text = f"{state} {command}" if args.names else state
        text += f": {why}" if why else ""
        status.publish(String(data=text))
        if out:
            out.write(json.dumps({"command": command, "text": text, "t": time.time()}) + "\n")
            out.flush()

    def on_pose(msg) -> None:
        if args.answer == "silent":
            return
        command = f"{msg.header.stamp.sec}.{msg.header.stamp.nanosec:09d}" if args.pose_type == "pose" else ""
        if args.once and command in taken:
            return
        taken.add(command)
        if args.answer != "at_pose_only":
            say(command, "moving")
        time.sleep(args.move_s)
        for _ in range(2 if args.twice else 1):
            if args.answer == "failed":
                say(command, "failed", "gripper fault")
            else:
                say(command, "at_pose")

    pose_type = PoseStamped if args.pose_type == "pose" else String
    node.create_subscription(pose_type, "/handover/target_pose", on_pose, qos)
    print("ready", flush=True)
    spin_until_sigint(node)


if __name__ == "__main__":
    main()
