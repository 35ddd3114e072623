#!/usr/bin/env python3
"""A minimal robot-side ROS 2 node for `handover run --robot ros2` (rclpy; any ROS 2 distro).

It takes each handover pose the console publishes on /handover/target_pose
(geometry_msgs/msg/PoseStamped: the object's centre and orientation, in the frame the header
names: `shoulder`, the participant's shoulder, unless the lab's --robot-config gives a
base_frame) and the trial on /handover/trial (std_msgs/msg/String, JSON: phase, trial,
attempt, query, label, object, grips), and answers on /handover/robot_status
(std_msgs/msg/String): `moving` when it starts, `at_pose` once it holds the object there, or
`failed` (optionally `failed: why`).

Replace `move_to` with your robot's motion (MoveIt's move_group, a Cartesian controller, …),
after transforming the pose into your planning frame with tf2.

    source /opt/ros/$ROS_DISTRO/setup.bash
    python3 docs/examples/robot_node.py
"""

import json

import rclpy
from geometry_msgs.msg import PoseStamped
from rclpy.node import Node
from std_msgs.msg import String


class HandoverRobot(Node):
    def __init__(self):
        super().__init__("handover_robot")
        # The ROS 2 default QoS (reliable, volatile, depth 10): what the console uses.
        self.status = self.create_publisher(String, "/handover/robot_status", 10)
        self.create_subscription(String, "/handover/trial", self.on_trial, 10)
        self.create_subscription(PoseStamped, "/handover/target_pose", self.on_pose, 10)
        self.trial = {}

    def on_trial(self, msg: String):
        self.trial = json.loads(msg.data)

    def say(self, text: str):
        self.status.publish(String(data=text))

    def on_pose(self, msg: PoseStamped):
        p, q = msg.pose.position, msg.pose.orientation
        self.get_logger().info(
            f"trial {self.trial.get('trial')} ({self.trial.get('query')}, attempt {self.trial.get('attempt')}): "
            f"{self.trial.get('object')} at ({p.x:.3f}, {p.y:.3f}, {p.z:.3f}) m, "
            f"q = ({q.x:.3f}, {q.y:.3f}, {q.z:.3f}, {q.w:.3f}) in '{msg.header.frame_id}'"
        )
        self.say("moving")
        try:
            self.move_to(msg)
        except Exception as e:  # noqa: BLE001 - any failure is the robot's answer
            self.say(f"failed: {e}")
            return
        self.say("at_pose")

    def move_to(self, pose: PoseStamped):
        """Move the object to `pose` and hold it there (here: nothing to move)."""


def main():
    rclpy.init()
    rclpy.spin(HandoverRobot())


if __name__ == "__main__":
    main()
