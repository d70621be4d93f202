"""Reading back what the car does, with the same names over every link: typed reply events with
a way to wait for one, and the car's state (None where the link cannot tell)."""

import subprocess
import sys

import pytest

from conftest import ROOT, wait_for
from roar import EventKind, Vehicle
from roar.telemetry import parse_event


@pytest.mark.parametrize("line, kind, detail", [("READY 1", EventKind.READY, "1"), ("ARMED", EventKind.ARMED, None),
                                                ("FAILSAFE", EventKind.FAILSAFE, None),
                                                ("ERR too_long", EventKind.ERROR, "too_long")])
def test_reply_lines_become_typed_events(line, kind, detail):
    event = parse_event(line, 1.0)
    assert (event.kind, event.detail, event.line, event.at_s) == (kind, detail, line, 1.0)


def test_other_lines_are_no_events():
    assert parse_event("hello", 0.0) is None and parse_event("", 0.0) is None


def test_the_simulated_car_reports_events_state_and_sensors():
    with Vehicle("sim://oval") as car:
        assert car.wait_armed(timeout_s=5) and car.latched is False
        assert car.wait_for(EventKind.READY, since=0.0).detail == "1"
        car.drive(throttle=0.4)
        assert wait_for(lambda: (car.state().speed_m_s or 0) > 0.5, timeout_s=5)
        s = car.state()
        assert None not in (s.time_s, s.x_m, s.y_m, s.yaw_rad, s.yaw_rate_rad_s, s.wheel_encoder_counts)
        assert s.x_m > 0 and s.wheel_encoder_counts > 0 and s.throttle_out_us == 1700.0
        scan = car.lidar()
        assert scan.shape == (1080,) and 0 < scan.min() < 10
        rgb, depth = car.camera(80, 60)
        assert rgb.shape == (60, 80, 3) and depth.shape == (60, 80)
        car.transport.write(b"(15x0,1500)\n")  # what a buggy host would send: the car says why
        error = car.wait_for(EventKind.ERROR, timeout_s=2)
        assert error.detail == "syntax" and car.errors == 1


def test_a_serial_car_reports_events_and_no_state(pty_car):
    with Vehicle(f"serial://{pty_car.path}") as car:
        assert car.wait_armed(timeout_s=3)
        assert car.state().x_m is None and car.state().speed_m_s is None and car.lidar() is None


def test_wait_for_returns_none_after_the_timeout_on_a_link_without_replies():
    with Vehicle("loop://") as car:
        assert car.wait_for(EventKind.ARMED, timeout_s=0.1) is None and car.latched is None
        assert car.state().x_m is None


def test_the_stop_at_wall_example_drives_reads_and_stops_before_the_wall():
    proc = subprocess.run([sys.executable, str(ROOT / "examples" / "stop_at_wall.py")], capture_output=True,
                          text=True, timeout=60, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.strip().splitlines()
    assert len(lines) > 5 and lines[0].startswith("x ") and " m/s" in lines[0]
    assert lines[-1].startswith("stopped ") and float(lines[-1].split()[1]) > 0.3, \
        proc.stdout[-1500:] + proc.stderr[-1500:]  # metres short of the wall (about 1 m here)
    text = (ROOT / "examples" / "stop_at_wall.py").read_text()
    code = text.split('"""', 2)[2].strip().splitlines()
    assert len([line for line in code if line.strip()]) <= 15
