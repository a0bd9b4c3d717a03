#!/bin/sh
# fdv_ros_node fed at real time from `rosbag play` at about 6 M events/s (hover_headon at
# 1280x720): prints the input event rate, whether every message arrived (it fails otherwise) and
# the node's latency per window. Needs the ROS 1 build; starts its own roscore on loopback.
#   bench/ros_node_realtime.sh [BUILD_DIR] [WORK_DIR]
exec /usr/bin/python3 "$(dirname "$0")/../ros/test/node_replay_test.py" "${1:-build}" "${2:-/tmp/fdv_ros_realtime}" \
  --rate 1 --resolution 1280x720
