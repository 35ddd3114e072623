"""A robot node for the ROS 2 interop tests (rclpy) that answers as told, to test what the
console does when a robot fails, says nothing, or cannot be matched.

--answer: `at_pose` ("moving", then "at_pose"), `failed` ("moving", then "failed: …"), or
`silent` (nothing). --durability transient_local subscribes to the pose topic with a QoS the
console's volatile publisher cannot match (a latched-topic habit); --pose-type string
subscribes to it with the wrong message type. Prints "ready" once its endpoints exist.
"""

import argparse

import rclpy
from geometry_msgs.msg import PoseStamped
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import String


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--answer", choices=["at_pose", "failed", "silent"], default="at_pose")
    ap.add_argument("--durability", choices=["volatile", "transient_local"], default="volatile")
    ap.add_argument("--pose-type", choices=["pose", "string"], default="pose")
    args = ap.parse_args()
    rclpy.init()
    node = Node("handover_test_robot")
    status = node.create_publisher(String, "/handover/robot_status", 10)
    durability = {"volatile": DurabilityPolicy.VOLATILE, "transient_local": DurabilityPolicy.TRANSIENT_LOCAL}
    qos = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE, durability=durability[args.durability])

    def on_pose(_msg) -> None:
        if args.answer == "silent":
            return
        status.publish(String(data="moving"))
        status.publish(String(data="at_pose" if args.answer == "at_pose" else "failed: gripper fault"))

    pose_type = PoseStamped if args.pose_type == "pose" else String
    node.create_subscription(pose_type, "/handover/target_pose", on_pose, qos)
    print("ready", flush=True)
    rclpy.spin(node)


if __name__ == "__main__":
    main()
