"""Vehicle on a car with a speed controller (the IARRC car, READY 2): drive(speed=...) in m/s,
refused in one line on a throttle car and for bad values, and the car's telemetry (battery,
distance, mode) through state() -- in-process (sim://?robot=iarrc) and over a real pty."""

import math
import subprocess
import sys
import time

import pytest

from conftest import ROOT, wait_for
from roar import Vehicle
from roar.protocol import spec
from roar.telemetry import parse_telemetry

pytest.importorskip("pybullet", reason="pip install pybullet (make setup installs it)")

TEL = "TEL autonomous none 11850 1 4321 1498 1500 1712 1540 -2500 500 400 0 110 3"


def test_a_telemetry_line_parses_into_state_fields():
    t = parse_telemetry(TEL)
    assert t["mode"] == "autonomous" and t["failsafe"] == "none" and t["battery_v"] == 11.85 and t["battery_low"]
    assert t["distance_m"] == 4.321 and t["speed_m_s"] == 1.498 and t["setpoint_m_s"] == 1.5
    assert t["throttle_out_us"] == 1712 and t["steering_out_us"] == 1540 and t["yaw_rate_rad_s"] == pytest.approx(math.radians(-2.5))
    assert t["pid_gains_pm"] == (500, 400, 0, 110) and t["overruns"] == 3
    for bad in ("TEL autonomous none 1", TEL.replace("11850", "x"), "READY 2", "", TEL + " 7"):
        assert parse_telemetry(bad) is None


def test_the_simulated_iarrc_car_drives_by_speed_and_reports_telemetry():
    with Vehicle("sim://?robot=iarrc&speedup=2") as car:
        car.drive(speed=1.5, steering=0.0)
        assert car.protocol_version == spec.META_SPEED_VERSION
        assert wait_for(lambda: abs((car.state().speed_m_s or 0) - 1.5) < 0.1, timeout_s=5)
        time.sleep(0.5)
        s = car.state()
        assert s.mode == "autonomous" and s.failsafe == "none" and s.setpoint_m_s == 1.5
        assert s.battery_v == pytest.approx(12.0, abs=0.02) and s.battery_low is False
        assert s.distance_m > 1.0 and s.x_m > 1.0  # telemetry fills what the link does not give
        assert car.pid_gains_pm == (500, 400, 0, 110)
        assert car.errors == 0
        with pytest.raises(ValueError, match=r"drives by speed .*drive\(speed="):
            car.drive(throttle=0.3)
        car.stop()
        assert wait_for(lambda: abs(car.state().speed_m_s) < 0.05, timeout_s=5)


def test_speed_is_refused_in_one_line_on_a_throttle_car_and_for_bad_values():
    with Vehicle("sim://") as car:
        with pytest.raises(ValueError) as e:
            car.drive(speed=1.0)
        assert "READY 1" in str(e.value) and "drive(throttle=...)" in str(e.value) and "\n" not in str(e.value)
        for bad in (float("nan"), 9.0, -6, "fast", True):
            with pytest.raises(ValueError, match="speed must be"):
                car.drive(speed=bad)
        with pytest.raises(ValueError, match="not both"):
            car.drive(throttle=0.1, speed=1.0)
        assert car.pulses_us() == (1500, 1500)  # nothing of it was sent


def test_over_a_serial_port_the_car_rearms_on_zero_speed_and_holds_speed():
    from roar_sim.robots.iarrc import IarrcCar
    from roar_sim.links.pty import PtyCar

    sim = IarrcCar(realtime=True, operator=False)
    sim.run(0.1)  # the receiver locks with the switch at off; then autonomous, before any host talks:
    sim.transmitter.mode = "autonomous"  # the car fails safe (host silent) and waits for zero speed
    pty = PtyCar(sim).start()
    try:
        assert wait_for(lambda: sim.status()["failsafe"] == "host_silent", timeout_s=3)
        with Vehicle(f"serial://{pty.path}") as car:
            car.drive(speed=1.0, steering=-0.5)  # learns the version from the car's replies
            assert wait_for(lambda: sim.status()["mode"] == "autonomous", timeout_s=3)
            assert wait_for(lambda: abs(sim.state().speed - 1.0) < 0.1, timeout_s=5)
            assert sim.board.pulses[1] < 1500  # steering -0.5: left of centre
            assert wait_for(lambda: car.state().mode == "autonomous" and car.state().battery_v > 11, timeout_s=2)
            assert car.state().x_m is None  # a serial link gives no pose; telemetry gives the rest
        assert wait_for(lambda: sim.status()["setpoint_mm_s"] == 0, timeout_s=2)  # closing sent zero speed
    finally:
        pty.close()


def test_roar_sim_serves_the_iarrc_car_on_a_pty_and_roar_send_drives_it_by_speed():
    sim = subprocess.Popen([sys.executable, "-m", "roar.cli", "sim", "--serial", "--robot", "iarrc", "--seconds", "20"],
                           cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        first = sim.stdout.readline()
        assert "simulated IARRC car on /dev/pts/" in first, sim.stderr.read()
        path = first.split(" on ")[1].split()[0]
        send = subprocess.run([sys.executable, "-m", "roar.cli", "send", f"serial://{path}", "--speed", "1.2",
                               "--for", "3"], cwd=ROOT, capture_output=True, text=True, timeout=60)
        assert send.returncode == 0, send.stderr
        assert "zero speed sent; link ok" in send.stdout and "mode autonomous" in send.stdout
        driven = float(send.stdout.split("driven ")[1].split()[0])
        assert 1.5 < driven < 4.0  # about 1.2 m/s for 3 s, after the start
    finally:
        sim.kill()
        sim.communicate()
    for argv, message in ((["--car", "iarrc"], "--car is --robot now"),
                          (["--robot", "junior", "--serial"], "the ROAR Junior has no serial port")):
        bad = subprocess.run([sys.executable, "-m", "roar.cli", "sim", *argv], cwd=ROOT, capture_output=True, text=True,
                             timeout=60)
        lines = bad.stderr.strip().splitlines()
        assert bad.returncode == 1 and len(lines) == 1 and lines[0].startswith(f"roar sim: error: {message}"), bad.stderr
