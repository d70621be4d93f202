"""A car's physical limits read from logs of driving it, as the simulator's robots are measured
(roar_sim.robots) and as a real car's could be from its state readings: top speed, acceleration
and braking from a full-power run and the stop after it, the lateral acceleration it holds on a
steady circle, and how that grip fades at higher speeds. A log is [(t [s], state)], each state
with speed [m/s] and yaw_rate [rad/s]."""

from __future__ import annotations

import statistics

from roar.autopilot.curvature_tracking import FLOOR_PER_M, SHARE

HOLDS_LINE = 1.12  # a circle within 12 % of the radius the car should hold counts as grip
# A faster circle still counts towards the fade when the curvature its steering asks (the slowest
# circle's at that steering) is within this share of what the curvature tracker may add to it.
TRACKED_SHARE = 0.8


def straight_line(run: list, stop: list) -> tuple[float, float, float]:
    """(top speed [m/s], acceleration [m/s^2], deceleration [m/s^2]) from a full-power run and
    the stop after it, each rate over the 10 %..90 % band of the top speed."""
    top = max(s.speed for _, s in run)
    t10 = next(t for t, s in run if s.speed >= 0.1 * top)
    t90 = next(t for t, s in run if s.speed >= 0.9 * top)
    f90 = next(t for t, s in stop if s.speed <= 0.9 * top)
    f10 = next(t for t, s in stop if s.speed <= 0.1 * top)
    return top, 0.8 * top / (t90 - t10), 0.8 * top / (f10 - f90)


def tracked(asked_radius_m: float, radius_m: float) -> bool:
    """Whether the autopilot's curvature tracker could hold a circle of radius_m [m] that asked
    for asked_radius_m [m] (the slowest circle's at that steering), with TRACKED_SHARE to spare."""
    return 1 / asked_radius_m <= TRACKED_SHARE * ((1 + SHARE) / radius_m + FLOOR_PER_M)


def fade(peak: tuple[float, float], limits: list[tuple[float, float]]) -> tuple[tuple[float, float], ...]:
    """CarLimits.lateral_fade from the peak grip (speed [m/s], lateral [m/s^2]) and each steering's
    last tracked circle before it slid (speed, lateral): those faster than the peak and below it,
    each no higher than a slower one; () when none is (the car holds its peak up to top speed)."""
    points, held = [], peak[1]
    for speed, lateral in sorted(limits):
        if speed > peak[0] and lateral < held:
            held = lateral
            points.append((round(speed, 2), round(lateral, 2)))
    return ((round(peak[0], 2), round(peak[1], 2)), *points) if points else ()


def circle(log: list) -> tuple[float, float]:
    """(radius [m], lateral acceleration [m/s^2]) of a steady circle, medians over the log."""
    radius = statistics.median(abs(s.speed / s.yaw_rate) for _, s in log if abs(s.yaw_rate) > 1e-3)
    return radius, statistics.median(abs(s.speed * s.yaw_rate) for _, s in log)
