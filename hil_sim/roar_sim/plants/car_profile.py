"""A car's own numbers in one file: roar_sim/plants/car_profiles/NAME.toml (or any .toml a user
writes), read by the racecar plant and the ESC car. The default is `roar`, the ROAR car; `f1tenth`
is an F1TENTH-like car (about 8 m/s). The limits the autopilot plans with are measured from a
profile by driving it (roar_sim.robots.esc.EscCar.measure_limits), never typed beside it.

    profile = load("f1tenth")          # or load("my_car.toml")
    profile.motor.max_speed_rad_s, profile.scale, profile.fingerprint
"""

from __future__ import annotations

import hashlib
import json
import tomllib
from dataclasses import dataclass, fields
from pathlib import Path

from roar.checks import number, printable
from roar_sim import ProfileError
from roar_sim.plants.esc_servo import HobbyEsc
from roar.user_files import read_parsed

FOLDER = Path(__file__).with_name("car_profiles")
DEFAULT = "roar"
URDF_WHEELBASE_M = 0.325  # [m] racecar.urdf's hinge axis to rear axle
URDF_MASS_KG = 5.89  # [kg] racecar.urdf's links together
RANGES = {  # (low, high, unit) of every number a profile holds
    "wheelbase_m": (0.15, 0.6, "m"), "mass_kg": (0.5, 20.0, "kg"), "motor_speed_rad_s": (50.0, 6000.0, "rad/s"),
    "gear_ratio": (1.0, 50.0, ""), "motor_torque_nm": (0.01, 5.0, "N m"), "tyre_friction": (0.1, 2.0, ""),
    "max_steer_rad": (0.1, 0.7, "rad"), "steer_rate_rad_s": (0.5, 30.0, "rad/s"),
}
# A real car's differences from a perfect one: keys a profile may leave out (low, high, unit); each absent
# key is CarProfile's default, a perfect car's, and stays out of the fingerprint (older profiles keep theirs)
OPTIONAL_RANGES = {
    "steering_trim_deg": (-10.0, 10.0, "deg"),  # the wheels' angle at a neutral pulse, left positive
    "servo_lag_s": (0.0, 0.5, "s"),  # the servo's first-order lag behind its slew
    "esc_deadband_us": (0.0, 200.0, "us"),  # pulses this near neutral are neutral
    "latency_s": (0.0, 0.5, "s"),  # from the board's output pulse to the ESC and servo acting on it
    "brake_torque_nm": (0.1, 20.0, "N m"),  # per rear wheel at full brake
    "rolling_drag_nm": (0.0, 1.0, "N m"),  # per rear wheel: what slows a coasting car
}

# How far real cars of one kind differ from the one a profile describes (issue 46's survey: steering trim,
# servo lag, command latency, ESC dead band as they are; motor and grip as shares of the profile's): the
# hidden cars a fit is judged on are drawn within it, and learning is randomised over it (real_car_spans)
REAL_CARS_ABSOLUTE = {"steering_trim_deg": (-4.0, 4.0), "servo_lag_s": (0.02, 0.08), "latency_s": (0.0, 0.06),
                      "esc_deadband_us": (0.0, 60.0)}
REAL_CARS_SHARE = {"motor": (0.7, 1.2), "tyre_friction": (0.7, 1.1)}  # motor: its speed and torque alike


def real_car_spans(base: CarProfile | None = None) -> dict[str, tuple[float, float]]:
    """{profile key: (low, high)} that real cars like `base` (default: the default profile) span,
    for Race-v0's randomize= (the motor's speed and torque each over its share)."""
    base = base or load()
    spans = dict(REAL_CARS_ABSOLUTE)
    low, high = REAL_CARS_SHARE["motor"]
    for key in ("motor_speed_rad_s", "motor_torque_nm"):
        spans[key] = (getattr(base, key) * low, getattr(base, key) * high)
    low, high = REAL_CARS_SHARE["tyre_friction"]
    spans["tyre_friction"] = (base.tyre_friction * low, base.tyre_friction * high)
    return spans


@dataclass(frozen=True)
class Motor:
    """The drive motor and the tyres, as the floor feels them (at the wheel, after the gearing)."""

    max_speed_rad_s: float = 60.0  # [rad/s] wheel speed at full throttle
    max_torque_nm: float = 1.5  # [N m] per rear wheel
    tyre_friction: float = 0.5  # the wheels' friction coefficient (times the floor's 1.0)


@dataclass(frozen=True)
class CarProfile:
    name: str
    title: str
    wheelbase_m: float  # [m]
    mass_kg: float  # [kg]
    motor_speed_rad_s: float  # [rad/s] no-load, at the motor
    gear_ratio: float
    motor_torque_nm: float  # [N m] at the motor, per rear wheel
    tyre_friction: float
    max_steer_rad: float  # [rad]
    steer_rate_rad_s: float  # [rad/s]
    steering_trim_deg: float = 0.0  # [deg] (OPTIONAL_RANGES: what each means)
    servo_lag_s: float = 0.0  # [s]
    esc_deadband_us: float = float(HobbyEsc.deadband_us)  # [us] the emulated ESC's own
    latency_s: float = 0.0  # [s]
    brake_torque_nm: float = 2.0  # [N m] the ROAR car's
    rolling_drag_nm: float = 0.02  # [N m] the ROAR car's

    @property
    def scale(self) -> float:
        """How much larger than racecar.urdf the car is drawn (its wheelbase over the URDF's)."""
        return self.wheelbase_m / URDF_WHEELBASE_M

    @property
    def motor(self) -> Motor:
        return Motor(self.motor_speed_rad_s / self.gear_ratio, self.motor_torque_nm * self.gear_ratio,
                     self.tyre_friction)

    @property
    def fingerprint(self) -> str:
        """Short hex of every number: measured limits are kept under it."""
        return fingerprint(self, OPTIONAL_RANGES)


def fingerprint(profile, optional: dict) -> str:
    """Short hex of a profile's numbers (those of `optional` only where they differ from their
    defaults: older profiles keep theirs): every robot's measured limits are kept under it."""
    numbers = ",".join(f"{getattr(profile, f.name)!r}" for f in fields(profile) if f.name not in ("name", "title")
                       and not (f.name in optional and getattr(profile, f.name) == f.default))
    return hashlib.sha256(numbers.encode()).hexdigest()[:16]


def save(profile: CarProfile, path: str | Path, header: str = "") -> None:
    """Write `profile` as a TOML file load() reads back, each number with its unit; header: comment
    lines put first. ProfileError (one line) when it cannot be written."""
    from roar.user_files import unwritable

    units = {k: unit for k, (_, _, unit) in (RANGES | OPTIONAL_RANGES).items()}
    title = json.dumps(profile.title)  # a JSON string is a TOML one
    lines = [f"# {line}" for line in header.splitlines()] + [f"title = {title}"]
    for f in fields(profile):
        if f.name in units:
            value = getattr(profile, f.name)
            unit = f"  # [{units[f.name]}]" if units[f.name] else ""
            lines.append(f"{f.name} = {float(value)!r}{unit}")
    problem = unwritable(path)
    if problem:
        raise ProfileError(problem)
    Path(path).write_text("\n".join(lines) + "\n", encoding="utf-8")


def names() -> list[str]:
    return sorted(p.stem for p in FOLDER.glob("*.toml"))


def load(name_or_path: str = DEFAULT) -> CarProfile:
    """A shipped profile by name, or a .toml file; ProfileError (one line) for anything else."""
    return read(name_or_path, FOLDER, CarProfile, RANGES, OPTIONAL_RANGES, "car profile")


def read(name_or_path: str, folder: Path, kind: type, ranges: dict, optional: dict, what: str):
    """A profile of dataclass `kind` (name, title, then its numbers): a shipped one by name (in
    `folder`) or a .toml file, each number checked against `ranges` (`optional`: keys it may leave
    out); ProfileError (one line naming the file) for anything else. Every robot's profiles load so."""
    path = Path(name_or_path) if name_or_path.endswith(".toml") else folder / f"{name_or_path}.toml"
    if not path.exists():
        shipped = sorted(p.stem for p in folder.glob("*.toml"))
        raise ProfileError(f"no {what} {printable(name_or_path)!r}: use {', '.join(shipped)} or a .toml file")
    data = read_parsed(path, tomllib.loads, ProfileError, "TOML")
    keys = {f.name for f in fields(kind)} - {"name"}
    missing, unknown = keys - set(data) - set(optional), set(data) - keys
    if missing or unknown:
        raise ProfileError(f"{path}: " + "; ".join(
            ([f"missing {', '.join(sorted(missing))}"] if missing else []) +
            ([f"unknown keys {', '.join(sorted(unknown))}"] if unknown else [])))
    if not isinstance(data["title"], str):
        raise ProfileError(f"{path}: title must be a string")
    try:
        values = {key: number(key, data[key], low, high, unit) for key, (low, high, unit) in ranges.items()}
        values.update({key: number(key, data[key], low, high, unit)
                       for key, (low, high, unit) in optional.items() if key in data})
    except ValueError as e:
        raise ProfileError(f"{path}: {e}") from None
    return kind(path.stem, printable(data["title"], 60), **values)
