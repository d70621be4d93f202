"""ROAR's Gym environment with the firmware in the loop:

    env = gymnasium.make("roar_sim.gym_env:roar/Race-v0", track="figure-eight")
    env = gymnasium.make("roar_sim.gym_env:roar/Race-v0", robot="junior")   # the ROAR Junior
    env = gymnasium.make("roar_sim.gym_env:roar/Race-v0", robot="iarrc")    # the IARRC car, by speed

(the module prefix makes Gymnasium import this module, which registers roar/Race-v0; Gymnasium
1.x has no plug-in entry points, so `import roar_sim.gym_env` then `gymnasium.make("roar/Race-v0")`
is the other way).

Each action travels the way a user's script drives the robot (roar_sim.robots), 50 actions a
second. The ESC car (robot="esc", the default): throttle and steering -> the control message's
bytes (roar.protocol, through the library's calibration) -> the firmware core's board loop at
1 kHz -> the emulated ESC and servo -> the PyBullet car. The IARRC car: the throttle asks for a
speed (a fraction of 5 m/s) -> a setpoint message -> its tasks and speed PID. The ROAR Junior:
throttle and steering -> wheel duties (smooth mixing) -> the GET request's bytes -> its firmware
(its HTTP reader, JuniorControl, the L298N pins) -> the two motors; its reply, the ultrasonic
distance, is observed.

    action       [throttle, steering], each -1..1 (+ steering = right); a value beyond is clipped
                 to the range, a NaN or an infinity is a ValueError
    observation  {"state": [x, y, cos yaw, sin yaw, speed, yaw rate, cross-track, heading error],
                  "lidar": ranges [m] over 270 deg, right to left (a scan every 2nd action;
                           lidar_beams=0 leaves it out, the fastest; robots with a lidar),
                  "ultrasonic": [m] the Junior's reply (4 m when no echo; robots with one),
                  "camera": RGB and "depth": metres, when camera=(width, height) is asked for}
    reward       metres of progress along the centre line, minus contact_penalty a step at a wall
    terminated   touching a wall (crash_ends=True), or off the track
    truncated    after max_seconds of simulated time

Keywords (each checked, all problems in one ValueError): track, robot, camera=(width, height)
(16..1280 x 16..960 px), max_seconds (more than 0, at most a day), contact_penalty (>= 0),
crash_ends, lidar_beams, render_mode ("rgb_array", or "human": the PyBullet window, which needs
a display -- headless, check_env(env, skip_render_check=True)).

reset(seed=...) builds a fresh world, so the same seed and actions give the same observations
bit for bit; the seed draws the start: up to 0.1 m across the centre line and 0.05 rad of heading.
"""

from __future__ import annotations

import dataclasses
import math
import os

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from roar.checks import number, shown
from roar_sim import robots
from roar_sim.core.lockstep import CONTROL_PERIOD_S as PERIOD_S  # [s] one action
from roar_sim.robots import Robot
from roar.tracks import Track, get
from roar.tracks.names import FORMS
from roar.tracks.track import MAX_DISTANCE_M, MAX_EXTENT_M

LIDAR_BEAMS = 72  # over 270 deg
LIDAR_EVERY = 2  # actions per scan: 25 scans/s (a Hokuyo UST-10LX turns at 40 Hz); held in between
LIDAR_RANGE_M = 10.0  # [m]
START_OFFSET_M = 0.1  # [m] most the seed moves the start across the centre line
START_HEADING_RAD = 0.05  # [rad] most the seed turns it
FAR_M = 10.0  # [m] the depth camera's far plane
VIEW_SIZE = (320, 240)  # [px] render()'s chase view
MAX_SPEED_M_S = 20.0  # [m/s] the state's bound (the car tops out near 3)
MAX_YAW_RATE_RAD_S = 50.0  # [rad/s]
MIN_CAMERA_PX = 16  # [px] the smallest camera side
MAX_CAMERA_SIZE = (1280, 960)  # [px] the largest camera (a bigger one renders for seconds a step)
MAX_SECONDS_S = 24 * 3600.0  # [s] the longest episode
MAX_CONTACT_PENALTY = 1e6  # the largest reward penalty a step at a wall
MAX_LIDAR_BEAMS = 1080  # beams of the largest scan
SLIDE_M_S = 3.0  # [m/s] allowed sideways besides the speed along the heading, for the projection's search
# What randomize= may draw besides a profile's keys: the sensors' (low, high, unit) and what each needs
SENSOR_RANGES = {
    "lidar_noise_m": (0.0, 0.2, "m"),  # the spread (sigma) of the noise on every range of a scan
    "lidar_yaw_rad": (-0.2, 0.2, "rad"),  # the lidar's mount turned (left +): a scan's beams all turned by it
    "camera_yaw_rad": (-0.2, 0.2, "rad"),  # the camera's mount turned (left +)...
    "camera_pitch_rad": (-0.2, 0.2, "rad"),  # ...and tilted (down +)
}
SENSOR_NEEDS = {"lidar": "lidar_beams above 0", "camera": "camera=(width, height)"}


def number_check(problems: list[str]):
    """check(name, value, low, high, unit="", low_open=False): a number out of its range adds its
    phrase (roar.checks.number's) to `problems`."""
    def check(name, value, low, high, unit="", low_open=False):
        try:
            number(name, value, low, high, unit, low_open)
        except ValueError as e:
            problems.append(str(e))
    return check


def chase_view(world, s, behind_m: float = 1.2, up_m: float = 0.8, fov_deg: float = 60.0, far_m: float = 10.0):
    """RGB (VIEW_SIZE) from a camera behind_m [m] behind a car in state s and up_m above the floor."""
    position = [s.x - behind_m * math.cos(s.yaw), s.y - behind_m * math.sin(s.yaw), up_m]
    rgb, _ = world.render(position, s.yaw, math.atan2(up_m, behind_m + 1.0), *VIEW_SIZE, fov_deg, far_m=far_m)
    return rgb


def _problems(render_modes, track, camera, max_seconds, contact_penalty, crash_ends, lidar_beams, render_mode,
              robot, kind) -> list[str]:
    """What is wrong with RaceEnv's keywords, one phrase each."""
    problems = []
    check = number_check(problems)

    if not isinstance(robot, str):
        problems.append(f"robot must be a robot's name ({', '.join(robots.names())}), got {shown(robot)}")
    if not isinstance(track, (str, Track)):
        problems.append(f"track must be a Track or a track's name ({FORMS}), got {shown(track)}")
    camera_check(camera, problems)
    check("max_seconds", max_seconds, 0, MAX_SECONDS_S, "s", low_open=True)
    check("contact_penalty", contact_penalty, 0, MAX_CONTACT_PENALTY)
    if not isinstance(crash_ends, bool):
        problems.append(f"crash_ends must be True or False, got {shown(crash_ends)}")
    if lidar_beams is not None:
        if not isinstance(lidar_beams, int) or isinstance(lidar_beams, bool):
            problems.append(f"lidar_beams must be a whole number 0..{MAX_LIDAR_BEAMS}, got {shown(lidar_beams)}")
        elif kind is not None and lidar_beams and not kind.has_lidar:
            problems.append(f"the {kind.title} has no lidar: leave lidar_beams out")
        else:
            check("lidar_beams", lidar_beams, 0, MAX_LIDAR_BEAMS)
    if render_mode is not None and render_mode not in render_modes:
        problems.append(f"render_mode must be one of {render_modes} or None, got {shown(render_mode)}")
    if render_mode == "human" and not os.environ.get("DISPLAY"):
        problems.append("render_mode='human' opens the PyBullet window and needs a display (DISPLAY is not set): "
                        "use render_mode='rgb_array'; gymnasium's check_env(env, skip_render_check=True) skips "
                        "the human mode")
    return problems


def camera_check(camera, problems: list[str]) -> None:
    """What is wrong with a camera=(width, height) keyword (None: no camera) goes to problems."""
    if camera is None:
        return
    size = tuple(camera) if isinstance(camera, (tuple, list)) else ()
    if len(size) != 2 or not all(isinstance(v, int) and not isinstance(v, bool) for v in size):
        problems.append(f"camera must be (width, height) in whole pixels, got {shown(camera)}")
        return
    check = number_check(problems)
    check("camera width", size[0], MIN_CAMERA_PX, MAX_CAMERA_SIZE[0], "px")
    check("camera height", size[1], MIN_CAMERA_PX, MAX_CAMERA_SIZE[1], "px")


def profile_draws(randomize: dict[str, tuple[float, float]], rng: np.random.Generator) -> dict[str, float]:
    """An episode's draw of randomize='s profile keys (in the order of their names), from rng."""
    return {k: float(rng.uniform(a, b)) for k, (a, b) in sorted(randomize.items()) if k not in SENSOR_RANGES}


def sensor_draws(randomize: dict[str, tuple[float, float]], rng: np.random.Generator) -> dict[str, float]:
    """An episode's draw of randomize='s sensor keys (SENSOR_RANGES'), from rng, after its profile's."""
    return {k: float(rng.uniform(a, b)) for k, (a, b) in sorted(randomize.items()) if k in SENSOR_RANGES}


def least_turning(profile, base, randomize: dict[str, tuple[float, float]]):
    """The profile a track's bends are checked against: of those randomize= may draw around base, the
    one that turns least (the least steering, the longest wheelbase); `profile` where none turns less."""
    worst = {}
    if "max_steer_rad" in randomize:
        worst["max_steer_rad"] = randomize["max_steer_rad"][0]
    if "wheelbase_m" in randomize:
        worst["wheelbase_m"] = randomize["wheelbase_m"][1]
    return dataclasses.replace(base, **worst) if worst else profile


def action_values(action) -> tuple[float, float]:
    """(throttle, steering), each clipped to -1..1 (the action space's bounds); a ValueError in
    one line for anything but two finite numbers."""
    try:
        values = np.asarray(action, dtype=np.float64).reshape(-1).tolist()
    except (TypeError, ValueError):
        values = []
    if len(values) != 2 or not all(map(math.isfinite, values)):
        raise ValueError(f"an action is (throttle, steering), two finite numbers (each clipped to -1..1); "
                         f"got {shown(action)}")
    throttle, steering = (min(1.0, max(-1.0, v)) for v in values)
    return throttle, steering


def state_bounds() -> np.ndarray:
    """The state observation's upper bounds (its lower ones are their negatives)."""
    far = MAX_DISTANCE_M + MAX_EXTENT_M  # [m] no track reaches further from the origin
    return np.array([far, far, 1.0, 1.0, MAX_SPEED_M_S, MAX_YAW_RATE_RAD_S, far, math.pi], np.float32)


def start_pose(pose: tuple[float, float, float], rng: np.random.Generator) -> tuple[float, float, float]:
    """A start pose the seed moved: up to START_OFFSET_M across its heading and START_HEADING_RAD."""
    x, y, yaw = pose
    offset = float(rng.uniform(-START_OFFSET_M, START_OFFSET_M))
    yaw += float(rng.uniform(-START_HEADING_RAD, START_HEADING_RAD))
    return x - offset * math.sin(yaw), y + offset * math.cos(yaw), yaw


class Place:
    """A car's place on a track from one step to the next: its segment, how far along the centre
    line and across it; its progress, the state observation, whether it left the track."""

    def __init__(self, track: Track, state) -> None:
        self.track = track
        self._shortest_m = float(track.segment_lengths.min())  # [m] of a centre-line segment
        self._high = state_bounds()
        self.hint, self.s, self.cte = track.project((state.x, state.y), heading=state.yaw)

    def advance(self, state) -> float:
        """[m] of progress along the centre line since the last state."""
        # centre-line segments searched each side of the last one: what the car can cross in a step
        window = math.ceil((abs(state.speed) + SLIDE_M_S) * PERIOD_S / self._shortest_m) + 1
        self.hint, s_now, self.cte = self.track.project((state.x, state.y), self.hint, window)
        progress = self.track.arc_delta(self.s, s_now)
        self.s = s_now
        return progress

    def off_track(self) -> bool:
        left, right = self.track.half_widths_at(self.hint)
        return self.cte > left or -self.cte > right

    def observation(self, s) -> np.ndarray:
        """[x, y, cos yaw, sin yaw, speed, yaw rate, cross-track, heading error], within bounds."""
        pts = self.track.centerline
        i = self.hint or 0
        a, b = pts[i], pts[(i + 1) % len(pts)]
        heading_error = (s.yaw - math.atan2(b[1] - a[1], b[0] - a[0]) + math.pi) % (2 * math.pi) - math.pi
        state = np.array([s.x, s.y, math.cos(s.yaw), math.sin(s.yaw), s.speed, s.yaw_rate, self.cte, heading_error],
                         np.float32)
        return np.clip(state, -self._high, self._high)


def _profile(profile, kind, problems: list[str]):
    """The robot's profile that profile names (None: the robot's own); what is wrong goes to problems."""
    if profile is None:
        return None
    if not isinstance(profile, str) or not profile.strip():
        problems.append(f"profile must be a robot profile's name or a .toml file, got {shown(profile)}")
    elif kind is not None:
        from roar_sim import ProfileError

        try:
            return kind.profile_of(profile)
        except ProfileError as e:
            problems.append(str(e))
    return None


def _randomize(randomize, kind, problems: list[str], sensors: tuple[str, ...] = ()) -> dict[str, tuple[float, float]]:
    """{key: (low, high)} checked: keys the robot's profiles have, or a sensor's of SENSOR_RANGES
    where the environment has that sensor (`sensors`: "lidar", "camera"), bounds within their
    ranges; what is wrong goes to problems."""
    if randomize is None:
        return {}
    if not isinstance(randomize, dict) or not randomize:
        problems.append(f"randomize must be a dict of profile keys to (low, high), got {shown(randomize)}")
        return {}
    if kind is None:
        return {}
    profile_keys, checked = kind.profile_ranges(), {}
    ranges = {**profile_keys, **SENSOR_RANGES}
    for key, span in randomize.items():
        if key not in ranges:
            problems.append(f"randomize: no profile key {shown(key)} (keys: {', '.join(sorted(profile_keys))}; the "
                            f"sensors': {', '.join(SENSOR_RANGES)})")
            continue
        sensor = key.split("_")[0] if key in SENSOR_RANGES else None
        if sensor is not None and sensor not in sensors:
            problems.append(f"randomize[{key!r}] draws the {sensor}'s: it needs {SENSOR_NEEDS[sensor]}")
            continue
        if not isinstance(span, (tuple, list)) or len(span) != 2:
            problems.append(f"randomize[{key!r}] must be (low, high), got {shown(span)}")
            continue
        low, high, unit = ranges[key]
        try:
            a, b = (number(f"randomize[{key!r}]", v, low, high, unit) for v in span)
        except ValueError as e:
            problems.append(str(e))
            continue
        if a > b:
            problems.append(f"randomize[{key!r}]: low {a:g} is above high {b:g}")
            continue
        checked[key] = (a, b)
    return checked


class RaceEnv(gym.Env):
    metadata = {"render_modes": ["rgb_array", "human"], "render_fps": round(1 / PERIOD_S)}

    def __init__(self, track: str | Track = "oval", camera: tuple[int, int] | None = None, max_seconds: float = 60.0,
                 contact_penalty: float = 1.0, crash_ends: bool = True, lidar_beams: int | None = None,
                 render_mode: str | None = None, robot: str = "esc", profile: str | None = None,
                 randomize: dict[str, tuple[float, float]] | None = None) -> None:
        """Every keyword is checked before anything is built; what is wrong, all of it, in one
        ValueError. profile: the robot's own numbers (a racecar's, the ESC and IARRC cars':
        roar_sim.plants.car_profile; the Junior's motors: roar_sim.plants.junior_profile), a name
        or a .toml file, as `roar race --car-profile` and sim://?profile=; None: the robot's default.
        randomize: domain randomisation, {profile key: (low, high)}: each episode's car has each
        key drawn uniformly within its span from the episode's seed (info["profile"] says what was
        drawn), e.g. {"tyre_friction": (0.35, 0.55), "latency_s": (0.0, 0.06)}; and the sensors'
        (SENSOR_RANGES: the lidar's noise and mount, the camera's mount; info["sensors"])."""
        self.kind = robots.get(robot) if isinstance(robot, str) else None
        problems = _problems(self.metadata["render_modes"], track, camera, max_seconds, contact_penalty, crash_ends,
                             lidar_beams, render_mode, robot, self.kind)
        self.profile = _profile(profile, self.kind, problems)
        if lidar_beams is None:
            lidar_beams = LIDAR_BEAMS if self.kind is None or self.kind.has_lidar else 0
        sensors = (*(("lidar",) if lidar_beams else ()), *(("camera",) if camera is not None else ()))
        self.randomize = _randomize(randomize, self.kind, problems, sensors)
        if problems:
            raise ValueError("RaceEnv: " + "; ".join(problems))
        self.track = track if isinstance(track, Track) else get(track)
        self.kind.check_track(self.track, self._least_turning())  # a bend the robot cannot turn: no lap to learn
        self.robot, self.lidar_beams = robot, lidar_beams
        self.camera_size, self.max_seconds = camera, max_seconds
        self.contact_penalty, self.crash_ends, self.render_mode = contact_penalty, crash_ends, render_mode
        self.action_space = spaces.Box(-1.0, 1.0, (2,), np.float32)  # throttle, steering (+ = right)
        high = state_bounds()
        observation = {"state": spaces.Box(-high, high, (8,), np.float32)}
        if lidar_beams:
            observation["lidar"] = spaces.Box(0.0, LIDAR_RANGE_M, (lidar_beams,), np.float32)
        self.ultrasonic_max_m = self.kind.ultrasonic_max_m
        if self.ultrasonic_max_m is not None:
            observation["ultrasonic"] = spaces.Box(0.0, self.ultrasonic_max_m, (1,), np.float32)
        if camera is not None:
            w, h = camera
            observation["camera"] = spaces.Box(0, 255, (h, w, 3), np.uint8)
            observation["depth"] = spaces.Box(0.0, FAR_M, (h, w), np.float32)
        self.observation_space = spaces.Dict(observation)
        self.sim: Robot | None = None  # the robot, from reset() until close()
        self._place: Place | None = None  # the car's, from reset()
        self._scan: np.ndarray | None = None  # the latest lidar scan
        self._steps = 0
        self._sensors: dict[str, float] = {}  # this episode's draws of SENSOR_RANGES' keys
        self._noise = np.random.default_rng(0)

    # --- gymnasium ---------------------------------------------------------------------------

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        self.close()
        pose = start_pose(self.track.start_pose, self.np_random)
        profile = self._drawn()
        own = {} if profile is None else {"profile": profile}
        self.sim = self.kind(self.track, pose, gui=self.render_mode == "human", **own)
        self.sim.arm()  # the ESC car boots latched until it hears neutral
        self._sensors = sensor_draws(self.randomize, self.np_random)
        # the scans' noise from a generator of the episode's own: the same seed, the same noise
        self._noise = np.random.default_rng(int(self.np_random.integers(2**63)))
        state = self.sim.state()
        self._place = Place(self.track, state)
        self._scan, self._steps = None, 0
        return self._observation(state), self._info()

    def step(self, action):
        if self.sim is None:
            raise RuntimeError("call reset() before step()")
        self.sim.drive(*action_values(action))
        self.sim.run(PERIOD_S)
        state = self.sim.state()  # one reading for the reward and the observation
        progress = self._place.advance(state)
        touching = self.sim.touching_wall()
        reward = progress - (self.contact_penalty if touching else 0.0)
        terminated = self._place.off_track() or (touching and self.crash_ends)
        truncated = self.sim.t_us / 1e6 >= self.max_seconds
        return self._observation(state), float(reward), bool(terminated), bool(truncated), self._info(touching)

    def render(self):
        if self.render_mode != "rgb_array" or self.sim is None:
            return None
        return chase_view(self.sim.plant.world, self.sim.state())

    def close(self) -> None:
        if self.sim is not None:
            self.sim.close()
            self.sim = None

    # --- helpers -----------------------------------------------------------------------------

    def _base(self):
        return self.profile or self.kind.profile_of()

    def _drawn(self):
        """This episode's profile: the base with each randomized key drawn (None: the default car)."""
        draws = profile_draws(self.randomize, self.np_random)
        return dataclasses.replace(self._base(), **draws) if draws else self.profile

    def _least_turning(self):
        return least_turning(self.profile, self._base(), self.randomize)

    def _observation(self, s) -> dict:
        plant = self.sim.plant
        observation = {"state": self._place.observation(s)}
        if self.lidar_beams:
            if self._steps % LIDAR_EVERY == 0:
                scan = plant.lidar(beams=self.lidar_beams, range_m=LIDAR_RANGE_M,
                                   turn_rad=self._sensors.get("lidar_yaw_rad", 0.0))
                noise = self._sensors.get("lidar_noise_m", 0.0)
                if noise:  # a beam that met nothing stays at the range
                    scan = np.where(scan < LIDAR_RANGE_M, scan + self._noise.normal(0.0, noise, scan.shape), scan)
                self._scan = np.clip(scan, 0.0, LIDAR_RANGE_M).astype(np.float32)
            observation["lidar"] = self._scan.copy()
        if self.ultrasonic_max_m is not None:
            observation["ultrasonic"] = np.array([min(self.sim.range_m, self.ultrasonic_max_m)], np.float32)
        self._steps += 1
        if self.camera_size is not None:
            shake = (self._sensors.get("camera_yaw_rad", 0.0), self._sensors.get("camera_pitch_rad", 0.0))
            rgb, depth = plant.camera(*self.camera_size, shake_rad=shake)
            observation["camera"] = np.ascontiguousarray(rgb)
            observation["depth"] = np.clip(depth, 0.0, FAR_M).astype(np.float32)
        return observation

    def _info(self, touching: bool = False) -> dict:
        drawn = {k: getattr(self.sim.profile, k) for k in self.randomize if k not in SENSOR_RANGES}
        return {"time_s": self.sim.t_us / 1e6, "progress_m": self._place.s, "wall_contact": touching, **self.sim.info(),
                **({"profile": drawn} if drawn else {}), **({"sensors": dict(self._sensors)} if self._sensors else {})}


if "roar/Race-v0" not in gym.registry:  # make_vec(..., vectorization_mode="vector_entry_point"): every core
    gym.register(id="roar/Race-v0", entry_point="roar_sim.gym_env:RaceEnv",
                 vector_entry_point="roar_sim.gym_env.vector:RaceVectorEnv")
if "roar/BatchRace-v0" not in gym.registry:  # the batched world's cars (roar_sim.gym_env.batched), one or many
    gym.register(id="roar/BatchRace-v0", entry_point="roar_sim.gym_env.batched:BatchCarEnv",
                 vector_entry_point="roar_sim.gym_env.batched:BatchRaceEnv")
