"""A laser scan as the host library takes it, from the simulator's lidar or a real one's driver:
each beam's angle in the sensor's frame and the range it read, and the moment it was taken.

    scan = LaserScan.fan(ranges, fov_rad=math.radians(270), time_s=t)      # beams right to left
    scan = LaserScan.from_ros(angle_min, angle_increment, ranges, time_s=t,  # a sensor_msgs/LaserScan
                              range_min_m=0.06, range_max_m=10.0)

A reading that is no number (NaN), negative or below the sensor's minimum range is not a
measurement: it is left out beam by beam (scan.usable(), scan.skipped) and never fails a scan. A
reading at or beyond the maximum range (+inf too, as ROS drivers write "no return") is a max
reading: the beam met nothing. A scan with no beams, angles or times that are no numbers, or
ranges and angles of different lengths are refused (ScanError, one line).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from roar.errors import ScanError

RANGE_MIN_M = 0.06  # [m] a Hokuyo UST-10LX's minimum range (the simulator's lidar too)
RANGE_MAX_M = 10.0  # [m] its maximum range
MAX_BEAMS = 100_000  # beams a scan may have (a 1080-beam scan is a Hokuyo's)


@dataclass(frozen=True)
class LaserScan:
    angles: np.ndarray  # [rad] of each beam in the sensor's frame, anticlockwise from straight ahead
    ranges: np.ndarray  # [m] what each beam read
    time_s: float  # [s] when the scan was taken, on the clock the odometry uses
    range_min_m: float = RANGE_MIN_M
    range_max_m: float = RANGE_MAX_M

    def __post_init__(self) -> None:
        angles = np.asarray(self.angles, dtype=np.float64).ravel()
        try:
            ranges = np.asarray(self.ranges, dtype=np.float64).ravel()
        except (TypeError, ValueError):
            raise ScanError("a scan's ranges must be numbers") from None
        if ranges.size == 0:
            raise ScanError("an empty scan: a laser scan needs at least one beam")
        if ranges.size > MAX_BEAMS:
            raise ScanError(f"a scan of {ranges.size:,} beams (at most {MAX_BEAMS:,})")
        if angles.shape != ranges.shape:
            raise ScanError(f"a scan of {ranges.size} ranges and {angles.size} angles: one angle per beam")
        if not np.isfinite(angles).all():
            raise ScanError("a scan's angles must be finite numbers")
        if not (isinstance(self.time_s, (int, float)) and math.isfinite(self.time_s)):
            raise ScanError(f"a scan's time must be a finite number of seconds, got {self.time_s!r}")
        if not (0 <= self.range_min_m < self.range_max_m < math.inf):
            raise ScanError(f"a scan's range limits must be 0 <= min < max < inf, got {self.range_min_m!r} and "
                            f"{self.range_max_m!r}")
        object.__setattr__(self, "angles", angles)
        object.__setattr__(self, "ranges", ranges)

    @classmethod
    def fan(cls, ranges, fov_rad: float, time_s: float, range_min_m: float = RANGE_MIN_M,
            range_max_m: float = RANGE_MAX_M) -> LaserScan:
        """Beams evenly over fov_rad centred straight ahead, the first on the right (as the
        simulator's lidar and a Hokuyo give them)."""
        n = np.asarray(ranges).size
        return cls(np.linspace(-fov_rad / 2, fov_rad / 2, n), ranges, time_s, range_min_m, range_max_m)

    @classmethod
    def from_ros(cls, angle_min: float, angle_increment: float, ranges, time_s: float,
                 range_min_m: float = RANGE_MIN_M, range_max_m: float = RANGE_MAX_M) -> LaserScan:
        """The fields of a ROS sensor_msgs/LaserScan (its time in seconds)."""
        n = np.asarray(ranges).size
        return cls(angle_min + angle_increment * np.arange(n), ranges, time_s, range_min_m, range_max_m)

    def usable(self) -> np.ndarray:
        """Which beams are measurements: a number at or above the minimum range (max readings too)."""
        with np.errstate(invalid="ignore"):
            return ~np.isnan(self.ranges) & (self.ranges >= self.range_min_m)

    @property
    def skipped(self) -> int:
        """Beams that are not measurements (NaN, negative, below the minimum range)."""
        return int(self.ranges.size - np.count_nonzero(self.usable()))

    def clipped(self) -> np.ndarray:
        """The ranges with max readings (and +inf) at range_max_m; unusable beams as NaN."""
        out = np.minimum(self.ranges, self.range_max_m)
        out[~self.usable()] = np.nan
        return out

    def every(self, beams: int) -> LaserScan:
        """At most `beams` beams spread evenly over this scan (the particle filter's subset)."""
        if beams >= self.ranges.size:
            return self
        pick = np.round(np.linspace(0, self.ranges.size - 1, beams)).astype(int)
        return LaserScan(self.angles[pick], self.ranges[pick], self.time_s, self.range_min_m, self.range_max_m)

    def points(self) -> np.ndarray:
        """(N, 2) [m] the usable, non-max readings as points in the sensor's frame (x ahead, y left)."""
        keep = self.usable() & (self.ranges < self.range_max_m)
        r, a = self.ranges[keep], self.angles[keep]
        return np.column_stack([r * np.cos(a), r * np.sin(a)])
