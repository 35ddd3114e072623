#!/usr/bin/env python3
"""A robot-side ROS 2 node for `handover run --robot ros2` (rclpy; any ROS 2 distro): the
template to start a lab's own from.

The console publishes each handover pose on /handover/target_pose
(geometry_msgs/msg/PoseStamped: the object's centre and orientation, in the frame the header
names: `shoulder`, the participant's shoulder, unless the lab's --robot-config gives a
base_frame) and the trial on /handover/trial (std_msgs/msg/String, JSON: command, phase,
trial, attempt, query, label, object, grips, …). Every command has an id, the pose's
`header.stamp` as `SEC.NANOSEC` (also the trial's `command`); a command is published again,
with the same id, until the robot answers. The robot answers on /handover/robot_status
(std_msgs/msg/String) naming the command: `moving ID` when it starts, `at_pose ID` once it
holds the object there, or `failed ID: why`. A status naming another command is logged as
stale and moves nothing, so a late answer can never be taken for the next pose.

Replace `move_to` with your robot's motion (MoveIt's move_group, a Cartesian controller, …),
after transforming the pose into your planning frame with tf2. It may block: repeats of the
command that arrive meanwhile are recognised by their id and not executed again.

    source /opt/ros/$ROS_DISTRO/setup.bash
    python3 docs/examples/robot_node.py [--move-s SECONDS]
"""

import argparse
import json
import time
from collections import OrderedDict

import rclpy
from geometry_msgs.msg import PoseStamped
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from std_msgs.msg import String


class HandoverRobot(Node):
    def __init__(self, move_s: float):
        super().__init__("handover_robot")
        self.move_s = move_s
        # The ROS 2 default QoS (reliable, volatile, depth 10): what the console uses.
        self.status = self.create_publisher(String, "/handover/robot_status", 10)
        self.create_subscription(String, "/handover/trial", self.on_trial, 10)
        self.create_subscription(PoseStamped, "/handover/target_pose", self.on_pose, 10)
        self.trials = OrderedDict()  # command id -> its trial, the last few
        self.started = OrderedDict()  # ids of the commands already taken on, the last few

    def on_trial(self, msg: String):
        trial = json.loads(msg.data)
        self.trials[trial.get("command")] = trial
        while len(self.trials) > 16:
            self.trials.popitem(last=False)

    def say(self, state: str, command: str, why: str = ""):
        self.status.publish(String(data=f"{state} {command}" + (f": {why}" if why else "")))

    def on_pose(self, msg: PoseStamped):
        command = f"{msg.header.stamp.sec}.{msg.header.stamp.nanosec:09d}"
        if command in self.started:
            return  # a repeat of a command under way or done: executed once
        self.started[command] = True
        while len(self.started) > 64:
            self.started.popitem(last=False)
        trial, p, q = self.trials.get(command, {}), msg.pose.position, msg.pose.orientation
        self.get_logger().info(
            f"command {command}: trial {trial.get('trial')} ({trial.get('query')}, attempt {trial.get('attempt')}): "
            f"{trial.get('object')} at ({p.x:.3f}, {p.y:.3f}, {p.z:.3f}) m, "
            f"q = ({q.x:.3f}, {q.y:.3f}, {q.z:.3f}, {q.w:.3f}) in '{msg.header.frame_id}'"
        )
        self.say("moving", command)
        try:
            self.move_to(msg)
        except Exception as e:  # noqa: BLE001 - any failure is the robot's answer
            self.say("failed", command, str(e))
            return
        self.say("at_pose", command)

    def move_to(self, pose: PoseStamped):
        """Move the object to `pose` and hold it there, returning once it is held (raise to
        fail). With MoveIt: `move_group.set_pose_target(pose); ok = move_group.go(wait=True)`.
        Here: wait --move-s seconds, as a blocking move would."""
        time.sleep(self.move_s)


def main():
    ap = argparse.ArgumentParser(description="A handover robot node (template).")
    ap.add_argument("--move-s", type=float, default=0.0, help="how long a move takes here (s)")
    args, ros_args = ap.parse_known_args()
    rclpy.init(args=ros_args)
    node = HandoverRobot(args.move_s)
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass  # Ctrl+C
    finally:
        node.destroy_node()  # DDS releases its shared memory
        rclpy.try_shutdown()


if __name__ == "__main__":
    main()
