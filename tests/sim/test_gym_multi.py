"""Several cars in one world for multi-agent learning (roar_sim.gym_env.multi): PettingZoo's own
API and seed tests, the lidar meeting the other cars, contacts in the reward, seeds giving the same
runs, bad actions and keywords refused in one ValueError."""

import math

import numpy as np
import pytest

pytest.importorskip("pybullet", reason="pip install pybullet (make setup installs it)")
pytest.importorskip("pettingzoo", reason="pip install pettingzoo (make setup installs it)")

from roar_sim.gym_env.multi import parallel_env  # noqa: E402

TRACK = "random:3,width=2.2"


def test_pettingzoos_api_test_passes():
    from pettingzoo.test import parallel_api_test

    import warnings

    env = parallel_env(track=TRACK, cars=3, max_seconds=1.0)
    with warnings.catch_warnings():  # its findings short of an assertion are warnings: each one fails here
        warnings.filterwarnings("error", module="pettingzoo")
        parallel_api_test(env, num_cycles=60)  # raises AssertionError on an API breach
    assert env.agents == []  # every car truncated at max_seconds (50 steps) within the 60 cycles
    env.close()


def test_pettingzoos_seed_test_passes_and_a_seed_gives_the_same_run_bit_for_bit():
    from pettingzoo.test import parallel_seed_test

    parallel_seed_test(lambda: parallel_env(track=TRACK, cars=2, max_seconds=1.0), num_cycles=20)

    def run(seed):
        env = parallel_env(track=TRACK, cars=2, max_seconds=1.0)
        observations, _ = env.reset(seed=seed)
        trace = [observations]
        while env.agents:
            observations, rewards, *_ = env.step({a: np.array([0.6, 0.1]) for a in env.agents})
            trace.append((observations, rewards))
        env.close()
        return trace

    def flat(trace):
        return np.concatenate([np.ravel(v) for item in trace for part in np.atleast_1d(item) for v in _leaves(part)])

    assert np.array_equal(flat(run(7)), flat(run(7)))
    assert not np.array_equal(flat(run(7)), flat(run(8)))


def _leaves(tree):
    if isinstance(tree, dict):
        for key in sorted(tree):
            yield from _leaves(tree[key])
    elif isinstance(tree, (tuple, list)):
        for v in tree:
            yield from _leaves(v)
    else:
        yield np.asarray(tree, dtype=np.float64)


def test_each_cars_lidar_meets_the_car_ahead_and_its_own_state_is_its_own():
    env = parallel_env(track=TRACK, cars=2, lidar_beams=181)
    observations, infos = env.reset(seed=0)
    behind, ahead = observations["car_1"], observations["car_0"]
    assert infos["car_0"]["position"] == 1 and infos["car_1"]["position"] == 2
    assert -2.3 < infos["car_1"]["raced_m"] < -1.7  # a grid slot, 2 m behind
    # the car behind sees the one in front ~1.5 m away straight ahead (its rear at 2 m less its nose)
    middle = behind["lidar"][80:101]
    assert 1.0 < middle.min() < 2.0
    # without the other car its lidar would see the walls alone: compare with a one-car world
    alone = parallel_env(track=TRACK, cars=1, lidar_beams=181)
    single, _ = alone.reset(seed=0)
    assert single["car_0"]["lidar"][80:101].min() > 3.0
    assert np.linalg.norm(behind["state"][:2] - ahead["state"][:2]) == pytest.approx(2.0, abs=0.3)
    env.close()
    alone.close()


def test_driving_into_the_car_ahead_costs_the_reward_and_is_named_in_the_info():
    env = parallel_env(track=TRACK, cars=2, car_contact_penalty=5.0)
    observations, _ = env.reset(seed=0)
    contact = None
    for _ in range(150):  # 3 s: the car behind steers for the one standing still (+ steering: right)
        x, y, cos_yaw, sin_yaw = observations["car_1"]["state"][:4]
        target = observations["car_0"]["state"][:2]
        error = math.remainder(math.atan2(target[1] - y, target[0] - x) - math.atan2(sin_yaw, cos_yaw), math.tau)
        actions = {"car_0": [0.0, 0.0], "car_1": [0.5, max(-1.0, min(1.0, -2.0 * error))]}
        observations, rewards, terminations, _, infos = env.step(actions)
        if infos["car_1"]["car_contact"]:
            contact = rewards, infos
            break
    assert contact is not None, "the car behind never reached the car ahead"
    rewards, infos = contact
    assert infos["car_1"]["car_contact"] == ["car_0"] and infos["car_0"]["car_contact"] == ["car_1"]
    assert rewards["car_0"] < -4.0  # standing still: the penalty alone
    assert rewards["car_1"] < -4.0
    env.close()


def test_a_crashed_car_leaves_the_race_and_the_others_drive_on():
    env = parallel_env(track=TRACK, cars=2, max_seconds=6.0)
    env.reset(seed=0)
    gone = None
    for step in range(300):
        actions = {"car_0": [0.8, 1.0], "car_1": [0.0, 0.0]}  # car_0 steers hard right into the wall
        _, _, terminations, truncations, _ = env.step({a: actions[a] for a in env.agents})
        if terminations.get("car_0"):
            gone = step
            break
    assert gone is not None and env.agents == ["car_1"]
    with pytest.raises(ValueError, match="car_0 not racing"):
        env.step({"car_0": [0.0, 0.0], "car_1": [0.0, 0.0]})
    _, _, terminations, _, infos = env.step({"car_1": [0.3, 0.0]})
    assert set(terminations) == {"car_1"} and not terminations["car_1"]
    env.close()


@pytest.mark.parametrize("actions, words", [
    ({"car_0": [np.nan, 0.0], "car_1": [0.0, 0.0]}, "car_0: an action is (throttle, steering)"),
    ({"car_0": [0.0, 0.0]}, "none for car_1"),
    ({"car_0": [0.0, 0.0], "car_1": [0.0, 0.0], "car_9": [0.0, 0.0]}, "car_9 not racing"),
    ([0.0, 0.0], "actions are a dict"),
])
def test_a_bad_action_is_one_value_error_and_nothing_moves(actions, words):
    env = parallel_env(track=TRACK, cars=2)
    env.reset(seed=0)
    before = env.state()
    with pytest.raises(ValueError) as e:
        env.step(actions)
    assert words in str(e.value) and "\n" not in str(e.value)
    assert np.array_equal(env.state(), before)
    env.close()


@pytest.mark.parametrize("keywords, words", [
    ({"cars": 0}, "cars must be a whole number 1..8"),
    ({"cars": 9}, "cars must be a whole number 1..8"),
    ({"cars": 2, "max_seconds": float("nan"), "lidar_beams": -1}, "max_seconds"),
    ({"cars": 2, "track": "figure-eight"}, "crosses itself"),
    ({"cars": 8, "track": "oval"}, "a grid of 8 cars"),
    ({"cars": 2, "render_mode": "human"}, "render_mode must be one of"),
])
def test_bad_keywords_are_one_value_error(keywords, words):
    with pytest.raises(ValueError) as e:
        parallel_env(**{"track": TRACK, **keywords})
    assert words in str(e.value) and "\n" not in str(e.value)


def test_the_rgb_array_render_shows_the_race_from_behind_the_first_car():
    env = parallel_env(track=TRACK, cars=2, render_mode="rgb_array")
    assert env.render() is None  # nothing to show before reset()
    env.reset(seed=0)
    frame = env.render()
    env.close()
    assert frame.shape == (240, 320, 3) and frame.dtype == np.uint8 and frame.std() > 5.0
