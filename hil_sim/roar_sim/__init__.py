"""Software-in-the-loop: the firmware's own logic, built for the host, driving simulated cars.

The simulator's errors, one tree under roar.RoarError (roar/errors.py holds the library's); each
is also importable from the module that raises it. str() of each is one line.

    RoarError
    └── SimError                  the simulator cannot start as asked
        ├── CoreBuildError        the firmware core did not build for this machine (toolchains.native)
        ├── CoreLoadError         ... or did not load (core.library)
        ├── UnknownRobot (ValueError)   a robot name the registry does not know (robots)
        ├── ProfileError (ValueError)   a car profile that cannot be used (plants.car_profile)
        ├── NetnsUnavailable      no network namespaces here (links.netns)
        ├── AutopilotError        an autopilot this car cannot have (links.autopilots)
        ├── CameraOff             a simulated Junior's camera with no renderer running (links.junior_camera)
        ├── StepError             a step response that could not be measured (runs.step_response)
        └── SweepError            bad input for a sweep, or a Ray that cannot start (runs.sweep)
"""

from roar.errors import RoarError


class SimError(RoarError):
    """The simulator cannot start as asked; str() is one line."""


class CoreBuildError(SimError):
    """The host build failed; str() is one line naming the first compiler error."""


class CoreLoadError(SimError):
    """The core library could not be built or loaded; str() is one line."""


class UnknownRobot(SimError, ValueError):
    """A robot name the registry does not know; str() names the ones it does."""


class ProfileError(SimError, ValueError):
    """A car profile that cannot be used; str() is one line naming the file."""


class NetnsUnavailable(SimError):
    """This machine (or user) cannot make network namespaces: the reason, in one line."""


class AutopilotError(SimError):
    """An autopilot this simulated car cannot have: no track to follow, no camera to drive by."""


class CameraOff(SimError):
    """A simulated Junior's camera asked for a frame while no renderer runs."""


class StepError(SimError):
    """The step could not be measured; str() is one line."""


class SweepError(SimError):
    """Bad input for a sweep or a Ray that cannot start: one line for the user."""
