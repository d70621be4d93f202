"""Teach a car to race with reinforcement learning: PPO (stable-baselines3, on the CPU) in ROAR's Gym
environment, where every action goes through the real firmware logic (roar_sim.gym_env).

    pip install 'roar-platform[gym]' stable-baselines3        # brings PyTorch
    python examples/train_ppo.py                              # 300k steps on the oval, 2 processes
    python examples/train_ppo.py --steps 50000 --track figure-eight --out out/ppo8
    python examples/train_ppo.py --drive out/ppo/model.zip    # watch-free: drive one episode, report

The policy sees the state (pose, speed, cross-track and heading error) and the lidar; the reward
is metres along the centre line (minus a penalty at a wall), an episode ends at a wall or after
30 s. Observations and rewards are normalised (VecNormalize); its statistics are saved beside the
model. Measured on 2 cores: ~260 steps/s; after 100k steps (7 min) episodes averaged 39 m (the
oval is 17.4 m round), and driven with sampled actions the policy covered 46-75 m in 30 s.
"""

import argparse
import sys
from pathlib import Path

try:
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import SubprocVecEnv, VecNormalize
except ImportError:
    sys.exit("this example needs stable-baselines3: pip install stable-baselines3")

ENV_ID = "roar_sim.gym_env:roar/Race-v0"  # the prefix registers it in every worker process too


def environments(track: str, count: int, seed: int):
    kwargs = {"track": track, "max_seconds": 30.0, "lidar_beams": 36}
    return make_vec_env(ENV_ID, n_envs=count, seed=seed, env_kwargs=kwargs,
                        vec_env_cls=SubprocVecEnv if count > 1 else None)


def train(args) -> None:
    torch.set_num_threads(1)  # the environments' processes need the cores more than the small network does
    envs = VecNormalize(environments(args.track, args.envs, args.seed), gamma=0.99)
    rollout = max(64, min(1024, args.steps // args.envs))  # steps per environment between updates
    model = PPO("MultiInputPolicy", envs, n_steps=rollout, batch_size=64, seed=args.seed, device="cpu", verbose=1)
    model.learn(total_timesteps=args.steps, progress_bar=False)
    args.out.mkdir(parents=True, exist_ok=True)
    model.save(args.out / "model.zip")
    envs.save(str(args.out / "normalise.pkl"))
    envs.close()
    print(f"saved {args.out / 'model.zip'} and {args.out / 'normalise.pkl'}")


def drive(args) -> None:
    """One episode with the trained policy, its actions sampled as in training (after 100k steps
    its mean action alone does not yet drive): how far it got and how it ended."""
    envs = VecNormalize.load(str(args.drive.parent / "normalise.pkl"), environments(args.track, 1, args.seed))
    envs.training, envs.norm_reward = False, False
    model = PPO.load(args.drive, device="cpu")
    model.set_random_seed(args.seed)
    observation, done, metres, info = envs.reset(), False, 0.0, {}
    while not done:
        action, _ = model.predict(observation, deterministic=False)
        observation, reward, dones, infos = envs.step(action)
        metres, done, info = metres + float(reward[0]), bool(dones[0]), infos[0]
    length = envs.get_attr("track")[0].length_m
    ending = "hit a wall" if info.get("wall_contact") else "time up" if info.get("TimeLimit.truncated") else "ended"
    print(f"drove {metres:.1f} m = {metres / length:.2f} laps of {args.track} in {info['time_s']:.1f} s ({ending})")
    envs.close()


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--track", default="oval", help="oval, figure-eight, course (default: oval)")
    parser.add_argument("--steps", type=int, default=300_000, help="environment steps to train (default 300000)")
    parser.add_argument("--envs", type=int, default=2, help="environments, each in its own process (default 2)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=Path("out/ppo"), help="model and statistics go here")
    parser.add_argument("--drive", type=Path, metavar="MODEL.zip", help="drive one episode with a trained model")
    args = parser.parse_args()
    if not 64 <= args.steps <= 100_000_000 or not 1 <= args.envs <= 64:
        parser.error("--steps must be 64..1e8 and --envs 1..64")
    drive(args) if args.drive else train(args)
