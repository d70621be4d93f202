"""The autopilot against the physical limit: for every built-in track, the best flying lap of
a 3-lap race through the firmware, divided by the lap time of the track's speed profile at the
simulated car's measured limits. Target: <= 1.15 with zero wall contacts."""

from roar_sim.race import race
from roar_sim.track import BUILTIN, get

TITLE = "autopilot lap time / physical-limit lap time (target <= 1.15, no wall contacts)"
LAPS = 3


def run() -> None:
    for name in sorted(BUILTIN):
        result = race(get(name), laps=LAPS)
        flying = result.lap_times_s[1:] or result.lap_times_s
        best = min(flying)
        verdict = "ok" if best / result.limit_lap_s <= 1.15 and result.wall_contacts == 0 else "MISSED"
        print(f"  {name:14} best flying lap {best:6.2f} s, limit {result.limit_lap_s:5.2f} s, "
              f"ratio {best / result.limit_lap_s:.3f}, wall contacts {result.wall_contacts}  {verdict}")
