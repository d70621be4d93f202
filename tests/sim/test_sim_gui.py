"""The PyBullet window (--gui) opens and the car drives in it, on a virtual screen (Xvfb)."""

import os
import subprocess
import sys

DRIVE_IN_WINDOW = """
from roar_sim.world.bullet import pb
from roar.protocol import encode
from roar_sim.robots.esc import EscCar
from roar.tracks.track import oval
with EscCar(oval(), gui=True) as sim:
    assert pb.getConnectionInfo(sim.plant.client)["connectionMethod"] == pb.GUI
    x0 = sim.state().x
    for i in range(70):  # neutral first: the firmware boots with its failsafe latched
        sim.write(encode(1650 if i >= 10 else 1500, 1500))
        sim.run(0.02)
    print("MOVED", sim.state().x - x0)
"""


def test_the_car_drives_in_the_pybullet_window(virtual_display):
    result = subprocess.run([sys.executable, "-c", DRIVE_IN_WINDOW], capture_output=True, text=True, timeout=120,
                            env={**os.environ, "DISPLAY": virtual_display})
    moved = [line for line in result.stdout.splitlines() if line.startswith("MOVED")]
    assert result.returncode == 0 and moved, result.stderr[-2000:]
    assert float(moved[0].split()[1]) > 0.2  # [m] forward along the straight
