import contextlib
import os
import shutil
import socket
import struct
import subprocess
import time
from pathlib import Path

import pytest
from hypothesis import HealthCheck, settings

ROOT = Path(__file__).resolve().parent.parent

# One BLAS/OpenMP thread in every test process and the programs it starts, set before numpy loads:
# the simulator's matrices are small, and OpenBLAS's spinning threads doubled a camera lap's CPU
# time (40 s against 19.5 s, and slower) while the suite's workers already fill every core.
for _threads in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_threads, "1")

# CI runs the same examples every time (derandomize) so a red build is reproducible; locally
# set HYPOTHESIS_PROFILE=explore to search with fresh random examples.
settings.register_profile("ci", derandomize=True, deadline=None, max_examples=200,
                          suppress_health_check=[HealthCheck.too_slow])
settings.register_profile("explore", deadline=None, max_examples=2000)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))


REALTIME_GROUP = "realtime"


@pytest.hookimpl(tryfirst=True)  # before xdist's own, which reads the groups
def pytest_collection_modifyitems(config, items):
    """Tests marked realtime keep to the wall clock: under xdist (--dist loadgroup) they share one
    group, so one worker runs them one after another while the others take the CPU-bound tests,
    and no two of them starve each other of a core."""
    grouping = bool(config.getvalue("loadgroup")) if hasattr(config.option, "loadgroup") else False
    for item in items:
        if item.get_closest_marker("realtime") is not None:
            item.add_marker(pytest.mark.xdist_group(REALTIME_GROUP))
        group = item.get_closest_marker("xdist_group")  # the realtime one, or a module's (one set-up, one worker)
        if grouping and group is not None:
            _join_group(item, group.args[0] if group.args else group.kwargs["name"])


BACKGROUND_NICE = 10  # the CPU-bound tests' priority under xdist: a realtime test's threads go first


@pytest.hookimpl(tryfirst=True)
def pytest_runtest_setup(item):
    """Under xdist the realtime tests' worker runs them at normal priority and every other test
    (and what it starts) at BACKGROUND_NICE, so the CPU-bound tests beside a realtime one yield the
    cores to it. Raising a priority back needs root (CI runs as root); elsewhere both stay low."""
    if "PYTEST_XDIST_WORKER" not in os.environ:
        return
    nice = 0 if item.get_closest_marker("realtime") is not None else BACKGROUND_NICE
    try:
        os.setpriority(os.PRIO_PROCESS, 0, nice)
    except PermissionError:
        pass


def _join_group(item, group: str) -> None:
    """What xdist's loadgroup does itself to group a test: a node id ending @GROUP, which its
    scheduler reads. With pytest 9.2's structured node ids, xdist 3.8's own assignment no longer
    takes effect (pytest-dev/pytest-xdist#1386), so the id is set here; a fixed xdist suffixing it
    again leaves the group the same (the scheduler reads the last @)."""
    suffixed = f"{item.nodeid}@{group}"
    if hasattr(item, "_id"):  # pytest >= 9.2: a NodeId, whose string is the one parsed
        item._id = type(item._id).parse(suffixed)
    else:
        item._nodeid = suffixed


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


def _x_server_answers(number, timeout_s=2.0):
    """True when the X server on :number completes the X11 connection handshake, through the
    socket a client tries first (Linux: the abstract one) or its file."""
    hello = struct.pack("<cxHHHHxx", b"l", 11, 0, 0, 0)  # little-endian, protocol 11.0, no auth
    for address in (f"\0/tmp/.X11-unix/X{number}", f"/tmp/.X11-unix/X{number}"):
        try:
            with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as client:
                client.settimeout(timeout_s)
                client.connect(address)
                client.sendall(hello)
                if client.recv(1) == b"\x01":  # 1 = Success
                    return True
        except OSError:
            continue
    return False


@pytest.fixture(scope="session")
def virtual_display(tmp_path_factory):
    """A virtual screen for the session: Xvfb picks a free display itself (-displayfd) and says
    which, so no two servers can race for one number. -noreset: by default an X server resets
    when its last client leaves, and a client that connects during the reset is refused ("cannot
    connect to X server": check_env closes one PyBullet window and opens the next at once, and on
    a loaded machine the reset takes long enough). The fixture then completes an X11 handshake
    with it before any test uses it (a server that announced itself and cannot be reached is
    replaced, twice at most) and yields the DISPLAY value. The server's own output is kept in
    xvfb.log under the session's temporary directory, for a failing test to show."""
    xvfb = shutil.which("Xvfb")
    if xvfb is None:
        pytest.skip("Xvfb not installed: apt-get install xvfb")
    log_path = tmp_path_factory.mktemp("xvfb") / "xvfb.log"
    for _attempt in range(3):
        read, write = os.pipe()
        with open(log_path, "ab") as log:
            server = subprocess.Popen([xvfb, "-displayfd", str(write), "-nolisten", "tcp", "-noreset", "-screen", "0",
                                   "1280x1024x24"],
                                      pass_fds=(write,), stdout=log, stderr=log)
        os.close(write)
        with os.fdopen(read) as announced:
            number = announced.readline().strip()
        if number and server.poll() is None and _x_server_answers(number):
            break
        server.kill()
        server.wait(timeout=10)
    else:
        pytest.fail(f"Xvfb did not start or did not answer: {log_path.read_text(errors='replace')[-2000:]}")
    yield f":{number}"
    server.terminate()
    server.wait(timeout=10)


def free_port() -> int:
    """A TCP port on 127.0.0.1 nobody listens on now."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@contextlib.contextmanager
def served(*argv: str, lines: int):
    """`roar sim ...` in a subprocess: yields its first `lines` lines of output; Ctrl-C at the end."""
    import signal
    import sys

    sim = subprocess.Popen([sys.executable, "-m", "roar.cli", "sim", *argv], stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE, text=True)
    try:
        yield [sim.stdout.readline() for _ in range(lines)]
    finally:
        sim.send_signal(signal.SIGINT)
        sim.communicate(timeout=30)

