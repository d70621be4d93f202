"""The batched car's Physics fitted to the PyBullet car: both driven by the same pulses on an open
floor (piecewise-constant throttle and steering, drawn from a seed: launches, bends at every speed,
lifts and brakes), the batch restarted from the PyBullet car's state every WINDOW_S (multiple
shooting), and the Physics that brings each window's path nearest PyBullet's found by least squares
(scipy), with intervals as roar fit gives them (roar.fit.identify.sigma_of).

    drives = pybullet_drives(profile, seeds=range(8))    # what the PyBullet car did
    fitted = fit(profile, drives)                         # Fitted: physics, intervals, errors
    python -m roar_sim.batch.identify roar                # fit a profile, print the TOML to keep

A window's error is where it ends: the issue's open-loop measure (the same 1 s of pulses from the
same state, the two ends' distance).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace

import numpy as np

from roar.protocol import encode
from roar_sim.batch.model import Physics
from roar_sim.batch.world import BatchWorld
from roar_sim.core.lockstep import CONTROL_PERIOD_S
from roar_sim.plants.car_profile import CarProfile

DRIVE_S = 12.0  # [s] each drive
WINDOW_S = 1.0  # [s] the batch runs this long from each of the PyBullet car's states
HOLD_S = (0.25, 0.9)  # [s] each command held this long (drawn)
FREE = ("mu_share", "slip_tau_s", "cg_share", "yaw_radius", "cg_height_m", "tau_s", "roll_n_per_kg", "damping_per_s",
        "sliding_grip", "wheel_share")
BOUNDS = {"mu_share": (0.3, 2.0), "slip_tau_s": (0.001, 0.1), "cg_share": (0.2, 0.8),
          "yaw_radius": (0.05, 0.3), "cg_height_m": (0.0, 0.2), "tau_s": (0.002, 0.5), "roll_n_per_kg": (0.0, 2.0),
          "damping_per_s": (0.0, 2.0), "sliding_grip": (0.0, 1.0), "wheel_share": (0.8, 1.2)}
YAW_M = 0.3  # [m] a radian of heading weighs as this far in a window's error
SPEED_S = 0.3  # [s] a m/s of speed weighs as this far


@dataclass
class Drive:
    """What the PyBullet car did under one drive's pulses (sent each control period)."""

    throttle_us: np.ndarray  # [steps] int
    steering_us: np.ndarray  # [steps] int
    body: np.ndarray  # [steps + 1, 6]: the base's x, y [m], yaw [rad], and at the base: speed along, across [m/s],
    #                   yaw rate [rad/s]; row 0 before the first command (after the arming period)


def commands(seed: int, steps: int) -> tuple[np.ndarray, np.ndarray]:
    """(throttle, steering) [us] for `steps` control periods: each pair held HOLD_S, throttle mostly
    forward at any strength (some lifts to neutral, some brakes and reverses), steering anywhere."""
    rng = np.random.default_rng(seed)
    throttle, steering = [], []
    while len(throttle) < steps:
        hold = int(rng.uniform(*HOLD_S) / CONTROL_PERIOD_S)
        pick = rng.uniform()
        th = 1500 if pick < 0.12 else int(rng.uniform(1000, 1400)) if pick < 0.22 else int(rng.uniform(1560, 2000))
        st = int(rng.uniform(1000, 2000)) if rng.uniform() < 0.8 else 1500
        throttle += [th] * hold
        steering += [st] * hold
    return np.array(throttle[:steps]), np.array(steering[:steps])


def pybullet_drives(profile: CarProfile, seeds, drive_s: float = DRIVE_S) -> list[Drive]:
    """The PyBullet car (EscCar on an open floor) under each seed's commands."""
    steps = round(drive_s / CONTROL_PERIOD_S)
    return [pybullet_drive(profile, *commands(seed, steps)) for seed in seeds]


def pybullet_drive(profile: CarProfile, throttle: np.ndarray, steering: np.ndarray) -> Drive:
    """The PyBullet car (EscCar on an open floor), armed, then sent these pulses a control period each."""
    from roar_sim.robots.esc import EscCar
    from roar_sim.world.bullet import pb

    rows = []
    with EscCar(profile=profile) as car:
        car.arm()

        def record():
            s = car.state()
            (vx, vy, _), _ = pb.getBaseVelocity(car.plant.car, physicsClientId=car.plant.client)
            c, si = math.cos(s.yaw), math.sin(s.yaw)
            rows.append((s.x, s.y, s.yaw, c * vx + si * vy, -si * vx + c * vy, s.yaw_rate))

        record()
        for th, st in zip(np.asarray(throttle).tolist(), np.asarray(steering).tolist()):
            car.write(encode(th, st))
            car.run(CONTROL_PERIOD_S)
            record()
    return Drive(np.asarray(throttle), np.asarray(steering), np.array(rows))


def batch_drives(profile: CarProfile, physics: Physics, drives: list[Drive], window_s: float | None = WINDOW_S,
                 ) -> np.ndarray:
    """[len(drives), steps + 1, 3]: the base's x, y, yaw of the batch's cars under the drives'
    pulses, each put where its PyBullet car was every window_s (None: never, the batch alone)."""
    n, steps = len(drives), len(drives[0].throttle_us)
    world = BatchWorld(n, tracks=None, profile=profile, physics=physics)
    world.reset(np.arange(n), np.array([d.body[0, :3] for d in drives]))
    world.step(np.zeros(n, np.uint16), np.zeros(n, np.uint16))  # the arming period, as the PyBullet car's
    every = None if window_s is None else round(window_s / CONTROL_PERIOD_S)
    out = np.empty((n, steps + 1, 3))
    throttle = np.array([d.throttle_us for d in drives], dtype=np.uint16)
    steering = np.array([d.steering_us for d in drives], dtype=np.uint16)
    world.place_bodies(np.array([d.body[0] for d in drives]))
    for j in range(steps + 1):
        out[:, j] = world.states()[:, :3]  # (at a window's end: before it is put back)
        if every and j % every == 0:
            world.place_bodies(np.array([d.body[j] for d in drives]))
        if j < steps:
            world.step(throttle[:, j], steering[:, j])
    return out


def window_errors(drives: list[Drive], predicted: np.ndarray, window_s: float = WINDOW_S) -> np.ndarray:
    """[drives, windows] [m]: where each window ended, the batch's against PyBullet's."""
    every = round(window_s / CONTROL_PERIOD_S)
    truth = np.array([d.body[:, :3] for d in drives])
    ends = np.arange(every, truth.shape[1], every)
    return np.hypot(*(predicted[:, ends, :2] - truth[:, ends, :2]).transpose(2, 0, 1))


def residuals(drives: list[Drive], predicted: np.ndarray) -> np.ndarray:
    """Every period's distance, heading and speed error (weighed in metres), all drives'."""
    truth = np.array([d.body for d in drives])
    dyaw = np.remainder(predicted[:, :, 2] - truth[:, :, 2] + math.pi, 2 * math.pi) - math.pi
    return np.concatenate([(predicted[:, :, 0] - truth[:, :, 0]).ravel(), (predicted[:, :, 1] - truth[:, :, 1]).ravel(),
                           YAW_M * dyaw.ravel()])


@dataclass
class Fitted:
    physics: Physics
    sigma: dict[str, float]  # one standard deviation of each fitted number
    window_m: np.ndarray  # [drives, windows] [m] each window's end error with the fitted physics
    evaluations: int

    def table(self) -> str:
        from roar.fit.identify import Z95

        rows = [f"  {name:14} {getattr(self.physics, name):9.4g} ± {Z95 * self.sigma[name]:.2g}" for name in FREE]
        e = self.window_m
        rows.append(f"  1 s windows' ends: median {np.median(e) * 100:.1f} cm, 95th percentile "
                    f"{np.percentile(e, 95) * 100:.1f} cm, worst {e.max() * 100:.1f} cm")
        return "\n".join(rows)


def fit(profile: CarProfile, drives: list[Drive], start: Physics | None = None) -> Fitted:
    """The Physics (FREE's numbers) that brings the batch's windows nearest the PyBullet car's."""
    from scipy.optimize import least_squares

    from roar.fit.identify import sigma_of

    start = start or Physics()
    low = np.array([BOUNDS[n][0] for n in FREE])
    high = np.array([BOUNDS[n][1] for n in FREE])
    x0 = np.clip([getattr(start, n) for n in FREE], low, high)
    calls = [0]

    def physics_of(x) -> Physics:
        return replace(start, **dict(zip(FREE, map(float, x))))

    def res(x):
        calls[0] += 1
        return residuals(drives, batch_drives(profile, physics_of(x), drives))

    result = least_squares(res, x0, bounds=(low, high), x_scale=high - low, diff_step=1e-3, max_nfev=200)
    physics = physics_of(result.x)
    window = window_errors(drives, batch_drives(profile, physics, drives))
    return Fitted(physics, dict(zip(FREE, sigma_of(result, len(result.fun)))), window, calls[0])


def physics_toml(profile: CarProfile, fitted: Fitted) -> str:
    lines = [f"[{profile.name}]", f'fingerprint = "{profile.fingerprint}"']
    lines += [f"{f.name} = {getattr(fitted.physics, f.name)!r}" for f in fields(Physics)]
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    import argparse

    from roar_sim.plants import car_profile

    parser = argparse.ArgumentParser(prog="python -m roar_sim.batch.identify", description=__doc__.split("\n\n")[0])
    parser.add_argument("profile", nargs="?", default=car_profile.DEFAULT, help="a car profile's name or .toml file")
    parser.add_argument("--drives", type=int, default=12, help="PyBullet drives to fit on (default 12)")
    args = parser.parse_args(argv)
    profile = car_profile.load(args.profile)
    drives = pybullet_drives(profile, range(args.drives))
    from roar_sim.batch.model import physics_for

    fitted = fit(profile, drives, physics_for(profile))  # from its last fit (or the default's): least squares finds
    #                                                      the nearest minimum
    print(fitted.table())
    print(physics_toml(profile, fitted))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
