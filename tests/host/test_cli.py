"""The `roar` command line."""

import csv
import os
import re
import select
import shutil
import subprocess
import sys
import time

import pytest

from conftest import ROOT, wait_for
from roar.calibration import Calibration, default_path
from roar.cli import main
from roar.cli.sdk import EXIT_STATUSES
from roar.cli.teleop import Teleop

pytestmark = pytest.mark.realtime  # keeps to the wall clock: one at a time under xdist (conftest)

COMMANDS = ["send", "drive", "calibrate", "scan", "ports", "sim"]


@pytest.fixture
def no_stdin(monkeypatch):
    with open(os.devnull) as f:
        monkeypatch.setattr(sys, "stdin", f)
        yield


def run(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_help_teaches_every_command(capsys):
    with pytest.raises(SystemExit) as e:
        main(["--help"])
    out = capsys.readouterr().out
    assert e.value.code == 0
    assert all(c in out for c in COMMANDS) and "serial:///dev/ttyUSB0" in out
    from roar.transports.registry import schemes

    listed = re.findall(r"^  (\w+)://", out, re.M)
    assert sorted(listed) == schemes() and "sim" in listed  # every URL this installation opens
    assert EXIT_STATUSES in out
    for command in COMMANDS:
        with pytest.raises(SystemExit):
            main([command, "--help"])
        text = capsys.readouterr().out
        assert "usage: roar " + command in text and EXIT_STATUSES in text


def test_the_roar_script_is_installed():
    roar = shutil.which("roar", path=os.path.dirname(sys.executable))
    assert roar, "pip install -e . installs the roar command"
    assert subprocess.run([roar, "--help"], capture_output=True, text=True).returncode == 0


def test_send_holds_a_command_then_stops(capsys):
    code, out, err = run(capsys, "send", "loop://", "--throttle", "0.5", "--steering", "-1", "--for", "0.2")
    assert code == 0, err
    assert "sending (1750,1000) to loop:// for 0.2 s" in out and "neutral sent" in out


def test_send_drives_the_simulated_car(capsys, tmp_path):
    trace = tmp_path / "t.csv"
    code, out, err = run(capsys, "send", f"sim://?speedup=4&trace={trace}", "--throttle", "0.5", "--for", "0.5")
    assert code == 0, err
    with trace.open() as f:
        rows = list(csv.DictReader(f))
    assert float(rows[-1]["x_m"]) > 0.3 and abs(float(rows[-1]["y_m"])) < 0.05  # straight ahead


@pytest.mark.parametrize("argv, words", [
    (["send", "loop://", "--throttle", "nan"], "throttle must be a finite number"),
    (["send", "loop://", "--steering", "2"], "steering must be a finite number -1..1, got 2.0"),
    (["send", "loop://", "--for", "0"], "--for must be more than 0"),
    (["send", "tcp://car"], "unknown URL scheme"),
    (["send", "serial:///dev/nonexistent-port"], "cannot open serial port /dev/nonexistent-port"),
    (["send", "sim://monza"], "unknown track 'monza'"),
    (["drive", "loop://"], "run it in a terminal"),
    (["scan", "--timeout", "0"], "argument --timeout: must be a finite number more than 0 and at most 60 s, got '0'"),
    (["send", "loop://", "--calibration", "/nonexistent.toml"], "cannot read"),
])
def test_bad_input_gives_one_line_and_status_1(capsys, argv, words, no_stdin):
    code, out, err = run(capsys, *argv)
    assert code == 1
    assert words in err and err.count("\n") == 1 and err.startswith(f"roar {argv[0]}: error: "), err


def test_scan_without_bluetooth_is_one_line(capsys):
    code, out, err = run(capsys, "scan", "--timeout", "0.5")
    assert "Traceback" not in err
    assert code == 1 and ("Bluetooth is not available" in err or "no cars found" in out)


def test_ports_lists_or_explains(capsys):
    code, out, err = run(capsys, "ports")
    assert (code == 0 and "roar drive serial://" in out) or (code == 1 and "no serial ports found" in out)


def test_sim_serial_prints_a_pty_path():
    proc = subprocess.run([sys.executable, "-m", "roar.cli", "sim", "--serial", "--seconds", "0.3"], cwd=ROOT,
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    assert "simulated ESC car on /dev/pts/" in proc.stdout


def test_sim_without_serial_drives_laps(capsys, tmp_path):
    code, out, err = run(capsys, "sim", "--laps", "1", "--plot", str(tmp_path / "lap.png"))
    assert code == 0 and "lap 1:" in out and (tmp_path / "lap.png").exists()


CALIBRATION_ANSWERS = "\n".join([
    "1520", "",  # steering trim: typed (the car holds it), then Enter accepts
    "-30",  # left end: 1000 - 30 is out of range, asked again
    "1100", "",  # left end
    "",  # right end: keep 2000
    "n",  # the wheels turned left at the high end: steering reversed
    "",  # throttle trim: keep 1500
    "1800", "",  # high end
    "y",  # forward
    "1250", "",  # low end
]) + "\n"


def test_calibrate_walks_through_and_saves(tmp_path, monkeypatch):
    import io

    from roar import Vehicle
    from roar.cli.calibrate import walk as calibrate

    out = io.StringIO()
    path = tmp_path / "cal.toml"
    with Vehicle("loop://") as car:
        assert calibrate(car, path, io.StringIO(CALIBRATION_ANSWERS), out) == 0
        sent = car.transport.messages()
    c = Calibration.load(path)
    assert (c.steering.trim_us, c.steering.min_us, c.steering.max_us, c.steering.reversed) == (1520, 1100, 2000, True)
    assert (c.throttle.trim_us, c.throttle.min_us, c.throttle.max_us, c.throttle.reversed) == (1500, 1250, 1800, False)
    assert "outside 1000..1520 us" in out.getvalue()
    assert b"(1500,1100)" in sent and b"(1800,1520)" in sent  # the car held each value as it was typed


def test_calibrate_without_answers_saves_nothing(capsys, no_stdin):
    code, out, err = run(capsys, "calibrate", "loop://")
    assert code == 1 and err.strip() == "roar calibrate: error: input ended: calibration not saved"
    assert not default_path().exists()


def test_teleop_steps_and_clamps():
    t = Teleop()
    for action in ["faster"] * 9 + ["left"] * 7:
        t.apply(action)
    assert (t.throttle, t.steering) == (0.5, -1.0)  # clamped: keyboard teleop tops out at half throttle
    assert t.apply("stop") and (t.throttle, t.steering) == (0, 0) and not t.apply("quit")


# What a terminal sends for the arrow keys: ESC [ x normally, ESC O x in application cursor
# mode (set by `printf '\033[?1h'`, or by programs such as vim).
ARROWS = {"normal": {"up": b"\x1b[A", "down": b"\x1b[B", "right": b"\x1b[C", "left": b"\x1b[D"},
          "application": {"up": b"\x1bOA", "down": b"\x1bOB", "right": b"\x1bOC", "left": b"\x1bOD"}}


@pytest.mark.parametrize("mode", sorted(ARROWS))
@pytest.mark.parametrize("split", [False, True], ids=["whole", "split"])
def test_drive_from_a_terminal_moves_the_car(pty_car, mode, split):
    """`roar drive` in a real terminal (a pty as its stdin and stdout), driving the simulated car
    over serial: arrow keys in both cursor modes, each sequence written whole or split across
    two writes (as a slow terminal or ssh delivers them), letter keys, and q. The test plays the
    terminal, and answers cursor-position queries as every terminal does."""
    master, slave = os.openpty()
    proc = subprocess.Popen([sys.executable, "-m", "roar.cli", "drive", f"serial://{pty_car.path}"], cwd=ROOT,
                            stdin=slave, stdout=slave, stderr=subprocess.PIPE,
                            env=dict(os.environ, TERM="xterm-256color"))
    os.close(slave)
    screen = b""

    def read_screen():
        nonlocal screen
        while select.select([master], [], [], 0)[0]:
            try:
                chunk = os.read(master, 4096)
            except OSError:
                break
            screen += chunk
            for _ in range(chunk.count(b"\x1b[6n")):  # "where is the cursor?" -> row 24, column 1
                os.write(master, b"\x1b[24;1R")
        return screen

    def press(key: bytes):
        if split:
            os.write(master, key[:1])
            time.sleep(0.05)  # the rest of the sequence comes in a later read
            os.write(master, key[1:])
        else:
            os.write(master, key)
        time.sleep(0.05)

    arrow = ARROWS[mode]
    try:
        assert wait_for(lambda: b"throttle +0.0" in read_screen(), timeout_s=10)
        for _ in range(3):
            press(arrow["up"])
        assert wait_for(lambda: pty_car.sim.outputs.throttle_us == 1650)
        press(arrow["right"])
        assert wait_for(lambda: pty_car.sim.outputs.steering_us == 1600)
        press(arrow["left"])
        press(arrow["left"])
        assert wait_for(lambda: pty_car.sim.outputs.steering_us == 1400)
        press(arrow["down"])
        press(b"w")
        press(b"w")
        assert wait_for(lambda: pty_car.sim.outputs.throttle_us == 1700)
        press(b"q")
        assert proc.wait(timeout=10) == 0, proc.stderr.read()
        assert wait_for(lambda: pty_car.sim.outputs.throttle_us == 1500)
        assert b"throttle +0.4  steering -0.2" in read_screen()
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        proc.stderr.close()
        os.close(master)


def test_ctrl_c_during_send_leaves_the_car_at_neutral(pty_car):
    import signal

    proc = subprocess.Popen([sys.executable, "-m", "roar.cli", "send", f"serial://{pty_car.path}",
                             "--throttle", "0.3", "--for", "60"], cwd=ROOT,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        assert wait_for(lambda: pty_car.sim.outputs.throttle_us == 1650, timeout_s=10)
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=10)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 130 and "Traceback" not in err
    assert wait_for(lambda: pty_car.sim.outputs.throttle_us == 1500)
    assert not pty_car.sim.outputs.latched  # neutral came from the host, not from the car's failsafe
