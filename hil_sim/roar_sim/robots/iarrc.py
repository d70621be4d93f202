"""The IARRC car: the core's IARRC tasks on the host scheduler (FreeRTOS's rules, the board's
task table and declared costs), SBUS frames from a simulated transmitter, setpoints from the
host on the serial port, a 10,240-count wheel encoder, and the PyBullet car with a stronger
motor and grippier tyres than the ESC car's (it reaches 2 m/s in 0.7 s). It drives by speed:
a command's throttle t asks it for t x FULL_SCALE_M_S as a setpoint, which its own PID holds.

    car = IarrcCar()                          # the operator flips the mode switch to autonomous
    car.host(b"[2000,1500]")                  # when the first setpoint arrives: 2 m/s, straight
    car.run(1.0)
    car.status()["speed_mm_s"], car.state()
    IarrcCar(operator=False).transmitter.mode = "manual"   # or the switches and sticks are yours

    python -m roar_sim.runs.limits iarrc      # re-measure its limits
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from roar.autopilot import Agent, CarLimits, CarModel, SpeedSetpoint, race_agent
from roar.autopilot.limits import straight_line
from roar.autopilot.pure_pursuit import PurePursuit
from roar.calibration import Calibration
from roar.protocol import encode_setpoint, spec
from roar.telemetry import VehicleState
from roar_sim.core.lockstep import CONTROL_PERIOD_S, LOOP_US, PHYSICS_US
from roar_sim.core.rtos import Scheduler
from roar_sim.core.iarrc import IarrcBoard, iarrc_tasks
from roar_sim.core.library import IarrcTask
from roar_sim.plants.esc_servo import EscMode, HobbyEsc, PulseDelay, SteeringServo, actuators
from roar_sim.plants import car_profile
from roar_sim.plants.car_profile import URDF_WHEELBASE_M, CarProfile
from roar_sim.plants.racecar import CarState, Racecar
from roar_sim.robots import Pose, ProfileLimits, ProfileModel, ReplyLines, Robot, grip_on_circles
from roar.tracks.track import Track
from roar.vision.geometry import SIMULATED_CAR_CAMERA
from roar_sim.world.scene import World
from roar_wire import sbus

FRAME_US = spec.TIMING_SERVO_FRAME_US  # [us] ESC/servo frame
SBUS_PERIOD_US = 14_000  # [us] a FrSky receiver's frame period (normal speed)
SBUS_BYTE_US = 120  # [us] one byte at 100 kbaud, 8E2 (12 bits)
ENCODER_COUNTS_PER_REV = 10_240  # [counts] the seed's magnetic encoder, per wheel turn
ROLLING_RADIUS_M = 0.0505  # [m] measured: distance over wheel angle at 1-2 m/s (the tyre contact, not the 0.05 m mesh)
COUNTS_PER_M = round(ENCODER_COUNTS_PER_REV / (2 * math.pi * ROLLING_RADIUS_M))  # [counts/m] calibrated, as on a car
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


FULL_SCALE_M_S = spec.SETPOINT_MAX_SPEED_MM_S / 1000  # [m/s] the setpoint a command's throttle of 1 asks for
LIMITS = CarLimits(max_speed_m_s=4.51, max_accel_m_s2=2.65, max_brake_m_s2=3.16, max_lateral_m_s2=8.03)
MODEL = CarModel(wheelbase_m=URDF_WHEELBASE_M, max_steer_rad=SteeringServo().max_angle_rad, limits=LIMITS)


class IarrcCar(Robot):
    """host() setpoints (or write() any bytes on its host port), run() time, read() its lines."""

    name = "iarrc"
    title = "IARRC car"
    half_width_m = 0.15  # [m] half its width as the walls feel it (the same racecar as the ESC car's)
    limits = ProfileLimits(LIMITS)  # its default profile's; a car's own profile's, measured when first asked for
    model = ProfileModel(MODEL)
    profiles = car_profile
    default_profile = "iarrc"  # roar_sim/plants/car_profiles/iarrc.toml: a 5 m/s motor, rubber tyres
    links = ("serial",)
    laterals = ("pursuit", "pid")
    replies = True
    has_lidar = True
    camera = SIMULATED_CAR_CAMERA

    def __init__(self, track: Track | None = None, pose: Pose | None = None, realtime: bool = False,
                 speedup: float = 1.0, gui: bool = False, esc: HobbyEsc | None = None,
                 servo: SteeringServo | None = None, battery_v: float = 12.0, task_cost=None,
                 clock_offset_us: int = 0, operator: bool = True, nvm: bytes | None = None,
                 profile: CarProfile | str | None = None, world: World | None = None) -> None:
        """profile: the car's own numbers (roar_sim.plants.car_profile: a name, a file or a
        CarProfile; default `iarrc`): its size, mass, motor, tyres, servo, ESC and latency;
        nvm: the board's flash as a previous run left it (`.nvm`: its signing key and session);
        battery_v: [V] its 3S pack; task_cost: (task, job number) -> [us] (default: the declared
        costs); clock_offset_us: [us] the board's counter at simulated time 0 (to test its 2^32
        wrap); operator: the person at the transmitter, who, after the receiver has locked with
        the mode switch at off, flips it to autonomous as soon as the host sends its first
        setpoint (False: the switches are the caller's, in `transmitter`); world: one car more in a
        world that another steps (roar_sim.runs.fleet), which then calls firmware(), actuate() and
        plant.tick(), and runs the receiver's lock (OPERATOR_LOCK_S) before a setpoint is sent."""
        super().__init__(track, realtime, speedup)
        self.profile = profile = self.profile_of(profile)
        self.plant = Racecar(track, dt_s=PHYSICS_US / 1e6, gui=gui, world=world, pose=pose, profile=profile)
        self.board = IarrcBoard(counts_per_m=COUNTS_PER_M, nvm=nvm)
        self.tasks = iarrc_tasks()
        self.scheduler = Scheduler(self.tasks, self._body, cost=task_cost, overran=self.board.overran,
                                   keep_starts=False)
        own_esc, own_servo = actuators(profile)
        self.esc, self.servo = esc or own_esc, servo or own_servo
        self._delay = PulseDelay(profile.latency_s)  # from a frame's pulses to the ESC and servo
        self._esc_out = self.esc.pulse(spec.CONTROL_NEUTRAL_US)
        self.transmitter = Transmitter()
        self.battery_v, self.clock_offset_us, self.operator = battery_v, clock_offset_us, operator
        self.calibration = Calibration()
        self._next_sbus_us = 0
        self._host_lines, self._link_lines = ReplyLines(), ReplyLines()
        self.board.begin()
        if operator and world is None:
            self.run(OPERATOR_LOCK_S)

    # --- what the host and the user see ------------------------------------------------------

    def host(self, data: bytes) -> None:
        """Bytes from the vision computer's serial port, arriving now."""
        self.board.host(data)
        if self.operator and self.transmitter.mode == "off" and spec.SETPOINT_START_CHAR.encode() in data:
            self.transmitter.mode = "autonomous"

    write = host  # its serial port, as every robot names it

    def drive(self, throttle: float, steering: float) -> None:
        """A setpoint of throttle x FULL_SCALE_M_S, as a vision computer sends it."""
        speed_mm_s = round(throttle * FULL_SCALE_M_S * 1000)
        self.host(encode_setpoint(speed_mm_s, self.calibration.steering.to_us(steering)))

    def host_drive(self, throttle: float, steering: float) -> dict:
        return {"speed": throttle * FULL_SCALE_M_S, "steering": steering}

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
        return self._host_lines.take()

    def read_link(self) -> list[str]:
        self._collect()
        return self._link_lines.take()

    @property
    def nvm(self) -> bytes:
        """The board's flash now (signing key and session)."""
        return self.board.nvm

    def status(self) -> dict:
        return self.board.status()

    def state(self) -> CarState:
        return self.plant.state()

    def vehicle_state(self) -> VehicleState:
        s = self.state()
        return VehicleState(self.time_s, s.x, s.y, s.yaw, s.speed, s.yaw_rate, s.encoder_counts,
                            float(self.throttle_out_us))

    def info(self) -> dict:
        return {"throttle_us": self.throttle_out_us, "setpoint_mm_s": self.status()["setpoint_mm_s"]}

    def braking(self) -> bool:
        return self.esc.mode in (EscMode.BRAKE, EscMode.REVERSE)

    def agent(self, line, margin: float = 0.9, lateral: str = "pursuit", k_dd_s: float | None = None) -> Agent:
        """Pure pursuit (or the heading PID) and the speed profile's speed as the setpoint: the
        car's own PID holds it, braking through the brake sequence."""
        pursuit = None if k_dd_s is None else PurePursuit(self.model.wheelbase_m, k_dd_s=k_dd_s)
        return race_agent(line, self.model, CONTROL_PERIOD_S, margin=margin, lateral=lateral, pursuit=pursuit,
                          speed=self.speed_control())

    def speed_control(self) -> SpeedSetpoint:
        """Its setpoint is the speed: its own PID holds it."""
        return SpeedSetpoint(FULL_SCALE_M_S)

    def _collect(self) -> None:
        for out, lines in ((self.board.host_out, self._host_lines), (self.board.link_out, self._link_lines)):
            lines.add(bytes(out))
            out.clear()

    # --- time --------------------------------------------------------------------------------

    def _body(self, task: IarrcTask, now_us: int) -> None:
        b = self.board
        if task == IarrcTask.CONTROL:
            b.encoder_count = int(self.plant.wheel_angle() / (2 * math.pi) * ENCODER_COUNTS_PER_REV)
        elif task == IarrcTask.GYRO:
            b.set_inputs(gyro_z_raw=round(math.degrees(self.plant.state().yaw_rate) * GYRO_COUNTS_PER_DEG_S))
        elif task == IarrcTask.BATTERY:
            b.set_inputs(battery_adc=round(self.battery_v * 1e6 / BATTERY_UV_PER_COUNT))
        b.run(task, now_us + self.clock_offset_us)

    def _advance(self, end_us: int) -> None:
        t = self.t_us
        self._tasks_until(min(end_us, (t // PHYSICS_US + 1) * PHYSICS_US))
        if t % PHYSICS_US == 0:
            self.actuate()
            self.plant.step()

    def firmware(self, loops: int) -> None:
        """Its tasks for `loops` firmware-loop periods (a Fleet's step: up to the next physics step)."""
        self._tasks_until(self.t_us + loops * LOOP_US)

    def actuate(self) -> None:
        """The ESC's and servo's outputs onto the car, for the physics step to come."""
        esc = self._esc_out
        self.plant.apply(esc.drive, esc.brake, self.servo.advance(PHYSICS_US / 1e6))

    def _tasks_until(self, step_end: int) -> None:
        """The receiver's frames and the board's tasks up to step_end [us]; the ESC and the servo
        take an output frame that started."""
        t = self.t_us
        while self._next_sbus_us < step_end:  # the receiver's frames that start in this step
            frame = self.transmitter.frame()
            if frame is not None:
                self.board.sbus(frame, self._next_sbus_us + self.clock_offset_us, SBUS_BYTE_US)
            self._next_sbus_us += SBUS_PERIOD_US
        self.scheduler.run_until(step_end)
        self.t_us = step_end
        if t % FRAME_US == 0:  # an output frame starts: the ESC and the servo take its pulses (after the latency)
            self._delay.put(t, *self.board.pulses)
        for throttle_us, steering_us in self._delay.due(t):
            self._esc_out = self.esc.pulse(throttle_us)
            self.servo.pulse(steering_us)

    # --- its limits --------------------------------------------------------------------------

    @classmethod
    def measure_limits(cls, profile: CarProfile | None = None) -> CarLimits:
        """Top speed and acceleration at the fastest setpoint, braking when the setpoint drops to
        zero (its PID brakes through the brake sequence), and the steady lateral acceleration on
        circles at fixed steering, faster and faster until the tyres slide."""
        def hold(car: IarrcCar, speed_mm_s: int, steering_us: int, seconds: float) -> list:
            return car.log_driving(lambda: car.host(encode_setpoint(speed_mm_s, steering_us)), seconds)

        n, fastest = spec.CONTROL_NEUTRAL_US, spec.SETPOINT_MAX_SPEED_MM_S
        with cls(profile=profile) as car:
            hold(car, 0, n, 0.3)
            run = hold(car, fastest, n, 4.0)
            top, accel, brake = straight_line(run, hold(car, 0, n, 3.0))
        def drive_circle(car: IarrcCar, speed_mm_s: int, steering_us: int) -> list:
            hold(car, 0, n, 0.3)
            return hold(car, speed_mm_s, steering_us, 5.0)[-100:]  # the last 2 s

        lateral, fade = grip_on_circles(lambda: cls(profile=profile), (1650, 1700, 1750, 1800),
                                        range(1000, fastest + 1, 500), drive_circle)
        return CarLimits(round(top, 2), round(accel, 2), round(brake, 2), round(lateral, 2), lateral_fade=fade)


ROBOT = IarrcCar
