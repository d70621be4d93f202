import os
import time
from pathlib import Path

import pytest
from hypothesis import HealthCheck, settings

ROOT = Path(__file__).resolve().parent.parent

# CI runs the same examples every time (derandomize) so a red build is reproducible; locally
# set HYPOTHESIS_PROFILE=explore to search with fresh random examples.
settings.register_profile("ci", derandomize=True, deadline=None, max_examples=200,
                          suppress_health_check=[HealthCheck.too_slow])
settings.register_profile("explore", deadline=None, max_examples=2000)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))


@pytest.fixture
def pty_car():
    """A simulated car (open floor, real time) served on a pty from a background thread; yields
    the PtyCar (its .path is the serial port, its .sim the SimCar)."""
    from roar_sim.robots.esc import SimCar, SimConfig
    from roar_sim.links.pty import PtyCar

    car = PtyCar(SimCar(None, SimConfig(realtime=True))).start()
    yield car
    car.close()


def wait_for(condition, timeout_s=3.0, poll_s=0.01):
    """Poll until condition() is true; returns its last value (tests then assert on it)."""
    deadline = time.monotonic() + timeout_s
    while True:
        value = condition()
        if value or time.monotonic() > deadline:
            return value
        time.sleep(poll_s)


@pytest.fixture(autouse=True)
def _no_user_calibration(monkeypatch, tmp_path_factory):
    """Tests never read or write the user's own ~/.config/roar."""
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path_factory.mktemp("config")))
