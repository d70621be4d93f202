"""Every long-running `roar` command ends within a second of Ctrl-C or SIGTERM -- sent to the
process alone (`kill -INT PID`), to its process group (a terminal's Ctrl-C) or as SIGTERM --
with the documented exit status, no traceback and no process of its own left behind, on a
machine kept busy by other processes, and also when it was started with SIGINT ignored (a shell
script's `roar ... &`)."""

import os
import re
import signal
import subprocess
import sys
import textwrap
import time
import urllib.request
from collections.abc import Iterator
from contextlib import contextmanager

import pytest

from roar.cli.sdk import ExitStatus

pytestmark = pytest.mark.realtime  # keeps to the wall clock: one at a time under xdist (conftest)

pytest.importorskip("pybullet", reason="pip install pybullet (make setup installs it)")

READY_S = 60.0  # [s] for a command to say it is running, on a busy machine
ENDS_WITHIN_S = 1.0  # [s] from the signal to the command's exit (the promise)
GONE_WITHIN_S = 2.0  # [s] for the processes it started to be gone after it exits


def junior_camera(output: str) -> None:
    """Ask the simulated Junior for a frame, so that its renderer processes are at work."""
    url = re.search(r"camera  (http://\S+)", output).group(1)
    urllib.request.urlopen(url, timeout=30).read()


def ray_at_work(proc: subprocess.Popen) -> None:
    """Until the sweep's Ray runs a race (a worker process named for the task)."""
    deadline = time.monotonic() + READY_S
    while not any("ray::attempt" in p for p in session_alive(proc.pid)):
        assert proc.poll() is None and time.monotonic() < deadline, "no Ray worker racing"
        time.sleep(0.2)


# command (after `roar`), what it prints once running, what to do then
LONG_RUNS = {
    "race": (["race", "--laps", "100"], "racing oval", None),
    "sim": (["sim", "--robot", "iarrc", "--laps", "100"], "racing oval", None),
    "sim-serial": (["sim", "--serial"], "Ctrl-C to stop", None),
    "sim-http": (["sim", "--robot", "junior", "--http", "127.0.0.1:0"], "Ctrl-C stops", junior_camera),
    "sim-stream": (["sim", "--stream"], "streaming the simulated car", None),
    "stream": (["stream", "udp://127.0.0.1"], "Ctrl-C stops", None),
    "send": (["send", "sim://", "--for", "600"], "sending", None),
    "platoon": (["platoon", "--seconds", "600"], "platoon", None),
    "limits": (["limits"], "ESC car", None),
    "sweep": (["sweep", "--serial", "--laps", "20", "--out", "{tmp}"], "to run here", None),
    "sweep-ray": (["sweep", "--ray", "--workers", "2", "--laps", "20", "--out", "{tmp}"], "to run on a local Ray",
                  "ray"),
    "sweep-processes": (["sweep", "--workers", "2", "--laps", "20", "--out", "{tmp}"], "to run on 2 local processes",
                        None),
    "calibrate": (["calibrate", "sim://", "--file", "{tmp}/calibration.toml"], "trim", None),
}
SIGNALS = {  # how the signal is sent -> the exit status it must give
    "int-process": (signal.SIGINT, False, ExitStatus.INTERRUPTED),
    "int-group": (signal.SIGINT, True, ExitStatus.INTERRUPTED),
    "term-process": (signal.SIGTERM, False, ExitStatus.TERMINATED),
}
# each command with one way of sending, in turn (every way on several commands; the suite stays short)
CASES = [(name, list(SIGNALS)[i % len(SIGNALS)]) for i, name in enumerate(LONG_RUNS)]


@pytest.fixture(scope="module")
def busy_machine():
    """Two processes spinning on a two-core machine for the module's duration (load ~3 with the
    command under test)."""
    spinners = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(2)]
    yield
    for p in spinners:
        p.kill()
        p.wait()


def session_alive(sid: int) -> list[str]:
    """Processes of the session that are still running (zombies waiting to be reaped are not):
    the command's and all it started, also those in groups of their own (Ray's workers)."""
    alive = []
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            with open(f"/proc/{pid}/stat") as f:
                fields = f.read().rsplit(")", 1)[1].split()
            if int(fields[3]) == sid and fields[0] != "Z":
                with open(f"/proc/{pid}/cmdline", "rb") as f:
                    alive.append(f.read().replace(b"\0", b" ").decode()[:120])
        except (OSError, IndexError, ValueError):
            continue
    return alive


@contextmanager
def started(argv: list[str], tmp_path, sigint_ignored: bool = False) -> Iterator[tuple[subprocess.Popen, object]]:
    """`roar *argv` in its own process group (as a terminal's foreground job), its stdin a pipe
    nobody writes, its output in a file; killed with its group if it outlives the test."""
    argv = [a.replace("{tmp}", str(tmp_path)) for a in argv]

    def child_setup():
        os.setsid()  # a session and group of its own, as a terminal's foreground job
        if sigint_ignored:
            signal.signal(signal.SIGINT, signal.SIG_IGN)

    with open(tmp_path / "output.txt", "w+") as out:
        proc = subprocess.Popen([sys.executable, "-m", "roar.cli", *argv], stdin=subprocess.PIPE, stdout=out,
                                stderr=subprocess.STDOUT, preexec_fn=child_setup, cwd=tmp_path)
        try:
            yield proc, out
        finally:
            if proc.poll() is None:
                os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
            proc.stdin.close()


def wait_for_output(proc: subprocess.Popen, out, marker: str) -> str:
    deadline = time.monotonic() + READY_S
    while time.monotonic() < deadline:
        out.seek(0)
        text = out.read()
        if marker in text:
            return text
        assert proc.poll() is None, f"it ended before it was interrupted:\n{text}"
        time.sleep(0.1)
    raise AssertionError(f"no {marker!r} within {READY_S} s:\n{text}")


def interrupt(proc: subprocess.Popen, out, how: str) -> tuple[int, float, str]:
    signum, group, _ = SIGNALS[how]
    time.sleep(1.0)  # well into its work
    t0 = time.monotonic()
    if group:
        os.killpg(proc.pid, signum)
    else:
        os.kill(proc.pid, signum)
    status = proc.wait(timeout=30)
    ended_s = time.monotonic() - t0
    out.seek(0)
    return status, ended_s, out.read()


@pytest.mark.parametrize("name, how", CASES, ids=[f"{n}-{h}" for n, h in CASES])
def test_a_long_run_ends_at_once_on_a_signal(busy_machine, tmp_path, name, how):
    argv, marker, then = LONG_RUNS[name]
    with started(argv, tmp_path) as (proc, out):
        text = wait_for_output(proc, out, marker)
        if then == "ray":
            ray_at_work(proc)
        elif then:
            then(text)
        status, ended_s, text = interrupt(proc, out, how)
    assert status == SIGNALS[how][2], text
    assert ended_s < ENDS_WITHIN_S, f"{ended_s:.2f} s to end:\n{text}"
    assert "Traceback" not in text and "KeyboardInterrupt" not in text, text
    deadline = time.monotonic() + GONE_WITHIN_S
    while (left := session_alive(proc.pid)) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert left == [], f"left running: {left}"


def test_ctrl_c_ends_a_command_started_with_sigint_ignored(busy_machine, tmp_path):
    """A script's `roar sim --robot junior --http ... &` inherits SIGINT ignored; Ctrl-C still ends it."""
    argv, marker, then = LONG_RUNS["sim-http"]
    with started(argv, tmp_path, sigint_ignored=True) as (proc, out):
        then(wait_for_output(proc, out, marker))
        status, ended_s, text = interrupt(proc, out, "int-process")
    assert status == ExitStatus.INTERRUPTED and ended_s < ENDS_WITHIN_S and "Traceback" not in text, text


def run_python(tmp_path, source: str, *args: str) -> subprocess.CompletedProcess:
    """`python -m probe ARGS` (as `python -m roar.cli` runs) with source as probe.py."""
    (tmp_path / "probe.py").write_text(textwrap.dedent(source))
    return subprocess.run([sys.executable, "-m", "probe", *args], cwd=tmp_path, capture_output=True, text=True,
                          timeout=120)


def test_a_ctrl_c_that_landed_in_an_import_does_not_turn_the_status_into_a_death_by_sigint(tmp_path):
    """A Ctrl-C that lands while scipy imports leaves its `exec("from numpy import *")`; the command
    catches it and reports 130 (here: the error status of a bad command), and CPython 3.11 must not
    then kill it by SIGINT at exit (which a shell shows as 130 too; a parent process sees -2)."""
    done = run_python(tmp_path, """
        import sys
        from roar.cli.main import main, parser
        parser()  # what main() would import and build first, built here
        try:
            exec("raise KeyboardInterrupt")  # a Ctrl-C that left an exec() of a string, caught
        except KeyboardInterrupt:
            pass
        sys.exit(main())
        """, "no-such-command")
    assert done.returncode == ExitStatus.ERROR, done.stderr


def test_ctrl_c_while_osqp_solves_the_racing_line_interrupts_the_command(tmp_path):
    """OSQP takes SIGINT for itself while it solves (and returns "interrupted"): the racing line
    raises the Ctrl-C as the KeyboardInterrupt it is, instead of racing on with a half-solved line."""
    done = run_python(tmp_path, """
        import os, signal, threading
        import numpy as np
        import osqp
        import scipy.sparse as sp
        from roar.autopilot.racing_line import _solve

        solve = osqp.OSQP.solve

        def solve_until_ctrl_c(self, *args, **kwargs):
            threading.Timer(0.05, os.kill, (os.getpid(), signal.SIGINT)).start()
            return solve(self, *args, **kwargs)

        osqp.OSQP.solve = solve_until_ctrl_c
        n = 100_000  # a solve of about a second, well past the Ctrl-C
        d2 = sp.diags([1.0, -2.0, 1.0], [-1, 0, 1], shape=(n, n))
        try:
            _solve(osqp, sp, (d2.T @ d2).tocsc(), np.random.default_rng(0).normal(size=n), -np.ones(n), np.ones(n))
            print("solved on")
        except KeyboardInterrupt:
            print("interrupted")
        """)
    assert done.stdout.split()[-1:] == ["interrupted"], done.stdout + done.stderr
