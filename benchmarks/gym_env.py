"""The Gym environment's speed: steps/s of roar/Race-v0 (50 Hz actions, the firmware core at
1 kHz) for one environment, state only and with the 72-beam lidar, and for two async environments
(processes), beside the bare simulator harness doing the same stepping (and the same lidar scans)
in the same run: the ratio is what the environment adds."""

import time

import numpy as np

TITLE = "Gym environment steps/s (50 Hz control)"
STEPS = 300  # the car drives ahead at 0.2 throttle; it meets the oval's first bend wall at step ~308
REPEATS = 5  # best of, interleaved


def run() -> None:
    try:
        import gymnasium as gym
    except ImportError as e:
        print(f"  skipped: {e}")
        return
    from roar.calibration import Calibration
    from roar_sim.gym_env import LIDAR_BEAMS, LIDAR_EVERY, LIDAR_RANGE_M, PERIOD_S
    from roar_sim.robots.esc import EscCar
    from roar.tracks import get

    message = Calibration().message(0.2, 0.0)

    def bare(lidar: bool) -> float:
        """The harness stepping as the environment does, with the same lidar scans or none."""
        with EscCar(get("oval")) as sim:
            sim.write(Calibration().message(0.0, 0.0))  # armed, as the environment's reset does
            sim.run(PERIOD_S)
            start = time.perf_counter()
            for step in range(STEPS):
                sim.write(message)
                sim.run(PERIOD_S)
                if lidar and step % LIDAR_EVERY == 0:
                    sim.plant.lidar(beams=LIDAR_BEAMS, range_m=LIDAR_RANGE_M)
            return STEPS / (time.perf_counter() - start)

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

    # best of REPEATS, interleaved: this machine's speed drifts from second to second
    bare_state, bare_lidar, state_only, one = (max(r) for r in zip(*[
        (bare(False), bare(True), steps_per_s(lidar_beams=0), steps_per_s()) for _ in range(REPEATS)]))
    envs = gym.make_vec("roar_sim.gym_env:roar/Race-v0", num_envs=2, vectorization_mode="async")
    envs.reset(seed=[0, 1])
    actions = np.tile(action, (2, 1))
    start = time.perf_counter()
    for _ in range(STEPS):
        envs.step(actions)
    two = 2 * STEPS / (time.perf_counter() - start)
    envs.close()
    print(f"  state only: bare harness {bare_state:,.0f} steps/s ({bare_state * PERIOD_S:.0f}x real time), one "
          f"environment {state_only:,.0f} ({state_only / bare_state:.2f} of bare; target >= 0.8)")
    print(f"  with the {LIDAR_BEAMS}-beam lidar every {LIDAR_EVERY}nd step: bare harness {bare_lidar:,.0f} steps/s, one "
          f"environment {one:,.0f} ({one / bare_lidar:.2f} of bare; target >= 0.8); two async environments "
          f"{two:,.0f} steps/s together ({two / one:.2f}x one); f1tenth_gym's recorded 6,757 steps/s is a far "
          f"simpler model")
