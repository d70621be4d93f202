"""The IARRC controller's AnyFC F7 glue, built for QEMU's netduinoplus2 (STM32F405, Cortex-M4):
it boots, takes SBUS on USART6 and setpoints on USART1 through their interrupts, runs the task
table from SysTick, and reports its mode and outputs in telemetry lines. Driven here through those
serial ports as a transmitter and a vision computer would: manual, autonomous, host silence,
re-arming, RC loss, and PID gains over the Bluetooth port (USART3)."""

import threading
import time

import pytest

from roar.protocol import spec
from roar.protocol.control import encode, encode_setpoint
from roar.telemetry import parse_telemetry
from roar_sim.emulators import qemu
from roar_sim.toolchains import arm
from roar_wire import signing

if qemu.available():
    pytest.skip(qemu.available(), allow_module_level=True)

from roar_sim.robots.iarrc import SBUS_PERIOD_US, Transmitter  # noqa: E402

pytestmark = pytest.mark.realtime  # keeps to the wall clock: one at a time under xdist (conftest)

HOST_PERIOD_S = spec.TIMING_HOST_SEND_PERIOD_US / 1e6


class Bench:
    """The emulated board with a transmitter and a vision computer sending on their own threads."""

    def __init__(self, board):
        self.board = board
        self.transmitter = Transmitter()
        self.setpoint = None  # (speed mm/s, steering us) sent at 50 Hz, None: silent
        self.signing = None  # (key, session) once the board has a key
        self.counter = 0
        self._running = True
        self._threads = [threading.Thread(target=self._sbus, daemon=True),
                         threading.Thread(target=self._host, daemon=True)]
        for t in self._threads:
            t.start()

    def _sbus(self):
        while self._running:
            frame = self.transmitter.frame()
            if frame is not None:
                self.board.send("sbus", frame)
            time.sleep(SBUS_PERIOD_US / 1e6)

    def _host(self):
        while self._running:
            if self.setpoint is not None:
                message = encode_setpoint(*self.setpoint)
                if self.signing is not None:  # (key, session): signed, the counter rising
                    self.counter += 1
                    message = signing.sign(message, *self.signing, self.counter)
                self.board.send("host", message)
            time.sleep(HOST_PERIOD_S)

    def telemetry(self, match, port="host", timeout_s=5.0):
        """The next telemetry line from now on whose fields satisfy match, or None."""
        since = len(self.board.lines[port])
        line = self.board.wait_line(port, lambda l: (t := parse_telemetry(l)) is not None and match(t),
                                    timeout_s, since)
        return parse_telemetry(line) if line else None

    def stop(self):
        self._running = False
        for t in self._threads:
            t.join()


@pytest.fixture(scope="module")
def bench(tmp_path_factory):
    elf = arm.build_iarrc_emulated()
    with qemu.EmulatedIarrc(elf, tmp_path_factory.mktemp("qemu")) as board:
        b = Bench(board)
        yield b
        b.stop()


def test_it_boots_says_ready_2_and_reports_at_10_hz(bench):
    assert bench.board.wait_line("host", lambda l: l == f"{spec.SERIAL_REPLY_READY} {spec.META_SPEED_VERSION}")
    t = bench.telemetry(lambda t: t["mode"] == "disarmed" and t["battery_v"] > 0)  # once the battery task ran
    assert t and t["throttle_out_us"] == 1500 and abs(t["battery_v"] - 12.0) < 0.05
    start = len(bench.board.lines["host"])
    time.sleep(1.0)
    count = sum(1 for line in bench.board.lines["host"][start:] if line.startswith(spec.TELEMETRY_REPLY))
    assert 7 <= count <= 13  # 10 Hz of the emulated clock, give or take the host's scheduling


def test_manual_mode_follows_the_sticks(bench):
    tx = bench.transmitter
    tx.mode, tx.throttle_us, tx.steering_us = "manual", 1700, 1800
    t = bench.telemetry(lambda t: t["mode"] == "manual" and t["throttle_out_us"] == 1700)
    assert t, bench.board.lines["host"][-3:]


def test_autonomous_mode_drives_by_the_hosts_setpoints(bench):
    bench.setpoint = (1000, 1600)
    time.sleep(0.1)  # the computer is talking before the switch goes to autonomous (else: host_silent)
    bench.transmitter.mode = "autonomous"
    # The wheel does not turn in the emulator: the PID pushes the throttle up towards its limit.
    t = bench.telemetry(lambda t: t["mode"] == "autonomous" and t["throttle_out_us"] > 1800)
    assert t and t["setpoint_m_s"] == 1.0 and t["failsafe"] == "none", bench.board.lines["host"][-3:]
    assert t["steering_out_us"] == 1600  # steering from the setpoint


def test_host_silence_fails_safe_and_zero_speed_rearms(bench):
    bench.setpoint = None
    t = bench.telemetry(lambda t: t["mode"] == "failsafe")
    assert t and t["failsafe"] == "host_silent" and t["throttle_out_us"] <= 1500
    assert bench.board.wait_line("host", lambda l: l == spec.SERIAL_REPLY_FAILSAFE)
    bench.setpoint = (0, 1500)
    assert bench.telemetry(lambda t: t["mode"] == "autonomous")
    assert bench.board.wait_line("host", lambda l: l == spec.SERIAL_REPLY_ARMED)


def test_throttle_messages_are_refused_in_one_line(bench):
    since = len(bench.board.lines["host"])
    bench.board.send("host", encode(1600, 1500))
    line = bench.board.wait_line("host", lambda l: l.startswith(spec.SERIAL_REPLY_ERROR), since=since)
    assert line == f"{spec.SERIAL_REPLY_ERROR} {spec.SERIAL_ERROR_UNSUPPORTED}"


def test_pid_gains_are_set_over_the_bluetooth_port(bench):
    bench.board.send("link", b"PID 300 200 10 100\n")
    t = bench.telemetry(lambda t: t["pid_gains_pm"] == (300, 200, 10, 100), port="link")
    assert t
    since = len(bench.board.lines["link"])
    bench.board.send("link", b"PID 1 2\n")
    assert bench.board.wait_line("link", lambda l: l == "ERR syntax", since=since)


def test_losing_the_transmitter_fails_safe_and_no_task_overran(bench):
    bench.setpoint = (1000, 1500)
    bench.transmitter.on = False  # the receiver sends failsafe frames
    t = bench.telemetry(lambda t: t["mode"] == "failsafe")
    assert t and t["failsafe"] == "rc_lost" and t["throttle_out_us"] <= 1500
    assert t["overruns"] == 0


def test_a_key_set_on_the_host_port_is_kept_in_flash_and_only_signed_setpoints_drive(bench):
    """Last (from here on the board takes signed setpoints only): the key goes into the flash
    log (the emulator's sectors are RAM), and the board drives by signed setpoints alone."""
    key = bytes(range(0x20, 0x30))
    bench.setpoint = None
    bench.transmitter.on, bench.transmitter.mode = True, "off"  # back from the lost transmitter: disarmed
    assert bench.telemetry(lambda t: t["mode"] == "disarmed")
    since = len(bench.board.lines["host"])
    bench.board.send("host", f"KEY {key.hex()}\n".encode())
    assert bench.board.wait_line("host", lambda l: l == f"KEY {signing.fingerprint(key)}", since=since)
    assert bench.board.wait_line("host", lambda l: l == "SESSION 00000001", since=since)
    bench.board.send("host", encode_setpoint(1000, 1500))
    assert bench.board.wait_line("host", lambda l: l == "ERR unsigned 00000001", since=since)
    bench.signing, bench.setpoint = (key, 1), (0, 1500)
    time.sleep(0.1)  # the computer is talking before the switch goes to autonomous
    bench.transmitter.mode = "autonomous"
    assert bench.telemetry(lambda t: t["mode"] == "autonomous")
    bench.setpoint = (1000, 1600)
    t = bench.telemetry(lambda t: t["mode"] == "autonomous" and t["setpoint_m_s"] == 1.0)
    assert t and t["steering_out_us"] == 1600, bench.board.lines["host"][-3:]
    since = len(bench.board.lines["host"])
    bench.board.send("host", signing.sign(encode_setpoint(2000, 1500), key, 1, 1))  # an old counter
    assert bench.board.wait_line("host", lambda l: l.startswith("ERR replay "), since=since)
    bench.board.send("host", b"KEY ?\n")
    assert bench.board.wait_line("host", lambda l: l == f"KEY {signing.fingerprint(key)}", since=since)
