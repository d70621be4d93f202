"""The numbers a batched car is simulated with (roar_sim.batch.kernels' parameter columns): most
come straight from its car profile (mass, size, motor, ESC, servo, latency); the rest say how the
PyBullet car's contacts behave as a single-track model's tyres and body (Physics), identified by
least squares from the PyBullet car itself (roar_sim.batch.identify) and kept per profile.

    params = parameters(car_profile.load("roar"))          # float64 [PARAMS]
    params = parameters(profile, Physics(mu_share=0.9))
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, fields
from functools import lru_cache
from pathlib import Path

import numpy as np

from roar_sim.batch import kernels as k
from roar_sim.plants import car_profile
from roar_sim.plants.car_profile import CarProfile
from roar_sim.plants.esc_servo import HobbyEsc
from roar_sim.plants.racecar import FOOTPRINT_M, WHEEL_RADIUS_M

URDF_LIDAR_AHEAD_M = 0.265  # [m] the Hokuyo link ahead of the base's origin (racecar.urdf; Racecar.lidar_mount)


@dataclass(frozen=True)
class Physics:
    """What the single-track model needs beyond a profile: how PyBullet's contacts behave, each a
    share or a length of the car drawn at the URDF's size (scaled with the profile)."""

    mu_share: float = 1.0  # the tyres' friction as the body feels it, a share of the profile's tyre_friction
    slip_tau_s: float = 0.005  # [s] how soon a wheel's sideways slide is stopped when its friction allows
    cg_share: float = 0.5  # the centre of mass's distance from the rear axle, a share of the wheelbase
    yaw_radius: float = 0.12  # [m] the body's radius of gyration about its vertical axis
    cg_height_m: float = 0.05  # [m] the centre of mass's height (longitudinal load transfer)
    tau_s: float = 0.01  # [s] how soon a velocity motor reaches its target when its torque allows
    roll_n_per_kg: float = 0.1  # [N/kg] rolling resistance besides the motors' drag
    damping_per_s: float = 0.3  # [1/s] drag in proportion to speed (the bodies' and spinning wheels' damping)
    sliding_grip: float = 0.5  # the sideways grip left to rear wheels that spin or lock, a share of their friction
    wheel_share: float = 0.95  # the wheels' rolling radius, a share of theirs (they sink into the floor a little)
    base_ahead_m: float = 0.0  # [m] the base's origin ahead of the rear axle


def parameters(profile: CarProfile, physics: Physics | None = None) -> np.ndarray:
    """float64 [kernels.PARAMS]: the kernels' numbers for a car of this profile."""
    ph = physics or Physics()
    scale = profile.scale
    motor = profile.motor
    wheel = WHEEL_RADIUS_M * scale * ph.wheel_share  # [m] as they roll
    p = np.zeros(k.PARAMS)
    wheelbase = profile.wheelbase_m
    p[k.P_MASS] = profile.mass_kg
    p[k.P_LR] = ph.cg_share * wheelbase
    p[k.P_LF] = wheelbase - p[k.P_LR]
    p[k.P_IZ] = profile.mass_kg * (ph.yaw_radius * scale) ** 2
    p[k.P_H] = ph.cg_height_m * scale
    p[k.P_MU] = ph.mu_share * motor.tyre_friction
    p[k.P_SLIP] = ph.slip_tau_s
    p[k.P_VTOP] = motor.max_speed_rad_s * wheel
    p[k.P_FDRIVE] = 2 * motor.max_torque_nm / wheel  # two rear wheels
    p[k.P_FDRAG] = 2 * profile.rolling_drag_nm / wheel
    p[k.P_FBRAKE] = 2 * profile.brake_torque_nm / wheel
    p[k.P_TAU] = ph.tau_s
    p[k.P_ROLL] = ph.roll_n_per_kg * profile.mass_kg
    p[k.P_DAMP] = ph.damping_per_s
    p[k.P_SLIDING] = ph.sliding_grip
    p[k.P_MAXSTEER], p[k.P_RATE], p[k.P_LAG] = profile.max_steer_rad, profile.steer_rate_rad_s, profile.servo_lag_s
    p[k.P_TRIM] = math.radians(profile.steering_trim_deg)
    p[k.P_DEADBAND] = profile.esc_deadband_us
    p[k.P_REVERSE] = HobbyEsc.reverse_limit
    p[k.P_LATENCY] = profile.latency_s
    p[k.P_BASE] = p[k.P_LR] - ph.base_ahead_m * scale  # [m] from the base's origin ahead to the centre of mass
    rear, front, half_width = (v * scale for v in FOOTPRINT_M)
    p[k.P_REAR], p[k.P_FRONT], p[k.P_HALFW] = rear, front, half_width
    p[k.P_LIDAR] = URDF_LIDAR_AHEAD_M * scale
    return p


PHYSICS_FILE = Path(__file__).with_name("physics.toml")  # the shipped profiles' Physics, as identify fitted them


def physics_for(profile: CarProfile) -> Physics:
    """A profile's identified Physics (PHYSICS_FILE, found by the profile's fingerprint: a profile
    changed since is not taken for the one fitted); any other profile's: the default profile's (its
    numbers are shares and lengths of the URDF's car, drawn to scale, so they carry over)."""
    table = _table()
    for entry in table.values():
        if entry.get("fingerprint") == profile.fingerprint:
            return _physics(entry)
    return _physics(table.get(car_profile.DEFAULT, {}))


def _physics(entry: dict) -> Physics:
    names = {f.name for f in fields(Physics)}
    return Physics(**{key: float(value) for key, value in entry.items() if key in names})


@lru_cache(maxsize=1)
def _table() -> dict:
    return tomllib.loads(PHYSICS_FILE.read_text()) if PHYSICS_FILE.exists() else {}
