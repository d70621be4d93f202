"""Checks of the numbers a caller hands the library: each is a finite number within its range, or
a ValueError that names the argument, says the range and shows what was given, in one line.

    number("timeout_s", 2, 0, 3600, "s")        # 2.0
    number("timeout_s", float("nan"), 0, 3600, "s")
    ValueError: timeout_s must be a finite number of s in 0..3600, got nan
"""

from __future__ import annotations

import math
import numbers
import unicodedata

MAX_WAIT_S = 24 * 3600.0  # [s] the longest any call may be asked to wait
MAX_SCAN_S = 60.0  # [s] the longest Bluetooth scan


def describe(low: float, high: float, unit: str = "", low_open: bool = False) -> str:
    """The range in words: "0..30 s", or "more than 0 and at most 30 s"."""
    unit = f" {unit}" if unit else ""
    return f"more than {low:g} and at most {high:g}{unit}" if low_open else f"{low:g}..{high:g}{unit}"


def shown(value) -> str:
    """A value as a message shows it: exactly (1.0000001, not 1), and short when it is long."""
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def printable(text, limit: int = 80) -> str:
    """A string from a file or the network as it may reach a terminal: control and format
    characters (escape sequences, carriage returns, bidi overrides) shown escaped, and at most
    `limit` characters."""
    text = str(text)
    out = "".join(c if unicodedata.category(c)[0] != "C" else c.encode("unicode_escape").decode("ascii")
                  for c in text[: limit + 1])
    return out if len(out) <= limit else out[: limit - 3] + "..."


def number(name: str, value, low: float, high: float, unit: str = "", low_open: bool = False,
           given=None) -> float:
    """value as a float, if it is a finite number in low..high (above low when low_open); the
    message shows `given` (what the user typed) when there is one, else the value."""
    what = f"{name} must be" if name else "must be"
    what += f" a finite number {describe(low, high, unit, low_open)}"
    got = shown(value if given is None else given)
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(f"{what}, got {got}")
    try:
        v = float(value)
    except OverflowError:  # an int beyond any float
        raise ValueError(f"{what}, got an integer of {len(str(abs(value)))} digits") from None
    if not math.isfinite(v) or v > high or v < low or (low_open and v == low):
        raise ValueError(f"{what}, got {got}")
    return v


def timeout(name: str, value, high: float = MAX_WAIT_S) -> float:
    """[s] how long a call may wait: 0 (do not wait) up to `high`."""
    return number(name, value, 0.0, high, "s")
