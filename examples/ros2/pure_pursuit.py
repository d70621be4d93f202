"""A plain ROS 2 node, as an F1TENTH team writes one: pure pursuit round a centre line, on /odom,
sending AckermannDriveStamped on /drive at 40 Hz. Nothing from roar: it drives whatever serves
those topics, our car included.

    roar ros2 sim://oval &                          the simulated car as a ROS 2 node
    roar track oval --save oval.csv                 the centre line (x_m, y_m, ... per row)
    python examples/ros2/pure_pursuit.py oval.csv   [--laps 1] [--speed 1.2] [--f1tenth]

It prints each lap's time (by the odometry: the start line crossed after the whole line was
driven) and exits 0 after --laps laps, 2 when it falls short within --timeout.
"""

import argparse
import math
import sys
import time

import numpy as np
import rclpy
from ackermann_msgs.msg import AckermannDriveStamped
from nav_msgs.msg import Odometry

WHEELBASE_M = 0.325  # [m]
LOOKAHEAD_M = 0.8  # [m]


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("centreline", help="CSV of x_m, y_m (more columns ignored; # comments)")
    p.add_argument("--laps", type=int, default=1)
    p.add_argument("--speed", type=float, default=1.2, help="[m/s]")
    p.add_argument("--timeout", type=float, default=60.0, help="[s] give up after this long")
    p.add_argument("--f1tenth", action="store_true", help="f1tenth_gym_ros's odometry topic")
    args = p.parse_args()
    line = np.loadtxt(args.centreline, delimiter=",", comments="#")[:, :2]

    rclpy.init()
    node = rclpy.create_node("pure_pursuit")
    drive = node.create_publisher(AckermannDriveStamped, "/drive", 10)
    pose = {}
    node.create_subscription(Odometry, "/ego_racecar/odom" if args.f1tenth else "/odom",
                             lambda m: pose.update(msg=m), 10)
    visited, laps, lap_start, start = set(), [], None, time.monotonic()

    def step() -> None:
        nonlocal lap_start
        msg = pose.get("msg")
        if msg is None:
            return
        p, q = msg.pose.pose.position, msg.pose.pose.orientation
        yaw = 2 * math.atan2(q.z, q.w)
        nearest = int(np.argmin(np.hypot(line[:, 0] - p.x, line[:, 1] - p.y)))
        visited.add(nearest * 10 // len(line))  # which tenth of the line it has been on
        if nearest == 0 and lap_start is None:
            lap_start = time.monotonic()
        elif nearest < len(line) // 10 and len(visited) == 10 and lap_start is not None:
            laps.append(time.monotonic() - lap_start)
            print(f"lap {len(laps)}: {laps[-1]:.2f} s", flush=True)
            lap_start = time.monotonic()
            visited.clear()
        goal = nearest  # the first point LOOKAHEAD_M ahead along the line
        while math.hypot(line[goal, 0] - p.x, line[goal, 1] - p.y) < LOOKAHEAD_M:
            goal = (goal + 1) % len(line)
        dx, dy = line[goal, 0] - p.x, line[goal, 1] - p.y
        ahead_y = -math.sin(yaw) * dx + math.cos(yaw) * dy  # the goal's offset to the left
        curvature = 2 * ahead_y / (dx * dx + dy * dy)
        out = AckermannDriveStamped()
        out.header.stamp = node.get_clock().now().to_msg()
        out.drive.speed = float(args.speed)
        out.drive.steering_angle = float(math.atan(WHEELBASE_M * curvature))
        drive.publish(out)

    node.create_timer(1 / 40, step)
    while len(laps) < args.laps and time.monotonic() - start < args.timeout:
        rclpy.spin_once(node, timeout_sec=0.05)
    drive.publish(AckermannDriveStamped())  # speed 0
    node.destroy_node()
    rclpy.shutdown()
    if len(laps) < args.laps:
        heard = "no odometry" if "msg" not in pose else f"{len(visited)} tenths of the line driven this lap"
        print(f"{len(laps)} of {args.laps} laps in {args.timeout:g} s ({heard})", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
