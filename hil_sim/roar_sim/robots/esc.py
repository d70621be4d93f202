"""The ESC car: the board loop every ESC car runs (CarBoard::poll of the firmware core, host
build) drives an emulated hobby ESC and steering servo, which drive PyBullet's 1/10 racecar.
Commands reach it as they reach a real one, as control messages on its serial port.

    firmware loop   1 kHz   CarBoard::poll on the board's 32-bit microsecond counter
    output frames   50 Hz   each frame carries the pulses written before it starts; the ESC
                            and the servo take them at the frame start
    physics         200 Hz  PyBullet steps

    with EscCar(get("oval")) as car:          # lockstep: time moves only in run()
        car.write(b"(1500,1500)")             # bytes on its serial port
        car.run(0.1)
        car.read()                            # ['READY 1', 'ARMED']

    python -m roar_sim.runs.limits esc        # re-measure its limits
"""

from __future__ import annotations

import math

from roar.autopilot import Agent, CarLimits, CarModel, race_agent
from roar.autopilot.limits import straight_line
from roar.autopilot.pure_pursuit import PurePursuit
from roar.calibration import Calibration
from roar.protocol import encode, spec
from roar.telemetry import VehicleState
from roar_sim.core.lockstep import CONTROL_PERIOD_S, LOOP_US, PHYSICS_US, loops_until
from roar_sim.core.car import CarBoard, CarConfig, CarOutputs
from roar_sim.plants.esc_servo import EscMode, HobbyEsc, PulseDelay, SteeringServo, actuators
from roar_sim.plants import car_profile
from roar_sim.plants.car_profile import CarProfile
from roar_sim.plants.racecar import CarState, Racecar
from roar_sim.robots import Pose, ProfileLimits, ProfileModel, ReplyLines, Robot, grip_on_circles
from roar_sim.world.scene import World
from roar.tracks.track import Track
from roar.vision.geometry import SIMULATED_CAR_CAMERA

FRAME_US = spec.TIMING_SERVO_FRAME_US  # [us]
REVERSE_TRIES = (1.0, 0.75, 0.5, 0.35, 0.25)  # reverse throttle tried for braking, strongest first
STOP_WITHIN_S = 8.0  # [s] the longest a stop from top speed is waited for
STRAIGHT_DEG = 5.0  # [deg] a stop from top speed that turns the car more than this does not brake it straight
LIMITS_VERSION = 4  # of the way limits are measured: limits kept in the user's cache by an older one are measured again
# [us] the steerings its grip is measured at: the larger ones find the peak, the smaller ones reach
# the speeds where a fast car's grip fades
CIRCLE_STEERINGS_US = (1560, 1600, 1650, 1700, 1750, 1800)
# The default profile's (roar) limits as measured from it; `roar limits esc` and the suite measure
# them again. Any other profile's are measured on first use and kept in the user's cache. Full
# reverse from its top speed turns the ROAR car 28 degrees before it stops: it brakes at half.
LIMITS = CarLimits(max_speed_m_s=2.93, max_accel_m_s2=1.78, max_brake_m_s2=2.53, max_lateral_m_s2=3.38, max_reverse=0.5)
MODEL = CarModel(wheelbase_m=car_profile.load().wheelbase_m, max_steer_rad=car_profile.load().max_steer_rad,
                 limits=LIMITS)
N = spec.CONTROL_NEUTRAL_US


class EscCar(Robot):
    """write() control bytes, run() time, read() the car's reply lines."""

    name = "esc"
    title = "ESC car"
    half_width_m = 0.15  # [m] half its width as the walls feel it (wheels and steering), measured
    limits = ProfileLimits(LIMITS)  # the default profile's; a car's own profile's, measured when first asked for
    model = ProfileModel(MODEL)
    profiles = car_profile
    default_profile = car_profile.DEFAULT
    limits_version = LIMITS_VERSION
    links = ("serial", "stream")
    laterals = ("pursuit", "pid")
    lane_driving = True
    replies = True
    has_lidar = True
    camera = SIMULATED_CAR_CAMERA

    def __init__(self, track: Track | None = None, pose: Pose | None = None, realtime: bool = False,
                 speedup: float = 1.0, gui: bool = False, firmware: CarConfig | None = None,
                 esc: HobbyEsc | None = None, servo: SteeringServo | None = None, world: World | None = None,
                 profile: CarProfile | str | None = None, nvm: bytes | None = None) -> None:
        """nvm: the board's EEPROM as a previous run left it (`.nvm`: its signing key and session),
        None: blank; firmware: the core's configuration; world: one car more in a world that another steps
        (roar_sim.runs.fleet), which then calls firmware(), actuate() and plant.tick(); profile:
        the car's own numbers (roar_sim.plants.car_profile: a name, a file or a CarProfile;
        default the ROAR car's)."""
        super().__init__(track, realtime, speedup)
        self.firmware_config = firmware or CarConfig()
        self.board = CarBoard(self.firmware_config, loop_us=LOOP_US, frame_us=FRAME_US, nvm=nvm)
        self.profile = profile = self.profile_of(profile)
        own_esc, own_servo = actuators(profile)
        self.esc, self.servo = esc or own_esc, servo or own_servo
        self._delay = PulseDelay(profile.latency_s)  # from a frame's pulses to the ESC and servo
        self.plant = Racecar(track, dt_s=PHYSICS_US / 1e6, gui=gui, world=world, pose=pose, profile=profile)
        self.calibration = Calibration()
        self._frames = self.board.frames
        self._replies = ReplyLines()
        self._esc_out = self.esc.pulse(self.board.wire[0])
        self.board.begin()

    # --- what the host sees ------------------------------------------------------------------

    def drive(self, throttle: float, steering: float) -> None:
        self.write(self.calibration.message(throttle, steering))

    def write(self, data: bytes) -> None:
        """Bytes arriving on the car's serial port now."""
        self.board.serial_in(data)

    def read(self) -> list[str]:
        return self._replies.take()

    @property
    def nvm(self) -> bytes:
        """The board's EEPROM now (signing key and session)."""
        return self.board.nvm

    def rc_transmitter(self, pulses: tuple[int, int] | None) -> None:
        """(throttle, steering) pulses from an RC receiver from now on at 50 Hz; None = switched off."""
        self.board.rc(pulses)

    @property
    def outputs(self) -> CarOutputs:
        """What the firmware decided in its latest loop iteration."""
        return self.board.outputs

    def state(self) -> CarState:
        return self.plant.state()

    @property
    def throttle_out_us(self) -> int:
        """[us] the throttle pulse on the wire now."""
        return self.board.wire[0]

    def vehicle_state(self) -> VehicleState:
        s = self.state()
        return VehicleState(self.time_s, s.x, s.y, s.yaw, s.speed, s.yaw_rate, s.encoder_counts,
                            float(self.throttle_out_us))

    def info(self) -> dict:
        return {"throttle_us": self.throttle_out_us}

    @property
    def esc_mode(self) -> EscMode:
        return self.esc.mode

    def braking(self) -> bool:
        return self.esc.mode in (EscMode.BRAKE, EscMode.REVERSE)

    def agent(self, line, margin: float = 0.9, lateral: str = "pursuit", k_dd_s: float | None = None) -> Agent:
        pursuit = None if k_dd_s is None else PurePursuit(self.model.wheelbase_m, k_dd_s=k_dd_s)
        return race_agent(line, self.model, CONTROL_PERIOD_S, margin=margin, lateral=lateral, pursuit=pursuit)

    # --- time --------------------------------------------------------------------------------

    def _advance(self, end_us: int) -> None:
        """Run the firmware up to the next physics step or end_us, whichever comes first; a
        physics period's step follows the loop iteration at its start (where frames start)."""
        t = self.t_us
        self.firmware(loops_until(t, end_us))
        if t % PHYSICS_US == 0:
            self.actuate()
            self.plant.step()

    def firmware(self, loops: int) -> None:
        """`loops` iterations of the board loop; the ESC and servo take a frame that started."""
        self.board.run(loops)
        self.t_us += loops * LOOP_US
        if self.board.frames != self._frames:  # an output frame started: the ESC and servo take it
            self._frames = self.board.frames
            self._delay.put(self.t_us, *self.board.wire)
        for throttle_us, steering_us in self._delay.due(self.t_us):  # (after the profile's latency)
            self._esc_out = self.esc.pulse(throttle_us)
            self.servo.pulse(steering_us)
        self._replies.add(self.board.serial_out())

    def actuate(self) -> None:
        """The ESC's and servo's outputs onto the car, for the physics step to come."""
        esc = self._esc_out
        self.plant.apply(esc.drive, esc.brake, self.servo.advance(PHYSICS_US / 1e6))

    # --- its limits --------------------------------------------------------------------------

    @classmethod
    def measure_limits(cls, profile: CarProfile | None = None) -> CarLimits:
        """Top speed and acceleration at full throttle, braking by reversing the motor (the ESC
        has no brake of its own beyond the first tap) at the strongest reverse that stops it in a
        straight line (REVERSE_TRIES: a fast car's rear wheels reversed at full power lose their
        grip and it spins), and the steady lateral acceleration it holds on circles at fixed
        steering, faster and faster until the tyres slide."""
        def hold(car: EscCar, throttle_us: int, steering_us: int, seconds: float) -> list:
            return car.log_driving(lambda: car.write(encode(throttle_us, steering_us)), seconds)

        for reverse in REVERSE_TRIES:  # the strongest reverse that stops it in a straight line
            with cls(profile=profile) as car:
                hold(car, N, N, 0.2)
                run = hold(car, spec.CONTROL_MAX_US, N, 4.0)
                top = max(s.speed for _, s in run)
                stop = []
                while len(stop) * CONTROL_PERIOD_S < STOP_WITHIN_S and (not stop or stop[-1][1].speed > 0.1 * top):
                    stop += hold(car, round(N - reverse * (N - spec.CONTROL_MIN_US)), N, 1.0)  # till it stops
            braking = [s for _, s in stop][:next((k for k, (_, s) in enumerate(stop) if s.speed <= 0.1 * top), None)]
            turned = max(abs(math.remainder(s.yaw - run[-1][1].yaw, math.tau)) for s in braking or [run[-1][1]])
            if turned <= math.radians(STRAIGHT_DEG):
                break
        top, accel, brake = straight_line(run, stop)
        def drive_circle(car: EscCar, throttle_us: int, steering_us: int) -> list:
            hold(car, N, N, 0.2)
            return hold(car, throttle_us, steering_us, 5.0)[-100:]  # the last 2 s

        lateral, fade = grip_on_circles(lambda: cls(profile=profile), CIRCLE_STEERINGS_US, range(1700, 2001, 50),
                                        drive_circle)
        return CarLimits(round(top, 2), round(accel, 2), round(brake, 2), round(lateral, 2), reverse, fade)


ROBOT = EscCar
