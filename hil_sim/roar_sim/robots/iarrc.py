"""The IARRC car in the simulator: the core's IARRC tasks on the host scheduler (FreeRTOS's rules,
the board's task table and declared costs), SBUS frames from a simulated transmitter, setpoints
from the host on the serial port, a 10,240-count wheel encoder, and the PyBullet car with a
stronger motor than the ROAR car's (the IARRC car reaches 2 m/s in 0.7 s).

    car = IarrcCar()
    car.transmitter.mode = "autonomous"       # the RC switches, sticks, or on = False
    car.host(b"[2000,1500]")                  # 2 m/s, straight
    car.run(1.0)
    car.status()["speed_mm_s"], car.state()
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from roar.protocol import spec
from roar_sim.plants.esc_servo import HobbyEsc, SteeringServo
from roar_sim.core.iarrc import IarrcBoard, iarrc_tasks
from roar_sim.clock.lockstep import Lockstep
from roar_sim.plants.racecar import CarState, Motor, Plant
from roar_sim.clock.rtos import Scheduler
from roar_sim.world.track import Track
from roar_wire import sbus

PHYSICS_US = 5_000  # [us] physics step
FRAME_US = spec.TIMING_SERVO_FRAME_US  # [us] ESC/servo frame
SBUS_PERIOD_US = 14_000  # [us] a FrSky receiver's frame period (normal speed)
SBUS_BYTE_US = 120  # [us] one byte at 100 kbaud, 8E2 (12 bits)
ENCODER_COUNTS_PER_REV = 10_240  # [counts] the seed's magnetic encoder, per wheel turn
ROLLING_RADIUS_M = 0.0505  # [m] measured: distance over wheel angle at 1-2 m/s (the tyre contact, not the 0.05 m mesh)
COUNTS_PER_M = round(ENCODER_COUNTS_PER_REV / (2 * math.pi * ROLLING_RADIUS_M))  # [counts/m] calibrated, as on a car
IARRC_MOTOR = Motor(max_speed_rad_s=100.0, max_torque_nm=0.8, tyre_friction=1.0)  # 5 m/s top speed, rubber tyres
GYRO_COUNTS_PER_DEG_S = 16.4  # MPU6000 at +-2000 deg/s
BATTERY_UV_PER_COUNT = 8862  # [uV per ADC count] the core's default divider
OPERATOR_LOCK_S = 0.1  # [s] the receiver locks with the mode switch at off before the operator acts
MODE_SWITCH_US = {"off": 1000, "manual": 1500, "autonomous": 2000}  # [us] a 3-position switch


@dataclass
class Transmitter:
    """The FrSky transmitter and receiver: sticks and switches -> SBUS frames every 14 ms.
    on=False: the receiver has lost the transmitter; with failsafe_frames it then sends frames
    with the failsafe flag (FrSky's default), otherwise it goes silent."""

    throttle_us: int = spec.CONTROL_NEUTRAL_US
    steering_us: int = spec.CONTROL_NEUTRAL_US
    mode: str = "off"  # off, manual, autonomous
    stop: bool = False  # the emergency-stop switch
    on: bool = True
    failsafe_frames: bool = True

    def frame(self) -> bytes | None:
        channels = [sbus.us_to_raw(spec.CONTROL_NEUTRAL_US)] * sbus.CHANNELS
        if not self.on:
            return sbus.encode(channels, spec.SBUS_FLAG_FAILSAFE) if self.failsafe_frames else None
        channels[0] = sbus.us_to_raw(self.steering_us)
        channels[2] = sbus.us_to_raw(self.throttle_us)
        channels[4] = sbus.us_to_raw(MODE_SWITCH_US[self.mode])
        channels[5] = sbus.us_to_raw(2000 if self.stop else 1000)
        return sbus.encode(channels)


@dataclass
class IarrcSimConfig:
    motor: Motor = IARRC_MOTOR
    esc: HobbyEsc = field(default_factory=HobbyEsc)
    servo: SteeringServo = field(default_factory=SteeringServo)
    battery_v: float = 12.0  # [V] 3S LiPo
    task_cost: object = None  # (task index, job number) -> [us]; None: the declared costs
    clock_offset_us: int = 0  # [us] the board's counter at simulated time 0 (to test its 2^32 wrap)
    # The person at the transmitter: after the receiver has locked with the mode switch at off,
    # flip it to autonomous as soon as the computer sends its first setpoint (sim://?car=iarrc,
    # roar sim --serial --car iarrc). False: the switches are the caller's (car.transmitter).
    operator: bool = False
    realtime: bool = False
    speedup: float = 1.0
    gui: bool = False


class IarrcCar(Lockstep):
    def __init__(self, track: Track | None = None, config: IarrcSimConfig | None = None) -> None:
        self.config = config or IarrcSimConfig()
        self.track = track
        self.plant = Plant(track, dt_s=PHYSICS_US / 1e6, gui=self.config.gui, motor=self.config.motor)
        self.board = IarrcBoard(counts_per_m=COUNTS_PER_M)
        self.tasks = iarrc_tasks()
        names = [t.name for t in self.tasks]
        self._control, self._gyro, self._battery = (names.index(n) for n in ("control", "gyro", "battery"))
        self.scheduler = Scheduler(self.tasks, self._body, cost=self.config.task_cost,
                                   overran=self.board.overran, keep_starts=False)
        self.esc, self.servo = self.config.esc, self.config.servo
        self._esc_out = self.esc.pulse(spec.CONTROL_NEUTRAL_US)
        self.transmitter = Transmitter()
        self.battery_v = self.config.battery_v
        self.t_us = 0
        self._next_sbus_us = 0
        self._host_lines: list[str] = []
        self._link_lines: list[str] = []
        self._partial = {"host": b"", "link": b""}
        self.board.begin()
        if self.config.operator:
            self.run(OPERATOR_LOCK_S)

    # --- what the host and the user see ------------------------------------------------------

    def host(self, data: bytes) -> None:
        """Bytes from the vision computer's serial port, arriving now."""
        self.board.host(data)
        if self.config.operator and self.transmitter.mode == "off" and spec.SETPOINT_START_CHAR.encode() in data:
            self.transmitter.mode = "autonomous"

    write = host  # the serial port, as SimCar names it

    @property
    def throttle_out_us(self) -> int:
        """[us] the throttle pulse the control task last wrote."""
        return self.board.pulses[0]

    def link(self, data: bytes) -> None:
        """Bytes from the Bluetooth serial module (PID commands)."""
        self.board.link(data)

    def read(self) -> list[str]:
        """Lines the car wrote to the vision computer since the last read."""
        self._collect()
        lines, self._host_lines = self._host_lines, []
        return lines

    def read_link(self) -> list[str]:
        self._collect()
        lines, self._link_lines = self._link_lines, []
        return lines

    def status(self) -> dict:
        return self.board.status()

    def state(self) -> CarState:
        return self.plant.state()

    def _collect(self) -> None:
        for name, out, lines in (("host", self.board.host_out, self._host_lines),
                                 ("link", self.board.link_out, self._link_lines)):
            if out:
                *done, self._partial[name] = (self._partial[name] + bytes(out)).split(b"\n")
                out.clear()
                lines += [line.decode("ascii", "replace") for line in done]

    # --- time --------------------------------------------------------------------------------

    def _body(self, task: int, now_us: int) -> None:
        b = self.board
        if task == self._control:
            b.encoder_count = int(self.plant.wheel_angle() / (2 * math.pi) * ENCODER_COUNTS_PER_REV)
        elif task == self._gyro:
            b.set_inputs(gyro_z_raw=round(math.degrees(self.plant.state().yaw_rate) * GYRO_COUNTS_PER_DEG_S))
        elif task == self._battery:
            b.set_inputs(battery_adc=round(self.battery_v * 1e6 / BATTERY_UV_PER_COUNT))
        b.run(task, now_us + self.config.clock_offset_us)

    def _advance(self, end_us: int) -> None:
        t = self.t_us
        step_end = min(end_us, (t // PHYSICS_US + 1) * PHYSICS_US)
        while self._next_sbus_us < step_end:  # the receiver's frames that start in this step
            frame = self.transmitter.frame()
            if frame is not None:
                self.board.sbus(frame, self._next_sbus_us + self.config.clock_offset_us, SBUS_BYTE_US)
            self._next_sbus_us += SBUS_PERIOD_US
        self.scheduler.run_until(step_end)
        self.t_us = step_end
        if t % FRAME_US == 0:  # an output frame starts: the ESC and the servo take the pulses
            throttle_us, steering_us = self.board.pulses
            self._esc_out = self.esc.pulse(throttle_us)
            self.servo.pulse(steering_us)
        if t % PHYSICS_US == 0:
            esc = self._esc_out
            self.plant.apply(esc.drive, esc.brake, self.servo.advance(PHYSICS_US / 1e6))
            self.plant.step()
