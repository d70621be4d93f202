"""How closely the batched car matches the PyBullet car, measured as the issue asks:

    closed loop   the same driver (the ESC car's pure-pursuit agent round the centre line) laps a
                  track in both worlds: each lap's time and the batch's path against PyBullet's (RMS)
    open loop     the same 1 s of pulses from the same state (the PyBullet car's, at 0.5-2.5 m/s):
                  where the two end (roar_sim.batch.identify's drives and windows)

    lap = closed_loop(get("oval"), car_profile.load("roar"))    # Laps of both worlds
    lap.time_ratio, lap.path_rms_m
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from roar.autopilot.agent import Observation
from roar.calibration import Calibration
from roar.tracks import Track
from roar_sim.batch.identify import Drive, batch_drives
from roar_sim.batch.model import Physics
from roar_sim.batch.track_pool import TrackPool
from roar_sim.batch.world import BatchWorld
from roar_sim.core.lockstep import CONTROL_PERIOD_S
from roar_sim.plants.car_profile import CarProfile

MOVING_M_S = (0.5, 2.5)  # [m/s] the open-loop windows' starting speeds


@dataclass
class Run:
    t: np.ndarray  # [s]
    xy: np.ndarray  # [m] the base's path
    laps: list[float]  # [s] each whole lap's time, the first from the standing start
    walls: int  # control periods at a wall


@dataclass
class Laps:
    pybullet: Run
    batch: Run

    @property
    def time_ratio(self) -> np.ndarray:
        """Each lap's time in the batch over PyBullet's."""
        k = min(len(self.pybullet.laps), len(self.batch.laps))
        return np.array(self.batch.laps[:k]) / np.array(self.pybullet.laps[:k])

    @property
    def path_rms_m(self) -> float:
        """[m] RMS of the batch's path's distance from PyBullet's."""
        import shapely

        line = shapely.LineString(self.pybullet.xy)
        return float(np.sqrt(np.mean(shapely.distance(shapely.points(self.batch.xy), line) ** 2)))


def _drive(track: Track, step, laps: int, max_s: float) -> Run:
    """Run a car by step(t) -> (x, y, yaw, touching) each control period until `laps` laps are done."""
    t, xy, lap_times, walls = 0.0, [], [], 0
    hint, s_last, travelled, last_lap_t = None, None, 0.0, 0.0
    while len(lap_times) < laps and t < max_s:
        x, y, yaw, touching = step(t)
        walls += touching
        hint, s, _ = track.project((x, y), hint, heading=yaw)
        if s_last is not None:
            travelled += track.arc_delta(s_last, s)
            if travelled >= track.length_m * (len(lap_times) + 1):
                lap_times.append(t - last_lap_t)
                last_lap_t = t
        s_last = s
        xy.append((x, y))
        t += CONTROL_PERIOD_S
    return Run(np.arange(len(xy)) * CONTROL_PERIOD_S, np.array(xy), lap_times, walls)


def closed_loop(track: Track, profile: CarProfile, physics: Physics | None = None, laps: int = 2,
                max_s: float = 120.0) -> Laps:
    """Both worlds' car lapped by the ESC car's agent (its limits measured from the profile)."""
    from roar_sim.robots.esc import EscCar

    calibration = Calibration()
    with EscCar(track, pose=track.start_pose, profile=profile) as car:
        agent = car.agent(track.centerline)
        car.arm()

        def pybullet_step(t):
            s = car.state()
            command = agent.step(Observation(t, s.x, s.y, s.yaw, abs(s.speed), s.yaw_rate))
            car.drive(command.throttle, command.steering)
            car.run(CONTROL_PERIOD_S)
            return s.x, s.y, s.yaw, car.touching_wall()

        bullet = _drive(track, pybullet_step, laps, max_s)
        model = car.model  # what its agent plans with: the batch's agent the same
    world = BatchWorld(1, profile=profile, physics=physics, pool=TrackPool([track]))
    world.reset([0], [track.start_pose])
    world.step(np.zeros(1, np.uint16), np.zeros(1, np.uint16))  # arming
    agent = _agent(model, track)

    def batch_step(t):
        x, y, yaw, speed, rate = world.states()[0]
        command = agent.step(Observation(t, x, y, yaw, abs(speed), rate))
        throttle = calibration.throttle.to_us(command.throttle)
        steering = calibration.steering.to_us(command.steering)
        world.step(np.array([throttle], np.uint16), np.array([steering], np.uint16))
        return x, y, yaw, bool(world.touching[0])

    return Laps(bullet, _drive(track, batch_step, laps, max_s))


def _agent(model, track: Track):
    from roar.autopilot import race_agent

    return race_agent(track.centerline, model, CONTROL_PERIOD_S)


FULL_THROTTLE_US = 1900  # [us] a window with a pulse this high: full throttle (wheelspin in PyBullet)
BRAKING_US = 1450  # [us] a window with a pulse this low: braking (locked wheels in PyBullet)


def open_loop(profile: CarProfile, drives: list[Drive], physics: Physics | None = None,
              speeds=MOVING_M_S) -> dict[str, np.ndarray]:
    """[m] where each 1 s window that starts at `speeds` ends, the batch's against PyBullet's: all
    of them ("all"), and apart by what the window asks: "full throttle" (a pulse at or above
    FULL_THROTTLE_US), "braking" (one at or below BRAKING_US), "gentle" (neither)."""
    from roar_sim.batch.identify import WINDOW_S, window_errors
    from roar_sim.batch.model import physics_for

    physics = physics or physics_for(profile)
    errors = window_errors(drives, batch_drives(profile, physics, drives))
    every = round(WINDOW_S / CONTROL_PERIOD_S)
    out = {"all": [], "full throttle": [], "braking": [], "gentle": []}
    for drive, ends in zip(drives, errors):
        for w, end in enumerate(ends.tolist()):
            pulses = drive.throttle_us[w * every:(w + 1) * every]
            if not speeds[0] <= abs(drive.body[w * every, 3]) <= speeds[1]:
                continue
            out["all"].append(end)
            full, braking = pulses.max() >= FULL_THROTTLE_US, pulses.min() <= BRAKING_US
            if full:
                out["full throttle"].append(end)
            if braking:
                out["braking"].append(end)
            if not (full or braking):
                out["gentle"].append(end)
    return {kind: np.array(values) for kind, values in out.items()}
