#!/bin/sh
# An example --robot-command program: handover runs it once per handover with the command as
# one line of JSON on standard input, e.g.
#   {"command":"1765130000.123456789","phase":"training","trial":1,"attempt":1,
#    "query":"bars-chest-turned-left",
#    "label":"Handlebars at chest height, turned left","object":"handlebars",
#    "grips":[{"id":"left-grip","label":"Left grip (blue)"}, ...],"frame":"shoulder",
#    "position":[0.42,-0.09,-0.05],"orientation":{"x":0,"y":0,"z":0.17,"w":0.98},
#    "rpy_deg":[0,0,20]}
# and waits for it: exit status 0 means the robot holds the object at the pose; any other
# status (with a reason on standard error) that it could not. It is killed, with everything it
# started, at the settings' timeout_s (60 s by default).
#
# This one publishes the pose once with the ROS 2 command line, stamped with the command's
# id (as --robot ros2 does), and waits for the robot's `at_pose ID` (or a bare `at_pose`)
# on /handover/robot_status (a ROS 2 install and python3 are needed; with no ROS 2 on
# the console's machine, use --robot ros2 instead). Any robot interface fits the same shape:
# a vendor SDK call, an HTTP request, a serial command.
set -eu
command=$(cat)
pose=$(printf '%s' "$command" | python3 -c '
import json, sys
c = json.load(sys.stdin)
p, o = c["position"], c["orientation"]
sec, nanosec = c["command"].split(".")
print("{header: {stamp: {sec: %d, nanosec: %d}, frame_id: %s}, pose: {position: {x: %r, y: %r, z: %r}, orientation: {x: %r, y: %r, z: %r, w: %r}}}"
      % (int(sec), int(nanosec), c["frame"], p[0], p[1], p[2], o["x"], o["y"], o["z"], o["w"]))')
id=$(printf '%s' "$command" | python3 -c 'import json, sys; print(json.load(sys.stdin)["command"])')
ros2 topic pub --once /handover/target_pose geometry_msgs/msg/PoseStamped "$pose" > /dev/null
while :; do
  status=$(ros2 topic echo --once --field data /handover/robot_status std_msgs/msg/String | head -1)
  case "$status" in
    "at_pose $id" | at_pose) exit 0 ;;
    "failed $id"* | "failed:"* | failed) echo "robot: $status" >&2; exit 1 ;;
  esac
done
