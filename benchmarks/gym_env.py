"""The Gym environment's speed: steps/s of roar/Race-v0 (50 Hz actions, the firmware core at
1 kHz, state + 72-beam lidar observations) for one environment and for two async environments
(processes), beside the bare simulator harness doing the same stepping in the same run."""

import time

import numpy as np

TITLE = "Gym environment steps/s (50 Hz control)"
STEPS = 300


def run() -> None:
    try:
        import gymnasium as gym
    except ImportError as e:
        print(f"  skipped: {e}")
        return
    from roar.calibration import Calibration
    from roar_sim.gym_env import PERIOD_S
    from roar_sim.harness import SimCar
    from roar_sim.track import get

    message = Calibration().message(0.2, 0.0)
    with SimCar(get("oval")) as sim:
        start = time.perf_counter()
        for _ in range(STEPS):
            sim.write(message)
            sim.run(PERIOD_S)
        bare = STEPS / (time.perf_counter() - start)
    action = np.array([0.2, 0.0], np.float32)

    def steps_per_s(**options) -> float:
        env = gym.make("roar_sim.gym_env:roar/Race-v0", **options)
        env.reset(seed=0)
        start = time.perf_counter()
        for _ in range(STEPS):
            env.step(action)
        rate = STEPS / (time.perf_counter() - start)
        env.close()
        return rate

    one, state_only = steps_per_s(), steps_per_s(lidar_beams=0)
    envs = gym.make_vec("roar_sim.gym_env:roar/Race-v0", num_envs=2, vectorization_mode="async")
    envs.reset(seed=[0, 1])
    actions = np.tile(action, (2, 1))
    start = time.perf_counter()
    for _ in range(STEPS):
        envs.step(actions)
    two = 2 * STEPS / (time.perf_counter() - start)
    envs.close()
    print(f"  bare harness {bare:,.0f} steps/s ({bare * PERIOD_S:.0f}x real time); one environment {one:,.0f} "
          f"steps/s ({one / bare:.2f} of bare; target >= 0.8), without the lidar {state_only:,.0f} "
          f"({state_only / bare:.2f}); two async environments {two:,.0f} steps/s together ({two / one:.2f}x one); "
          f"f1tenth_gym's recorded 6,757 steps/s is a far simpler model")
