"""Simulation speed in simulated seconds per wall second: bare PyBullet stepping of the same car
and track, against the full firmware-in-the-loop harness (the board loop CarBoard::poll at
1 kHz, ESC/servo emulation, physics at 200 Hz, host messages at 50 Hz), lidar off. Targets:
harness >= 30x real time, and >= 0.5 of bare stepping. The two are measured alternately,
ROUNDS times each, and the best of each is kept, so a busy moment on the machine does not
decide the ratio."""

import time

from roar.protocol import encode
from roar_sim.clock.lockstep import PHYSICS_US
from roar_sim.robots.esc import EscCar
from roar_sim.plants.racecar import Racecar
from roar.tracks.track import oval

TITLE = "simulation speed (simulated s per wall s)"
SIM_SECONDS = 10.0
ROUNDS = 3
TARGET_SPEED, TARGET_RATIO = 30.0, 0.5


def bare() -> float:
    plant = Racecar(oval(), dt_s=PHYSICS_US / 1e6)
    try:
        start = time.perf_counter()
        for _ in range(int(SIM_SECONDS / plant.dt_s)):
            plant.apply(0.3, 0.0, 0.1)
            plant.step()
        return SIM_SECONDS / (time.perf_counter() - start)
    finally:
        plant.close()


def harness() -> float:
    with EscCar(oval()) as sim:
        sim.write(encode(1500, 1500))
        sim.run(0.02)
        message = encode(1650, 1550)
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
    print(f"{'ratio to bare:':31}{h / b:8.2f}   (target >= {TARGET_RATIO})")


def run() -> None:
    compare(bare, harness, "firmware-in-the-loop harness")
