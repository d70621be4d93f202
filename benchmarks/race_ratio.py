"""The autopilot against the physical limit: for every built-in track and every robot of the
registry (the ESC car, the IARRC car by speed, the Junior by its HTTP requests), the best flying
lap of a 3-lap race through the firmware, divided by the lap time of the track's speed profile at
that robot's measured limits. Target: <= 1.15 with zero wall contacts."""

from roar_sim import robots
from roar_sim.runs.race import race
from roar_sim.world.track import BUILTIN, get

TITLE = "autopilot lap time / physical-limit lap time (target <= 1.15, no wall contacts)"
LAPS = 3
TARGET = 1.15


def run() -> None:
    for robot, name in ((robot, name) for robot in robots.names() for name in sorted(BUILTIN)):
        result = race(get(name), laps=LAPS, robot=robot)
        flying = result.lap_times_s[1:] or result.lap_times_s
        if not flying:
            print(f"  {robot:6} {name:14} MISSED: {result.shortfall(LAPS, 0)}")
            continue
        best = min(flying)
        ratio = best / result.limit_lap_s
        verdict = "ok" if ratio <= TARGET and result.wall_contacts == 0 else \
            f"MISSED by {ratio - TARGET:+.3f}" if result.wall_contacts == 0 else "MISSED: touched a wall"
        print(f"  {robot:6} {name:14} best flying lap {best:6.2f} s, limit {result.limit_lap_s:5.2f} s, "
              f"ratio {ratio:.3f}, wall contacts {result.wall_contacts}  {verdict}")
