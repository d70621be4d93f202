"""Compile every Numba kernel of the project into Numba's disk cache, by running each the way the
project runs it: a short challenge run (the planner, the particle filter, the local grid, the
lidar's beams, the ray-cast camera, the object detector), a few seconds of the lane driver (its
line walk), a global start (the filter's every-place search), the batched world with its lidar
and camera, and a speed-model fit. `make setup` runs it (~45 s the first time, ~12 s again), so
that the suite's workers do not compile on first use (a fresh checkout's suite compiled the same
kernels in several workers at once).

    .venv/bin/python scripts/warm_kernels.py
"""

from __future__ import annotations

import time

import numpy as np


def _camera() -> None:
    from roar_sim.world.ray_camera import warm

    warm()


def _challenge() -> None:
    from roar.tracks import get
    from roar_sim.runs.challenge import challenge

    challenge(get("tunnel:3"), goal_m=3.0, seed=0)


def _lane_driver() -> None:
    from roar.tracks import get
    from roar_sim.runs.race import race

    race(get("oval"), laps=1, lateral="lane", timeout_s=1.0)


def _global_start() -> None:
    from roar.tracks import get
    from roar_sim.runs.localize import Localize
    from roar_sim.runs.race import race

    track = get("random:1")
    race(track, laps=1, localize=Localize(track, global_start=True), timeout_s=0.5)


def _batched() -> None:
    from roar_sim.gym_env.batched import BatchRaceEnv

    env = BatchRaceEnv(2, max_seconds=0.2, camera=(32, 24))
    env.reset(seed=0)
    for _ in range(3):
        env.step(np.zeros((2, 2)))
    env.close()


def _fit() -> None:
    from roar.fit.model import Car, speeds

    speeds(Car.start(), np.full(20, 1600.0), np.array([0, 5]), np.zeros(2), 10)


STEPS = [("the ray-cast camera", _camera), ("a challenge run", _challenge), ("the lane driver", _lane_driver),
         ("a global start", _global_start), ("the batched world", _batched), ("the fit", _fit)]


def main() -> None:
    started = time.perf_counter()
    took = []
    for what, step in STEPS:
        t = time.perf_counter()
        step()
        took.append(f"{what} {time.perf_counter() - t:.0f} s")
    print(f"Numba's kernels in its cache in {time.perf_counter() - started:.0f} s ({', '.join(took)})")


if __name__ == "__main__":
    main()
