"""The IARRC car in the simulator: the core's tasks on the host scheduler, SBUS from a simulated
transmitter, setpoints from the host, the 10,240-count encoder on the PyBullet wheel. The speed
step meets the seed's figures, and every mode the RC and the host can put it in drives the car."""

import math
import subprocess
import sys

import pytest

from conftest import ROOT
from roar.protocol import spec
from roar.protocol.control import encode_setpoint

pytest.importorskip("pybullet", reason="pip install pybullet (make setup installs it)")

from roar_sim.robots.iarrc import IarrcCar  # noqa: E402
from roar_sim.runs.step_response import (OVERSHOOT_TARGET, RISE_TARGET_S, STEADY_ERROR_TARGET,  # noqa: E402
                                    measure)

NEUTRAL = spec.CONTROL_NEUTRAL_US
HOST_S = spec.TIMING_HOST_SEND_PERIOD_US / 1e6


def drive(car, speed_mm_s, seconds, steering_us=NEUTRAL):
    """The vision computer streaming one setpoint at 50 Hz."""
    for _ in range(round(seconds / HOST_S)):
        car.host(encode_setpoint(speed_mm_s, steering_us))
        car.run(HOST_S)
    return car.status()


def autonomous(**options):
    car = IarrcCar(operator=False, **options)
    car.run(0.1)  # the receiver locks with the mode switch at off
    car.transmitter.mode = "autonomous"
    assert drive(car, 0, 0.2)["mode"] == "autonomous"
    return car


def test_a_two_metre_per_second_step_meets_the_seed_figures():
    r = measure(2.0, 3.0)
    assert r.rise_s is not None and r.rise_s <= RISE_TARGET_S
    assert r.overshoot <= OVERSHOOT_TARGET and r.steady_error <= STEADY_ERROR_TARGET
    assert r.meets_targets()
    # The controller's own estimate agrees with the true speed once settled (calibrated encoder).
    tail = len(r.times_s) // 3
    est, true = sum(r.estimates_m_s[-tail:]) / tail, sum(r.speeds_m_s[-tail:]) / tail
    assert est == pytest.approx(true, rel=0.02)


def test_mistuned_gains_miss_the_figures():
    assert not measure(2.0, 3.0, gains=(100, 0, 0, 50)).meets_targets()  # too soft: never gets there


def test_the_step_response_command_plots_and_reports(tmp_path):
    png = tmp_path / "step.png"
    r = subprocess.run([sys.executable, "-m", "roar.cli", "step-response", "--plot", str(png)], cwd=ROOT,
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert "rise (10-90 %)" in r.stdout and "targets met" in r.stdout
    assert png.stat().st_size > 10_000
    bad = subprocess.run([sys.executable, "-m", "roar.cli", "step-response", "--speed", "9"], cwd=ROOT,
                         capture_output=True, text=True, timeout=60)
    assert bad.returncode == 1 and bad.stderr.strip().splitlines()[-1].startswith("roar step-response: error:")


def test_manual_mode_drives_by_the_sticks_and_the_stop_switch_stops():
    car = IarrcCar(operator=False)
    car.run(0.1)
    car.transmitter.mode = "manual"
    car.transmitter.throttle_us, car.transmitter.steering_us = 1700, 1800
    car.run(1.0)
    st = car.status()
    assert st["mode"] == "manual" and car.board.pulses == (1700, 1800)
    moving = car.state().speed
    assert moving > 0.5 and car.state().yaw_rate < -0.3  # forward, turning right
    car.transmitter.stop = True
    car.run(0.05)  # within 3 SBUS frames
    assert car.status()["mode"] == "emergency" and car.board.pulses == (NEUTRAL, NEUTRAL)
    car.transmitter.stop, car.transmitter.mode = False, "manual"  # releasing the switch is not enough
    car.run(1.0)
    assert car.status()["mode"] == "emergency" and car.state().speed < moving / 2  # motor off: it coasts down


@pytest.mark.parametrize("failsafe_frames", [True, False], ids=["failsafe-flag", "receiver-silent"])
def test_losing_the_transmitter_fails_safe_within_a_tenth_of_a_second(failsafe_frames):
    car = autonomous()
    drive(car, 1500, 1.0)
    car.transmitter.on = False
    car.transmitter.failsafe_frames = failsafe_frames
    drive(car, 1500, 0.12)  # the host keeps asking; the RC is what decides
    st = car.status()
    assert st["mode"] == "failsafe" and st["failsafe"] == "rc_lost" and car.board.pulses[0] <= NEUTRAL
    assert "FAILSAFE" in car.read()


def test_host_silence_fails_safe_and_a_zero_setpoint_rearms():
    car = autonomous()
    drive(car, 1500, 1.0)
    car.read()
    car.run(0.3)  # the vision computer stops talking
    assert car.status()["failsafe"] == "host_silent" and "FAILSAFE" in car.read()
    assert drive(car, 1500, 0.2)["mode"] == "failsafe"  # a moving setpoint does not re-arm
    assert drive(car, 0, 0.1)["mode"] == "autonomous" and "ARMED" in car.read()


def test_telemetry_reports_battery_distance_and_state_and_takes_pid_gains():
    car = autonomous()
    x0, y0 = car.state().x, car.state().y
    drive(car, 1000, 2.0)
    travelled_mm = 1000 * math.hypot(car.state().x - x0, car.state().y - y0)
    fields = spec.TELEMETRY_FIELDS.split()
    tel = [dict(zip(fields, line.split()[1:])) for line in car.read() if line.startswith(spec.TELEMETRY_REPLY)]
    assert len(tel) >= 20  # 10 Hz
    last = tel[-1]
    assert last["mode"] == "autonomous" and last["failsafe"] == "none"
    assert abs(int(last["battery_mv"]) - 12000) < 20
    assert int(last["distance_mm"]) == pytest.approx(travelled_mm, rel=0.05)
    assert int(last["setpoint_mm_s"]) == 1000 and abs(int(last["speed_mm_s"]) - 1000) < 100
    car.link(b"PID 300 200 10 100\n")
    car.link(b"PID 1 2 3\n")
    drive(car, 1000, 0.3)
    link = car.read_link()
    assert "ERR syntax" in link
    assert [line.split()[-5:-1] for line in link if line.startswith("TEL")][-1] == ["300", "200", "10", "100"]


def test_a_low_battery_warns_and_a_flat_one_cuts_the_motor():
    car = autonomous()
    drive(car, 1000, 0.5)
    car.battery_v = 10.2  # below the 10.5 V warning, above the cutoff
    drive(car, 1000, 0.6)
    fields = spec.TELEMETRY_FIELDS.split()
    tel = [dict(zip(fields, line.split()[1:])) for line in car.read() if line.startswith(spec.TELEMETRY_REPLY)]
    assert tel[-1]["battery_low"] == "1" and tel[-1]["mode"] == "autonomous"  # a warning: it still drives
    car.battery_v = 9.5  # below the 9.9 V cutoff
    st = drive(car, 1000, 0.7)  # the battery task runs every 0.5 s
    assert st["mode"] == "failsafe" and st["failsafe"] == "battery" and st["battery_cutoff"]
    assert car.board.pulses[0] <= NEUTRAL


def test_speed_control_is_unchanged_across_the_boards_32_bit_clock_wrap():
    # The board's counter starts 0.6 s before it wraps: the step and the hold straddle the wrap.
    car = autonomous(clock_offset_us=2**32 - 600_000)
    speeds = []
    for _ in range(100):
        st = drive(car, 1500, HOST_S)
        speeds.append(car.state().speed)
        assert st["mode"] == "autonomous" and st["rc_present"]
    assert abs(sum(speeds[-25:]) / 25 - 1.5) < 0.05


def test_signed_setpoints_on_the_iarrc_car():
    """A key set on the host port (never the Bluetooth link): only signed setpoints drive; the
    rest are refused with the reason and do not count as hearing the host (its failsafe trips);
    a reboot starts a new session."""
    from roar_wire import signing

    key = bytes(range(16))
    car = autonomous()
    car.link(b"KEY " + key.hex().encode() + b"\n")  # the Bluetooth module cannot set a key
    car.run(0.2)
    car.host(b"KEY ?\n")
    car.run(0.05)
    assert "KEY none" in car.read()
    car.host(b"KEY " + key.hex().encode() + b"\n")
    car.run(0.05)
    assert car.read()[-2:] == [f"KEY {signing.fingerprint(key)}", f"SESSION {car.board.session:08x}"]
    session, counter = car.board.session, 0
    for i in range(60):  # signed setpoints at 50 Hz, zero first (the host was silent: it re-arms): it drives
        counter += 1
        car.host(signing.sign(encode_setpoint(0 if i < 10 else 1000, NEUTRAL), key, session, counter))
        car.run(HOST_S)
    assert car.status()["mode"] == "autonomous" and car.state().speed > 0.5
    for _ in range(25):  # 0.5 s of unsigned and replayed setpoints: refused, the host counts as silent
        car.host(encode_setpoint(1000, NEUTRAL) + signing.sign(encode_setpoint(1000, NEUTRAL), key, session, counter))
        car.run(HOST_S)
    lines = car.read()
    assert f"ERR unsigned {session:08x}" in lines and f"ERR replay {counter:x}" in lines
    assert car.status()["failsafe"] == "host_silent"
    rebooted = IarrcCar(operator=False, nvm=car.nvm)
    assert rebooted.board.session == session + 1
