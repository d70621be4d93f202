"""The simulated car as a serial port: a separate program drives it through a real pty with the
same bytes it would send a real car, and reads the firmware's reply lines."""

import os
import subprocess
import sys
import termios
import time
import tty

import pytest

from conftest import ROOT
from roar.protocol import encode
from roar_sim.robots.esc import EscCar
from roar_sim.links.pty import PtyCar

pytestmark = pytest.mark.realtime  # keeps to the wall clock: one at a time under xdist (conftest)


def open_port(path):
    fd = os.open(path, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
    tty.setraw(fd, termios.TCSANOW)
    return fd


def read_lines(fd):
    try:
        return os.read(fd, 4096).decode().splitlines()
    except BlockingIOError:
        return []


def test_pty_drives_the_car_and_answers_like_the_firmware():
    with PtyCar(EscCar()) as car:
        fd = open_port(car.path)
        try:
            lines = []
            for _ in range(10):
                os.write(fd, encode(1500, 1500) + b"\n")
                car.pump(0.02)
                lines += read_lines(fd)
            os.write(fd, b"(1500,25000)\n")  # malformed: answered with an error line
            for _ in range(100):
                os.write(fd, encode(1700, 1500) + b"\n")
                car.pump(0.02)
                lines += read_lines(fd)
            assert lines[:2] == ["READY 1", "ARMED"] and "ERR too_long" in lines and "FAILSAFE" not in lines
            assert car.sim.state().speed > 0.5
        finally:
            os.close(fd)


def test_serial_mode_as_a_separate_process():
    """The CLI prints the pty path; a separate process (this test) speaks to it in real time."""
    proc = subprocess.Popen([sys.executable, "-m", "roar_sim.links.pty", "--seconds", "3"], cwd=ROOT,
                            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    try:
        first = proc.stdout.readline()
        path = first.split(" on ")[1].split(" ")[0]
        fd = open_port(path)
        lines, deadline = [], time.monotonic() + 1.5
        while time.monotonic() < deadline:
            os.write(fd, encode(1500, 1500) + b"\n")
            time.sleep(0.02)
            lines += read_lines(fd)
        os.close(fd)
        assert "READY 1" in lines and "ARMED" in lines
        out, _ = proc.communicate(timeout=20)
        assert proc.returncode == 0 and "stopped after 3.0 s" in out
    finally:
        proc.kill()
