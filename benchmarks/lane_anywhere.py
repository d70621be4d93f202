"""The camera-only lane driver on tracks no one tuned it for: two laps on each of the random tracks
random:1..20 (1.2 m wide, bends >= 1.5 m) and five 2.2 m wide ones with bends >= 1 m (the real
circuits' shape), a row per seed: laps, wall contacts, the largest cross-track error (target 0,
<= 0.25 m), its best lap against the pose-based autopilot's on the same track (target <= 1.3),
and its stops, each explained."""

import sys
from concurrent.futures import ProcessPoolExecutor

from roar.tracks import get
from roar_sim.runs.race import race, race_timeout_s

TITLE = "camera-only laps on unseen random tracks (targets: 2 laps, 0 wall contacts, cross-track <= 0.25 m, <= 1.3 x pose)"
NARROW = [f"random:{seed}" for seed in range(1, 21)]
WIDE = [f"random:{seed},width=2.2,radius=1" for seed in range(1, 6)]
LAPS = 2
MAX_CROSS_TRACK_M = 0.25  # [m]
MAX_RATIO = 1.3


def one(name: str) -> str:
    track = get(name)
    by_camera = race(track, laps=LAPS, lateral="lane")
    by_pose = race(track, laps=LAPS)
    end_s = by_camera.path[-1][4] if by_camera.path else 0.0
    stops = "; ".join(stop.line(end_s) for stop in by_camera.stops) or "no stops"
    if len(by_camera.lap_times_s) < LAPS:
        return f"  {name:32} MISSED: {by_camera.shortfall(LAPS, race_timeout_s(by_camera, LAPS))}"
    ratio = min(by_camera.lap_times_s) / min(by_pose.lap_times_s)
    ok = by_camera.wall_contacts == 0 and by_camera.max_cross_track_m <= MAX_CROSS_TRACK_M and ratio <= MAX_RATIO
    return (f"  {name:32} {LAPS} laps, best {min(by_camera.lap_times_s):5.2f} s = {ratio:.2f} x pose, wall contacts "
            f"{by_camera.wall_contacts}, max cross-track {by_camera.max_cross_track_m:.2f} m, {stops}  "
            f"{'ok' if ok else 'MISSED'}")


def run(names: list[str] | None = None) -> None:
    names = names or [*NARROW, *WIDE]
    with ProcessPoolExecutor(max_workers=2) as pool:  # two races at once: this machine's cores
        rows = list(pool.map(one, names))
    for row in rows:
        print(row, flush=True)
    done = sum(row.endswith(" ok") for row in rows)
    print(f"  {done} of {len(rows)} tracks met every target")


if __name__ == "__main__":
    run(sys.argv[1:] or None)
