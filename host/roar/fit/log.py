"""A test drive's record: the pulses the car was sent and the poses measured, on one clock, with
the manoeuvre each moment belongs to; and the speed and yaw rate measured from the poses.

    record = FitLog.from_mcap("run.mcap")     # or built while driving (roar.fit.drive)
    record.check()                            # FitError, one line, for a record a fit cannot use
    speed, yaw_rate = record.motion()         # [m/s], [rad/s] at record.pose_t
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from roar.errors import FitError

PULSE_TOPIC = "/fit/pulses"  # the pulses as the test drive sent them (throttle_us, steering_us)
POSE_TOPIC = "/fit/pose"  # the pose source's poses as measured (x, y, yaw, and the source's name)
PHASE_TOPIC = "/fit/phase"  # each manoeuvre's name as it begins
MIN_POSE_HZ = 15.0  # [Hz] fewer poses a second cannot show a 20 ms servo or delay
MIN_DRIVE_S = 20.0  # [s] a record shorter than this holds too few manoeuvres to fit
SMOOTH_S = 0.16  # [s] the window speed and yaw rate are measured over from the poses (zero-phase)


@dataclass
class FitLog:
    pulse_t: np.ndarray  # [s] when each control message was sent
    throttle_us: np.ndarray  # [us]
    steering_us: np.ndarray  # [us]
    pose_t: np.ndarray  # [s] when each pose was measured, on the same clock
    x: np.ndarray  # [m]
    y: np.ndarray  # [m]
    yaw: np.ndarray  # [rad]
    phases: list[tuple[float, str]] = field(default_factory=list)  # (start [s], manoeuvre)
    source: str = ""  # what measured the poses

    @classmethod
    def from_arrays(cls, pulses, poses, phases=(), source: str = "") -> FitLog:
        """pulses: rows (t, throttle_us, steering_us); poses: rows (t, x, y, yaw)."""
        p = np.asarray(pulses, dtype=float).reshape(-1, 3)
        q = np.asarray(poses, dtype=float).reshape(-1, 4)
        return cls(p[:, 0], p[:, 1], p[:, 2], q[:, 0], q[:, 1], q[:, 2], q[:, 3], list(phases), source)

    @classmethod
    def from_mcap(cls, path: str | Path) -> FitLog:
        """A record `roar fit URL` wrote (its /fit/pulses, /fit/pose and /fit/phase channels)."""
        from mcap.exceptions import McapError
        from mcap.reader import make_reader

        pulses, poses, phases, source = [], [], [], ""
        try:
            with open(path, "rb") as f:
                for _, channel, message in make_reader(f).iter_messages(topics=[PULSE_TOPIC, POSE_TOPIC, PHASE_TOPIC]):
                    data, t = json.loads(message.data), message.log_time / 1e9
                    if channel.topic == PULSE_TOPIC:
                        pulses.append((t, data["throttle_us"], data["steering_us"]))
                    elif channel.topic == POSE_TOPIC:
                        poses.append((t, data["x"], data["y"], data["yaw"]))
                        source = data.get("source", source)
                    elif channel.topic == PHASE_TOPIC:
                        phases.append((t, str(data["name"])))
        except OSError as e:
            raise FitError(f"{path}: {e.strerror}") from None
        except (McapError, ValueError, KeyError, TypeError, EOFError) as e:
            raise FitError(f"{path}: not a test drive's MCAP record ({type(e).__name__}: {e})") from None
        missing = [name for name, rows in (("pulses (/fit/pulses)", pulses), ("poses (/fit/pose)", poses))
                   if not rows]
        if missing:
            raise FitError(f"{path}: no {' and no '.join(missing)}: record a test drive with `roar fit URL --out ...`")
        return cls.from_arrays(pulses, poses, phases, source)

    def check(self) -> None:
        """FitError (one line) for a record no fit can use: NaN, too short, too few poses."""
        for name in ("pulse_t", "throttle_us", "steering_us", "pose_t", "x", "y", "yaw"):
            values = getattr(self, name)
            if not np.all(np.isfinite(values)):
                k = int(np.flatnonzero(~np.isfinite(values))[0])
                raise FitError(f"the record's {name} is not a number at sample {k} of {len(values)}")
        if len(self.pose_t) < 2 or len(self.pulse_t) < 2:
            raise FitError("the record holds fewer than 2 poses or pulses")
        span = min(self.pose_t[-1], self.pulse_t[-1]) - max(self.pose_t[0], self.pulse_t[0])
        if span < MIN_DRIVE_S:
            raise FitError(f"the record covers {max(span, 0):.1f} s of driving with poses; a fit needs "
                           f"{MIN_DRIVE_S:.0f} s or more (the whole test drive is about a minute)")
        rate = (len(self.pose_t) - 1) / (self.pose_t[-1] - self.pose_t[0])
        if rate < MIN_POSE_HZ:
            raise FitError(f"poses at {rate:.1f} Hz; a fit needs {MIN_POSE_HZ:.0f} Hz or more to see the servo "
                           f"and the delay")
        if np.any(np.diff(self.pose_t) <= 0) or np.any(np.diff(self.pulse_t) < 0):
            raise FitError("the record's times go backwards")

    def motion(self) -> tuple[np.ndarray, np.ndarray]:
        """(speed along the heading [m/s], yaw rate [rad/s]) at each pose, from the poses by a
        zero-phase Savitzky-Golay derivative over SMOOTH_S (no lag, so no delay is added)."""
        from scipy.signal import savgol_filter

        dt = float(np.median(np.diff(self.pose_t)))
        window = max(5, int(round(SMOOTH_S / dt)) | 1)
        if window >= len(self.pose_t):
            window = (len(self.pose_t) - 1) | 1 if len(self.pose_t) > 4 else 3
        # poses resampled evenly first: a source's jitter would otherwise read as speed
        t = np.arange(self.pose_t[0], self.pose_t[-1], dt)
        yaw = np.unwrap(self.yaw)
        xs, ys, ws = (np.interp(t, self.pose_t, v) for v in (self.x, self.y, yaw))
        vx, vy, wz = (savgol_filter(v, window, 2, deriv=1, delta=dt) for v in (xs, ys, ws))
        heading = savgol_filter(ws, window, 2)
        speed = vx * np.cos(heading) + vy * np.sin(heading)
        return np.interp(self.pose_t, t, speed), np.interp(self.pose_t, t, wz)

    def pose_noise_m(self) -> float:
        """[m] the poses' noise, one standard deviation: from the third differences of x and y,
        where a car's own motion is far below a pose source's noise (a noise of s gives third
        differences of s * sqrt(20)), taken robustly (a median) so a jump or a turn adds nothing."""
        if len(self.pose_t) < 10:
            return 0.0
        third = np.concatenate([np.diff(self.x, 3), np.diff(self.y, 3)])
        return float(1.4826 * np.median(np.abs(third - np.median(third))) / np.sqrt(20))

    def phase_at(self, t: np.ndarray) -> np.ndarray:
        """The index into self.phases of the manoeuvre under way at each time (-1 before the first)."""
        starts = np.array([s for s, _ in self.phases]) if self.phases else np.zeros(0)
        return np.searchsorted(starts, t, side="right") - 1

    def shifted(self) -> FitLog:
        """The same record with its clock starting at 0."""
        t0 = min(self.pulse_t[0], self.pose_t[0])
        return FitLog(self.pulse_t - t0, self.throttle_us, self.steering_us, self.pose_t - t0, self.x, self.y,
                      self.yaw, [(s - t0, n) for s, n in self.phases], self.source)


def wrap(angle: float) -> float:
    return math.remainder(angle, math.tau)
