"""Several ESC cars racing in one world, for multi-agent learning: a PettingZoo ParallelEnv.

    from roar_sim.gym_env.multi import parallel_env
    env = parallel_env(track="random:3,width=2.2", cars=3)
    observations, infos = env.reset(seed=1)
    while env.agents:
        actions = {agent: policy(observations[agent]) for agent in env.agents}
        observations, rewards, terminations, truncations, infos = env.step(actions)

Every car is a roar/Race-v0 car (roar_sim.gym_env): its own firmware board loop at 1 kHz, ESC,
servo and link, all in one PyBullet world (roar_sim.runs.fleet), so the cars collide and each
one's lidar meets the others. They start on a race's staggered grid (roar_sim.runs.head_to_head:
2 m apart, alternately left and right of the centre line), car_0 in front.

    agents       car_0 .. car_{N-1}; a car leaves env.agents when it is terminated or truncated
                 and then stands at neutral where it stopped, an obstacle to the others
    action       per car [throttle, steering], each -1..1 (+ steering = right), as Race-v0's;
                 a NaN, a missing car or a car that is not racing: one ValueError
    observation  per car {"state": Race-v0's 8 numbers, "lidar": ranges [m] over 270 deg, right to
                 left, meeting the walls and the other cars (a scan every 2nd step; lidar_beams=0
                 leaves it out)}
    reward       per car: metres of progress along the centre line, minus contact_penalty a step
                 at a wall and car_contact_penalty a step touching another car
    terminated   a car touching a wall (crash_ends=True) or off the track
    truncated    every car after max_seconds of simulated time
    info         per car: time_s, progress_m (along the centre line), raced_m (from its grid slot),
                 position (1: leading by distance raced), wall_contact, car_contact (the cars it
                 touches), throttle_us

reset(seed=...) builds a fresh world: the same seed and actions give the same observations bit
for bit; the seed moves each car's start by up to 0.1 m along the track and 0.05 rad of heading.
"""

from __future__ import annotations

import functools
import math

import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from pettingzoo import ParallelEnv

from roar.checks import shown
from roar.tracks import Track, get
from roar.tracks.names import FORMS
from roar_sim.core.lockstep import CONTROL_PERIOD_S as PERIOD_S
from roar_sim.gym_env import (LIDAR_BEAMS, LIDAR_EVERY, LIDAR_RANGE_M, MAX_CONTACT_PENALTY, MAX_LIDAR_BEAMS,
                              MAX_SECONDS_S, START_HEADING_RAD, START_OFFSET_M, Place, action_values, chase_view,
                              number_check, state_bounds)
from roar_sim.robots.esc import EscCar
from roar_sim.runs.fleet import MAX_CARS, Fleet
from roar_sim.runs.head_to_head import check_race_track, grid


def _problems(track, cars, max_seconds, contact_penalty, car_contact_penalty, crash_ends, lidar_beams,
              render_mode, render_modes) -> list[str]:
    problems = []
    check = number_check(problems)

    if not isinstance(track, (str, Track)):
        problems.append(f"track must be a Track or a track's name ({FORMS}), got {shown(track)}")
    if not isinstance(cars, int) or isinstance(cars, bool) or not 1 <= cars <= MAX_CARS:
        problems.append(f"cars must be a whole number 1..{MAX_CARS}, got {shown(cars)}")
    check("max_seconds", max_seconds, 0, MAX_SECONDS_S, "s", low_open=True)
    check("contact_penalty", contact_penalty, 0, MAX_CONTACT_PENALTY)
    check("car_contact_penalty", car_contact_penalty, 0, MAX_CONTACT_PENALTY)
    if not isinstance(crash_ends, bool):
        problems.append(f"crash_ends must be True or False, got {shown(crash_ends)}")
    if not isinstance(lidar_beams, int) or isinstance(lidar_beams, bool):
        problems.append(f"lidar_beams must be a whole number 0..{MAX_LIDAR_BEAMS}, got {shown(lidar_beams)}")
    else:
        check("lidar_beams", lidar_beams, 0, MAX_LIDAR_BEAMS)
    if render_mode is not None and render_mode not in render_modes:
        problems.append(f"render_mode must be one of {render_modes} or None, got {shown(render_mode)}")
    return problems


class RaceParallelEnv(ParallelEnv):
    metadata = {"name": "roar_race_v0", "render_modes": ["rgb_array"], "render_fps": round(1 / PERIOD_S)}

    def __init__(self, track: str | Track = "oval", cars: int = 2, max_seconds: float = 60.0,
                 contact_penalty: float = 1.0, car_contact_penalty: float = 1.0, crash_ends: bool = True,
                 lidar_beams: int = LIDAR_BEAMS, render_mode: str | None = None) -> None:
        """Every keyword is checked before anything is built (the grid too: it must fit the
        track); what is wrong, all of it, in one ValueError."""
        problems = _problems(track, cars, max_seconds, contact_penalty, car_contact_penalty, crash_ends,
                             lidar_beams, render_mode, self.metadata["render_modes"])
        if problems:
            raise ValueError("RaceParallelEnv: " + "; ".join(problems))
        self.track = track if isinstance(track, Track) else get(track)
        try:
            check_race_track(self.track)
            EscCar.check_track(self.track)
            self._grid = grid(self.track, cars, EscCar.half_width_m)  # car_0 in front
        except ValueError as e:  # TrackError is one
            raise ValueError(f"RaceParallelEnv: {e}") from None
        self.max_seconds, self.contact_penalty, self.car_contact_penalty = max_seconds, contact_penalty, \
            car_contact_penalty
        self.crash_ends, self.lidar_beams, self.render_mode = crash_ends, lidar_beams, render_mode
        self.possible_agents = [f"car_{i}" for i in range(cars)]
        self.agents: list[str] = []
        high = state_bounds()
        observation = {"state": spaces.Box(-high, high, (8,), np.float32)}
        if lidar_beams:
            observation["lidar"] = spaces.Box(0.0, LIDAR_RANGE_M, (lidar_beams,), np.float32)
        self._observation_space = spaces.Dict(observation)
        self._action_space = spaces.Box(-1.0, 1.0, (2,), np.float32)  # throttle, steering (+ = right)
        self.fleet: Fleet | None = None
        self._places: list[Place] = []
        self._scans: list[np.ndarray | None] = []
        self._raced: list[float] = []
        self._steps = 0
        self.np_random, _ = seeding.np_random(None)

    @functools.lru_cache(maxsize=None)
    def observation_space(self, agent: str) -> spaces.Space:
        return self._observation_space

    @functools.lru_cache(maxsize=None)
    def action_space(self, agent: str) -> spaces.Space:
        return self._action_space

    # --- pettingzoo --------------------------------------------------------------------------

    def reset(self, seed: int | None = None, options: dict | None = None):
        if seed is not None:
            self.np_random, _ = seeding.np_random(seed)
        self.close()
        poses = []
        for x, y, yaw in self._grid:
            along = float(self.np_random.uniform(-START_OFFSET_M, START_OFFSET_M))
            yaw += float(self.np_random.uniform(-START_HEADING_RAD, START_HEADING_RAD))
            poses.append((x + along * math.cos(yaw), y + along * math.sin(yaw), yaw))
        self.fleet = Fleet(self.track, poses=poses)
        for car in self.fleet.cars:
            car.drive(0.0, 0.0)  # the ESC boots latched until it hears neutral
        self.fleet.run(PERIOD_S)
        states = [car.state() for car in self.fleet.cars]
        self._places = [Place(self.track, s) for s in states]
        first = self._places[0].s
        self._raced = [self.track.arc_delta(first, p.s) for p in self._places]  # [m] behind car_0: negative
        self._scans = [None] * len(states)
        self._steps = 0
        self.agents = list(self.possible_agents)
        observations = self._observations(states)
        return observations, {a: self._info(i, False, []) for i, a in enumerate(self.possible_agents)}

    def step(self, actions: dict):
        if self.fleet is None:
            raise RuntimeError("call reset() before step()")
        if not isinstance(actions, dict):
            raise ValueError(f"actions are a dict of each racing car's (throttle, steering), got {shown(actions)}")
        unknown = sorted(set(actions) - set(self.agents), key=str)
        missing = [a for a in self.agents if a not in actions]
        if unknown or missing:
            raise ValueError("actions must name every racing car once: "
                             + "; ".join([f"{', '.join(map(str, unknown))} not racing"] * bool(unknown)
                                         + [f"none for {', '.join(missing)}"] * bool(missing))
                             + f" (racing: {', '.join(self.agents)})")
        commands = {}
        for agent, action in actions.items():
            try:
                commands[agent] = action_values(action)
            except ValueError as e:
                raise ValueError(f"{agent}: {e}") from None
        cars = self.fleet.cars
        for i, agent in enumerate(self.possible_agents):
            cars[i].drive(*commands.get(agent, (0.0, 0.0)))  # a car out of the race stands at neutral
        self.fleet.run(PERIOD_S)
        states = [car.state() for car in cars]
        pairs = self.fleet.touching_pairs()
        touching = [sorted(b if a == i else a for a, b in pairs if i in (a, b)) for i in range(len(cars))]
        observations = self._observations(states)
        time_up = self.fleet.time_s >= self.max_seconds
        rewards, terminations, truncations, infos = {}, {}, {}, {}
        for i, agent in enumerate(self.possible_agents):
            progress = self._places[i].advance(states[i])
            self._raced[i] += progress
            if agent not in self.agents:
                continue
            wall = cars[i].touching_wall()
            rewards[agent] = float(progress - self.contact_penalty * wall
                                   - self.car_contact_penalty * bool(touching[i]))
            terminations[agent] = bool(self._places[i].off_track() or (wall and self.crash_ends))
            truncations[agent] = bool(time_up)
            infos[agent] = self._info(i, wall, touching[i])
        self.agents = [a for a in self.agents if not (terminations[a] or truncations[a])]
        return observations, rewards, terminations, truncations, infos

    def render(self):
        """A chase view behind car_0 (rgb_array)."""
        if self.render_mode != "rgb_array" or self.fleet is None:
            return None
        return chase_view(self.fleet.world, self.fleet.cars[0].state(), 2.0, 1.5, 70.0, far_m=30.0)

    def state(self) -> np.ndarray:
        """Every car's state observation, car_0 first, in one array."""
        if self.fleet is None:
            raise RuntimeError("call reset() before state()")
        return np.concatenate([p.observation(car.state()) for p, car in zip(self._places, self.fleet.cars)])

    def close(self) -> None:
        if self.fleet is not None:
            self.fleet.close()
            self.fleet = None

    # --- helpers -----------------------------------------------------------------------------

    def _observations(self, states) -> dict:
        cars = self.fleet.cars
        scan = self.lidar_beams and self._steps % LIDAR_EVERY == 0
        self._steps += 1
        observations = {}
        for i, agent in enumerate(self.possible_agents):
            if agent not in self.agents:
                continue
            observation = {"state": self._places[i].observation(states[i])}
            if self.lidar_beams:
                if scan:
                    others = [car.plant.footprint() for j, car in enumerate(cars) if j != i]
                    ranges = cars[i].plant.lidar(beams=self.lidar_beams, range_m=LIDAR_RANGE_M, boxes=others)
                    self._scans[i] = np.clip(ranges, 0.0, LIDAR_RANGE_M).astype(np.float32)
                observation["lidar"] = self._scans[i].copy()
            observations[agent] = observation
        return observations

    def _info(self, i: int, wall: bool, touching: list[int]) -> dict:
        ahead = sum(1 for r in self._raced if r > self._raced[i])
        return {"time_s": self.fleet.time_s, "progress_m": self._places[i].s, "raced_m": self._raced[i],
                "position": ahead + 1, "wall_contact": bool(wall),
                "car_contact": [self.possible_agents[j] for j in touching], **self.fleet.cars[i].info()}


parallel_env = RaceParallelEnv  # PettingZoo's convention: module.parallel_env(**kwargs)
