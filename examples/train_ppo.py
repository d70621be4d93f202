"""Teach a car to race with reinforcement learning: PPO (stable-baselines3, on the CPU) in ROAR's Gym
environment, where every action goes through the real firmware logic (roar_sim.gym_env), the
environments stepped on every core (roar_sim.gym_env.sb3.RaceVecEnv).

    pip install 'roar-platform[rl]'                           # stable-baselines3 and PyTorch
    python examples/train_ppo.py                              # on the oval until episodes average 2 laps
    python examples/train_ppo.py --until-laps 1 --track figure-eight --out out/ppo8
    python examples/train_ppo.py --drive out/ppo/model.zip    # drive one episode, report
    python examples/train_ppo.py --randomize --out out/ppo_dr    # each episode another car (domain randomisation)
    python examples/train_ppo.py --drive out/ppo_dr/model.zip --car-profile mycar.toml   # drive your fitted car
    python examples/train_ppo.py --batched --out out/ppo_b    # 128 cars of the batched world: seconds, not minutes
    python examples/train_ppo.py --drive out/ppo_b/model.zip  # ...and the policy drives the PyBullet car
    python examples/train_ppo.py --drive out/ppo_b/model.zip --url "sim://oval?speedup=4"   # ...or a car by URL

The policy sees the state (pose, speed, cross-track and heading error) and the lidar; the reward
is metres along the centre line (minus a penalty at a wall); an episode ends at a wall or after
30 s. Observations and rewards are normalised (VecNormalize); its statistics are saved beside the
model. Training stops when the last 20 episodes average --until-laps laps (or after --steps).

The same --seed gives the same policy, bit for bit, however many processes step the environments
(--workers): the run ends by printing the policy's fingerprint to show it. Exit status, as the
roar commands': 0 when the episodes reached --until-laps, 2 when training stopped short of it (at
--steps), 1 for bad input, 130 on Ctrl-C.

--randomize draws each episode's car within what real cars of its kind differ by (steering trim
±4 deg, servo lag 20-80 ms, command latency 0-60 ms, ESC dead band 0-60 us, motor 70-120 %, grip
70-110 %: roar_sim.plants.car_profile.real_car_spans), so the policy learns to drive cars it has not
met; --car-profile trains or drives one car (a shipped profile, or the .toml `roar fit` writes).
`make bench` (benchmarks/rl_transfer.py) trains with and without it and drives five such cars.

--batched trains on the batched world (roar_sim.gym_env.batched: the same spaces, the firmware core's
board loop in C for every car, a single-track body fitted to the PyBullet car), 128 cars in this
process by default, with larger batches for the learner (BATCHED_PPO); --drive then drives the
PyBullet car, as without it. `make bench` (benchmarks/batched_world.py) times it against 10 s.

--drive with --url drives a car by its URL through roar.Vehicle, as any script would: the policy's
observation made from what the link reports (the car's pose, speed and yaw rate; its lidar's scan,
resampled to the policy's beams), its action sent at 50 Hz of the car's time; the lap counted along
the track's centre line, and the car's nearest approach to a wall (its half width beside the
cross-track error) reported. sim:// is the simulated car in real time (?speedup= runs it faster).

Measured here (2 cores, the defaults: 4 environments on 2 processes, seed 0, on a day this machine
ran at about 60 % of its best): the last 20 episodes averaged two laps of the oval (2 x 17.4 m in
30 s) after 43,012 steps and 47 s of wall time (915 steps/s, PPO's updates included); the same
training on SB3's SubprocVecEnv (--vec subproc) took 66 s, for the same policy (f845f473eb5ba71b).
Driven with seeds 0, 1, 2 it covered 3.8 (then a wall), 4.0 and 4.0 laps in 30 s. `make bench`
measures both trainings again.
"""

import argparse
import hashlib
import sys
import time
from pathlib import Path

try:
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.callbacks import BaseCallback
    from stable_baselines3.common.logger import Logger
    from stable_baselines3.common.vec_env import SubprocVecEnv, VecMonitor, VecNormalize
except ImportError:
    sys.exit("this example needs stable-baselines3 and PyTorch: pip install 'roar-platform[rl]'")
from tqdm import tqdm

from roar.cli.sdk import ExitStatus
from roar_sim.gym_env import RaceEnv
from roar_sim.gym_env.sb3 import RaceVecEnv
from roar_sim.plants import car_profile

EPISODE_S = 30.0  # [s] of simulated time, the longest episode
BATCHED_ENVS = 128  # --batched's cars by default
# PPO's settings on the batched world: many cars, so longer batches and fewer epochs (the learner's time
# is most of a batched training's)
BATCHED_PPO = {"n_steps": 64, "batch_size": 2048, "n_epochs": 4, "learning_rate": 1e-3}
LIDAR_BEAMS = 36  # over 270 deg
MEAN_OF = 20  # episodes averaged for --until-laps


def environments(track: str, count: int, workers: int | None, vec: str = "race", profile: str | None = None,
                 randomize: bool = False) -> VecMonitor:
    """count environments on `workers` processes (default one per core), episodes recorded; or,
    for comparison, in SB3's SubprocVecEnv (a process each, woken by pipes every step); vec="batched":
    the batched world's cars, in this process. profile: the car (None: the default); randomize: each
    episode's car drawn around it."""
    kwargs = {"track": track, "max_seconds": EPISODE_S, "lidar_beams": LIDAR_BEAMS, "profile": profile}
    if randomize:
        kwargs["randomize"] = car_profile.real_car_spans(car_profile.load(profile) if profile else None)
    if vec == "subproc":
        return VecMonitor(SubprocVecEnv([lambda: RaceEnv(**kwargs)] * count, start_method="fork"))
    if vec == "batched":
        return VecMonitor(RaceVecEnv(count, batched=True, **kwargs))
    return VecMonitor(RaceVecEnv(count, workers=workers, **kwargs))


def fingerprint(model) -> str:
    """The policy's parameters, hashed: equal fingerprints, equal policies."""
    digest = hashlib.sha256()
    for name, tensor in model.policy.state_dict().items():
        digest.update(name.encode() + tensor.detach().cpu().numpy().tobytes())
    return digest.hexdigest()[:16]


class Progress(BaseCallback):
    """A progress bar over the steps, showing laps per episode; stops at the target."""

    def __init__(self, steps: int, lap_m: float, until_laps: float) -> None:
        super().__init__()
        # on a terminal only (disable=None): in a log a bar is a stream of carriage-return frames
        self.bar = tqdm(total=steps, unit="step", unit_scale=True, dynamic_ncols=True, mininterval=1.0, disable=None)
        self.lap_m, self.until_laps, self.reached = lap_m, until_laps, False
        self.env_s, self._rollout_began = 0.0, 0.0  # [s] spent collecting rollouts (the environments and the policy's
        #                                               actions); the rest of a training is the learner's

    def laps(self) -> float | None:
        episodes = list(self.model.ep_info_buffer)[-MEAN_OF:]
        return sum(e["r"] for e in episodes) / len(episodes) / self.lap_m if len(episodes) == MEAN_OF else None

    def _on_step(self) -> bool:
        self.bar.update(self.training_env.num_envs)
        return not self.reached  # (checked again after the update that followed the rollout that reached it)

    def _on_rollout_start(self) -> None:
        self._rollout_began = time.perf_counter()

    def _on_rollout_end(self) -> None:
        self.env_s += time.perf_counter() - self._rollout_began
        laps = self.laps()
        if laps is not None:
            self.bar.set_postfix_str(f"{laps:.2f} laps/episode")
            self.reached = laps >= self.until_laps


def train(args) -> int:
    # the environments' processes need the cores more than the small network does; the batched world
    # steps in this process, and then the learner's time is most of the training's
    torch.set_num_threads(2 if args.vec == "batched" else 1)
    envs = VecNormalize(environments(args.track, args.envs, args.workers, args.vec, args.car_profile, args.randomize),
                        gamma=0.99)
    lap_m = envs.get_attr("track")[0].length_m
    if args.vec == "batched":
        settings = BATCHED_PPO
    else:
        settings = {"n_steps": max(64, min(512, args.steps // args.envs)), "batch_size": 64}  # steps per env an update
    model = PPO("MultiInputPolicy", envs, seed=args.seed, device="cpu", **settings)
    model.set_logger(Logger(None, []))  # the progress bar says it all (SB3's own would leave a folder in /tmp per run)
    progress = Progress(args.steps, lap_m, args.until_laps)
    start = time.perf_counter()
    try:
        model.learn(total_timesteps=args.steps, callback=progress)
    finally:
        progress.bar.close()
    wall_s = time.perf_counter() - start
    args.out.mkdir(parents=True, exist_ok=True)
    model.save(args.out / "model.zip")
    envs.save(str(args.out / "normalise.pkl"))
    envs.close()
    steps, laps = model.num_timesteps, progress.laps()
    done = f"{laps:.2f} laps/episode" if laps is not None else f"fewer than {MEAN_OF} episodes ended"
    verdict = "reached" if progress.reached else "did not reach"
    print(f"{verdict} {args.until_laps:g} laps/episode on {args.track}: {done} after {steps} steps, "
          f"{wall_s:.0f} s ({steps / wall_s:.0f} steps/s; environments {progress.env_s:.1f} s, learner "
          f"{wall_s - progress.env_s:.1f} s)")
    print(f"saved {args.out / 'model.zip'} and {args.out / 'normalise.pkl'}; policy {fingerprint(model)} "
          f"(seed {args.seed})")
    return ExitStatus.OK if progress.reached else ExitStatus.SHORT  # the roar commands' convention: 2, it fell short


def drive(args) -> int:
    """One episode with the trained policy, its actions sampled as in training: how far it got
    and how it ended."""
    statistics = args.drive.parent / "normalise.pkl"
    missing = [str(path) for path in (args.drive, statistics) if not path.is_file()]
    if missing:
        raise ValueError(f"no {' and no '.join(missing)} (train first: python examples/train_ppo.py --out DIR)")
    if args.url:
        return drive_url(args, statistics)
    envs = VecNormalize.load(str(statistics), environments(args.track, 1, 1, profile=args.car_profile))
    envs.training, envs.norm_reward = False, False
    model = PPO.load(args.drive, device="cpu")
    model.set_random_seed(args.seed)
    envs.seed(args.seed)
    observation, done, metres, info = envs.reset(), False, 0.0, {}
    while not done:
        action, _ = model.predict(observation, deterministic=False)
        observation, reward, dones, infos = envs.step(action)
        metres, done, info = metres + float(reward[0]), bool(dones[0]), infos[0]
    length = envs.get_attr("track")[0].length_m
    ending = "hit a wall" if info.get("wall_contact") else "time up" if info.get("TimeLimit.truncated") else "ended"
    print(f"drove {metres:.1f} m = {metres / length:.2f} laps of {args.track} in {info['time_s']:.1f} s ({ending})")
    envs.close()
    return ExitStatus.OK


def drive_url(args, statistics: Path) -> int:
    """The policy drives the car at args.url for --seconds of the car's time (roar.Vehicle)."""
    import math
    import pickle
    from types import SimpleNamespace

    import numpy as np

    from roar import Vehicle
    from roar.tracks import get
    from roar_sim.gym_env import LIDAR_EVERY, LIDAR_RANGE_M, Place
    from roar_sim.robots.esc import EscCar
    from roar_sim.sensors.lidar import FOV_RAD

    with open(statistics, "rb") as f:
        normalise = pickle.load(f)  # VecNormalize's running statistics (without its environments)
    model = PPO.load(args.drive, device="cpu")
    model.set_random_seed(args.seed)
    track = get(args.track)
    beams = model.observation_space["lidar"].shape[0]
    angles = np.linspace(-FOV_RAD / 2, FOV_RAD / 2, beams)
    with Vehicle(args.url) as car:
        if not car.wait_armed(timeout_s=5):
            raise ValueError(f"{args.url}: the car did not arm within 5 s")
        deadline = time.monotonic() + 2.0  # [s] for the first pose and scan (a scan comes at its own rate)
        while (car.state().x_m is None or car.lidar() is None) and time.monotonic() < deadline:
            time.sleep(0.02)
        pose, scan = car.state().x_m is not None, car.lidar() is not None
        if not (pose and scan):
            raise ValueError(f"{args.url}: the policy needs the car's pose and its lidar, and this link gives "
                             f"{'neither' if not (pose or scan) else 'only one'}")

        def now():
            s = car.state()
            return SimpleNamespace(x=s.x_m, y=s.y_m, yaw=s.yaw_rad, speed=s.speed_m_s, yaw_rate=s.yaw_rate_rad_s or 0.0,
                                   t=s.time_s)

        state = now()
        place, start_s, steps = Place(track, state), state.t, 0
        metres, nearest_m, scan = 0.0, math.inf, None
        while state.t - start_s < args.seconds:
            if steps % LIDAR_EVERY == 0:
                ranges = np.asarray(car.lidar(), dtype=float)
                scan = np.interp(angles, np.linspace(-FOV_RAD / 2, FOV_RAD / 2, len(ranges)), ranges)
            observation = {"state": place.observation(state)[None], "lidar": np.clip(scan, 0, LIDAR_RANGE_M)[None]}
            action, _ = model.predict(normalise.normalize_obs(observation), deterministic=False)
            throttle, steering = np.clip(action[0], -1.0, 1.0).tolist()
            car.drive(throttle=throttle, steering=steering)
            while (later := now()).t - state.t < 0.02:  # a control period of the car's time
                time.sleep(0.002)
            state, steps = later, steps + 1
            metres += place.advance(state)
            left, right = track.half_widths_at(place.hint)
            nearest_m = min(nearest_m, (left - place.cte if place.cte > 0 else right + place.cte) - EscCar.half_width_m)
    laps = metres / track.length_m
    print(f"drove {metres:.1f} m = {laps:.2f} laps of {args.track} in {state.t - start_s:.1f} s on {args.url}; "
          f"nearest a wall {nearest_m:.2f} m ({'touched it' if nearest_m <= 0 else 'never touched one'})")
    return ExitStatus.OK


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--track", default="oval", help="oval, figure-eight, course, random:SEED, ... (default: oval)")
    parser.add_argument("--until-laps", type=float, default=2.0, metavar="LAPS",
                        help=f"stop when the last {MEAN_OF} episodes average this many laps (default 2)")
    parser.add_argument("--steps", type=int, default=1_000_000, help="the most environment steps (default 1000000)")
    parser.add_argument("--envs", type=int, help=f"environments (default 4; with --batched {BATCHED_ENVS})")
    parser.add_argument("--workers", type=int, help="processes stepping them, this one among them (default: one "
                                                    "per core); the result does not depend on it")
    parser.add_argument("--vec", choices=("race", "subproc"), default="race",
                        help="race: RaceVecEnv (default); subproc: SB3's SubprocVecEnv, for comparison (the same "
                             "policy, slower)")
    parser.add_argument("--seed", type=int, default=0, help="the same seed trains the same policy (default 0)")
    parser.add_argument("--out", type=Path, default=Path("out/ppo"), help="model and statistics go here")
    parser.add_argument("--drive", type=Path, metavar="MODEL.zip", help="drive one episode with a trained model")
    parser.add_argument("--seconds", type=float, default=EPISODE_S,
                        help=f"with --url: how long to drive, of the car's time (default {EPISODE_S:g})")
    parser.add_argument("--url", help="with --drive: the car to drive, by URL (e.g. \"sim://oval?speedup=4\"; a car "
                                      "whose link gives its pose and lidar)")
    parser.add_argument("--car-profile", metavar="NAME|FILE",
                        help="the car trained or driven: a shipped profile (roar, f1tenth) or a .toml, e.g. the one "
                             "`roar fit` wrote for your car (default: the ROAR car)")
    parser.add_argument("--batched", action="store_true",
                        help="train on the batched world's cars (many in this process; the policy then drives the "
                             "PyBullet car with --drive)")
    parser.add_argument("--randomize", action="store_true",
                        help="train on a different car each episode, drawn within what real cars differ by "
                             "(trim, servo lag, latency, dead band, motor, grip)")
    args = parser.parse_args()
    if args.batched:
        if args.vec != "race" or args.workers is not None:
            parser.error("--batched steps its cars in this process: leave out --vec and --workers")
        args.vec = "batched"
    most_envs = 4096 if args.batched else 64
    args.envs = args.envs if args.envs is not None else BATCHED_ENVS if args.batched else 4
    if not 64 <= args.steps <= 100_000_000 or not 1 <= args.envs <= most_envs:
        parser.error(f"--steps must be 64..1e8 and --envs 1..{most_envs}")
    if args.vec == "subproc" and args.workers is not None:
        parser.error("--workers is RaceVecEnv's (--vec race); SubprocVecEnv runs a process per environment")
    if args.workers is not None and not 1 <= args.workers <= args.envs:
        parser.error("--workers must be 1..--envs")
    if not 0 < args.until_laps <= 1000:
        parser.error("--until-laps must be more than 0 and at most 1000")
    if args.url and not args.drive:
        parser.error("--url is the car --drive drives")
    if not 0 < args.seconds <= 3600:
        parser.error("--seconds must be more than 0 and at most 3600")
    if args.drive and args.randomize:
        parser.error("--randomize is for training; to drive another car give --car-profile")
    try:
        sys.exit(drive(args) if args.drive else train(args))
    except KeyboardInterrupt:
        sys.exit(ExitStatus.INTERRUPTED)
    except ValueError as error:  # a bad track name, said in one line
        sys.exit(f"train_ppo: {error}")
