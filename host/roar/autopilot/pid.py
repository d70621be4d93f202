"""A PID controller with output clamps and anti-windup (the integral stops growing while the
output is saturated in the same direction)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field


@dataclass
class PID:
    kp: float
    ki: float = 0.0
    kd: float = 0.0
    out_min: float = -1.0
    out_max: float = 1.0
    integral: float = field(default=0.0, init=False)
    _last_error: float | None = field(default=None, init=False, repr=False)

    def __post_init__(self) -> None:
        if not self.out_min < self.out_max:
            raise ValueError(f"out_min must be below out_max, got {self.out_min} and {self.out_max}")

    def reset(self) -> None:
        self.integral, self._last_error = 0.0, None

    def step(self, error: float, dt_s: float, feed_forward: float = 0.0) -> float:
        """Output for this error (setpoint - measurement) after dt_s seconds, clamped."""
        if not (math.isfinite(error) and dt_s > 0):
            raise ValueError(f"PID needs a finite error and dt > 0, got {error} and {dt_s}")
        derivative = 0.0 if self._last_error is None else (error - self._last_error) / dt_s
        self._last_error = error
        unclamped = feed_forward + self.kp * error + self.ki * (self.integral + error * dt_s) + self.kd * derivative
        out = min(self.out_max, max(self.out_min, unclamped))
        saturated_up, saturated_down = unclamped > self.out_max, unclamped < self.out_min
        if not ((saturated_up and error > 0) or (saturated_down and error < 0)):
            self.integral += error * dt_s  # anti-windup: no integration into a saturated output
        return out
