"""The simulated ROAR Junior: the Junior's own loop (JuniorBoard of the C++ core: its HTTP
request reader and responses, JuniorControl, the L298N driver with its dead time, the failsafe)
drives the PyBullet robot of roar_sim.plants.junior. Requests are bytes, as on the robot: each
Connection feeds them to the firmware's reader and returns the firmware's response bytes.

    firmware loop   1 kHz   JuniorBoard::poll on the board's 32-bit microsecond counter
    ultrasonic      every 60 ms, as the firmware pings
    physics         200 Hz  the pins at each step set the motors' currents

Lockstep by default (time moves only in run()); with realtime=True run() keeps pace with the
wall clock. Connections may be used from other threads while run() goes on: board access is
serialised by one lock.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass

from roar_sim.core.junior import HttpRequestReader, JuniorBoard, SidePins
from roar_sim.core.library import HttpRead
from roar_sim.plants.junior import JuniorPlant, JuniorState
from roar_sim.clock.lockstep import Lockstep
from roar_sim.world.track import Track

LOOP_US = 1_000  # [us] firmware loop period
PHYSICS_US = 5_000  # [us]
PING_US = 60_000  # [us] between ultrasonic readings (the firmware's ping period)


@dataclass
class JuniorConfig:
    realtime: bool = False
    speedup: float = 1.0  # simulated seconds per wall second when realtime
    gui: bool = False
    pose: tuple[float, float, float] | None = None  # (x, y, yaw); default: the track's start


class Connection:
    """One HTTP connection to the simulated Junior, as the robot's server keeps it."""

    def __init__(self, sim: JuniorSim) -> None:
        self.sim, self.reader, self.open = sim, HttpRequestReader(), True

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
            reply, keep_open = self.sim.respond(self.reader)
            replies.append(reply)
            if keep_open:
                self.reader.reset()
            else:
                self.open = False
        return replies


class JuniorSim(Lockstep):
    def __init__(self, track: Track | None = None, config: JuniorConfig | None = None) -> None:
        self.config = config or JuniorConfig()
        self.track = track
        self.board = JuniorBoard(loop_us=LOOP_US)
        self.plant = JuniorPlant(track, PHYSICS_US / 1e6, self.config.gui, self.config.pose)
        self.t_us = 0
        # When a list: (simulated t [us], wall clock [s], left, right) each time the firmware's
        # outputs change, as seen after each run of loop iterations (at most one physics period)
        self.pin_log: list[tuple[int, float, SidePins, SidePins]] | None = None
        self._lock = threading.Lock()
        self._next_ping_us = 0
        self.pose = self.plant.pose()  # (position, quaternion) after the latest physics step, for other threads

    # --- what a client sees ----------------------------------------------------------------------

    def connect(self) -> Connection:
        return Connection(self)

    def respond(self, reader: HttpRequestReader) -> tuple[bytes, bool]:
        with self._lock:
            return self.board.respond(reader)

    def get(self, query: str) -> tuple[int, str]:
        """One request (a fresh connection, as the original client opens): (status, body)."""
        reply = self.connect().feed(f"GET /?{query} HTTP/1.1\r\nConnection: close\r\n\r\n".encode())[0]
        head, _, body = reply.partition(b"\r\n\r\n")
        return int(head.split()[1]), body.decode()

    def state(self) -> JuniorState:
        return self.plant.state()

    @property
    def pins(self) -> tuple[SidePins, SidePins]:
        return self.board.pins

    # --- time --------------------------------------------------------------------------------

    def _advance(self, end_us: int) -> None:
        """The firmware up to the next physics step or end_us; a physics period's step follows the
        loop iterations that start it, with the pins they left."""
        t = self.t_us
        loops = max(1, (min((t // PHYSICS_US + 1) * PHYSICS_US, end_us) - t) // LOOP_US)
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
