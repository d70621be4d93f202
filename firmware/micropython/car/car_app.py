"""The ESP32-CAM car on MicroPython: control messages "(THROTTLE,STEERING)" over Bluetooth LE
(the ROAR GATT layout, PROTOCOL.md section 4) and the serial console, ESC and steering pulses
at 50 Hz from the PWM peripheral, the brake/reverse sequence, the 250 ms failsafe latched until
neutral, and the same reply lines as every ROAR car ("READY 1", "ERR <reason>", "FAILSAFE",
"ARMED") on the console. The logic is roar_car (the twin of the C++ core); this file is the
glue.

Every LOOP_MS the loop takes the bytes that arrived (BLE writes are queued by the Bluetooth
interrupt; the console is polled), steps the car, writes the pulses and the replies, and feeds
the watchdog. Output frames are counted from the PWM's start (one every 20 ms): MicroPython
does not expose the PWM timer's interrupt, so a new pulse is taken to be on the wire at the
next 20 ms boundary after it is written, as the PWM peripheral does.
"""

import asyncio
import binascii
import struct
import time

import bluetooth
import config
import machine
from roar_car import Car, Channel
from roar_clock import FRAME_MS, Clock
from roar_console import Console
from roar_wire import signing, spec

LOOP_MS = 1  # [ms] loop period
MAX_BYTES_PER_LOOP = 64  # keep the loop short under a byte flood
MAX_QUEUED_BYTES = 256  # [bytes] BLE writes waiting for the loop; a write that does not fit is dropped
STATE_PERIOD_MS = 100  # [ms] between updates of the state characteristic
WATCHDOG_MS = max(1000, spec.TIMING_LOOP_WATCHDOG_US // 1000)  # [ms] the ESP32's watchdog takes >= 1 s
ADVERTISE_US = 100000  # [us] advertising interval

_IRQ_CENTRAL_CONNECT = 1
_IRQ_CENTRAL_DISCONNECT = 2
_IRQ_GATTS_WRITE = 3
_FLAG_READ = 0x0002
_FLAG_WRITE_NO_RESPONSE = 0x0004
_FLAG_WRITE = 0x0008
_FLAG_READ_ENCRYPTED = 0x0200
_FLAG_WRITE_ENCRYPTED = 0x1000
_IO_CAPABILITY_NO_INPUT_OUTPUT = 3


def uuid_le(text):
    """A 128-bit UUID's bytes as advertisements carry them (little-endian)."""
    return bytes(reversed(binascii.unhexlify(text.replace("-", ""))))


def advertisement(name):
    """(advertising data, scan response): flags and the ROAR service; the name."""
    service = uuid_le(spec.BLE_SERVICE_UUID)
    adv = bytes((2, 0x01, 0x06, len(service) + 1, 0x07)) + service  # LE general discoverable, no BR/EDR
    name = name.encode()[:29]
    return adv, bytes((len(name) + 1, 0x09)) + name


class Radio:
    """The ROAR GATT service: control writes queued whole for the loop; velocity and state read;
    pid, name and override accepted. secure (the car has a key): control and session need an
    encrypted link, paired with LE Secure Connections, Just Works (a signing host pairs)."""

    def __init__(self, name, secure=False):
        self.ble = bluetooth.BLE()
        self.ble.active(True)
        self.ble.irq(self._irq)
        encrypted = 0
        if secure:
            self.ble.config(le_secure=True, mitm=False, bond=False, io=_IO_CAPABILITY_NO_INPUT_OUTPUT)
            encrypted = _FLAG_READ_ENCRYPTED | _FLAG_WRITE_ENCRYPTED
        U = bluetooth.UUID
        service = (U(spec.BLE_SERVICE_UUID), (
            (U(spec.BLE_CONTROL_UUID), _FLAG_READ | _FLAG_WRITE | _FLAG_WRITE_NO_RESPONSE | encrypted),
            (U(spec.BLE_VELOCITY_UUID), _FLAG_READ),
            (U(spec.BLE_PID_UUID), _FLAG_WRITE),
            (U(spec.BLE_STATE_UUID), _FLAG_READ),
            (U(spec.BLE_NAME_UUID), _FLAG_WRITE),
            (U(spec.BLE_OVERRIDE_UUID), _FLAG_WRITE),
            (U(spec.BLE_SESSION_UUID), _FLAG_READ | (encrypted & _FLAG_READ_ENCRYPTED)),
        ))
        ((self.control, self.velocity, self.pid, self.state, self.name, self.override, self.session),) = \
            self.ble.gatts_register_services((service,))
        self.ble.gatts_write(self.velocity, struct.pack("<f", 0.0))  # no speedometer on this car
        self.ble.gatts_write(self.state, struct.pack("<ff", 0.0, spec.CONTROL_NEUTRAL_US))
        self.pid_gains = (0.0, 0.0, 0.0)  # kp, kd, ki as the host packs them
        self.queued = bytearray()
        self.connected = 0
        self.advertised_name = name
        self.advertise()

    def advertise(self):
        adv, resp = advertisement(self.advertised_name)
        self.ble.gap_advertise(ADVERTISE_US, adv_data=adv, resp_data=resp)

    def _irq(self, event, data):
        if event == _IRQ_CENTRAL_CONNECT:
            self.connected += 1
        elif event == _IRQ_CENTRAL_DISCONNECT:
            self.connected = max(0, self.connected - 1)
            self.advertise()  # let the host reconnect; the failsafe covers the gap
        elif event == _IRQ_GATTS_WRITE:
            handle = data[1]
            value = self.ble.gatts_read(handle)
            if handle == self.control:
                if len(self.queued) + len(value) <= MAX_QUEUED_BYTES:  # whole, or dropped
                    self.queued.extend(value)
            elif handle == self.pid and len(value) == 12:
                self.pid_gains = struct.unpack("<fff", value)
            elif handle == self.name and 0 < len(value) <= 20:
                self.advertised_name = bytes(value).decode()  # advertised from the next start

    def take(self, n):
        data = bytes(self.queued[:n])
        self.queued = self.queued[n:]
        return data

    def publish(self, throttle_us, auth):
        self.ble.gatts_write(self.state, struct.pack("<ff", 0.0, throttle_us))
        self.ble.gatts_write(self.session, struct.pack("<II", auth.session, auth.last_counter))


class Outputs:
    """ESC and steering pulses, 50 Hz from the PWM peripheral; frames counted from its start."""

    def __init__(self, clock):
        freq = 1000000 // spec.TIMING_SERVO_FRAME_US  # [Hz] 50
        ns = spec.CONTROL_NEUTRAL_US * 1000
        self.pwm = [machine.PWM(machine.Pin(config.THROTTLE_PIN), freq=freq, duty_ns=ns),
                    machine.PWM(machine.Pin(config.STEERING_PIN), freq=freq, duty_ns=ns)]
        self.clock = clock
        self.start_ms = clock.now()
        self.written = (spec.CONTROL_NEUTRAL_US, spec.CONTROL_NEUTRAL_US)

    def frames(self, now_ms):
        """Output frames started so far (the first at the PWM's start)."""
        return (now_ms - self.start_ms) // FRAME_MS + 1

    def write(self, pulses):
        if pulses != self.written:
            self.written = pulses
            self.pwm[0].duty_ns(pulses[0] * 1000)
            self.pwm[1].duty_ns(pulses[1] * 1000)


class CarBoard:
    def __init__(self, console=None):
        self.clock = Clock()
        self.outputs = Outputs(self.clock)
        self.car = Car(Channel(config.THROTTLE_TRIM_US, config.THROTTLE_MIN_US, config.THROTTLE_MAX_US),
                       Channel(config.STEERING_TRIM_US, config.STEERING_MIN_US, config.STEERING_MAX_US))
        self.console = console or Console()
        self.car.boot(signing.FileNvm(config.KEY_FILE))  # the key first: it decides the link's security
        self.radio = Radio(config.NAME, secure=self.car.auth.key is not None)  # (a later key: from the next reset)
        self.led = machine.Pin(config.STATUS_LED_PIN, machine.Pin.OUT, value=1)
        self._last_state = 0

    def poll(self):
        """The loop body: bytes in, one car step, pulses out, replies out, watchdog fed."""
        now = self.clock.now()
        for byte in self.radio.take(MAX_BYTES_PER_LOOP):
            self.car.feed(byte, now)
        for byte in self.console.read(MAX_BYTES_PER_LOOP):  # the only link that may set the key
            self.car.feed(byte, now, serial=True)
        pulses = self.car.step(now, self.outputs.frames(now))
        self.outputs.write(pulses)
        line = self.car.take_reply()
        while line:
            self.console.write(line)
            line = self.car.take_reply()
        self.led.value(0 if self.radio.connected else 1)
        if now - self._last_state >= STATE_PERIOD_MS:
            self._last_state = now
            self.radio.publish(pulses[0], self.car.auth)
        return pulses


async def main():
    board = CarBoard()
    watchdog = machine.WDT(timeout=WATCHDOG_MS)
    next_tick = time.ticks_ms()
    while True:
        board.poll()
        watchdog.feed()
        next_tick = time.ticks_add(next_tick, LOOP_MS)
        await asyncio.sleep_ms(max(0, time.ticks_diff(next_tick, time.ticks_ms())))
