"""The fit's test drive (roar.fit.drive) on a simulated ESC car in lockstep: the firmware's board
loop fed the same control messages a Vehicle sends at 50 Hz, poses taken from the simulator at a
pose source's rate and noise. It serves the fit twice: as the reference that turns the fit's
model into a car profile (the simulated car with the base profile, driven as the user's car was),
and as the hidden cars that stand in for a user's car in tests and benchmarks.

    record = drive(load("roar"), Area(4, 6), pose_hz=50, noise_m=0.005, seed=1)
"""

from __future__ import annotations

import bisect
import numpy as np

from roar.fit.drive import Area, TestDrive, recent_speed
from roar.fit.live import SPEED_POSES
from roar.fit.log import FitLog
from roar.protocol import encode
from roar_sim.core.lockstep import CONTROL_PERIOD_S
from roar_sim.plants.car_profile import CarProfile

POSE_HZ = 50.0  # [Hz] poses a second: a motion-capture system's or a phone's at its best
NOISE_M = 0.0  # [m] the poses' noise (and [rad] the heading's)


def drive(profile: CarProfile, area: Area, pose_hz: float = POSE_HZ, noise_m: float = NOISE_M,
          seed: int = 0, pose_delay_s: float = 0.0) -> tuple[FitLog, str]:
    """(the test drive's record, why it ended early or ""), driven in lockstep on an open floor.
    pose_delay_s: each pose reaches the driver this much after it was measured (a stream's)."""
    from roar_sim.robots.esc import EscCar

    rng = np.random.default_rng(seed)
    plan = TestDrive(area, profile.wheelbase_m)
    pulses, poses, phases = [], [], []
    pose_period = 1.0 / pose_hz
    next_pose = 0.0
    with EscCar(None, profile=profile) as car:
        previous = None
        while True:
            t = car.time_s
            seen = bisect.bisect_right(poses, t + 1e-9 - pose_delay_s, key=lambda p: p[0])  # poses arrived by now
            usable = poses[max(0, seen - SPEED_POSES):seen]
            latest = usable[-1] if usable else None
            speed = recent_speed(usable)
            command = plan.step(t, latest[1:] if latest else None, latest[0] if latest else None, speed)
            if command is None:
                break
            if command.phase != previous:
                phases.append((t, command.phase))
                previous = command.phase
            pulses.append((t, command.throttle_us, command.steering_us))
            car.write(encode(command.throttle_us, command.steering_us))
            end = t + CONTROL_PERIOD_S
            while car.time_s < end - 1e-9:
                step = min(end, next_pose) - car.time_s
                if step > 1e-9:
                    car.run(step)
                if car.time_s >= next_pose - 1e-9:
                    s = car.state()
                    poses.append((car.time_s, s.x + rng.normal(0, noise_m), s.y + rng.normal(0, noise_m),
                                  s.yaw + rng.normal(0, noise_m)))
                    next_pose += pose_period
        car.write(encode(1500, 1500))
    return FitLog.from_arrays(pulses, poses, phases, "simulator"), plan.stopped

