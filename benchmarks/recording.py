"""What recording costs (roar.recorder): the simulated ESC car driven for a minute of its time at
50 Hz, with a 320x240 camera at 15 frames/s and the lidar at 25 Hz, once recording every control
message, state, pose, scan and frame into an MCAP file and once not (the same run, measured in
one process). Targets: recording adds <= 10 % to the run's wall time, and writes <= 50 MB a
minute."""

from __future__ import annotations

import math
import tempfile
import time
from pathlib import Path

TITLE = "recording: cost of an MCAP log of a 50 Hz run with camera (15 FPS) and lidar (25 Hz) (<= 10 % time, <= 50 MB/min)"
SECONDS = 60.0  # [s] of the car's time
CONTROL_HZ, CAMERA_HZ, LIDAR_HZ = 50, 15, 25
SIZE = (320, 240)  # [px]
TIME_TARGET = 0.10  # share of the run's wall time
SIZE_TARGET_MB_MIN = 50.0


def drive(record: Path | None) -> tuple[float, float]:
    """(wall time [s] of the run, of it spent recording [s]) for SECONDS of the car's time."""
    from roar.autopilot import Command
    from roar.recorder import Recorder
    from roar.tracks import get
    from roar_sim import robots

    rec = Recorder(record, {"car": "sim://oval", "benchmark": "recording"}, simulated=True) if record else None
    recording = 0.0
    began = time.perf_counter()
    with robots.get("esc")(get("oval")) as bot:
        bot.arm()
        steps = int(SECONDS * CONTROL_HZ)
        for k in range(steps):
            t = k / CONTROL_HZ
            command = Command(0.25, 0.3 * math.sin(t))
            bot.send(command)
            bot.wait(1.0 / CONTROL_HZ)
            due = lambda hz: int((k + 1) * hz / CONTROL_HZ) > int(k * hz / CONTROL_HZ)  # noqa: E731
            frame = bot.plant.camera(*SIZE) if due(CAMERA_HZ) else None
            scan = bot.plant.lidar() if due(LIDAR_HZ) else None
            state = bot.vehicle_state()
            if rec is not None:
                t_ns = int(round(t * 1e9))
                r0 = time.perf_counter()
                rec.control(f"({1500 + int(250 * command.throttle)},{1500 + int(500 * command.steering)})\n".encode(),
                            t_ns)
                rec.state(state, t_ns)
                if scan is not None:
                    rec.scan(scan, -math.radians(135), math.radians(135), t_ns)
                if frame is not None:
                    rec.image(frame[0], t_ns)
                recording += time.perf_counter() - r0
    if rec is not None:
        r0 = time.perf_counter()
        rec.close()
        recording += time.perf_counter() - r0
    return time.perf_counter() - began, recording


def run(_args=None) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "run.mcap"
        bare, _ = drive(None)
        wall, spent = drive(path)
        mb_min = path.stat().st_size / 1e6 / (SECONDS / 60)
    share = spent / bare
    print(f"  run without recording {bare:.1f} s, with {wall:.1f} s; recording itself {spent:.2f} s = {share:.1%} of "
          f"the run (target <= {TIME_TARGET:.0%})  {'ok' if share <= TIME_TARGET else 'MISSED'}")
    print(f"  file {mb_min:.1f} MB a minute (target <= {SIZE_TARGET_MB_MIN:g})  "
          f"{'ok' if mb_min <= SIZE_TARGET_MB_MIN else 'MISSED'}")


if __name__ == "__main__":
    run()
