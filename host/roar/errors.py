"""Every error the roar library raises on purpose, in one tree, as python-can keeps its own in
can.exceptions: `except roar.RoarError` catches a bad URL, a lost link, a bad calibration or
waypoint file and a malformed control message alike, and str() of each is one line a user can
act on. Each is also importable from the module that raises it (roar.transports.TransportError,
roar.tracks.track.TrackError, ...); the simulator's own (roar_sim) derive from RoarError too.

    RoarError
    ├── TransportError            the link to the car cannot be opened or used
    │   └── LinkLost              a link that was open has gone
    ├── UnknownHost               a host name that does not resolve
    ├── CameraError               a camera that cannot be reached or sent no image
    ├── SigningError              a key or key file that cannot be used
    ├── ControlError (ValueError) a control value or message the protocol does not allow
    ├── CalibrationError (ValueError)
    ├── WaypointError (ValueError)
    ├── TrackError (ValueError)
    ├── ScanError (ValueError)
    ├── LocalizationError (ValueError)
    ├── MissingNumba (ImportError)
    ├── PlanningError (ValueError)
    ├── NoPath                    no path from the start to the goal
    ├── RecordError               a recording that cannot be made
    ├── ReplayError               a recording that cannot be read
    ├── WebError                  a web server that cannot start
    ├── FitError                  a test drive or its record a car cannot be fitted from
    └── UserError                 a command's input (the roar command and its plug-ins)
        ├── StreamError           roar stream's URL or options
        └── FramesError           roar vision's folder or options

Wrong argument values (a throttle of 2, a NaN timeout) stay plain ValueErrors, as in the
standard library; the errors whose meaning is "this value" are both.
"""

from __future__ import annotations


class RoarError(Exception):
    """An error of the roar library or a plug-in of it (the simulator); str() is one line."""

    def __str__(self) -> str:
        text = super().__str__()
        return " ".join(line.strip() for line in text.splitlines() if line.strip()) if "\n" in text else text


# --- links to the car -----------------------------------------------------------------------

class TransportError(RoarError):
    """The link to the car cannot be opened or used. str() is one line a user can act on."""


class LinkLost(TransportError):
    """A link that was open has gone (cable pulled, car out of range). Reopening may work."""


class UnknownHost(RoarError):
    """A host name that does not resolve; str() is one line naming it."""


class CameraError(RoarError):
    """A camera that cannot be reached or sent no image; str() is one line."""


class SigningError(RoarError):
    """A key or key file that cannot be used; str() is one line."""


# --- values and files -------------------------------------------------------------------------

class ControlError(RoarError, ValueError):
    """A control value or message that the protocol does not allow. str() is one line."""


class CalibrationError(RoarError, ValueError):
    """An invalid calibration or calibration file; str() is one line."""


class WaypointError(RoarError, ValueError):
    """An invalid waypoint file; str() is one line naming the file and line."""


class TrackError(RoarError, ValueError):
    """An invalid track or track file; str() is one line."""


# --- localization and planning ----------------------------------------------------------------

class ScanError(RoarError, ValueError):
    """A laser scan that cannot be used; str() says why in one line."""


class LocalizationError(RoarError, ValueError):
    """A filter that cannot be set up as asked; str() says why in one line."""


class MissingNumba(RoarError, ImportError):
    """Numba is not installed; str() says what to install."""


class PlanningError(RoarError, ValueError):
    """A planner that cannot be set up as asked; str() says why in one line."""


class NoPath(RoarError):
    """No path from the start to the goal; str() is one line starting 'no path: '."""

    def __init__(self, reason: str) -> None:
        super().__init__(f"no path: {reason}")


# --- recordings and the web page --------------------------------------------------------------

class RecordError(RoarError):
    """A recording that cannot be made (one line)."""


class ReplayError(RoarError):
    """A recording that cannot be read (one line)."""


class FitError(RoarError):
    """A test drive, its area or pose source, or a record a fit cannot use (one line)."""


class Ros2Error(RoarError):
    """roar ros2: the message types that did not build, a rosbag2 that cannot be read or written."""


class RefusedCommand(Ros2Error, ValueError):
    """A ROS command no car could mean (not finite, an absurd speed or angle): counted, not driven."""


class WebError(RoarError):
    """A web server that cannot start: a port in use, a bad host."""


# --- commands ---------------------------------------------------------------------------------

class UserError(RoarError):
    """A one-line message for the user about a command's input; exit status 1."""


class StreamError(UserError):
    """A stream URL or option that cannot work (roar stream); str() is one line."""


class FramesError(UserError):
    """A folder or option that cannot work (roar vision); str() is one line."""
