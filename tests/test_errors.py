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
from roar.cli.errors import ExitStatus, run_command


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
