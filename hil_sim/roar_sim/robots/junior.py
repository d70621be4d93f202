"""The ROAR Junior: its own loop (JuniorBoard of the firmware core: its HTTP request reader and
responses, JuniorControl, the L298N driver with its dead time, the failsafe) drives the PyBullet
robot of roar_sim.plants.junior. Commands reach it as the http:// transport sends them: throttle
and steering mixed into wheel duties (roar.junior), one GET of its control route each, read by
the firmware's own HTTP reader on a kept-open connection; the reply is the ultrasonic distance.

    firmware loop   1 kHz   JuniorBoard::poll on the board's 32-bit microsecond counter
    ultrasonic      every 60 ms, as the firmware pings
    physics         200 Hz  the pins at each step set the motors' currents

Lockstep by default (time moves only in run()); with realtime=True run() keeps pace with the
wall clock. Connections may be used from other threads while run() goes on (`roar sim --robot
junior --http` serves each on its own): board access is serialised by one lock.

    python -m roar_sim.runs.limits junior     # re-measure its limits
"""

from __future__ import annotations

import math
import statistics
import threading
import time

from roar.autopilot import Agent, CarLimits, DiffDriveModel, diff_drive_agent
from roar.autopilot.limits import HOLDS_LINE, circle, straight_line
from roar.junior import MIXES, query_for
from roar.protocol import spec
from roar.telemetry import VehicleState
from roar.transports.base import unit_command
from roar_sim.core.lockstep import LOOP_US, PHYSICS_US, loops_until
from roar_sim.core.junior import HttpRequestReader, JuniorBoard, SidePins
from roar_sim.core.library import HttpRead
from roar_sim.plants import junior_profile
from roar_sim.plants.junior import WHEEL_TRACK_M, JuniorPlant, JuniorState
from roar_sim.plants.junior_profile import JuniorProfile
from roar_sim.robots import Pose, ProfileLimits, ProfileModel, Robot
from roar_sim.sensors.ultrasonic import MAX_RANGE_M
from roar.tracks.track import Track
from roar.vision.geometry import CameraPreset
from roar_sim.plants import junior as junior_plant

PING_US = 60_000  # [us] between ultrasonic readings (the firmware's ping period)
# The default profile's (junior) limits as measured from it; `roar limits junior` and the suite
# measure them again. Any other profile's are measured on first use and kept in the user's cache.
LIMITS = CarLimits(max_speed_m_s=0.55, max_accel_m_s2=3.11, max_brake_m_s2=1.36, max_lateral_m_s2=0.89)
MODEL = DiffDriveModel(track_width_m=WHEEL_TRACK_M, limits=LIMITS)
MIXING = "smooth"  # the autopilot's diff-drive controller sends what smooth mixing turns into its wheel speeds


def request(query: str, keep_alive: bool = True) -> bytes:
    """The bytes of a GET of the control route with `query`, as an HTTP/1.1 client sends them."""
    close = "" if keep_alive else "Connection: close\r\n"
    return f"GET /?{query} HTTP/1.1\r\nHost: junior\r\n{close}\r\n".encode()


def reply_parts(reply: bytes) -> tuple[int, str]:
    """(status, body) of one of the firmware's responses."""
    head, _, body = reply.partition(b"\r\n\r\n")
    return int(head.split()[1]), body.decode("ascii", "replace")


class Connection:
    """One HTTP connection to the simulated Junior, as the robot's server keeps it."""

    def __init__(self, junior: Junior) -> None:
        self.junior, self.reader, self.open = junior, HttpRequestReader(), True

    def feed(self, data: bytes) -> list[bytes]:
        """Bytes from the client -> the responses to every request they completed. After a
        response that closes the connection, `open` is False and the rest is dropped."""
        replies = []
        data = bytes(data)
        while data and self.open:
            used, state = self.reader.feed(data)
            data = data[used:]
            if state == HttpRead.INCOMPLETE:
                break
            reply, keep_open = self.junior.respond(self.reader)
            replies.append(reply)
            if keep_open:
                self.reader.reset()
            else:
                self.open = False
        return replies


class Junior(Robot):
    name = "junior"
    title = "ROAR Junior"
    half_width_m = 0.09  # [m] half its width: the wheels' outer faces
    camera = CameraPreset(fov_deg=junior_plant.CAMERA_FOV_DEG, x_m=junior_plant.CAMERA_POS_M[0],
                          z_m=junior_plant.CAMERA_POS_M[2], pitch_rad=junior_plant.CAMERA_PITCH_RAD)
    limits = ProfileLimits(LIMITS)  # the default profile's; a robot's own profile's, measured when first asked for
    model = ProfileModel(MODEL)
    profiles = junior_profile
    default_profile = junior_profile.DEFAULT
    links = ("http",)
    ultrasonic_max_m = MAX_RANGE_M

    def __init__(self, track: Track | None = None, pose: Pose | None = None, realtime: bool = False,
                 speedup: float = 1.0, gui: bool = False, mixing: str = MIXING, nvm: bytes | None = None,
                 profile: JuniorProfile | str | None = None) -> None:
        """mixing: how drive() turns throttle and steering into wheel duties (roar.junior.MIXES);
        nvm: the board's flash as a previous run left it (`.nvm`: its signing key and session);
        profile: its motors (roar_sim.plants.junior_profile: a name, a file or a JuniorProfile)."""
        super().__init__(track, realtime, speedup)
        self.profile = self.profile_of(profile)
        self.board = JuniorBoard(loop_us=LOOP_US, nvm=nvm)
        self.plant = JuniorPlant(track, PHYSICS_US / 1e6, gui, pose, self.profile)
        self.mix = MIXES[mixing]
        # When a list: (simulated t [us], wall clock [s], left, right) each time the firmware's
        # outputs change, as seen after each run of loop iterations (at most one physics period)
        self.pin_log: list[tuple[int, float, SidePins, SidePins]] | None = None
        self._lock = threading.Lock()
        self._next_ping_us = 0
        self.pose = self.plant.pose()  # (position, quaternion) after the latest physics step, for other threads
        self._host: Connection | None = None  # drive()'s kept-open connection
        self.range_m = math.inf  # [m] the distance in the latest reply to drive(); inf: no echo

    # --- what a client sees ----------------------------------------------------------------------

    def connect(self) -> Connection:
        return Connection(self)

    def respond(self, reader: HttpRequestReader) -> tuple[bytes, bool]:
        with self._lock:
            return self.board.respond(reader)

    def get(self, query: str) -> tuple[int, str]:
        """One request on a fresh connection, as the original client makes each: (status, body)."""
        return reply_parts(self.connect().feed(request(query, keep_alive=False))[0])

    def drive(self, throttle: float, steering: float) -> None:
        if self._host is None or not self._host.open:
            self._host = self.connect()
        status, body = reply_parts(self._host.feed(request(query_for(*self.mix(throttle, steering))))[0])
        cm = float(body) if status == 200 else 0.0
        self.range_m = cm / 100 if cm > 0 else math.inf

    def write(self, data: bytes) -> None:
        """A control message on the link, as the http:// transport takes it: one GET. A KEY line
        goes to the board's USB serial port instead (where a key is set: `roar key set`)."""
        if data.lstrip().startswith(spec.SIGNED_KEY_COMMAND.encode()):
            with self._lock:
                self.board.serial_in(data)
            return
        self.drive(*unit_command(data, "sim"))

    def read(self) -> list[str]:
        """Lines the board wrote on its USB serial port (answers to KEY lines, SESSION)."""
        with self._lock:
            return self.board.serial_out().decode("ascii", "replace").splitlines()

    @property
    def nvm(self) -> bytes:
        """The board's flash now (signing key and session)."""
        return self.board.nvm

    def state(self) -> JuniorState:
        return self.plant.state()

    def vehicle_state(self) -> VehicleState:
        s = self.state()
        return VehicleState(self.time_s, s.x, s.y, s.yaw, s.speed, s.yaw_rate, range_m=self.range_m)

    def info(self) -> dict:
        left, right = self.pins
        return {"duty_permille": (left.duty, right.duty)}

    @property
    def pins(self) -> tuple[SidePins, SidePins]:
        return self.board.pins

    def agent(self, line, margin: float = 0.9, lateral: str = "pursuit", k_dd_s: float | None = None) -> Agent:
        if lateral not in self.laterals:
            raise ValueError("the Junior steers by pure pursuit only (its wheels set the curvature)")
        return diff_drive_agent(line, self.model, margin, **({} if k_dd_s is None else {"k_dd_s": k_dd_s}))

    # --- time --------------------------------------------------------------------------------

    def _advance(self, end_us: int) -> None:
        """The firmware up to the next physics step or end_us; a physics period's step follows the
        loop iterations that start it, with the pins they left."""
        t = self.t_us
        loops = loops_until(t, end_us)
        if t >= self._next_ping_us:
            self.board.distance_cm = self.plant.ultrasonic_cm()
            self._next_ping_us += PING_US
        with self._lock:
            self.board.run(loops)
            left, right = self.board.pins
        self.t_us = t + loops * LOOP_US
        log = self.pin_log
        if log is not None and (not log or log[-1][2:] != (left, right)):
            log.append((self.t_us, time.perf_counter(), left, right))
        if t % PHYSICS_US == 0:
            self.plant.apply(left, right)
            self.plant.step()
            self.pose = self.plant.pose()

    # --- its limits --------------------------------------------------------------------------

    @classmethod
    def model_for(cls, profile: JuniorProfile, limits: CarLimits) -> DiffDriveModel:
        return DiffDriveModel(track_width_m=WHEEL_TRACK_M, limits=limits)

    @classmethod
    def min_turn_radius_m(cls, profile=None) -> float:
        return MODEL.min_turn_radius_m  # it turns on the spot, whatever its motors

    @classmethod
    def unmeasurable_hint(cls, profile: JuniorProfile) -> str:
        return (f" (a side whose dead band is near full duty barely turns: left "
                f"{profile.left_deadband_permille:g}, right {profile.right_deadband_permille:g} permille)")

    @classmethod
    def measure_limits(cls, profile: JuniorProfile | None = None) -> CarLimits:
        """Top speed and acceleration at full duty, how fast it slows when the duty drops to 0 (it
        coasts: the L298N's EN low, the gearbox's friction), and the steady lateral acceleration on
        a circle: it reaches its tightest circle (one wheel near stop) before its wheels slide, so
        that figure is what it can do, not where grip ends."""
        def hold(junior: Junior, left: float, right: float, seconds: float) -> list:
            return junior.log_driving(lambda: junior.get(query_for(left, right)), seconds)

        with cls(profile=profile) as junior:
            hold(junior, 0, 0, 0.2)
            run = hold(junior, 1, 1, 2.0)
            top, accel, brake = straight_line(run, hold(junior, 0, 0, 1.5))
        lateral = 0.0
        for inner in (0.9, 0.8, 0.7, 0.6, 0.5, 0.4, 0.3, 0.2):  # tighter and tighter circles at full outer duty
            with cls(profile=profile) as junior:
                hold(junior, 0, 0, 0.2)
                steady = hold(junior, 1.0, inner, 3.0)[-50:]  # the last second
            radius, accel_lateral = circle(steady)
            # no slip: the radius the wheels' own speeds ask for (a side's motor may be the weaker)
            outer, inner_rad_s = (statistics.median(getattr(s, side) for _, s in steady)
                                  for side in ("left_wheel_rad_s", "right_wheel_rad_s"))
            if outer <= inner_rad_s:
                continue  # its weaker outer motor turns it the other way: a tighter circle will not
            expected = (WHEEL_TRACK_M / 2) * (outer + inner_rad_s) / (outer - inner_rad_s)
            if radius > HOLDS_LINE * expected:
                break  # wider than the wheels ask for: they slide
            lateral = max(lateral, accel_lateral)
        return CarLimits(round(top, 2), round(accel, 2), round(brake, 2), round(lateral, 2))


ROBOT = Junior
