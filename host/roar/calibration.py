"""Calibration: how [-1, 1] commands become pulse widths, per channel, stored in a TOML file.

    # ~/.config/roar/calibration.toml (or $XDG_CONFIG_HOME/roar/calibration.toml)
    [throttle]
    trim_us = 1500     # pulse for 0 (ESC neutral): within 25 us of 1500, see below
    min_us = 1000      # pulse for -1 (full reverse)
    max_us = 2000      # pulse for +1 (full forward)
    reversed = false   # swap the directions (motor wired the other way)

    [steering]         # same keys; +1 steers right, -1 left (ROAR convention)
    trim_us = 1500     # any value between min_us and max_us
    ...

`roar calibrate URL` sets these interactively. Missing keys take the defaults above.

Where trim lives: the car boots with its failsafe latched and arms only on a throttle within
timing.arm_window_us (25 us) of 1500, the protocol's neutral. So the throttle trim here is kept
within that window, and every calibration this module accepts gives a car that arms; an ESC
whose neutral is further off is set on the ESC itself (most learn their neutral at power-up,
or have a neutral-set button). Steering trim has no such limit.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, field, fields
from pathlib import Path

from roar.checks import number
from roar.errors import CalibrationError
from roar.protocol import encode, spec
from roar.user_files import config_folder, read_parsed

LO, HI, MID = spec.CONTROL_MIN_US, spec.CONTROL_MAX_US, spec.CONTROL_NEUTRAL_US
ARM_WINDOW = spec.TIMING_ARM_WINDOW_US  # [us] the car arms on a throttle within this of MID
THROTTLE_TRIM_RANGE = (MID - ARM_WINDOW, MID + ARM_WINDOW)  # [us]
CHANNELS = ("throttle", "steering")  # a calibration's sections


@dataclass(frozen=True)
class ChannelCalibration:
    """One channel's pulses; a ValueError naming the key for values of the wrong type (an integer
    is an integer: not true, not 1500.0, not "1500") or out of order."""

    trim_us: int = MID  # [us] pulse for 0
    min_us: int = LO  # [us] pulse for -1
    max_us: int = HI  # [us] pulse for +1
    reversed: bool = False

    def __post_init__(self) -> None:
        for name in ("trim_us", "min_us", "max_us"):
            value = getattr(self, name)
            if type(value) is not int:
                raise ValueError(f"{name}: must be an integer [us], got {value!r}")
        if type(self.reversed) is not bool:
            raise ValueError(f"reversed: must be true or false, got {self.reversed!r}")
        if not LO <= self.min_us <= self.trim_us <= self.max_us <= HI:
            raise ValueError(f"need {LO} <= min_us <= trim_us <= max_us <= {HI} [us], got min_us={self.min_us}, "
                             f"trim_us={self.trim_us}, max_us={self.max_us}")
        if self.min_us == self.max_us:
            raise ValueError("min_us and max_us must differ")

    def to_us(self, value: float) -> int:
        """[-1, 1] -> [us]: 0 is the trim, -1 min_us, +1 max_us, linear on each side."""
        v = -value if self.reversed else value
        span = (self.max_us - self.trim_us) if v >= 0 else (self.trim_us - self.min_us)
        return int(round(self.trim_us + v * span))


KEYS = tuple(f.name for f in fields(ChannelCalibration))  # a section's keys


@dataclass(frozen=True)
class Calibration:
    """Both channels; a ValueError for a throttle that would never arm the car or drive it forward."""

    throttle: ChannelCalibration = field(default_factory=ChannelCalibration)
    steering: ChannelCalibration = field(default_factory=ChannelCalibration)

    def __post_init__(self) -> None:
        for name in CHANNELS:
            if not isinstance(getattr(self, name), ChannelCalibration):
                raise ValueError(f"{name}: must be a ChannelCalibration, got {getattr(self, name)!r}")
        th = self.throttle
        lo, hi = THROTTLE_TRIM_RANGE
        if not lo <= th.trim_us <= hi:
            raise ValueError(f"throttle trim_us {th.trim_us} is more than {ARM_WINDOW} us from {MID}: the car arms "
                             f"only on a throttle within {lo}..{hi} us, so it would never arm; keep trim_us there "
                             f"and set a further-off neutral on the ESC itself")
        if th.to_us(1.0) == th.trim_us:
            raise ValueError(f"throttle +1 gives the trim pulse ({th.trim_us} us): the car could not drive forward; "
                             f"{'min_us' if th.reversed else 'max_us'} must differ from trim_us")

    @classmethod
    def from_dict(cls, data: dict) -> Calibration:
        """From a file's tables ({"steering": {"trim_us": 1520}}, missing keys at their defaults):
        a ValueError naming the section and key that is wrong (`steering.trim: not a key ...`)."""
        channels = {}
        for section, values in data.items():
            if section not in CHANNELS:
                raise ValueError(f"{section}: not a section of a calibration (use {' and '.join(CHANNELS)})")
            if not isinstance(values, dict):
                raise ValueError(f"{section}: must be a table of {', '.join(KEYS)}")
            for key in values:
                if key not in KEYS:
                    raise ValueError(f"{section}.{key}: not a key of a channel (use {', '.join(KEYS)})")
            try:
                channels[section] = ChannelCalibration(**values)
            except ValueError as e:
                named = str(e).split(":")[0] in KEYS  # a key's own error: "trim_us: must be ..."
                raise ValueError(f"{section}{'.' if named else ': '}{e}") from None
        return cls(**channels)

    def message(self, throttle: float, steering: float) -> bytes:
        """The control message for throttle and steering in [-1, 1]."""
        return encode(self.throttle.to_us(throttle), self.steering.to_us(steering))

    @classmethod
    def load(cls, path: str | Path) -> Calibration:
        path = Path(path)
        data = read_parsed(path, tomllib.loads, CalibrationError, "TOML")
        try:
            return cls.from_dict(data)
        except ValueError as e:
            raise CalibrationError(f"{path}: {e}") from None

    def save(self, path: str | Path) -> None:
        path = Path(path)
        lines = ["# ROAR calibration: pulse widths [us] for -1 (min_us), 0 (trim_us) and +1 (max_us).",
                 "# Written by `roar calibrate`; edit by hand if you like."]
        for name in ("throttle", "steering"):
            ch: ChannelCalibration = getattr(self, name)
            lines += ["", f"[{name}]", f"trim_us = {ch.trim_us}", f"min_us = {ch.min_us}",
                      f"max_us = {ch.max_us}", f"reversed = {str(ch.reversed).lower()}"]
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            tmp = path.with_name(path.name + ".tmp")
            tmp.write_text("\n".join(lines) + "\n", encoding="utf-8")
            tmp.replace(path)  # never leave a half-written file behind
        except OSError as e:
            raise CalibrationError(f"{path}: cannot write: {e.strerror}") from None


def default_path() -> Path:
    """The user's calibration: ~/.config/roar/calibration.toml (or under $XDG_CONFIG_HOME)."""
    return config_folder() / "calibration.toml"


def load_default() -> Calibration:
    """The user's calibration file if there is one, else the defaults."""
    path = default_path()
    return Calibration.load(path) if path.exists() else Calibration()


def check_unit(name: str, value) -> float:
    """A command value as float in [-1, 1]; one-line ValueError otherwise (NaN and inf included)."""
    return number(name, value, -1.0, 1.0)

