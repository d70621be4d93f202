"""The autopilot against the physical limit: for every built-in track and every robot of the
registry (the ESC car, the IARRC car by speed, the Junior by its HTTP requests), the best flying
lap of a 3-lap race through the firmware, divided by the lap time of the track's speed profile at
that robot's measured limits. Target: <= 1.15 with zero wall contacts."""

import numpy as np

from roar_sim import robots
from roar_sim.runs.race import RaceResult, race, race_timeout_s
from roar.tracks import get
from roar.tracks.track import BUILTIN

TITLE = "autopilot lap time / physical-limit lap time (target <= 1.15, no wall contacts)"
LAPS = 3
TARGET = 1.15


def run() -> None:
    for robot, name in ((robot, name) for robot in robots.names() for name in sorted(BUILTIN)):
        result = race(get(name), laps=LAPS, robot=robot)
        flying = result.lap_times_s[1:] or result.lap_times_s
        if not flying:
            print(f"  {robot:6} {name:14} MISSED: {result.shortfall(LAPS, race_timeout_s(result, LAPS))}")
            continue
        best = min(flying)
        ratio = best / result.limit_lap_s
        verdict = "ok" if ratio <= TARGET and result.wall_contacts == 0 else \
            f"MISSED by {ratio - TARGET:+.3f}: {where_slow(result)}" if result.wall_contacts == 0 else \
            "MISSED: touched a wall"
        print(f"  {robot:6} {name:14} best flying lap {best:6.2f} s, limit {result.limit_lap_s:5.2f} s, "
              f"ratio {ratio:.3f}, wall contacts {result.wall_contacts}  {verdict}")


def where_slow(result: RaceResult) -> str:
    """Where the flying laps fell short of the physical-limit profile: the mean share of its speed
    driven, and the stretch of track driven furthest below it."""
    track, p = result.track, np.array(result.path)
    flying = p[p[:, 4] >= result.lap_times_s[0]]  # (x, y, speed, arc length, t) after the first lap
    limit = np.interp(flying[:, 3], track.arc_start, result.limit_speeds, period=track.length_m)
    share = flying[:, 2] / limit
    worst = int(np.argmin(share))
    return (f"driven at {share.mean():.0%} of the profile's speed on average, furthest below it "
            f"{flying[worst, 3]:.1f} m into the lap ({share[worst]:.0%}: {flying[worst, 2]:.2f} of "
            f"{limit[worst]:.2f} m/s)")
