"""One error base for the library (roar.RoarError, as python-can's CanError): every error class
the library and the simulator define derives from it, so a caller catches them all in one
`except`, and each says what went wrong in one line; the `roar` command has one error boundary
and one table of exit statuses."""

import importlib
import inspect
import pkgutil

import pytest

import roar
from roar import RoarError, Vehicle
from roar.cli.sdk import ExitStatus, run_command


def _modules(package: str):
    root = importlib.import_module(package)
    yield root
    for info in pkgutil.walk_packages(root.__path__, package + "."):
        if info.name.endswith("__main__"):  # importing it would run the command
            continue
        try:
            yield importlib.import_module(info.name)
        except ImportError:  # an extra that is not installed here (its own tests skip)
            continue


def error_classes(package: str) -> list[type]:
    found = {}
    for module in _modules(package):
        for name, obj in vars(module).items():
            if inspect.isclass(obj) and issubclass(obj, Exception) and obj.__module__ == module.__name__:
                found[f"{module.__name__}.{name}"] = obj
    return sorted(found.items())


@pytest.mark.parametrize("package", ["roar", "roar_sim"])
def test_every_error_the_library_defines_is_a_roar_error(package):
    classes = error_classes(package)
    assert len(classes) >= 5
    outside = [name for name, cls in classes if not issubclass(cls, RoarError) and not name.endswith(".Aborted")]
    assert outside == []


def test_each_package_keeps_its_errors_in_one_file_and_no_name_twice():
    """roar's in roar/errors.py, the simulator's in roar_sim/__init__.py (python-can's
    exceptions.py is the model); no two error classes share a name."""
    mine = {"roar": "roar.errors", "roar_sim": "roar_sim"}
    names = []
    for package, home in mine.items():
        classes = error_classes(package)
        elsewhere = [name for name, cls in classes if cls.__module__ != home and not name.endswith(".Aborted")]
        assert elsewhere == [], f"{package}'s errors belong in {home}"
        names += [cls.__name__ for _, cls in classes]
    assert sorted(set(names)) == sorted(names)


# where users have imported errors from: each still works, and is the one class
OLD_PATHS = [("roar.transports.base", "TransportError"), ("roar.transports.base", "LinkLost"),
             ("roar.transports", "TransportError"), ("roar.tracks.track", "TrackError"), ("roar.tracks", "TrackError"),
             ("roar.calibration", "CalibrationError"), ("roar.protocol.control", "ControlError"),
             ("roar.protocol", "ControlError"), ("roar.autopilot.waypoints", "WaypointError"),
             ("roar.autopilot", "WaypointError"), ("roar.camera", "CameraError"), ("roar.signing", "SigningError"),
             ("roar.recorder", "RecordError"), ("roar.replay", "ReplayError"), ("roar.stream", "UnknownHost"),
             ("roar.localization.scan", "ScanError"), ("roar.localization.particle_filter", "LocalizationError"),
             ("roar.localization.raycast", "MissingNumba"), ("roar.planning.grid", "PlanningError"),
             ("roar.planning.grid", "NoPath"), ("roar.web.server", "WebError"), ("roar.cli.sdk", "UserError"),
             ("roar.cli.stream", "StreamError"), ("roar.cli.vision", "FramesError"),
             ("roar_sim.world.scene", "SimError"), ("roar_sim.toolchains.native", "CoreBuildError"),
             ("roar_sim.core.library", "CoreLoadError"), ("roar_sim.robots", "UnknownRobot"),
             ("roar_sim.plants.car_profile", "ProfileError"), ("roar_sim.links.netns", "NetnsUnavailable"),
             ("roar_sim.links.autopilots", "AutopilotError"), ("roar_sim.runs.step_response", "StepError"),
             ("roar_sim.runs.sweep", "SweepError")]


@pytest.mark.parametrize("module, name", OLD_PATHS)
def test_an_error_imports_from_where_it_is_raised_too(module, name):
    import roar.errors
    import roar_sim

    home = roar_sim if module.startswith("roar_sim") else roar.errors
    assert getattr(importlib.import_module(module), name) is getattr(home, name)


def test_one_except_catches_a_bad_url_a_bad_calibration_and_a_bad_message():
    from roar.protocol import decode

    for fail in (lambda: Vehicle("nope://x"), lambda: roar.Calibration.load("/nonexistent/calibration.toml"),
                 lambda: decode(b"(1500,9999)")):
        with pytest.raises(RoarError) as caught:
            fail()
        assert "\n" not in str(caught.value) and str(caught.value)


def test_a_message_of_several_lines_reads_as_one():
    assert str(RoarError("cannot start:\n  no display\n")) == "cannot start: no display"
    assert str(RoarError("one line")) == "one line"


def test_the_boundary_prints_one_line_and_maps_ctrl_c_and_errors_to_their_statuses(capsys):
    def fails() -> int:
        raise RoarError("the car is\nnot there")

    def interrupted() -> int:
        raise KeyboardInterrupt

    assert run_command("roar x", fails) == ExitStatus.ERROR == 1
    assert capsys.readouterr().err == "roar x: error: the car is not there\n"
    assert run_command("roar x", interrupted) == ExitStatus.INTERRUPTED == 130
    assert run_command("roar x", lambda: 2) == ExitStatus.SHORT
