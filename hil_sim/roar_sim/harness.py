"""Software-in-the-loop harness: the firmware's car logic (C++ core, host build) drives the
emulated ESC and servo, which drive the PyBullet car. Host code talks to it with the same bytes
it would send a real car.

Lockstep: simulated time advances only in run(); with realtime=True run() also sleeps so that
simulated time keeps pace with the wall clock (or `speedup` times faster).

    firmware loop   1 kHz   Car.step() on the simulated clock (the sim HAL)
    output frames   50 Hz   the ESC and servo latch the pulse at each frame start
    physics         200 Hz  PyBullet steps
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

from roar.protocol import spec
from roar_sim.actuators import EscMode, HobbyEsc, SteeringServo
from roar_sim.firmware_core import Car, CarConfig, CarOutputs
from roar_sim.plant import CarState, Plant
from roar_sim.track import Track

LOOP_US = 1_000  # [us] firmware main-loop period
PHYSICS_US = 5_000  # [us] physics step
FRAME_US = spec.TIMING_SERVO_FRAME_US  # [us]


@dataclass
class SimConfig:
    firmware: CarConfig = field(default_factory=CarConfig)
    esc: HobbyEsc = field(default_factory=HobbyEsc)
    servo: SteeringServo = field(default_factory=SteeringServo)
    realtime: bool = False
    speedup: float = 1.0  # simulated seconds per wall second when realtime
    gui: bool = False


class SimCar:
    """A simulated car: write() control bytes, run() time, read() the car's reply lines."""

    def __init__(self, track: Track | None = None, config: SimConfig | None = None) -> None:
        self.config = config or SimConfig()
        self.track = track
        self.firmware = Car(self.config.firmware)
        self.esc, self.servo = self.config.esc, self.config.servo
        self.plant = Plant(track, dt_s=PHYSICS_US / 1e6, gui=self.config.gui)
        self.t_us = 0
        self.frames = 0
        self.outputs: CarOutputs = self.firmware.step(0, 0)
        self._rc: tuple[int, int] | None = None
        self._replies: list[str] = []
        self._wall_start: float | None = None
        self._esc_out = self.esc.pulse(self.outputs.throttle_us)
        self.firmware.boot()

    def close(self) -> None:
        self.plant.close()

    def __enter__(self) -> SimCar:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # --- what the host sees ------------------------------------------------------------------

    def write(self, data: bytes) -> None:
        """Bytes arriving on the car's serial port / BLE characteristic now."""
        self.firmware.feed(data, self.t_us)

    def read(self) -> list[str]:
        """Reply lines the car printed since the last read."""
        lines, self._replies = self._replies, []
        return lines

    def rc_transmitter(self, pulses: tuple[int, int] | None) -> None:
        """(throttle, steering) pulses from an RC receiver from now on at 50 Hz; None = switched off."""
        self._rc = pulses

    @property
    def time_s(self) -> float:
        return self.t_us / 1e6

    def state(self) -> CarState:
        return self.plant.state()

    # --- time --------------------------------------------------------------------------------

    def run(self, seconds: float) -> None:
        end = self.t_us + int(round(seconds * 1e6))
        while self.t_us < end:
            self._tick()
            if self.config.realtime:
                self._pace()

    def _tick(self) -> None:
        t = self.t_us
        if t % FRAME_US == 0:
            if self._rc is not None:
                self.firmware.rc_pulse(0, self._rc[0], t)
                self.firmware.rc_pulse(1, self._rc[1], t)
            # Output frame start: the ESC and the servo latch the pulses now on the pins.
            self.frames += 1
            self._esc_out = self.esc.pulse(self.outputs.throttle_us)
            self.servo.pulse(self.outputs.steering_us)
        self.outputs = self.firmware.step(t, self.frames)
        self._replies += [line.rstrip("\n") for line in self.firmware.replies()]
        if t % PHYSICS_US == 0:
            esc = self._esc_out
            self.plant.apply(esc.drive, esc.brake, self.servo.advance(PHYSICS_US / 1e6))
            self.plant.step()
        self.t_us = t + LOOP_US

    def _pace(self) -> None:
        now = time.perf_counter()
        wall_s = self.t_us / 1e6 / self.config.speedup
        if self._wall_start is None:
            self._wall_start = now - wall_s
        ahead = wall_s - (now - self._wall_start)
        if ahead > 0.002:
            time.sleep(ahead)

    @property
    def esc_mode(self) -> EscMode:
        return self.esc.mode
