"""ROAR's Gym environment: Gymnasium's own checker passes, actions go through the protocol and the
firmware core, the same seed and actions give the same observations bit for bit (also across
processes in an async vector environment), a crash terminates and the time limit truncates; the
ROAR Junior as the robot, driven by its HTTP requests."""

import os
import subprocess
import sys

import numpy as np
import pytest

from roar.tracks.names import FORMS

gym = pytest.importorskip("gymnasium", reason="pip install gymnasium (make setup installs it)")
pytest.importorskip("pybullet", reason="pip install pybullet (make setup installs it)")

ENV_ID = "roar_sim.gym_env:roar/Race-v0"


def rollout(env, seed: int, steps: int):
    """(observations, rewards) for `steps` actions drawn from a generator seeded with `seed`."""
    rng = np.random.default_rng(seed)
    observation, _ = env.reset(seed=seed)
    observations, rewards = [observation], []
    for _ in range(steps):
        action = np.array([rng.uniform(0.0, 0.6), rng.uniform(-0.3, 0.3)], np.float32)
        observation, reward, terminated, truncated, _ = env.step(action)
        observations.append(observation)
        rewards.append(reward)
        if terminated or truncated:
            break
    return observations, rewards


def same(a, b) -> bool:
    return a.keys() == b.keys() and all(np.array_equal(a[k], b[k]) for k in a)


def test_the_same_seed_and_actions_give_the_same_observations_bit_for_bit():
    env = gym.make(ENV_ID, camera=(64, 48))
    try:
        first, rewards_1 = rollout(env, 5, 60)
        second, rewards_2 = rollout(env, 5, 60)
        other, _ = rollout(env, 6, 60)
    finally:
        env.close()
    assert len(first) == len(second) and all(same(a, b) for a, b in zip(first, second)) and rewards_1 == rewards_2
    assert not same(first[0], other[0])  # the seed draws the start
    assert first[0]["camera"].shape == (48, 64, 3) and first[0]["depth"].shape == (48, 64)


def test_actions_drive_the_car_through_the_firmware_and_progress_is_the_reward():
    env = gym.make(ENV_ID)
    try:
        env.reset(seed=0)
        total = 0.0
        for _ in range(50):
            _, reward, terminated, _, info = env.step(np.array([0.5, 0.0], np.float32))
            total += reward
        assert not terminated and info["throttle_us"] > 1500  # the firmware's pulse to the ESC
        speed = env.unwrapped.sim.state().speed
        assert speed > 0.5 and 0.5 < total < 3.0  # metres along the centre line in 1 s
        with pytest.raises(ValueError, match="two finite numbers"):
            env.step(np.array([np.nan, 0.0]))
    finally:
        env.close()


@pytest.mark.parametrize("keywords, words", [
    ({"camera": (0, 0)}, "camera width must be a finite number 16..1280 px, got 0"),
    ({"camera": (10000, 10000)}, "camera width must be a finite number 16..1280 px, got 10000; camera height"),
    ({"camera": (32.5, 24)}, "camera must be (width, height) in whole pixels"),
    ({"camera": "320x240"}, "camera must be (width, height) in whole pixels"),
    ({"track": 42}, f"track must be a Track or a track's name ({FORMS}), got 42"),
    ({"max_seconds": float("nan")}, "max_seconds must be a finite number more than 0 and at most 86400 s, got nan"),
    ({"max_seconds": float("inf")}, "max_seconds must be a finite number"),
    ({"max_seconds": 0}, "max_seconds must be a finite number more than 0"),
    ({"max_seconds": -1}, "max_seconds must be a finite number more than 0"),
    ({"contact_penalty": float("nan")}, "contact_penalty must be a finite number"),
    ({"contact_penalty": -1}, "contact_penalty must be a finite number 0..1e+06, got -1"),
    ({"crash_ends": "no"}, "crash_ends must be True or False, got 'no'"),
    ({"lidar_beams": 7.5}, "lidar_beams must be a whole number 0..1080, got 7.5"),
    ({"render_mode": "window"}, "render_mode must be one of ['rgb_array', 'human'] or None, got 'window'"),
    ({"robot": 3}, "robot must be a robot's name (esc, iarrc, junior), got 3"),
    ({"profile": "warp"}, "no car profile 'warp': use f1tenth, iarrc, roar or a .toml file"),
    ({"profile": 3}, "profile must be a robot profile's name or a .toml file, got 3"),
    ({"profile": "f1tenth", "robot": "junior"}, "no ROAR Junior profile 'f1tenth': use junior or a .toml file"),
    ({"randomize": {"grip": (0.4, 0.5)}}, "randomize: no profile key 'grip' (keys: brake_torque_nm,"),
    ({"randomize": {"tyre_friction": (0.4, float("nan"))}}, "randomize['tyre_friction'] must be a finite number"),
    ({"randomize": {"latency_s": (0.0, 9.0)}}, "randomize['latency_s'] must be a finite number 0..0.5 s, got 9"),
    ({"randomize": {"latency_s": (0.05, 0.01)}}, "randomize['latency_s']: low 0.05 is above high 0.01"),
    ({"randomize": {"latency_s": 0.05}}, "randomize['latency_s'] must be (low, high), got 0.05"),
    ({"randomize": [("latency_s", 0.05)]}, "randomize must be a dict of profile keys to (low, high)"),
    ({"randomize": {"latency_s": (0, 0.1)}, "robot": "junior"}, "no profile key 'latency_s' (keys: left_deadband_perm"),
    ({"max_seconds": 0, "camera": (0, 0), "track": 42}, "track must be; camera width; camera height; max_seconds"),
])
def test_every_keyword_is_checked_before_the_world_is_built(keywords, words):
    """All that is wrong, in one ValueError naming each keyword; nothing is simulated first."""
    from roar_sim.gym_env import RaceEnv

    with pytest.raises(ValueError) as e:
        RaceEnv(**keywords)
    message = str(e.value)
    assert "\n" not in message and message.startswith("RaceEnv: ")
    for part in words.split("; "):
        assert part in message, message


def test_a_car_profile_is_the_car_the_environment_steps():
    """Race-v0(profile=...) steps the ESC car with that profile's numbers: full throttle for 2 s,
    the F1TENTH-like car goes faster than the ROAR car."""
    from roar_sim.gym_env import RaceEnv

    speeds = {}
    for profile in ("roar", "f1tenth"):
        env = RaceEnv("oval", profile=profile, lidar_beams=0)
        try:
            env.reset(seed=1)
            assert env.sim.profile.name == profile
            for _ in range(100):  # 2 s
                _, _, terminated, _, info = env.step(np.array([1.0, 0.0], np.float32))
                if terminated:
                    break
            speeds[profile] = env.sim.state().speed
        finally:
            env.close()
    assert speeds["f1tenth"] > 1.3 * speeds["roar"], speeds


def test_randomize_draws_each_episodes_car_from_its_seed():
    """Domain randomisation: each episode's car has the keys drawn within their spans; the same seed
    draws the same car (and the same run), another seed another car; the draws are in info."""
    from roar_sim.gym_env import RaceEnv

    spans = {"tyre_friction": (0.35, 0.55), "latency_s": (0.0, 0.06), "steering_trim_deg": (-4.0, 4.0)}
    env = RaceEnv("oval", lidar_beams=0, randomize=spans)
    try:
        runs = []
        for seed in (3, 3, 4):
            _, info = env.reset(seed=seed)
            drawn = info["profile"]
            assert set(drawn) == set(spans) and all(a <= drawn[k] <= b for k, (a, b) in spans.items())
            assert all(getattr(env.sim.profile, k) == v for k, v in drawn.items())
            for _ in range(25):
                observation, *_ = env.step(np.array([0.5, 0.0], np.float32))
            runs.append((drawn, observation["state"].tobytes()))
        assert runs[0] == runs[1] and runs[2][0] != runs[0][0] and runs[2][1] != runs[0][1]
    finally:
        env.close()


def test_randomize_draws_the_sensors_too():
    """The lidar's noise and mount and the camera's mount are drawn per episode from its seed: the
    same seed, the same scan bit for bit; a turned lidar's scan and a tilted camera's depth differ
    from a straight one's from the same start; a sensor's keys need that sensor."""
    from roar_sim.gym_env import RaceEnv

    def first(randomize=None, **kwargs):
        env = RaceEnv("oval", randomize=randomize, **kwargs)
        try:
            return [env.reset(seed=seed) for seed in (5, 5)]
        finally:
            env.close()

    lidar = {"lidar_noise_m": (0.05, 0.1), "lidar_yaw_rad": (0.1, 0.2)}
    (a, info), (b, _) = first(lidar, lidar_beams=36)
    (plain, _), _ = first(lidar_beams=36)
    assert 0.05 <= info["sensors"]["lidar_noise_m"] <= 0.1 and 0.1 <= info["sensors"]["lidar_yaw_rad"] <= 0.2
    assert a["lidar"].tobytes() == b["lidar"].tobytes() and "profile" not in info
    assert np.abs(a["lidar"] - plain["lidar"]).mean() > 0.03
    (tilted, info), _ = first({"camera_pitch_rad": (0.15, 0.2)}, lidar_beams=0, camera=(32, 24))
    (level, _), _ = first(lidar_beams=0, camera=(32, 24))
    assert tilted["depth"][12, 16] < 0.8 * level["depth"][12, 16]  # tilted down, it sees the floor nearer
    with pytest.raises(ValueError, match=r"randomize\['lidar_noise_m'\] draws the lidar's: it needs lidar_beams above "
                                         r"0; randomize\['camera_yaw_rad'\] draws the camera's: it needs camera="):
        RaceEnv("oval", lidar_beams=0, randomize={"lidar_noise_m": (0, 0.1), "camera_yaw_rad": (0, 0.1)})


def test_the_junior_randomizes_its_motors():
    """The Junior's profile keys are drawn too: its left motor weaker than its right, it veers left
    on an even throttle, episode after episode."""
    from roar_sim.gym_env import RaceEnv

    env = RaceEnv("oval", robot="junior", lidar_beams=0, randomize={"left_strength": (0.6, 0.7)})
    try:
        for seed in (1, 2):
            _, info = env.reset(seed=seed)
            assert 0.6 <= info["profile"]["left_strength"] == env.sim.profile.left_strength <= 0.7
            start = env.sim.state().yaw
            for _ in range(50):
                env.step(np.array([1.0, 0.0], np.float32))
            assert 0.2 < env.sim.state().yaw - start < 3.0  # turned left
    finally:
        env.close()


def test_human_rendering_without_a_display_says_how_to_check_headless(monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    with pytest.raises(ValueError, match=r"needs a display .*check_env\(env, skip_render_check=True\)"):
        gym.make(ENV_ID, render_mode="human")


@pytest.mark.parametrize("beyond, within", [([2.0, 0.0], [1.0, 0.0]), ([1e308, 0.0], [1.0, 0.0]),
                                            ([-5.0, 5.0], [-1.0, 1.0])])
def test_actions_beyond_the_range_are_clipped_to_it(beyond, within):
    """As the docs say: each value is clipped to -1..1 -- the same pulses as the bound itself."""
    pulses = []
    for action in (beyond, within):
        env = gym.make(ENV_ID)
        try:
            env.reset(seed=0)
            pulses.append([env.step(np.array(action))[4]["throttle_us"] for _ in range(3)])
        finally:
            env.close()
    assert pulses[0] == pulses[1]


@pytest.mark.parametrize("action", [[np.inf, 0.0], [0.0, np.nan], [1.0], [1.0, 0.0, 0.0], "fast", None])
def test_an_action_that_is_not_two_finite_numbers_is_refused(action):
    env = gym.make(ENV_ID, lidar_beams=0)
    try:
        env.reset(seed=0)
        with pytest.raises(ValueError, match=r"two finite numbers \(each clipped to -1..1\)"):
            env.step(action)
    finally:
        env.close()


def test_a_wall_terminates_and_the_time_limit_truncates():
    env = gym.make(ENV_ID, max_seconds=1.0)
    try:
        env.reset(seed=0)
        steps = 0
        while True:
            _, _, terminated, truncated, _ = env.step(np.array([0.2, 0.0], np.float32))
            steps += 1
            if terminated or truncated:
                break
        assert truncated and not terminated and steps == 49  # 1 s of 20 ms actions after the arming period
    finally:
        env.close()
    env = gym.make(ENV_ID)
    try:
        env.reset(seed=0)
        for _ in range(500):  # full throttle, hard left: into the inner wall
            _, reward, terminated, truncated, info = env.step(np.array([1.0, -1.0], np.float32))
            if terminated:
                break
        assert terminated and not truncated
    finally:
        env.close()


def test_an_async_vector_environment_gives_what_serial_ones_give():
    envs = gym.make_vec(ENV_ID, num_envs=2, vectorization_mode="async")
    try:
        observations, _ = envs.reset(seed=[11, 12])
        rng = np.random.default_rng(0)
        actions = [rng.uniform([0.0, -0.3], [0.6, 0.3], (2, 2)).astype(np.float32) for _ in range(30)]
        vector = [observations]
        for action in actions:
            observations, *_ = envs.step(action)
            vector.append(observations)
    finally:
        envs.close()
    for i, seed in enumerate((11, 12)):
        env = gym.make(ENV_ID)
        try:
            serial = [env.reset(seed=seed)[0]]
            serial += [env.step(action[i])[0] for action in actions]
        finally:
            env.close()
        assert all(same({k: v[i] for k, v in vec.items()}, one) for vec, one in zip(vector, serial))


def alone(seed: int, actions, **kwargs) -> list:
    """(observation, reward, terminated, truncated) after each action of one RaceEnv alone, reset
    with `seed` and, after an episode ends, on the next step without one (next-step autoreset)."""
    env = gym.make(ENV_ID, disable_env_checker=True, **kwargs)
    try:
        observation, _ = env.reset(seed=seed)
        out, ended = [(observation, 0.0, False, False)], False
        for action in actions:
            if ended:
                observation, _ = env.reset()
                out.append((observation, 0.0, False, False))
                ended = False
                continue
            observation, reward, terminated, truncated, _ = env.step(action)
            out.append((observation, reward, terminated, truncated))
            ended = terminated or truncated
        return out
    finally:
        env.close()


@pytest.mark.parametrize("num_envs, workers", [(3, 2), (2, 1)])
def test_our_vector_environment_gives_what_each_environment_alone_gives(num_envs, workers):
    """Environments on every core (roar_sim.gym_env.vector): each equals a RaceEnv alone with its seed
    and actions, bit for bit, through episodes that end (0.6 s: truncated) and reset by themselves."""
    from roar_sim.gym_env.vector import RaceVectorEnv

    rng = np.random.default_rng(num_envs)
    actions = [rng.uniform([0.0, -0.3], [0.6, 0.3], (num_envs, 2)).astype(np.float32) for _ in range(70)]
    envs = RaceVectorEnv(num_envs, workers=workers, max_seconds=0.6)
    try:
        observation, info = envs.reset(seed=20)
        vector = [(observation, np.zeros(num_envs), np.zeros(num_envs, bool), np.zeros(num_envs, bool))]
        vector += [envs.step(action)[:4] for action in actions]
        assert info["time_s"].shape == (num_envs,) and len(envs._processes) == workers - 1  # and this one
    finally:
        envs.close()
    assert not any(process.is_alive() for process in envs._processes)
    for i in range(num_envs):
        serial = alone(20 + i, [a[i] for a in actions], max_seconds=0.6)
        assert sum(t for _, _, _, t in serial) >= 2  # episodes ended and began again
        for (obs, rewards, terms, truncs), (one, reward, term, trunc) in zip(vector, serial, strict=True):
            assert same({k: v[i] for k, v in obs.items()}, one)
            assert (rewards[i], terms[i], truncs[i]) == (reward, term, trunc)


def test_same_step_autoreset_gives_what_gymnasiums_own_vector_environment_gives():
    """autoreset_mode=SAME_STEP (what SB3 and CleanRL expect): observations, rewards, ends and each
    ended episode's last observation equal Gymnasium's SyncVectorEnv of RaceEnvs, bit for bit;
    call, get_attr and set_attr reach the environments in every process."""
    from gymnasium.vector import AutoresetMode, SyncVectorEnv

    from roar_sim.gym_env import RaceEnv
    from roar_sim.gym_env.vector import RaceVectorEnv

    rng = np.random.default_rng(7)
    actions = [rng.uniform([0.0, -0.3], [0.6, 0.3], (3, 2)).astype(np.float32) for _ in range(70)]
    ours = RaceVectorEnv(3, workers=2, autoreset_mode="SameStep", max_seconds=0.6, lidar_beams=8)
    theirs = SyncVectorEnv([lambda: RaceEnv(max_seconds=0.6, lidar_beams=8)] * 3,
                           autoreset_mode=AutoresetMode.SAME_STEP)
    ends = 0
    try:
        assert ours.metadata["autoreset_mode"] == AutoresetMode.SAME_STEP
        assert same(ours.reset(seed=30)[0], theirs.reset(seed=30)[0])
        for action in actions:
            (obs, reward, term, trunc, info), (obs1, reward1, term1, trunc1, info1) = ours.step(action), \
                theirs.step(action)
            assert same(obs, obs1) and np.array_equal(reward, reward1)
            assert np.array_equal(term, term1) and np.array_equal(trunc, trunc1)
            assert np.array_equal(info.get("_final_obs", np.zeros(3, bool)), term1 | trunc1)
            for i in np.flatnonzero(term1 | trunc1):
                ends += 1
                assert same(info["final_obs"][i], info1["final_obs"][i])
        assert ours.get_attr("max_seconds") == (0.6,) * 3
        ours.set_attr("contact_penalty", [1.0, 2.0, 3.0])
        assert ours.call("contact_penalty") == (1.0, 2.0, 3.0)
        assert [track.name for track in ours.get_attr("track")] == ["oval"] * 3
    finally:
        ours.close()
        theirs.close()
    assert ends >= 6  # every environment ended episodes twice or more
    with pytest.raises(ValueError, match="autoreset_mode must be one of NextStep, SameStep"):
        RaceVectorEnv(2, autoreset_mode="Disabled")


def test_stable_baselines3s_vector_environment_gives_what_its_own_gives():
    """roar_sim.gym_env.sb3.RaceVecEnv on 2 processes equals SB3's SubprocVecEnv of RaceEnvs (a
    process each): same seeds, observations, rewards, dones, terminal observations, time limits."""
    pytest.importorskip("stable_baselines3", reason="pip install stable-baselines3 (make setup installs it)")
    from stable_baselines3.common.vec_env import SubprocVecEnv

    from roar_sim.gym_env import RaceEnv
    from roar_sim.gym_env.sb3 import RaceVecEnv

    rng = np.random.default_rng(8)
    actions = [rng.uniform([0.0, -0.3], [0.6, 0.3], (3, 2)).astype(np.float32) for _ in range(70)]
    ours = RaceVecEnv(3, workers=2, max_seconds=0.6)
    theirs = SubprocVecEnv([lambda: RaceEnv(max_seconds=0.6)] * 3, start_method="fork")
    dones = 0
    try:
        ours.seed(40)
        theirs.seed(40)
        assert same(ours.reset(), theirs.reset())
        for action in actions:
            for env in (ours, theirs):
                env.step_async(action)
            (obs, reward, done, info), (obs1, reward1, done1, info1) = ours.step_wait(), theirs.step_wait()
            assert same(obs, obs1) and np.array_equal(reward, reward1) and np.array_equal(done, done1)
            for a, b in zip(info, info1):
                assert a["TimeLimit.truncated"] == b["TimeLimit.truncated"]
                assert ("terminal_observation" in a) == ("terminal_observation" in b)
                if "terminal_observation" in b:
                    dones += 1
                    assert same(a["terminal_observation"], b["terminal_observation"])
        assert ours.get_attr("max_seconds", indices=[1]) == [0.6]
        assert ours.env_method("get_wrapper_attr", "max_seconds") == [0.6] * 3
    finally:
        ours.close()
        theirs.close()
    assert dones >= 6


def test_make_vec_gives_our_vector_environment_and_it_explains_bad_keywords():
    from roar_sim.gym_env.vector import RaceVectorEnv

    envs = gym.make_vec(ENV_ID, num_envs=2, vectorization_mode="vector_entry_point", lidar_beams=0)
    try:
        assert isinstance(envs.unwrapped, RaceVectorEnv) and set(envs.observation_space.spaces) == {"state"}
        observation, _ = envs.reset(seed=1)
        assert observation["state"].shape == (2, 8)
    finally:
        envs.close()
    with pytest.raises(ValueError, match="max_seconds"):
        RaceVectorEnv(2, max_seconds=-1)
    with pytest.raises(ValueError, match="workers .* must be a whole number"):
        RaceVectorEnv(2, workers=3)


def test_a_bad_action_is_refused_whole_and_a_dead_process_is_reported():
    import signal

    from roar_sim.gym_env.vector import RaceVectorEnv

    envs = RaceVectorEnv(2, workers=2, lidar_beams=0)
    try:
        envs.reset(seed=0)
        with pytest.raises(ValueError, match="finite numbers"):
            envs.step(np.array([[0.1, 0.0], [np.nan, 0.0]], np.float32))
        before = envs.step(np.zeros((2, 2), np.float32))[0]["state"]  # refused whole: nothing moved
        assert before.shape == (2, 8)
        (process,) = envs._processes
        os.kill(process.pid, signal.SIGKILL)
        with pytest.raises(RuntimeError, match="worker died"):
            envs.step(np.zeros((2, 2), np.float32))
    finally:
        envs.close()
    assert not process.is_alive()


CHECK = """
import gymnasium as gym
from gymnasium.utils.env_checker import check_env
env = gym.make("roar_sim.gym_env:roar/Race-v0", render_mode="rgb_array")
check_env(env.unwrapped)
env.reset(seed=0)
frame = env.render()
assert frame.shape == (240, 320, 3) and frame.std() > 5
check_env(gym.make("roar_sim.gym_env:roar/Race-v0", robot="junior", render_mode="rgb_array").unwrapped)
print("CHECKED")
"""


def test_gymnasiums_checker_passes_with_both_render_modes(virtual_display):
    """check_env makes the environment in every declared render mode, `human` (the PyBullet
    window) too: on a virtual screen."""
    result = subprocess.run([sys.executable, "-W", "error::UserWarning:gymnasium", "-c", CHECK],
                            capture_output=True, text=True, timeout=300, env={**os.environ, "DISPLAY": virtual_display})
    assert result.returncode == 0 and "CHECKED" in result.stdout, result.stderr[-3000:]


def test_the_lidar_is_a_scan_every_second_action_or_none_at_all():
    env = gym.make(ENV_ID)
    try:
        env.reset(seed=0)
        scans = [env.step(np.array([0.6, 0.0], np.float32))[0]["lidar"] for _ in range(6)]
    finally:
        env.close()
    assert scans[0].shape == (72,) and np.all(scans[0] > 0)
    assert [np.array_equal(a, b) for a, b in zip(scans, scans[1:])] == [False, True, False, True, False]
    env = gym.make(ENV_ID, lidar_beams=0)
    try:
        assert set(env.reset(seed=0)[0]) == {"state"} and set(env.observation_space.spaces) == {"state"}
    finally:
        env.close()
    with pytest.raises(ValueError, match="lidar_beams"):
        gym.make(ENV_ID, lidar_beams=-1)


def test_the_junior_drives_by_its_http_requests_and_observes_its_ultrasonic():
    """robot="junior": each action is the GET the http:// transport sends, read by the Junior's
    firmware; the L298N duties are the firmware's, the range is its reply."""
    env = gym.make(ENV_ID, robot="junior")
    try:
        observation, _ = env.reset(seed=0)
        assert set(observation) == {"state", "ultrasonic"}
        total, ranges = 0.0, []
        for _ in range(150):
            observation, reward, terminated, _, info = env.step(np.array([0.8, 0.0], np.float32))
            total += reward
            ranges.append(float(observation["ultrasonic"][0]))
        assert not terminated and info["duty_permille"] == (800, 800)
        assert 0.6 < total < 1.6  # metres along the centre line in 3 s (the Junior tops out near 0.55 m/s)
        # the reply to the latest request: the firmware's whole centimetres, one period old
        assert ranges[-1] == pytest.approx(env.unwrapped.sim.board.distance_cm / 100, abs=0.05)
        assert all(abs(r * 100 - round(r * 100)) < 1e-4 for r in ranges)
        assert ranges[-1] < ranges[0] - 0.5  # the bend's wall ahead comes nearer
        first, _ = rollout(env, 3, 40)
        second, _ = rollout(env, 3, 40)
        assert all(same(a, b) for a, b in zip(first, second))
    finally:
        env.close()
    with pytest.raises(ValueError, match="no lidar"):
        gym.make(ENV_ID, robot="junior", lidar_beams=72)
    with pytest.raises(ValueError, match="unknown robot 'truck': use one of esc, iarrc, junior"):
        gym.make(ENV_ID, robot="truck")
