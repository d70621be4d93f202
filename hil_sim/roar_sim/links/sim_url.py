"""sim:// -- the simulated car in this process: the firmware logic (host build) driving the
PyBullet car in real time, fed with the same bytes a real car receives. A plug-in of the roar
package: registered through the "roar.transports" entry point (pyproject.toml), installed with
roar-platform[sim].

    sim://                        an open floor, no walls
    sim://oval   sim://figure-eight   a built-in track
    sim://?track=random:7         any track name: random:SEED, circuit:SEED, tunnel:SEED (roar.tracks)
    sim:///home/me/track.json     a track file: .json, a centre-line .csv, a map .yaml

Options: robot=esc|iarrc|junior (roar_sim.robots; default esc): the IARRC car takes speed
setpoints and sends telemetry, its transmitter's mode switch going to autonomous when the first
setpoint arrives; the ROAR Junior takes each control message as the http:// transport sends it
(one GET, smooth mixing) and reports its ultrasonic range. speedup=2 (simulated seconds per wall
second, up to 4), gui=1 (PyBullet window), trace=drive.csv (t, x, y, yaw, speed every 20 ms),
plot=drive.png (the driven path), eeprom=FILE (the board's memory, its signing key, kept in FILE
between runs: roar_sim.links.board_memory), profile=NAME|FILE.toml (the robot's own numbers: a racecar's,
the ESC or IARRC car's, roar_sim.plants.car_profile; the Junior's motors, roar_sim.plants.junior_profile;
as `roar race --car-profile`; its limits are measured on first use).
"""

from __future__ import annotations

import collections
import concurrent.futures
import queue
import threading
from pathlib import Path

from roar.errors import RoarError
from roar.telemetry import VehicleState
from roar.transports.base import LinkLost, Transport, TransportError, pop_number, pop_option
from roar.user_files import unwritable
from roar_sim.links import board_memory
from roar_sim.world.plotting import png_problem


def missing_simulator(error: ImportError) -> str:
    return f"the simulator needs {error.name or 'its dependencies'}: pip install 'roar-platform[sim]'"


MAX_SPEEDUP = 4.0  # the host sends at 50 Hz wall time: at 4x the car still hears from it every 80 ms
CHUNK_S = 0.002  # [s] simulated time per pump step
TRACE_PERIOD_S = 0.02  # [s]


class SimTransport(Transport):
    scheme = "sim"
    min_period_s = 0.002

    def __init__(self, track: str = "", speedup: float = 1.0, gui: bool = False,
                 trace: Path | None = None, plot: Path | None = None, robot: str = "esc",
                 eeprom: Path | None = None, profile: str | None = None) -> None:
        from roar_sim import robots

        self.track_name, self.speedup, self.gui = track, speedup, gui
        self.trace_path, self.plot_path = trace, plot
        self.kind = robots.get(robot)  # the robot's class (UnknownRobot, one line, for a name there is not)
        if eeprom is not None and not hasattr(self.kind, "nvm"):
            raise TransportError(f"eeprom= keeps a board's key between runs: the {self.kind.title} has none here")
        self.eeprom = eeprom  # the board's EEPROM (signing key, session) kept in this file between runs
        self.robot = robot
        self.profile = None if profile is None else self.kind.profile_of(profile)  # ProfileError: one line
        self.replies = self.kind.replies  # the ESC and IARRC cars answer with lines, the Junior not
        self.sim = None  # the roar_sim.robots.Robot once open
        self.trace: list[tuple[float, float, float, float, float]] = []  # (t, x, y, yaw, speed)
        self._inbox: collections.deque[bytes] = collections.deque()
        self._outbox: collections.deque[str] = collections.deque()
        self._running = threading.Event()
        self._thread: threading.Thread | None = None
        self._error: BaseException | None = None
        self._state: VehicleState | None = None  # snapshot after each pump step
        self._requests: queue.SimpleQueue = queue.SimpleQueue()  # (fn(sim), Future) run by the pump

    @classmethod
    def from_url(cls, target: str, options: dict[str, str]) -> SimTransport:
        speedup = pop_number(options, "speedup", 1.0, 0.1, MAX_SPEEDUP, "x real time")
        for name in ("trace", "plot"):
            if name in options and not options[name].strip():
                raise TransportError(f"{name}= is empty: give a file name")
        trace = pop_option(options, "trace", Path, None)
        plot = pop_option(options, "plot", Path, None)
        for name, path, check in (("trace", trace, unwritable), ("plot", plot, png_problem)):
            problem = path is not None and check(path)
            if problem:  # checked now, not when the drive is over
                raise TransportError(f"{name}: {problem}")
        if "car" in options:
            raise TransportError("option car= is robot= now: e.g. sim://?robot=iarrc")
        robot = pop_option(options, "robot", str, "esc")
        track = target if target.lower().endswith((".json", ".csv", ".yaml", ".yml")) else target.strip("/")
        named = pop_option(options, "track", str, None)
        if named is not None and not named.strip():
            raise TransportError("track= is empty: name a track (sim://?track=oval, random:SEED, circuit:SEED, tunnel:SEED, a file)")
        if named is not None and track:
            raise TransportError(f"sim://{target}?track={named}: name the track once (sim://NAME or sim://?track=NAME)")
        track = named if named is not None else track
        eeprom = pop_option(options, "eeprom", Path, None)
        if eeprom is not None and not str(eeprom).strip():
            raise TransportError("eeprom= is empty: give a file name")
        profile = pop_option(options, "profile", str, None)
        if profile is not None and not profile.strip():
            raise TransportError("profile= is empty: name a profile (roar, iarrc, f1tenth) or a .toml file")
        try:
            return cls(track, speedup, pop_option(options, "gui", bool, False), trace, plot, robot, eeprom, profile)
        except ImportError as e:
            raise TransportError(missing_simulator(e)) from None
        except RoarError as e:
            raise TransportError(str(e)) from None

    def open(self) -> None:
        from roar.tracks import get

        stored = None
        if self.eeprom is not None:
            stored = board_memory.load(self.eeprom, self.robot)
            problem = stored is None and not self.read_only and unwritable(self.eeprom)
            if problem:
                raise TransportError(f"eeprom: {problem}")
        try:
            track = get(self.track_name) if self.track_name else None
            extra = {} if self.eeprom is None else {"nvm": stored}
            if self.profile is not None:
                extra["profile"] = self.profile
            self.sim = self.kind(track, realtime=True, speedup=self.speedup, gui=self.gui, **extra)
        except RoarError as e:
            raise TransportError(str(e)) from None
        self._stored = stored
        if self.eeprom is not None:
            try:
                board_memory.check(self.eeprom, stored, self.sim.nvm)
            except TransportError:
                self.sim.close()
                self.sim = None
                raise
        self._running.set()
        self._thread = threading.Thread(target=self._pump, name="roar-sim", daemon=True)
        self._thread.start()

    def _pump(self) -> None:
        sim = self.sim
        next_trace = 0.0
        saved_nvm = self._stored  # as the file held it: the board's boot (its next session) and a new key change it
        try:
            while self._running.is_set():
                while self._inbox:
                    sim.write(self._inbox.popleft())
                sim.run(CHUNK_S)
                self._outbox.extend(sim.read())
                if self.eeprom is not None and not self.read_only and sim.nvm != saved_nvm:  # a key, a session
                    saved_nvm = sim.nvm
                    board_memory.save(self.eeprom, self.robot, saved_nvm)
                s = self._state = sim.vehicle_state()
                if sim.time_s >= next_trace:
                    self.trace.append((sim.time_s, s.x_m, s.y_m, s.yaw_rad, s.speed_m_s))
                    next_trace += TRACE_PERIOD_S
                while not self._requests.empty():  # sensors asked for by the user's thread
                    fn, future = self._requests.get()
                    try:
                        future.set_result(fn(sim))
                    except Exception as e:  # the asker gets it; the simulator runs on
                        future.set_exception(e)
        except BaseException as e:  # surfaced to the sender on its next write
            self._error = e
            self._running.clear()
        while not self._requests.empty():
            self._requests.get()[1].set_result(None)

    def state(self) -> VehicleState | None:
        return self._state

    def _ask(self, fn):
        """Run fn(sim) on the pump thread (PyBullet is not shared between threads); None if stopped."""
        if not self._running.is_set():
            return None
        future: concurrent.futures.Future = concurrent.futures.Future()
        self._requests.put((fn, future))
        try:
            return future.result(timeout=5.0)
        except concurrent.futures.TimeoutError:
            return None

    def lidar(self):
        return self._ask(lambda sim: sim.plant.lidar()) if self.sim is not None and self.sim.has_lidar else None

    def camera(self, width: int = 160, height: int = 120):
        return self._ask(lambda sim: sim.plant.camera(width, height))

    def model(self):
        """The car's model: an open car's own (another profile, other limits), else its kind's."""
        return self.sim.model if self.sim is not None else self.kind.model

    def lidar_mount(self):
        if self.sim is None or not self.sim.has_lidar:
            return None
        return self._ask(lambda sim: sim.plant.lidar_mount())

    def camera_preset(self):
        return self.kind.camera

    def track(self) -> str | None:
        return self.track_name or None

    @property
    def autopilots(self) -> tuple[str, ...]:
        """What autopilot(name) offers this robot (roar web's choice): roar_sim.links.autopilots."""
        from roar_sim.links.autopilots import available

        return available(self)

    def autopilot(self, name: str):
        """A driver of the robot's own, stepped by the host on what it reads over sim://."""
        from roar_sim.links.autopilots import SimAutopilot

        return SimAutopilot(self, name)

    def write(self, data: bytes) -> None:
        if not self._running.is_set():
            raise LinkLost(f"simulator stopped: {self._error}" if self._error else "simulator is not running")
        self._inbox.append(bytes(data))

    def read_lines(self) -> list[str]:
        lines = []
        while self._outbox:
            lines.append(self._outbox.popleft())
        return lines

    def close(self) -> None:
        self._running.clear()
        if self._thread is not None:
            self._thread.join()
            self._thread = None
        if self.sim is not None:
            sim, self.sim = self.sim, None
            try:
                self._save_with(sim)
            finally:
                sim.close()

    def _save_with(self, sim) -> None:
        """Write the trace and the plot; a one-line TransportError if either cannot be written."""
        if self.trace_path is not None:
            try:
                with open(self.trace_path, "w", encoding="ascii") as f:
                    f.write("t_s,x_m,y_m,yaw_rad,speed_m_s\n")
                    f.writelines(",".join(f"{v:.4f}" for v in row) + "\n" for row in self.trace)
            except OSError as e:
                raise TransportError(f"cannot write trace {self.trace_path}: {e.strerror or e}") from None
        if self.plot_path is not None and self.trace:
            from roar_sim.world import plotting

            problem = plotting.write(lambda: plotting.path_figure(sim.track, self.trace), self.plot_path)
            if problem:
                raise TransportError(f"plot: {problem}")
