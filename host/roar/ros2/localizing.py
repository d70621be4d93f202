"""Where the car is on the map, for `roar ros2 --localize`: our particle filter
(roar.localization) on each scan, moved between scans as the odometry moved, and the map -> odom
transform that makes odom's dead reckoning agree with it (REP 105: map -> odom -> base_link, the
odometry continuous, the map pose jumping when a scan corrects it)."""

from __future__ import annotations


import numpy as np

from roar.localization import LaserScan, ParticleFilter
from roar.localization.odometry import Pose, compose, relative

PARTICLES = 2500
WARM_PARTICLES = 10  # a throwaway filter's, to compile the kernels before the node is up
WARM_BEAMS = 1080  # its scan's (a Hokuyo's)
WARM_FOV_RAD = 4.71238898038469  # [rad] 270 deg


class MapLocalizer:
    """start: the odometry's first pose when the link knows where the car starts on the map (the
    simulator's), else None: anywhere (a global start, which needs a map whose places tell apart);
    lidar_mount: where the lidar sits on the car (x ahead, y left, yaw)."""

    def __init__(self, known, start: Pose | None, lidar_mount: Pose = (0.0, 0.0, 0.0), seed: int = 0) -> None:
        # the filter's kernels compile on their first scan (seconds, once a process): on a throwaway
        # filter now, before the node is up, not while the car drives and its scans queue
        warm = ParticleFilter(known, WARM_PARTICLES, sensor=lidar_mount, seed=seed)
        warm.start_global()
        warm.correct(LaserScan.fan(np.full(WARM_BEAMS, 1.0), WARM_FOV_RAD, 0.0))
        self.filter = ParticleFilter(known, PARTICLES, sensor=lidar_mount, seed=seed)
        if start is None:
            self.filter.start_global()
        else:
            self.filter.start_at(start)
        self.scans = 0

    def step(self, odometry: Pose, angles: np.ndarray, ranges: np.ndarray, time_s: float,
             range_min_m: float, range_max_m: float) -> tuple[Pose, Pose]:
        """(the car's pose on the map, the map -> odom transform) after this scan, taken where the
        odometry said `odometry`."""
        self.filter.predict(odometry)
        self.filter.correct(LaserScan(angles, ranges, time_s, range_min_m, range_max_m))
        self.scans += 1
        pose = tuple(float(v) for v in self.filter.pose)
        # map -> odom = map -> base_link composed with (odom -> base_link) inverted
        back = relative(odometry, (0.0, 0.0, 0.0))  # odom's origin in the car's frame
        return pose, compose(pose, back)

    @property
    def covariance(self) -> np.ndarray:
        return self.filter.covariance
