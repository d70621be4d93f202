"""N ESC cars stepped together, each alone on one of a pool of tracks: the firmware core's board
loop at 1 kHz for every car (roar_sim.batch.boards, in C), then each car's ESC and servo behind its
latency and its single-track body (roar_sim.batch.kernels, compiled), in the PyBullet car's 5 ms
physics steps.

    world = BatchWorld(1024, tracks=["oval", "random:3"])
    world.track_of[:] = np.arange(1024) % 2           # which of the pool's tracks each car drives
    world.reset(np.arange(1024), poses)               # at poses [1024, 3], at rest, its board rebooted
    world.step(throttle_us, steering_us)              # one control period (20 ms) for every car
    world.scan(beams=72); world.states()              # lidar ranges; each car's pose, speed, yaw rate
    world.s, world.cte, world.touching                # where each car is on its track, at a wall

Cars never meet: each drives its own copy of its track. A car that touches a wall stops there.
"""

from __future__ import annotations

import math

import numpy as np

from roar.protocol import spec
from roar_sim.batch import kernels as k
from roar_sim.batch.boards import Boards
from roar_sim.batch.model import Physics, parameters, physics_for
from roar_sim.batch.track_pool import TrackPool
from roar_sim.core.lockstep import CONTROL_PERIOD_S, LOOP_US, PHYSICS_US
from roar_sim.plants import car_profile
from roar_sim.plants.car_profile import CarProfile
from roar_sim.sensors import lidar

PERIOD_LOOPS = round(CONTROL_PERIOD_S * 1e6 / LOOP_US)  # board loops a control period
PHYSICS_LOOPS = PHYSICS_US // LOOP_US  # board loops a physics step
SLIDE_M_S = 3.0  # [m/s] sideways besides the speed along the car, for progress's search window


class BatchWorld:
    def __init__(self, n: int, tracks="oval", profile: CarProfile | None = None, physics: Physics | None = None,
                 pool: TrackPool | None = None) -> None:
        """n cars (Boards' range); tracks: a TrackPool's tracks (or `pool`, one already built);
        profile and physics: every car's numbers until set_car() gives one its own. tracks=None:
        an open floor (no walls, no progress)."""
        self.boards = Boards(n)
        self.n = n
        self.pool = pool or (None if tracks is None else TrackPool(tracks))
        self.profile = profile or car_profile.load()
        self.physics = physics or physics_for(self.profile)
        self.params = np.tile(parameters(self.profile, self.physics), (n, 1))
        self.track_of = np.full(n, 0 if self.pool else -1, dtype=np.int64)  # the pool's track each car drives
        self.body = np.zeros((n, k.BODY))
        self.act = np.zeros((n, k.ACT))
        self.esc = np.zeros((n, 3), dtype=np.int8)
        self.ring = np.zeros((n, k.RING, 3), dtype=np.int32)
        self.ring_at = np.zeros((n, 2), dtype=np.int32)
        self.t_us = np.zeros(n, dtype=np.int64)  # [us] each car's time since its reset
        self.touching = np.zeros(n, dtype=bool)
        self.hint = np.zeros(n, dtype=np.int64)  # each car's centre-line segment
        self.s = np.zeros(n)  # [m] along its centre line
        self.cte = np.zeros(n)  # [m] across it, left +
        self.heading = np.zeros(n)  # [rad] of its segment
        self._neutral = np.full(n, spec.CONTROL_NEUTRAL_US, dtype=np.uint16)
        self._arming = np.zeros(n, dtype=bool)  # reset since their last step: armed by the next

    @property
    def bytes_per_car(self) -> int:
        """[bytes] a car's own state: its board and HAL, its plant's arrays and numbers."""
        own = (self.params, self.body, self.act, self.esc, self.ring, self.ring_at, self.t_us, self.touching,
               self.hint, self.s, self.cte, self.heading, self.track_of)
        return self.boards.bytes_per_board + sum(a.nbytes for a in own) // self.n

    def set_car(self, i: int, profile: CarProfile, physics: Physics | None = None) -> None:
        """Car i's own numbers from now on (its next reset puts it back at the start)."""
        self.params[i] = parameters(profile, physics or self.physics)

    def reset(self, cars, poses: np.ndarray) -> None:
        """Those cars placed at poses ([len(cars), 3]: the base's x, y [m] and yaw [rad]) on their
        tracks (track_of), at rest, their boards rebooted; their next step() is their arming:
        neutral, whatever it is given."""
        cars = np.atleast_1d(np.asarray(cars, dtype=np.int64))
        poses = np.asarray(poses, dtype=np.float64).reshape(len(cars), 3)
        self.boards.reboot(cars)
        ahead = self.params[cars, k.P_BASE]  # [m] the centre of mass ahead of the base
        self.body[cars] = 0.0
        self.body[cars, k.X] = poses[:, 0] + ahead * np.cos(poses[:, 2])
        self.body[cars, k.Y] = poses[:, 1] + ahead * np.sin(poses[:, 2])
        self.body[cars, k.YAW] = poses[:, 2]
        self.act[cars] = 0.0
        self.esc[cars] = 0
        self.ring[cars] = 0
        self.ring_at[cars] = 0
        self.t_us[cars] = 0
        self.touching[cars] = False
        self._arming[cars] = True
        if self.pool:
            for i, (x, y, yaw) in zip(cars.tolist(), poses.tolist()):  # the start's segment, over the whole line once
                self.hint[i] = self.pool.tracks[self.track_of[i]].locate((x, y), yaw)
            self._project()

    def place_bodies(self, rows: np.ndarray) -> None:
        """Every car's body put where rows say ([n, 6]: the base's x, y [m], yaw [rad], its velocity
        along and across the car [m/s], the yaw rate [rad/s]: the PyBullet car's), its actuators as
        they were."""
        rows = np.asarray(rows, dtype=np.float64)
        ahead = self.params[:, k.P_BASE]
        c, s = np.cos(rows[:, 2]), np.sin(rows[:, 2])
        self.body[:, k.X], self.body[:, k.Y], self.body[:, k.YAW] = rows[:, 0] + ahead * c, rows[:, 1] + ahead * s, \
            rows[:, 2]
        self.body[:, k.VX], self.body[:, k.VY] = rows[:, 3], rows[:, 4] + rows[:, 5] * ahead
        self.body[:, k.R], self.body[:, k.AX] = rows[:, 5], 0.0

    def step(self, throttle_us: np.ndarray, steering_us: np.ndarray, cars: np.ndarray | None = None) -> None:
        """One control period: each car's pulses as a control message (throttle 0: none), its board's
        loops, its ESC, servo and body; touching, s, cte and heading updated. A car reset since its
        last step is armed instead: neutral, whatever it is given. cars: a bool mask of the cars to
        step (None: all); the others stand still in time."""
        throttle = np.asarray(throttle_us, dtype=np.uint16)
        steering = np.asarray(steering_us, dtype=np.uint16)
        mask = np.ones(self.n, dtype=bool) if cars is None else np.asarray(cars, dtype=bool)
        arming = self._arming & mask
        if arming.any():
            throttle, steering = throttle.copy(), steering.copy()
            throttle[arming] = steering[arming] = self._neutral[arming]
            self._arming &= ~mask
        wire = self.boards.run(throttle, steering, PERIOD_LOOPS, None if cars is None else mask)
        k.advance(wire, PHYSICS_LOOPS, LOOP_US, self.t_us, self.body, self.act, self.esc, self.ring, self.ring_at,
                  self.params, self.track_of, *self._walls(), mask, self.touching)
        if self.pool:
            self._project()

    def _walls(self):
        """The kernels' wall arguments: the pool's distance fields (an empty one on an open floor)."""
        p = self.pool
        if p is None:
            return np.zeros(1, np.float32), np.zeros((1, 6))
        return p.field, p.meta

    def _project(self) -> None:
        p = self.pool
        speed = np.abs(self.body[:, k.VX]) + SLIDE_M_S
        window = int(math.ceil(float(speed.max()) * CONTROL_PERIOD_S / p.shortest_segment_m)) + 1
        k.project(self.base_xy(), self.hint, p.line, p.arc, p.seg_len, p.line_at, self.track_of, window, self.s,
                  self.cte, self.heading)

    def base_xy(self) -> np.ndarray:
        """[n, 2] [m] each car's base origin (where the PyBullet car's state is)."""
        c, s = np.cos(self.body[:, k.YAW]), np.sin(self.body[:, k.YAW])
        ahead = self.params[:, k.P_BASE]
        return np.column_stack([self.body[:, k.X] - ahead * c, self.body[:, k.Y] - ahead * s])

    def states(self) -> np.ndarray:
        """[n, 5]: each car's base x, y [m], yaw [rad], speed along it [m/s], yaw rate [rad/s] (the
        PyBullet car's CarState)."""
        return np.column_stack([self.base_xy(), self.body[:, k.YAW], self.body[:, k.VX], self.body[:, k.R]])

    def scan(self, beams: int = 72, range_m: float = 10.0, turn: np.ndarray | None = None,
             out: np.ndarray | None = None, cars: np.ndarray | None = None) -> np.ndarray:
        """[n, beams] [m] each car's lidar over 270 degrees, right to left (the PyBullet car's beams);
        turn: each car's mount turned [rad]; cars: a bool mask of the cars to scan (the others'
        rows of `out` are left as they were)."""
        angles = np.linspace(-lidar.FOV_RAD / 2, lidar.FOV_RAD / 2, beams)
        out = np.full((self.n, beams), range_m) if out is None else out
        turn = np.zeros(self.n) if turn is None else turn
        mask = np.ones(self.n, dtype=bool) if cars is None else cars
        k.scan(self.body, self.params, self.track_of, *self._walls(), angles, turn, range_m, lidar.MIN_RANGE_M, mask,
               out)
        return out
