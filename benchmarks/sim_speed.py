"""Simulation speed in simulated seconds per wall second: bare PyBullet stepping of the same car
on the same straight (the least work that scene can do: motors set once, then only physics
steps; on a straight so that neither run meets a wall), against
the full firmware-in-the-loop harness (the board loop CarBoard::poll at
1 kHz, ESC/servo emulation, physics at 200 Hz, host messages at 50 Hz), lidar off. Targets:
harness >= 30x real time, and >= 0.5 of bare stepping. The two are measured alternately,
ROUNDS times each, and the best of each is kept, so a busy moment on the machine does not
decide the ratio."""

import time

from roar.protocol import encode
from roar_sim.core.lockstep import PHYSICS_US
from roar_sim.robots.esc import EscCar
from roar_sim.plants.racecar import Racecar
from roar.tracks import get

TITLE = "simulation speed (simulated s per wall s)"
SIM_SECONDS = 10.0
ROUNDS = 3
TARGET_SPEED, TARGET_RATIO = 30.0, 0.5


def SCENE():  # noqa: N802 -- a straight long enough that neither run touches a wall in SIM_SECONDS
    return get("drag:80")  # (a wall's contacts cost more physics than the firmware's whole loop)


def bare() -> float:
    """The least work the harness's scene can do: the same car and track, physics at the same
    rate, the motors set once (the harness's command), nothing else."""
    plant = Racecar(SCENE(), dt_s=PHYSICS_US / 1e6)
    try:
        plant.apply(0.3, 0.0, 0.0)
        world = plant.world
        start = time.perf_counter()
        for _ in range(int(SIM_SECONDS / plant.dt_s)):
            world.step()
        return SIM_SECONDS / (time.perf_counter() - start)
    finally:
        plant.close()


def harness() -> float:
    with EscCar(SCENE()) as sim:
        sim.write(encode(1500, 1500))
        sim.run(0.02)
        message = encode(1650, 1500)  # straight ahead: neither run meets a wall
        start = time.perf_counter()
        for _ in range(int(SIM_SECONDS / 0.02)):
            sim.write(message)
            sim.run(0.02)
        return SIM_SECONDS / (time.perf_counter() - start)


def compare(bare_fn, harness_fn, harness_name: str) -> None:
    """Measure bare stepping and the harness alternately, ROUNDS times each; print the best of
    each against the targets, and their ratio."""
    results = [(bare_fn(), harness_fn()) for _ in range(ROUNDS)]
    b, h = max(r[0] for r in results), max(r[1] for r in results)
    print(f"{'bare PyBullet stepping:':31}{b:8.1f} x real time")
    print(f"{harness_name + ':':31}{h:8.1f} x real time   (target >= {TARGET_SPEED:.0f})")
    print(f"{'ratio to bare:':31}{h / b:8.2f}   (target >= {TARGET_RATIO}; <= 1: bare is the least work)")
    if h > b:
        print(f"  the harness beat the least work by {h / b - 1:.0%}: the two cars' paths differ (contacts cost physics)")


def run() -> None:
    compare(bare, harness, "firmware-in-the-loop harness")
