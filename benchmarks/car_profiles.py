"""Every car profile laps every track: each shipped profile (roar_sim/plants/car_profiles/) and five
profiles drawn at random within the span of 1/10 hobby cars (HOBBY_CARS, inside the ranges a
profile may hold: those also admit 100 m/s cars no 1.2 m track suits; seeded: the same five every run),
raced by the ESC car's autopilot round every built-in track and random:1..10, two laps each. Target:
no wall contact and the best lap within 1.10 x the profile's own physical-limit lap (issue 43,
item 6). A track with a bend tighter than the profile's car can turn is refused, and said so."""

import tempfile
from pathlib import Path

import numpy as np

from benchmarks.race_ratio import where_slow
from roar.tracks import TrackError, get
from roar.tracks.track import BUILTIN
from roar_sim import ProfileError
from roar_sim.plants import car_profile
from roar_sim.runs.race import race, race_timeout_s

TITLE = "every car profile laps every track (target: no wall, best lap <= 1.10 x its own limit)"
TARGET = 1.10
LAPS = 2
TRACKS = [*sorted(BUILTIN), *(f"random:{seed}" for seed in range(1, 11))]
RANDOM_PROFILES = 5


# What 1/10 hobby cars span (drawn uniformly): the wheel's top speed and torque are drawn, the
# motor's figures follow from them and the gear ratio (a 0.05 m wheel: 2.5-10 m/s unloaded).
HOBBY_CARS = {
    "wheelbase_m": (0.25, 0.40), "mass_kg": (1.5, 6.0), "gear_ratio": (6.0, 14.0), "tyre_friction": (0.5, 1.2),
    "max_steer_rad": (0.30, 0.50), "steer_rate_rad_s": (3.0, 12.0),
}
WHEEL_SPEED_RAD_S = (50.0, 200.0)  # [rad/s] at full throttle
WHEEL_TORQUE_NM = (0.5, 2.0)  # [N m] per rear wheel


def drawn(seed: int, folder: Path) -> str:
    """A profile .toml of numbers drawn uniformly within HOBBY_CARS (each inside car_profile.RANGES)."""
    rng = np.random.default_rng(seed)
    values = {key: rng.uniform(low, high) for key, (low, high) in HOBBY_CARS.items()}
    values["motor_speed_rad_s"] = rng.uniform(*WHEEL_SPEED_RAD_S) * values["gear_ratio"]
    values["motor_torque_nm"] = rng.uniform(*WHEEL_TORQUE_NM) / values["gear_ratio"]
    lines = [f'title = "random profile {seed}"']
    for key, (low, high, unit) in car_profile.RANGES.items():
        assert low <= values[key] <= high, key
        lines.append(f"{key} = {values[key]:.4f}  # [{unit}]" if unit else f"{key} = {values[key]:.4f}")
    path = folder / f"random{seed}.toml"
    path.write_text("\n".join(lines) + "\n")
    return str(path)


def run() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        profiles = [*car_profile.names(), *(drawn(seed, Path(tmp)) for seed in range(RANDOM_PROFILES))]
        missed = 0
        for profile in profiles:
            title = car_profile.load(profile).title
            print(f"  {title}:")
            for name in TRACKS:
                try:
                    result = race(get(name), LAPS, profile=profile)
                except ProfileError as e:
                    missed += 1
                    print(f"    MISSED: {e}")
                    break
                except TrackError as e:
                    print(f"    {name:14} refused: {e}")
                    continue
                if not result.lap_times_s:
                    missed += 1
                    print(f"    {name:14} MISSED: {result.shortfall(LAPS, race_timeout_s(result, LAPS))}")
                    continue
                ratio = min(result.lap_times_s) / result.limit_lap_s
                ok = ratio <= TARGET and result.wall_contacts == 0
                missed += not ok
                cause = "" if ok else (f"  MISSED: {result.wall_contacts} control periods on a wall" if result.wall_contacts
                                       else f"  MISSED by {ratio - TARGET:+.3f}: {where_slow(result)}")
                print(f"    {name:14} laps {len(result.lap_times_s)}, best {min(result.lap_times_s):6.2f} s, "
                      f"ratio {ratio:.3f}, wall contacts {result.wall_contacts}{cause}")
        print(f"  {missed} runs missed the target" if missed else "  every profile met the target on every track")
