"""The autopilot against the physical limit: for every built-in track and both robots (the ESC
car; the Junior over HTTP), the best flying lap of a 3-lap race through the firmware, divided by
the lap time of the track's speed profile at that robot's measured limits. Target: <= 1.15 with
zero wall contacts."""

from roar_sim.runs.race import ROBOTS, race
from roar_sim.world.track import BUILTIN, get

TITLE = "autopilot lap time / physical-limit lap time (target <= 1.15, no wall contacts)"
LAPS = 3


def run() -> None:
    for robot, name in ((robot, name) for robot in ROBOTS for name in sorted(BUILTIN)):
        result = race(get(name), laps=LAPS, robot=robot)
        flying = result.lap_times_s[1:] or result.lap_times_s
        best = min(flying)
        verdict = "ok" if best / result.limit_lap_s <= 1.15 and result.wall_contacts == 0 else "MISSED"
        print(f"  {robot:6} {name:14} best flying lap {best:6.2f} s, limit {result.limit_lap_s:5.2f} s, "
              f"ratio {best / result.limit_lap_s:.3f}, wall contacts {result.wall_contacts}  {verdict}")
