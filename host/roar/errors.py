"""One base for every error the roar library raises on purpose, as python-can has CanError:
`except roar.RoarError` catches a bad URL, a lost link, a bad calibration or waypoint file and a
malformed control message alike, and str() of each is one line a user can act on.

Wrong argument values (a throttle of 2, a NaN timeout) stay plain ValueErrors, as in the
standard library; the errors whose meaning is "this value" (CalibrationError, ControlError,
WaypointError) are both.
"""

from __future__ import annotations


class RoarError(Exception):
    """An error of the roar library or a plug-in of it (the simulator); str() is one line."""

    def __str__(self) -> str:
        text = super().__str__()
        return " ".join(line.strip() for line in text.splitlines() if line.strip()) if "\n" in text else text
