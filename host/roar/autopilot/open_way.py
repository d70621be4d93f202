"""Heading for open space by the lidar alone: what a car does while it does not know where it is
(a particle filter not yet localized, or lost) or has no plan. It steers towards the most open
direction ahead (a direction is as open as the nearest reading within a car's gap of it), the
nearer of two equals to a wanted direction (the course's next point, when the pose is good enough
for that), turned away from the nearer side wall, and creeps slower as the way ahead closes.

    way = OpenWay()
    command = way.command(scan, speed_m_s)                # a roar.autopilot.Command
    command = way.command(scan, speed_m_s, want_rad=0.4)  # prefer open ways 0.4 rad to the left
    way.reset()                                           # when something else drives again
"""

from __future__ import annotations

import math

import numpy as np

from roar.autopilot.agent import Command

SPEED_M_S = 1.5  # [m/s] the car creeps at most this fast (by its odometry)
SLOW_M = 3.0  # [m] free ahead below which it creeps slower, in proportion (a corner ahead)
GAIN = 0.03  # throttle added per m/s short of its speed, each call (an integral: the ESC's speed for a throttle
# depends on the car)
MAX_THROTTLE = 0.6
STEERING_GAIN = 1.5  # steering per radian towards the open way (+1 full right)
VIEW_RAD = math.radians(90)  # [rad] either side of ahead where it looks for the open way
REACH_M = 4.0  # [m] ranges beyond this count as this: the nearest open way, not the farthest
SIDE_RAD = (math.radians(30), math.radians(110))  # [rad] the beams that see the side walls
CENTRING_RAD = 0.8  # [rad] turned away from the nearer side wall, at one wall touching and the other far
HALF_GAP_M = 0.35  # [m] half the gap the car needs: a direction is as open as its beams this far either side
WANT_WEIGHT_M_RAD = 0.5  # [m/rad] openness a direction gives up per radian away from the wanted one


class OpenWay:
    def __init__(self) -> None:
        self.throttle = 0.0

    def reset(self) -> None:
        self.throttle = 0.0

    def command(self, scan, speed_m_s: float, want_rad: float = 0.0) -> Command:
        """The command for a scan (roar.localization.LaserScan, angles in the car's frame) at the
        car's speed [m/s]; want_rad: the direction sought [rad] in the scan's frame (0: ahead)."""
        from scipy import ndimage

        ranges = np.where(scan.usable(), np.minimum(scan.ranges, REACH_M), 0.0)
        step = float(np.median(np.abs(np.diff(scan.angles)))) if len(scan.angles) > 1 else 1.0
        half = max(1, int(math.atan2(HALF_GAP_M, 2.0) / max(step, 1e-6)))  # [beams] at 2 m
        openness = ndimage.minimum_filter1d(ranges, 2 * half + 1, mode="nearest")
        ahead = np.abs(scan.angles) <= VIEW_RAD
        score = np.where(ahead, openness - WANT_WEIGHT_M_RAD * np.abs(scan.angles - want_rad), -np.inf)
        best = int(np.argmax(score))
        front = float(openness[np.argmin(np.abs(scan.angles))])
        sides = (np.abs(scan.angles) >= SIDE_RAD[0]) & (np.abs(scan.angles) <= SIDE_RAD[1])
        left = float(np.min(ranges[sides & (scan.angles > 0)], initial=REACH_M))
        right = float(np.min(ranges[sides & (scan.angles < 0)], initial=REACH_M))
        heading = scan.angles[best] + CENTRING_RAD * (left - right) / max(left + right, 1e-6)
        speed = SPEED_M_S * min(1.0, max(0.3, front / SLOW_M))
        self.throttle = float(np.clip(self.throttle + GAIN * (speed - speed_m_s), 0.0, MAX_THROTTLE))
        return Command(self.throttle, float(np.clip(-STEERING_GAIN * heading, -1.0, 1.0)))
