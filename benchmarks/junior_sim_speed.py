"""The simulated Junior's speed in simulated seconds per wall second: bare PyBullet stepping of
the same robot on the same straight (the least work that scene can do), against the firmware-in-the-loop Junior (JuniorBoard::poll at 1 kHz
with its HTTP reader, the L298N and motor model, physics at 200 Hz, ultrasonic every 60 ms, a
control request every 20 ms on a kept-alive connection). Targets, rounds and the best-of rule
as for the ESC car (benchmarks.sim_speed)."""

import time

from benchmarks.sim_speed import compare
from roar.junior import query_for
from roar_sim.core.junior import SidePins
from roar_sim.plants.junior import JuniorPlant
from roar_sim.core.lockstep import PHYSICS_US
from roar_sim.robots.junior import Junior
from benchmarks.sim_speed import SCENE

TITLE = "Junior simulation speed (simulated s per wall s)"
SIM_SECONDS = 10.0
PERIOD_S = 0.02  # [s] between control requests
HALF = SidePins(True, False, 500)  # forward at half duty


def bare() -> float:
    """The least work the Junior's scene can do: the same robot on the same straight, physics at
    the same rate, half duty on both motors and nothing else. The motors' model runs each physics
    step (a DC motor's torque follows its speed: that is the plant's physics, not the firmware)."""
    plant = JuniorPlant(SCENE(), dt_s=PHYSICS_US / 1e6)
    try:
        start = time.perf_counter()
        for _ in range(int(SIM_SECONDS * 1e6 / PHYSICS_US)):
            plant.apply(HALF, HALF)
            plant.step()
        return SIM_SECONDS / (time.perf_counter() - start)
    finally:
        plant.close()


def harness() -> float:
    with Junior(SCENE()) as sim:
        connection = sim.connect()
        request = f"GET /?{query_for(0.5, 0.5)} HTTP/1.1\r\nHost: junior\r\n\r\n".encode()
        start = time.perf_counter()
        for _ in range(int(SIM_SECONDS / PERIOD_S)):
            connection.feed(request)
            sim.run(PERIOD_S)
        return SIM_SECONDS / (time.perf_counter() - start)


def run() -> None:
    compare(bare, harness, "firmware-in-the-loop Junior")
