"""The serial transport against a real pty whose other end is the firmware logic driving the
simulated car (real time)."""

import signal
import subprocess
import sys
import textwrap

import pytest

from conftest import ROOT, wait_for
from roar import TransportError, Vehicle
from roar_sim.robots.esc import EscCar
from roar_sim.links.pty import PtyCar

pytestmark = pytest.mark.realtime  # keeps to the wall clock: one at a time under xdist (conftest)


def outputs(pty_car):
    o = pty_car.sim.outputs
    return o.throttle_us, o.steering_us


def test_commands_arrive(pty_car):
    with Vehicle(f"serial://{pty_car.path}") as car:
        car.drive(throttle=0.4, steering=0.5)
        assert wait_for(lambda: outputs(pty_car) == (1700, 1750))
        assert wait_for(lambda: "ARMED" in car.replies)
        assert wait_for(lambda: pty_car.sim.state().speed > 0.2)
    assert wait_for(lambda: outputs(pty_car) == (1500, 1500))


def test_error_replies_are_surfaced(pty_car):
    with Vehicle(f"serial://{pty_car.path}") as car:
        car.transport.write(b"(1500,25000)\n")
        assert wait_for(lambda: car.errors == 1)
        assert "ERR too_long" in car.replies


def test_unplugging_gives_a_clear_error_and_replugging_reconnects(tmp_path):
    first = PtyCar(EscCar(realtime=True)).start()
    port = tmp_path / "ttyROAR"  # a stable name, as udev gives /dev/serial/by-id/...
    port.symlink_to(first.path)
    with Vehicle(f"serial://{port}") as car:
        car.drive(0.3)
        assert wait_for(lambda: outputs(first) == (1650, 1500))
        first.close()  # unplug
        assert wait_for(lambda: not car.connected)
        message = str(car.link_error)
        assert message.startswith(f"serial port {port} disconnected") or message.startswith(
            f"cannot open serial port {port}"), message
        assert "\n" not in message
        second = PtyCar(EscCar(realtime=True)).start()
        try:
            port.unlink()
            port.symlink_to(second.path)  # plugged in again
            assert wait_for(lambda: car.connected, timeout_s=5)
            car.stop()  # the new car boots with its failsafe latched: neutral arms it
            car.drive(0.3)
            assert wait_for(lambda: outputs(second) == (1650, 1500))
        finally:
            second.close()


def test_a_serial_link_without_reconnect_reports_the_loss(pty_car):
    with Vehicle(f"serial://{pty_car.path}", reconnect=False) as car:
        pty_car.close()
        assert wait_for(lambda: not car.connected)
        with pytest.raises(TransportError, match="disconnected"):
            car.drive(0.1)


HOST_PROGRAM = """
import os, signal, sys, time
from roar import TransportError, Vehicle
car = Vehicle("serial://" + sys.argv[1])
car.drive(0.3, 0.0)
time.sleep(0.5)
print("driving", flush=True)
if sys.argv[2] == "crash":
    os.kill(os.getpid(), signal.SIGKILL)  # no cleanup at all
# "forget": the program ends without closing the vehicle
"""


@pytest.mark.parametrize("how", ["forget", "crash"])
def test_when_the_host_program_stops_the_car_stops(pty_car, how):
    proc = subprocess.run([sys.executable, "-c", textwrap.dedent(HOST_PROGRAM), pty_car.path, how], cwd=ROOT,
                          capture_output=True, text=True, timeout=30)
    assert "driving" in proc.stdout, proc.stderr
    assert proc.returncode == (-signal.SIGKILL if how == "crash" else 0)
    # Nobody sends any more: the car's own failsafe holds it at neutral, latched.
    assert wait_for(lambda: pty_car.sim.outputs.latched)
    assert outputs(pty_car) == (1500, 1500)
    assert wait_for(lambda: abs(pty_car.sim.state().speed) < 0.05, timeout_s=5)


def test_a_closed_pty_cannot_be_opened():
    car = PtyCar(EscCar(realtime=True)).start()
    path = car.path
    car.close()
    with pytest.raises(TransportError, match=f"cannot open serial port {path}: "):
        Vehicle(f"serial://{path}")
