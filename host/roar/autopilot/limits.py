"""A car's physical limits read from logs of driving it, as the simulator's robots are measured
(roar_sim.robots) and as a real car's could be from its state readings: top speed, acceleration
and braking from a full-power run and the stop after it, the lateral acceleration it holds on a
steady circle. A log is [(t [s], state)], each state with speed [m/s] and yaw_rate [rad/s]."""

from __future__ import annotations

import statistics

HOLDS_LINE = 1.12  # a circle within 12 % of the radius the car should hold counts as grip


def straight_line(run: list, stop: list) -> tuple[float, float, float]:
    """(top speed [m/s], acceleration [m/s^2], deceleration [m/s^2]) from a full-power run and
    the stop after it, each rate over the 10 %..90 % band of the top speed."""
    top = max(s.speed for _, s in run)
    t10 = next(t for t, s in run if s.speed >= 0.1 * top)
    t90 = next(t for t, s in run if s.speed >= 0.9 * top)
    f90 = next(t for t, s in stop if s.speed <= 0.9 * top)
    f10 = next(t for t, s in stop if s.speed <= 0.1 * top)
    return top, 0.8 * top / (t90 - t10), 0.8 * top / (f10 - f90)


def circle(log: list) -> tuple[float, float]:
    """(radius [m], lateral acceleration [m/s^2]) of a steady circle, medians over the log."""
    radius = statistics.median(abs(s.speed / s.yaw_rate) for _, s in log if abs(s.yaw_rate) > 1e-3)
    return radius, statistics.median(abs(s.speed * s.yaw_rate) for _, s in log)
