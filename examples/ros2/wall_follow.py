"""A plain ROS 2 node that drives by its lidar alone: it keeps the car midway between the walls
on /scan, sending AckermannDriveStamped on /drive. Nothing from roar, no map, no odometry: it
drives whatever serves those topics.

    roar ros2 sim://oval &
    python examples/ros2/wall_follow.py --for 30 [--speed 1.0]

Exits 0 after --for seconds; 2 when no scan came within 5 s.
"""

import argparse
import math
import sys
import time

import numpy as np
import rclpy
from ackermann_msgs.msg import AckermannDriveStamped
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import LaserScan

WHEELBASE_M = 0.325  # [m]
GAIN_PER_M2 = 2.0  # [1/m^2] curvature per metre of difference between the walls' distances
SIDE_RAD = (math.radians(10), math.radians(120))  # each side's readings: from near ahead to behind abeam


def centring(scan: LaserScan) -> tuple[float, float]:
    """(the curvature that keeps the car between the walls [1/m], left positive; the nearest
    reading ahead [m]). Each side's wall is its nearest reading from just ahead to behind abeam:
    in a bend the outer wall comes nearer ahead and turns the car with the corridor."""
    r = np.nan_to_num(np.asarray(scan.ranges, dtype=float), nan=scan.range_max, posinf=scan.range_max)
    angles = scan.angle_min + scan.angle_increment * np.arange(len(r))
    left = r[(angles > SIDE_RAD[0]) & (angles < SIDE_RAD[1])].min()
    right = r[(angles < -SIDE_RAD[0]) & (angles > -SIDE_RAD[1])].min()
    return GAIN_PER_M2 * (left - right), float(r[np.abs(angles) < 0.2].min())


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--speed", type=float, default=1.0, help="[m/s]")
    p.add_argument("--for", dest="seconds", type=float, default=30.0, help="[s]")
    args = p.parse_args()
    rclpy.init()
    node = rclpy.create_node("wall_follow")
    drive = node.create_publisher(AckermannDriveStamped, "/drive", 10)
    seen = []

    def on_scan(scan: LaserScan) -> None:
        curvature, ahead_m = centring(scan)
        out = AckermannDriveStamped()
        out.header = scan.header
        out.drive.speed = float(args.speed if ahead_m > 0.6 else args.speed / 2)
        out.drive.steering_angle = float(math.atan(WHEELBASE_M * curvature))
        drive.publish(out)
        seen.append(time.monotonic())

    node.create_subscription(LaserScan, "/scan", on_scan, qos_profile_sensor_data)
    start = time.monotonic()
    while time.monotonic() - start < args.seconds:
        rclpy.spin_once(node, timeout_sec=0.05)
        if not seen and time.monotonic() - start > 5:
            print("no /scan within 5 s", file=sys.stderr)
            break
    drive.publish(AckermannDriveStamped())
    node.destroy_node()
    rclpy.shutdown()
    return 0 if seen else 2


if __name__ == "__main__":
    sys.exit(main())
