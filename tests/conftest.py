import os
import shutil
import subprocess
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
    the PtyCar (its .path is the serial port, its .sim the EscCar)."""
    from roar_sim.robots.esc import EscCar
    from roar_sim.links.pty import PtyCar

    car = PtyCar(EscCar(realtime=True)).start()
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


@pytest.fixture(scope="session")
def virtual_display():
    """A virtual screen for the session: Xvfb picks a free display itself (-displayfd) and says
    which, so no two servers can race for one number; yields the DISPLAY value."""
    xvfb = shutil.which("Xvfb")
    if xvfb is None:
        pytest.skip("Xvfb not installed: apt-get install xvfb")
    read, write = os.pipe()
    server = subprocess.Popen([xvfb, "-displayfd", str(write), "-nolisten", "tcp", "-screen", "0", "1280x1024x24"],
                              pass_fds=(write,), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    os.close(write)
    with os.fdopen(read) as announced:
        number = announced.readline().strip()
    if not number:
        server.kill()
        pytest.fail("Xvfb did not start")
    yield f":{number}"
    server.terminate()
    server.wait(timeout=10)
