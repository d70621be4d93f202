"""roar/Race-v0's cars, a thousand at a time: the batched world (roar_sim.batch) behind Gymnasium's
vector API, with Race-v0's observation and action spaces, rewards and ends, for learning at batched
speed (docs/gym.md: when to use it, when the PyBullet world, and how closely they agree).

    envs = BatchRaceEnv(1024, track=["oval", "random:3"])       # a pool of tracks, shared out in turn
    envs = gymnasium.make_vec("roar_sim.gym_env:roar/BatchRace-v0", num_envs=1024,
                              vectorization_mode="vector_entry_point")
    env = gymnasium.make("roar_sim.gym_env:roar/BatchRace-v0")   # one car (BatchCarEnv)

Each car is the ESC car: its action goes through the library's calibration to a control message,
the firmware core's board loop (in C, for all cars in one call), its ESC and servo behind its
latency, and a single-track body identified from the PyBullet car; its lidar is marched on its
track's distance field. Car i drives track i mod K of the pool. Everything else is Race-v0's:

    action       [throttle, steering], each -1..1 (clipped); a NaN or an infinity is a ValueError
    observation  {"state": [x, y, cos yaw, sin yaw, speed, yaw rate, cross-track, heading error],
                  "lidar": ranges [m] over 270 deg, right to left, a scan every 2nd action,
                  "camera": RGB and "depth": metres, when camera=(width, height) is asked for
                           (roar_sim.batch.camera: the floor's paint and the walls)}
    reward       metres of progress along the centre line, minus contact_penalty a step at a wall
    terminated   touching a wall (crash_ends=True), or off the track;  truncated: after max_seconds

reset(seed=s) gives car i the seed s + i, as RaceVectorEnv does: the same seed and actions give the
same run bit for bit, and a car's run does not depend on the other cars (BatchCarEnv, one car, is the
same car). Autoreset is Gymnasium's next step by default (the car that ended is reset by the next
step, its action unused, reward 0); AutoresetMode.SAME_STEP resets it at once, with its last
observation in infos["final_obs"] (step_each: per car, as Stable-Baselines3 wants them). randomize=
draws each episode's car within spans (profile keys, lidar_noise_m, lidar_yaw_rad), as Race-v0's.
"""

from __future__ import annotations

import dataclasses
import math

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.vector.utils import batch_space
from gymnasium.vector.vector_env import AutoresetMode

from roar.calibration import Calibration
from roar.checks import shown
from roar.tracks import Track, TrackError
from roar_sim import robots
from roar_sim.gym_env import (FAR_M, LIDAR_BEAMS, LIDAR_EVERY, LIDAR_RANGE_M, MAX_CONTACT_PENALTY, MAX_LIDAR_BEAMS,
                              MAX_SECONDS_S, _profile, _randomize, camera_check, least_turning, number_check,
                              profile_draws, sensor_draws, start_pose, state_bounds)
from roar_sim.batch.model import physics_for
from roar_sim.batch.track_pool import MAX_TRACKS, TrackPool
from roar_sim.batch.world import BatchWorld
from roar_sim.core.lockstep import CONTROL_PERIOD_S

MAX_ENVS = 65536  # the most cars a batch steps


def _tracks(track, problems: list[str]) -> list:
    """The pool's tracks that `track` names (one, or a list of 1..MAX_TRACKS); problems otherwise."""
    items = list(track) if isinstance(track, (list, tuple)) else [track]
    if not 1 <= len(items) <= MAX_TRACKS or not all(isinstance(t, (str, Track)) for t in items):
        problems.append(f"track must be a Track or a track's name, or a list of 1..{MAX_TRACKS} of them, got "
                        f"{shown(track)}")
        return []
    return items


class BatchRaceEnv(gym.vector.VectorEnv):
    metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP, "render_modes": []}

    def __init__(self, num_envs: int = 1024, track="oval", camera: tuple[int, int] | None = None,
                 max_seconds: float = 60.0, contact_penalty: float = 1.0, crash_ends: bool = True,
                 lidar_beams: int | None = None, profile: str | None = None,
                 randomize: dict[str, tuple[float, float]] | None = None,
                 autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP, physics=None) -> None:
        """Race-v0's keywords (a track may be a list: the pool), num_envs (1..MAX_ENVS), autoreset_mode;
        physics: the body's numbers (roar_sim.batch.model.Physics; default the profile's identified
        ones). Every keyword is checked before anything is built: what is wrong, all of it, in one
        ValueError."""
        problems: list[str] = []
        check = number_check(problems)
        if isinstance(num_envs, bool) or not isinstance(num_envs, (int, np.integer)) or not 1 <= num_envs <= MAX_ENVS:
            problems.append(f"num_envs must be a whole number 1..{MAX_ENVS}, got {shown(num_envs)}")
        tracks = _tracks(track, problems)
        camera_check(camera, problems)
        check("max_seconds", max_seconds, 0, MAX_SECONDS_S, "s", low_open=True)
        check("contact_penalty", contact_penalty, 0, MAX_CONTACT_PENALTY)
        if not isinstance(crash_ends, bool):
            problems.append(f"crash_ends must be True or False, got {shown(crash_ends)}")
        if lidar_beams is None:
            lidar_beams = LIDAR_BEAMS
        elif isinstance(lidar_beams, bool) or not isinstance(lidar_beams, int):
            problems.append(f"lidar_beams must be a whole number 0..{MAX_LIDAR_BEAMS}, got {shown(lidar_beams)}")
        else:
            check("lidar_beams", lidar_beams, 0, MAX_LIDAR_BEAMS)
        kind = robots.get("esc")
        base = _profile(profile, kind, problems)
        sensors = (*(("lidar",) if lidar_beams else ()), *(("camera",) if camera is not None else ()))
        self.randomize = _randomize(randomize, kind, problems, sensors)
        try:
            autoreset_mode = AutoresetMode(autoreset_mode)
        except ValueError:
            autoreset_mode = None
        if autoreset_mode not in (AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP):
            problems.append("autoreset_mode must be AutoresetMode.NEXT_STEP or SAME_STEP")
        if problems:
            raise ValueError("BatchRaceEnv: " + "; ".join(problems))
        self.num_envs = int(num_envs)
        self.profile = base or kind.profile_of()
        try:
            pool = TrackPool(tracks)
            least = least_turning(self.profile, self.profile, self.randomize)
            for t in pool.tracks:
                kind.check_track(t, least)
        except (TrackError, ValueError) as e:
            raise ValueError(f"BatchRaceEnv: {e}") from None
        self.pool = pool
        self.lidar_beams, self.max_seconds = lidar_beams, float(max_seconds)
        self.contact_penalty, self.crash_ends = float(contact_penalty), crash_ends
        self.metadata = {**self.metadata, "autoreset_mode": autoreset_mode}
        self.autoreset_mode = autoreset_mode
        self.physics = physics or physics_for(self.profile)
        self.world = BatchWorld(self.num_envs, profile=self.profile, physics=self.physics, pool=pool)
        n = self.num_envs
        self.world.track_of[:] = np.arange(n) % len(pool.tracks)
        self.calibration = Calibration()
        high = state_bounds()
        single = {"state": spaces.Box(-high, high, (8,), np.float32)}
        if lidar_beams:
            single["lidar"] = spaces.Box(0.0, LIDAR_RANGE_M, (lidar_beams,), np.float32)
        self.camera_size = camera
        self.floors = None
        if camera is not None:
            from roar_sim.batch.camera import FloorPool

            w, h = camera
            single["camera"] = spaces.Box(0, 255, (h, w, 3), np.uint8)
            single["depth"] = spaces.Box(0.0, FAR_M, (h, w), np.float32)
            self.floors = FloorPool(pool)
            self._frames = (np.zeros((n, h, w, 3), np.uint8), np.zeros((n, h, w), np.float32))
            self._mount = np.zeros((n, 2))  # each car's camera mount turned: (yaw, pitch) [rad] (randomize=)
        self.single_observation_space = spaces.Dict(single)
        self.single_action_space = spaces.Box(-1.0, 1.0, (2,), np.float32)
        self.observation_space = batch_space(self.single_observation_space, n)
        self.action_space = batch_space(self.single_action_space, n)
        self._high = high
        self._rngs = [np.random.default_rng() for _ in range(n)]
        self._noise = [np.random.default_rng() for _ in range(n)]
        self._lidar_noise = np.zeros(n)
        self._lidar_turn = np.zeros(n)
        self._scan = np.full((n, max(lidar_beams, 1)), LIDAR_RANGE_M)
        self._steps = np.zeros(n, dtype=np.int64)  # actions since each car's reset
        self._ended = np.zeros(n, dtype=bool)  # (next-step autoreset) ended by the last step
        self._started = False

    # --- gymnasium ---------------------------------------------------------------------------

    def reset(self, *, seed: int | list[int | None] | None = None, options: dict | None = None):
        n = self.num_envs
        if seed is None:
            seeds = [None] * n
        elif isinstance(seed, (int, np.integer)) and not isinstance(seed, bool):
            seeds = [int(seed) + i for i in range(n)]
        elif isinstance(seed, (list, tuple)) and len(seed) == n:
            seeds = list(seed)
        else:
            raise ValueError(f"BatchRaceEnv.reset: seed must be None, a whole number or a list of {n}, got "
                             f"{shown(seed)}")
        # a car without a seed goes on with its generator (fresh entropy before its first seed), as an Env's np_random
        self._rngs = [rng if s is None else np.random.default_rng(s) for rng, s in zip(self._rngs, seeds)]
        cars = np.ones(n, dtype=bool)
        self._reset_cars(cars)
        self.world.step(self._neutral_pulses(), self._neutral_pulses(), None)  # the arming period, as Race-v0's
        self._ended[:] = False
        self._started = True
        return self._observation(cars), self._infos(np.zeros(n, dtype=bool))

    def step_each(self, actions):
        """step() with each car's info as a dict of its own (what Stable-Baselines3 wants)."""
        observation, rewards, terminated, truncated, infos = self.step(actions)
        each = [_info_of(infos, i) for i in range(self.num_envs)]
        if "final_obs" in infos:
            for i in np.flatnonzero(infos["_final_obs"]).tolist():
                each[i]["final_obs"] = infos["final_obs"][i]
                each[i]["final_info"] = infos["final_info"][i]
        return observation, rewards, terminated, truncated, each

    def reset_each(self, *, seed=None, options=None):
        observation, infos = self.reset(seed=seed, options=options)
        return observation, [_info_of(infos, i) for i in range(self.num_envs)]

    def get_attr(self, name: str) -> tuple:
        """Each car's value of an attribute (as RaceVectorEnv's): its track for "track", else the batch's."""
        if name == "track":
            return tuple(self.pool.tracks[k] for k in self.world.track_of.tolist())
        return (getattr(self, name),) * self.num_envs

    def set_attr(self, name: str, values) -> None:
        raise AttributeError(f"BatchRaceEnv: {name} is the batch's, not a car's: set it when making the batch")

    def call(self, name: str, *args, **kwargs) -> tuple:
        return (getattr(self, name)(*args, **kwargs),) * self.num_envs

    # --- helpers -----------------------------------------------------------------------------

    def _neutral_pulses(self) -> np.ndarray:
        return np.full(self.num_envs, self.calibration.throttle.trim_us, dtype=np.uint16)

    def _reset_cars(self, cars: np.ndarray) -> None:
        """Those cars at their tracks' starts (each seed's), their episodes' cars and sensors drawn."""
        idx = np.flatnonzero(cars)
        poses = np.empty((len(idx), 3))
        for row, i in enumerate(idx.tolist()):
            rng = self._rngs[i]
            track = self.pool.tracks[self.world.track_of[i]]
            poses[row] = start_pose(track.start_pose, rng)
            draws = profile_draws(self.randomize, rng)
            if draws:
                self.world.set_car(i, dataclasses.replace(self.profile, **draws))
            sensors = sensor_draws(self.randomize, rng)
            self._lidar_noise[i] = sensors.get("lidar_noise_m", 0.0)
            self._lidar_turn[i] = sensors.get("lidar_yaw_rad", 0.0)
            if self.camera_size is not None:
                self._mount[i] = sensors.get("camera_yaw_rad", 0.0), sensors.get("camera_pitch_rad", 0.0)
            self._noise[i] = np.random.default_rng(int(rng.integers(2**63)))
        self.world.reset(idx, poses)
        self._steps[idx] = 0

    def _pulses(self, actions) -> tuple[np.ndarray, np.ndarray]:
        """(throttle, steering) [us] of each car's action through the calibration (to_us's arithmetic)."""
        a = np.asarray(actions, dtype=np.float64)
        if a.shape != (self.num_envs, 2) or not np.all(np.isfinite(a)):
            raise ValueError(f"BatchRaceEnv.step: actions are ({self.num_envs}, 2) finite numbers (throttle, "
                             f"steering; each clipped to -1..1), got {_first_bad(a, self.num_envs)}")
        a = np.clip(a, -1.0, 1.0)
        return _to_us(self.calibration.throttle, a[:, 0]), _to_us(self.calibration.steering, a[:, 1])

    def step(self, actions):
        if not self._started:
            raise RuntimeError("call reset() before step()")
        throttle, steering = self._pulses(actions)
        n, world = self.num_envs, self.world
        resetting = self._ended.copy() if self.autoreset_mode == AutoresetMode.NEXT_STEP else np.zeros(n, bool)
        if resetting.any():
            self._reset_cars(resetting)  # armed by this step, its action unused
        s_before = world.s.copy()
        world.step(throttle, steering)
        progress = self._arc_delta(s_before, world.s)
        touching = world.touching.copy()
        rewards = np.where(resetting, 0.0, progress - np.where(touching, self.contact_penalty, 0.0))
        off = self._off_track()
        terminated = ~resetting & (off | (touching & self.crash_ends))
        truncated = ~resetting & (world.t_us / 1e6 >= self.max_seconds)  # (the arming period counts, as Race-v0's)
        infos = self._infos(touching & ~resetting)
        ended = terminated | truncated
        self._steps[~resetting] += 1
        observation = self._observation(resetting | (self._steps % LIDAR_EVERY == 0))
        if self.autoreset_mode == AutoresetMode.SAME_STEP and ended.any():
            final_obs = _rows(observation, ended)
            final_info = [_info_of(infos, i) for i in np.flatnonzero(ended).tolist()]
            self._reset_cars(ended)
            world.step(self._neutral_pulses(), self._neutral_pulses(), ended)  # their arming period
            observation = self._observation(ended, observation)
            fresh = self._infos(np.zeros(n, bool))
            for key in ("time_s", "progress_m"):
                infos[key] = np.where(ended, fresh[key], infos[key])
            infos["final_obs"] = np.array([None] * n, dtype=object)
            infos["final_info"] = np.array([None] * n, dtype=object)
            for row, i in enumerate(np.flatnonzero(ended).tolist()):
                infos["final_obs"][i], infos["final_info"][i] = final_obs[row], final_info[row]
            infos["_final_obs"] = infos["_final_info"] = ended.copy()
        self._ended = ended & (self.autoreset_mode == AutoresetMode.NEXT_STEP)
        return observation, rewards.astype(np.float64), terminated, truncated, infos

    def _arc_delta(self, before: np.ndarray, after: np.ndarray) -> np.ndarray:
        length = self.pool.lengths[self.world.track_of]
        return (after - before + length / 2) % length - length / 2

    def _off_track(self) -> np.ndarray:
        w, p = self.world, self.pool
        at = p.line_at[w.track_of, 0] + w.hint
        left, right = p.half_widths[at, 0], p.half_widths[at, 1]
        return (w.cte > left) | (-w.cte > right)

    def _observation(self, scan: np.ndarray, into: dict | None = None) -> dict:
        """Every car's observation; the lidar scanned anew for the cars `scan` marks (the others hold
        theirs); into: an observation whose rows of those cars are replaced."""
        w = self.world
        states = w.states()
        heading_error = (states[:, 2] - w.heading + math.pi) % (2 * math.pi) - math.pi
        state = np.column_stack([states[:, 0], states[:, 1], np.cos(states[:, 2]), np.sin(states[:, 2]), states[:, 3],
                                 states[:, 4], w.cte, heading_error]).astype(np.float32)
        state = np.clip(state, -self._high, self._high)
        out = {"state": state} if into is None else {k: v.copy() for k, v in into.items()}
        if into is not None:
            out["state"][scan] = state[scan]
        if self.lidar_beams:
            if scan.any():
                w.scan(self.lidar_beams, LIDAR_RANGE_M, self._lidar_turn, self._scan, scan)
                for i in np.flatnonzero(scan & (self._lidar_noise > 0)).tolist():
                    ranges = self._scan[i]
                    noisy = ranges + self._noise[i].normal(0.0, self._lidar_noise[i], ranges.shape)
                    self._scan[i] = np.where(ranges < LIDAR_RANGE_M, noisy, ranges)
                np.clip(self._scan, 0.0, LIDAR_RANGE_M, out=self._scan)
            lidar = self._scan.astype(np.float32)
            if into is None:
                out["lidar"] = lidar
            else:
                out["lidar"][scan] = lidar[scan]
        if self.camera_size is not None:  # every car's frame, every step (only the lidar is held between scans)
            from roar_sim.batch.camera import render

            rgb, depth = render(w, self.floors, *self.camera_size, shake=self._mount, out=self._frames)
            if into is None:
                out["camera"], out["depth"] = rgb.copy(), depth.copy()
            else:
                out["camera"][scan], out["depth"][scan] = rgb[scan], depth[scan]
        return out

    def _infos(self, touching: np.ndarray) -> dict:
        n = self.num_envs
        every = np.ones(n, dtype=bool)
        return {"time_s": self.world.t_us / 1e6, "_time_s": every, "progress_m": self.world.s.copy(),
                "_progress_m": every, "wall_contact": touching, "_wall_contact": every}


def _to_us(channel, v: np.ndarray) -> np.ndarray:
    """ChannelCalibration.to_us over an array (the same arithmetic, rounding half to even as round())."""
    v = -v if channel.reversed else v
    span = np.where(v >= 0, channel.max_us - channel.trim_us, channel.trim_us - channel.min_us)
    return np.round(channel.trim_us + v * span).astype(np.uint16)


def _info_of(infos: dict, i: int) -> dict:
    """Car i's info as a dict of its own, from the batch's arrays."""
    return {"time_s": float(infos["time_s"][i]), "progress_m": float(infos["progress_m"][i]),
            "wall_contact": bool(infos["wall_contact"][i])}


def _first_bad(a: np.ndarray, n: int) -> str:
    if a.shape != (n, 2):
        return f"shape {a.shape}"
    i = int(np.flatnonzero(~np.all(np.isfinite(a), axis=1))[0])
    return f"car {i}'s {a[i].tolist()}"


def _rows(observation: dict, mask: np.ndarray) -> list[dict]:
    return [{k: v[i].copy() for k, v in observation.items()} for i in np.flatnonzero(mask).tolist()]


class BatchCarEnv(gym.Env):
    """One car of the batched world as a Gymnasium Env (roar/BatchRace-v0): BatchRaceEnv(1)'s car,
    with BatchRaceEnv's keywords but num_envs and autoreset_mode."""

    metadata = {"render_modes": [], "render_fps": round(1 / CONTROL_PERIOD_S)}

    def __init__(self, **kwargs) -> None:
        self.vector = BatchRaceEnv(1, **kwargs)
        self.observation_space = self.vector.single_observation_space
        self.action_space = self.vector.single_action_space

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        observation, infos = self.vector.reset_each(seed=None if seed is None else [seed])
        return {k: v[0] for k, v in observation.items()}, infos[0]

    def step(self, action):
        observation, rewards, terminated, truncated, infos = self.vector.step_each(np.asarray(action)[None])
        return ({k: v[0] for k, v in observation.items()}, float(rewards[0]), bool(terminated[0]),
                bool(truncated[0]), infos[0])

