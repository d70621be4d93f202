"""How a simulated robot's limits are read from logs of driving it: the pieces car_limits and
junior_limits share. A log is [(t [s], state)], the state having speed and yaw_rate."""

from __future__ import annotations

import statistics
from typing import Callable

from roar.protocol import spec

PERIOD_S = spec.TIMING_HOST_SEND_PERIOD_US / 1e6  # [s] one command per period, as a host sends them
HOLDS_LINE = 1.12  # a circle within 12 % of the radius the robot should hold counts as grip


def drive(sim, send: Callable[[], None], seconds: float) -> list[tuple[float, object]]:
    """send() and run one period, for `seconds`; the log of (time, state) after each period."""
    log = []
    for _ in range(round(seconds / PERIOD_S)):
        send()
        sim.run(PERIOD_S)
        log.append((sim.time_s, sim.state()))
    return log


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


def print_against(measured, table) -> None:
    """Each measured limit beside the table's value."""
    for name, value in vars(measured).items():
        print(f"{name:18} {value:6.2f}   (table: {getattr(table, name):.2f})")
