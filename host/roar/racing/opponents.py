"""The other cars as the ego knows them: detected in its lidar scans (roar.racing.detection),
tracked over scans (roar.vision.tracking's Kalman tracker, tuned for racing cars), and placed on
the track: how far along it, how far left of its centre line, how fast along it; predicted ahead
at that speed along the track (cars race along the track, not in straight lines).

    cars = Opponents(track, CarDetector(known))
    seen = cars.update(scan, lidar_pose, t_s)            # [Opponent]: confirmed tracks on the track
    s_m, d_m = seen[0].predict(1.0)                      # where it will be in 1 s
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from roar.racing.detection import CarDetector
from roar.tracks.track import Track
from roar.vision.tracking import Tracker

GATE_M = 0.7  # [m] a detection further than this from a car's prediction is another object (4 m/s x 2 scans)
CAR_ACCEL_M_S2 = 4.0  # [m/s^2] how hard a racing car changes speed (the tracker's process noise)
CONFIRM_HITS = 3  # scans a car must be seen in before it counts
MISSES_CONFIRMED = 15  # scans a confirmed car may go unseen (hidden behind another, in a bend) before it is dropped
COAST_S = 0.4  # [s] unseen longer than this, a car's velocity is forgotten


@dataclass(frozen=True)
class Opponent:
    id: int
    x: float  # [m] world frame
    y: float  # [m]
    s_m: float  # [m] along the centre line
    d_m: float  # [m] left of the centre line
    speed_m_s: float  # [m/s] along the track (negative: backwards)
    length_m: float  # [m] of the lap: predictions wrap

    def predict(self, dt_s: float) -> tuple[float, float]:
        """(s [m], d [m]) in dt_s [s], at its speed along the track and its distance from the centre line."""
        return (self.s_m + max(0.0, self.speed_m_s) * dt_s) % self.length_m, self.d_m


class Opponents:
    def __init__(self, track: Track, detector: CarDetector) -> None:
        self.track, self.detector = track, detector
        self.tracker = Tracker(gate_m=GATE_M, confirm_hits=CONFIRM_HITS, max_misses=2,
                               max_misses_confirmed=MISSES_CONFIRMED, accel_m_s2=CAR_ACCEL_M_S2, coast_s=COAST_S)
        self._hints: dict[int, int] = {}  # track id -> its last centre-line segment

    def update(self, scan, sensor_pose: tuple[float, float, float], t_s: float) -> list[Opponent]:
        """One scan (roar.localization.LaserScan) from sensor_pose (the lidar in the world): the cars now."""
        self.tracker.update(self.detector.detect(scan, sensor_pose), t_s)
        seen, hints = [], {}
        for car in self.tracker.objects("car"):
            hint = self._hints.get(car.id)
            seg, s, d = self.track.project((car.x, car.y), hint, heading=None if hint is not None else
                                           math.atan2(car.state[3], car.state[2]))
            hints[car.id] = seg
            a, b = self.track.centerline[seg], self.track.centerline[(seg + 1) % len(self.track.centerline)]
            along = math.atan2(b[1] - a[1], b[0] - a[0])
            speed = float(car.state[2] * math.cos(along) + car.state[3] * math.sin(along))
            seen.append(Opponent(car.id, car.x, car.y, s, d, speed, self.track.length_m))
        self._hints = hints
        return seen
