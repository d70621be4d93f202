"""The ROAR Junior's own numbers in one file: roar_sim/plants/junior_profiles/NAME.toml (or any
.toml a user writes), read by its plant (roar_sim.plants.junior). No two TT gear motors are alike:
one side's motor is stronger, so the robot veers on an even duty, and each needs some duty before
its wheel turns at all. The default is `junior`, a stock kit's. Its limits are measured from a
profile by driving it (roar_sim.robots.junior.Junior.measure_limits), never typed beside it.

    profile = load("my_junior.toml")      # --car-profile, sim://?robot=junior&profile=, Race-v0(profile=)
    profile.left_strength, profile.friction_nm(profile.left_deadband_permille, profile.left_strength)
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from roar_sim.plants.car_profile import fingerprint, read
from roar_sim.plants.l298n_motors import STALL_NM

FOLDER = Path(__file__).with_name("junior_profiles")
DEFAULT = "junior"
RANGES = {  # (low, high, unit) of every number a profile holds
    # each side's motor against a stock TT motor's: its torque-speed line scaled (no-load speed and stall alike)
    "left_strength": (0.5, 1.5, ""), "right_strength": (0.5, 1.5, ""),
    # each side's dead band: the least duty that turns its wheel from standing (its gearbox's friction
    # against the motor's torque); a stock kit's is 137 (0.01 N m against 0.073 at full duty)
    "left_deadband_permille": (0.0, 600.0, "permille"), "right_deadband_permille": (0.0, 600.0, "permille"),
}
OPTIONAL_RANGES: dict[str, tuple[float, float, str]] = {}  # keys a profile may leave out: none yet


@dataclass(frozen=True)
class JuniorProfile:
    name: str
    title: str
    left_strength: float
    right_strength: float
    left_deadband_permille: float  # [permille]
    right_deadband_permille: float  # [permille]

    @property
    def fingerprint(self) -> str:
        """Short hex of every number: measured limits are kept under it."""
        return fingerprint(self, OPTIONAL_RANGES)

    def sides(self) -> tuple[tuple[float, float], tuple[float, float]]:
        """((strength, gearbox friction [N m] at the wheel) of the left side, of the right)."""
        return ((self.left_strength, friction_nm(self.left_deadband_permille, self.left_strength)),
                (self.right_strength, friction_nm(self.right_deadband_permille, self.right_strength)))


def friction_nm(deadband_permille: float, strength: float) -> float:
    """[N m] the gearbox friction at which a motor of `strength` turns its wheel from `deadband_permille` up."""
    return deadband_permille / 1000 * strength * STALL_NM


def load(name_or_path: str = DEFAULT) -> JuniorProfile:
    """A shipped profile by name, or a .toml file; ProfileError (one line) for anything else."""
    return read(name_or_path, FOLDER, JuniorProfile, RANGES, OPTIONAL_RANGES, "ROAR Junior profile")
