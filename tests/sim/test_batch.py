"""The batched world (roar_sim.batch, roar/BatchRace-v0): its board loops are the core's, bit for
bit with the single-car board, across the 32-bit clock's wrap and the failsafe; its car matches the
PyBullet car closely on a lap and over 1 s of pulses; its lidar meets the walls where Bullet's rays
do; its vector environment is Race-v0's spaces, gives each car what that car alone gives, the same
seeds the same runs, refuses bad input in one line, and learns."""

import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

gym = pytest.importorskip("gymnasium", reason="pip install gymnasium (make setup installs it)")
pytest.importorskip("numba", reason="pip install numba (make setup installs it)")
pytest.importorskip("pybullet", reason="pip install pybullet (make setup installs it)")

from roar.protocol import encode, spec  # noqa: E402
from roar.tracks import get  # noqa: E402
from roar_sim.batch.boards import Boards  # noqa: E402
from roar_sim.core.car import CarBoard  # noqa: E402

N = spec.CONTROL_NEUTRAL_US
WRAP_US = 1 << 32  # [us] a board's counter wraps here


def command_script(seed: int, periods: int) -> list[tuple[int, int]]:
    """(throttle, steering) [us] per control period, 0 throttle for silence: driving, braking into
    reverse (the brake/reverse sequence), silences longer than the failsafe's timeout and back."""
    rng = np.random.default_rng(seed)
    script = []
    while len(script) < periods:
        kind = rng.integers(4)
        hold = int(rng.integers(3, 25))
        if kind == 0:  # silence: 60-500 ms
            script += [(0, 0)] * hold
        elif kind == 1:
            script += [(int(rng.integers(N + 30, spec.CONTROL_MAX_US + 1)), int(rng.integers(1000, 2001)))] * hold
        elif kind == 2:
            script += [(int(rng.integers(spec.CONTROL_MIN_US, N - 30)), int(rng.integers(1000, 2001)))] * hold
        else:
            script += [(N, N)] * hold
    return script[:periods]


def test_the_batch_runs_the_cores_board_loop_bit_for_bit_across_the_clocks_wrap():
    starts = [0, 7_000, WRAP_US - 150_000, WRAP_US - 1_000, WRAP_US - 20_000 * 13 - 3_000]  # [us] some wrap soon
    periods = 150
    scripts = [command_script(seed, periods) for seed in range(len(starts))]
    boards = Boards(len(starts), start_us=starts)
    singles = [CarBoard(start_us=s) for s in starts]
    for board in singles:
        board.begin()
    phases, seen = set(), 0
    for k in range(periods):
        throttle = np.array([s[k][0] for s in scripts], np.uint16)
        steering = np.array([s[k][1] for s in scripts], np.uint16)
        wire = boards.run(throttle, steering, 20)
        for i, board in enumerate(singles):
            if throttle[i]:
                board.serial_in(encode(int(throttle[i]), int(steering[i])))
            for loop in range(20):
                board.run(1)
                assert tuple(wire[loop, i]) == board.wire, f"car {i}, period {k}, loop {loop}"
            assert boards.now_us(i) == board.hal.now_us
            phases.add(board.outputs.brake_phase)
            seen += board.outputs.latched
    assert seen and len(phases) >= 3  # the failsafe latched and the brake sequence ran
    assert any(boards.now_us(i) < starts[i] for i in range(len(starts)))  # the counters wrapped


def test_a_board_not_run_keeps_its_time_and_a_reboot_starts_it_latched():
    boards = Boards(3)
    neutral = np.full(3, N, np.uint16)
    boards.run(neutral, neutral, 20)
    before = boards.now_us(1)
    boards.run(np.full(3, 1800, np.uint16), neutral, 20, cars=np.array([True, False, True]))
    assert boards.now_us(1) == before and boards.now_us(0) == before + 20_000
    forward = boards.run(np.full(3, 1800, np.uint16), neutral, 40)
    assert forward[-1, 0, 0] == 1800
    boards.reboot([0])
    again = boards.run(np.full(3, 1800, np.uint16), neutral, 40)
    assert again[-1, 0, 0] == N and again[-1, 2, 0] == 1800  # rebooted: latched until it hears neutral


def test_bad_batch_sizes_are_refused_in_one_line():
    from roar_sim.gym_env.batched import BatchRaceEnv

    for bad, words in ((0, "num_envs must be a whole number 1..65536, got 0"), (2.5, "got 2.5"),
                       (True, "got True")):
        with pytest.raises(ValueError, match="^BatchRaceEnv: ") as e:
            BatchRaceEnv(bad)
        assert words in str(e.value) and "\n" not in str(e.value)
    with pytest.raises(ValueError, match="unknown track 'nowhere'"):
        BatchRaceEnv(2, track="nowhere")
    with pytest.raises(ValueError, match=r"randomize\['camera_yaw_rad'\] draws the camera's: it needs camera="):
        BatchRaceEnv(2, randomize={"camera_yaw_rad": (0, 0.1)})
    with pytest.raises(ValueError, match=r"camera width must be a finite number 16\.\.1280 px, got 8"):
        BatchRaceEnv(2, camera=(8, 100))


def test_nan_actions_are_refused_naming_the_car_and_nothing_moves():
    from roar_sim.gym_env.batched import BatchRaceEnv

    env = BatchRaceEnv(3)
    env.reset(seed=1)
    before = env.world.states().copy()
    actions = np.zeros((3, 2))
    actions[2, 0] = np.nan
    with pytest.raises(ValueError, match=r"got car 2's \[nan, 0.0\]"):
        env.step(actions)
    with pytest.raises(ValueError, match=r"got shape \(2,\)"):
        env.step(np.zeros(2))
    assert np.array_equal(env.world.states(), before)


def rollout(env, seed: int, steps: int, n: int):
    rng = np.random.default_rng(seed)
    observation, _ = env.reset(seed=seed)
    out = [observation]
    for _ in range(steps):
        actions = np.column_stack([rng.uniform(0.1, 1.0, n), rng.uniform(-1.0, 1.0, n)])
        observation, reward, terminated, truncated, _ = env.step(actions)
        out.append((observation, reward, terminated, truncated))
    return out


def test_each_car_is_what_it_is_alone_and_the_same_seeds_give_the_same_runs():
    """The batch of 4 against a SyncVectorEnv of 4 one-car batched environments (roar/BatchRace-v0),
    with every car randomised, ends and autoresets among them; and against itself."""
    from roar_sim.gym_env.batched import BatchCarEnv, BatchRaceEnv

    keywords = dict(track="figure-eight", randomize={"tyre_friction": (0.4, 0.6), "latency_s": (0.0, 0.05),
                                                      "lidar_noise_m": (0.0, 0.05)}, max_seconds=3.0)
    batch = rollout(BatchRaceEnv(4, **keywords), 11, 200, 4)
    again = rollout(BatchRaceEnv(4, **keywords), 11, 200, 4)
    singles = gym.vector.SyncVectorEnv([lambda: BatchCarEnv(**keywords) for _ in range(4)])
    alone = rollout(singles, 11, 200, 4)
    ends = 0
    for a, b, c in zip(batch[1:], again[1:], alone[1:]):
        for part in range(4):
            x, y, z = a[part], b[part], c[part]
            if isinstance(x, dict):
                assert all(np.array_equal(x[key], y[key]) and np.array_equal(x[key], z[key]) for key in x)
            else:
                assert np.array_equal(x, y) and np.array_equal(x, z)
        ends += int(a[2].sum() + a[3].sum())
    assert ends >= 4  # episodes ended (walls, time) and began again within the run


def test_the_vector_api_has_race_v0s_spaces_and_both_autoresets():
    from gymnasium.vector.vector_env import AutoresetMode

    from roar_sim.gym_env import RaceEnv
    from roar_sim.gym_env.batched import BatchRaceEnv

    env = gym.make_vec("roar_sim.gym_env:roar/BatchRace-v0", num_envs=3,
                       vectorization_mode="vector_entry_point", max_seconds=0.5)
    single = RaceEnv(track="oval")
    assert env.single_observation_space == single.observation_space
    assert env.single_action_space == single.action_space
    observation, info = env.reset(seed=2)
    assert env.observation_space.contains(observation) and info["time_s"].tolist() == [0.02] * 3
    for _ in range(24):  # 0.5 s with the arming period
        observation, reward, terminated, truncated, info = env.step(np.zeros((3, 2)))
    assert truncated.all() and not terminated.any()
    observation, reward, terminated, truncated, info = env.step(np.ones((3, 2)))  # next step: reset, action unused
    assert (reward == 0).all() and info["time_s"].tolist() == [0.02] * 3
    same = BatchRaceEnv(3, max_seconds=0.5, autoreset_mode=AutoresetMode.SAME_STEP)
    same.reset(seed=2)
    for _ in range(24):
        observation, reward, terminated, truncated, info = same.step(np.zeros((3, 2)))
    assert truncated.all() and info["_final_obs"].all() and info["time_s"].tolist() == [0.02] * 3
    assert info["final_info"][0]["time_s"] == pytest.approx(0.5)
    env.close()
    single.close()


def test_the_lidar_meets_the_walls_where_bullets_rays_do():
    """From poses along two tracks (on the centre line and off it, turned), the marched 1,080-beam
    scan against PyBullet's own rays from the same lidar: within 1 cm but where a beam grazes a wall's
    end."""
    from roar_sim.batch.world import BatchWorld
    from roar_sim.plants.racecar import Racecar
    from roar_sim.world.bullet import pb

    for name in ("oval", "random:2"):
        track = get(name)
        world = BatchWorld(1, pool=None, tracks=[track])
        car = Racecar(track)
        try:
            rng = np.random.default_rng(0)
            for s in np.linspace(0, track.length_m, 6, endpoint=False):
                x, y, yaw = track.pose_at(float(s), float(rng.uniform(-0.2, 0.2)))
                yaw += float(rng.uniform(-0.3, 0.3))
                pb.resetBasePositionAndOrientation(car.car, [x, y, 0.05], pb.getQuaternionFromEuler([0, 0, yaw]),
                                                   physicsClientId=car.client)
                world.reset([0], [[x, y, yaw]])
                bullet = car.lidar(beams=1080)
                ours = world.scan(beams=1080)[0]
                error = np.abs(ours - bullet)
                assert np.percentile(error, 99) < 0.01 and np.median(error) < 0.001, (name, s, error.max())
        finally:
            car.close()


def test_the_batched_car_laps_as_the_pybullet_car_does():
    """The same pure-pursuit driver round the figure eight in both worlds: the flying lap within 3 %
    and the path within 5 cm RMS (docs/gym.md has every track's figures; make bench measures five)."""
    from roar_sim.batch.fidelity import closed_loop
    from roar_sim.plants import car_profile

    laps = closed_loop(get("figure-eight"), car_profile.load())
    assert len(laps.pybullet.laps) == len(laps.batch.laps) == 2
    assert abs(laps.time_ratio[1] - 1) <= 0.03, laps.time_ratio
    assert laps.path_rms_m <= 0.05
    assert laps.pybullet.walls == laps.batch.walls == 0


def test_the_camera_sees_what_pybullets_does_as_the_lane_detector_finds_it():
    """From poses along three tracks (off the centre line and turned), the batched camera's frame and
    PyBullet's at 320 x 240: the lane detector finds the road's centre in both, and where it puts it
    0.6-1.2 m ahead differs by a median of at most 2 px (docs/gym.md states the spread); depth agrees
    where both see the floor."""
    from roar.vision.geometry import SIMULATED_CAR_CAMERA, BirdsEye
    from roar.vision.lanes import LaneDetector
    from roar_sim.batch.camera import FloorPool, render
    from roar_sim.batch.world import BatchWorld
    from roar_sim.plants.racecar import Racecar
    from roar_sim.world.bullet import pb

    width, height = 320, 240
    model = SIMULATED_CAR_CAMERA.model(width, height)
    errors, floor_depth = [], []
    for name in ("oval", "random:1", "figure-eight"):
        track = get(name)
        world = BatchWorld(1, tracks=[track])
        floors = FloorPool(world.pool)
        car = Racecar(track)
        try:
            for _ in range(30):  # settled on its wheels
                car.step()
            z = pb.getBasePositionAndOrientation(car.car, physicsClientId=car.client)[0][2]
            rng = np.random.default_rng(1)
            for s in np.linspace(0, track.length_m, 10, endpoint=False):
                x, y, yaw = track.pose_at(float(s), float(rng.uniform(-0.15, 0.15)))
                yaw += float(rng.uniform(-0.15, 0.15))
                pb.resetBasePositionAndOrientation(car.car, [x, y, z], pb.getQuaternionFromEuler([0, 0, yaw]),
                                                   physicsClientId=car.client)
                world.reset([0], [[x, y, yaw]])
                theirs, their_depth = car.camera(width, height)
                ours, our_depth = render(world, floors, width, height)
                seen = [LaneDetector(BirdsEye(model)).detect(frame).centre for frame in (theirs, ours[0])]
                assert all(seen), (name, s)
                for ahead in (0.6, 0.9, 1.2):
                    u = [model.project(np.array([ahead]), np.array([line.y(ahead)]))[0][0] for line in seen]
                    errors.append(abs(u[0] - u[1]))
                floor_depth.append(np.abs(our_depth[0, -60:] - their_depth[-60:]).max())  # the nearest rows
        finally:
            car.close()
    assert np.median(errors) <= 2.0, np.percentile(errors, [50, 90, 100])
    assert max(floor_depth) < 0.01



def test_the_camera_sees_a_tunnels_cones_and_people_and_added_boxes_where_pybullet_does():
    """tunnel:3's cones (orange) and people (blue) from poses along it, and a box added to the
    pool's oval: the batched frame's pixels of each colour overlap PyBullet's (TinyRenderer's) by
    nine in ten where either has them."""
    from roar_sim.batch.camera import FloorPool, render
    from roar_sim.batch.world import BatchWorld
    from roar_sim.plants.racecar import Racecar
    from roar_sim.world.appearance import solid_row
    from roar_sim.world.bullet import pb
    from roar_sim.world.obstacles import BOX_RGBA, add_box

    def masks(rgb):
        rgb = rgb.astype(int)
        orange = (rgb[..., 0] > 120) & (rgb[..., 1] > 30) & (rgb[..., 2] < 40)
        blue = (rgb[..., 2] > 1.5 * rgb[..., 0]) & (rgb[..., 2] > 60)
        return orange, blue

    overlaps = []
    for name in ("tunnel:3", "oval"):
        track = get(name)
        world = BatchWorld(1, tracks=[track])
        floors = FloorPool(world.pool)
        car = Racecar(track)
        try:
            if name == "oval":  # a box 1.5 m ahead of the start, in both worlds
                x, y, yaw = track.pose_at(2.0, 0.1)
                add_box(car.world, x, y, yaw=yaw)
                floors.add(0, [solid_row(x, y, yaw, 0.1, 0.1, 0.0, 0.2, 0.0, BOX_RGBA)])
            for _ in range(30):
                car.step()
            z = pb.getBasePositionAndOrientation(car.car, physicsClientId=car.client)[0][2]
            for s in (np.linspace(0, track.length_m, 12, endpoint=False) if name != "oval" else [0.3]):
                x, y, yaw = track.pose_at(float(s))
                pb.resetBasePositionAndOrientation(car.car, [x, y, z], pb.getQuaternionFromEuler([0, 0, yaw]),
                                                   physicsClientId=car.client)
                world.reset([0], [[x, y, yaw]])
                theirs = masks(car.camera(320, 240)[0])
                ours = masks(render(world, floors, 320, 240)[0][0])
                for a, b in zip(theirs, ours):
                    if (a | b).sum() > 200:  # something of that colour in view
                        overlaps.append((a & b).sum() / (a | b).sum())
        finally:
            car.close()
    assert len(overlaps) >= 5 and min(overlaps) >= 0.9, overlaps


EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "train_ppo.py"


@pytest.fixture(scope="module")
def batched_policy(tmp_path_factory):
    """examples/train_ppo.py --batched: 128 cars of the batched world until episodes average two
    laps of the oval (make bench times it); the training's printout and the model's folder."""
    pytest.importorskip("stable_baselines3", reason="pip install 'roar-platform[rl]' (make setup installs it)")
    out = tmp_path_factory.mktemp("ppo_batched")
    # the suite's other workers keep both cores busy: torch's two OpenMP threads then wait for each
    # other asleep, not spinning (the same policy; alone it trains faster spinning, make bench's case)
    trained = subprocess.run([sys.executable, str(EXAMPLE), "--batched", "--steps", "1000000", "--out", str(out)],
                             capture_output=True, text=True, timeout=600,
                             env={**os.environ, "OMP_WAIT_POLICY": "PASSIVE"})
    assert trained.returncode == 0, trained.stdout[-1000:] + trained.stderr[-2000:]
    return trained.stdout, out


@pytest.mark.xdist_group("batched_policy")  # one training for both tests
def test_ppo_on_the_batched_world_learns_two_laps_and_drives_the_pybullet_car(batched_policy):
    """Environments' and learner's times printed apart; the policy drives the PyBullet car (RaceEnv)
    two laps or more, no wall; the example refuses --batched with processes of its own."""
    printed, out = batched_policy
    assert re.search(r"^reached 2 laps/episode on oval: .* environments [0-9.]+ s, learner [0-9.]+ s\)$", printed,
                     re.M), printed
    driven = subprocess.run([sys.executable, str(EXAMPLE), "--drive", str(out / "model.zip")],
                            capture_output=True, text=True, timeout=300)
    found = re.search(r"drove [0-9.]+ m = ([0-9.]+) laps of oval in [0-9.]+ s \(time up\)", driven.stdout)
    assert driven.returncode == 0 and found and float(found.group(1)) >= 2.0, driven.stdout + driven.stderr[-2000:]
    bad = subprocess.run([sys.executable, str(EXAMPLE), "--batched", "--workers", "2", "--steps", "64"],
                         capture_output=True, text=True, timeout=300)
    assert bad.returncode == 2 and "--batched steps its cars in this process" in bad.stderr, bad.stderr


@pytest.mark.xdist_group("batched_policy")
def test_the_batched_policy_drives_sim_by_its_url(batched_policy):
    """The same policy drives sim://oval through roar.Vehicle (in real time: the car's failsafe
    keeps its 250 ms on a busy machine) two laps in 16 s of the car's time, never at a wall."""
    _, out = batched_policy
    by_url = subprocess.run([sys.executable, str(EXAMPLE), "--drive", str(out / "model.zip"), "--url", "sim://oval",
                             "--seconds", "16"], capture_output=True, text=True, timeout=300)
    found = re.search(r"drove [0-9.]+ m = ([0-9.]+) laps of oval in 1[0-9.]+ s on sim://oval; nearest a wall "
                      r"[0-9.]+ m \(never touched one\)", by_url.stdout)
    assert by_url.returncode == 0 and found and float(found.group(1)) >= 2.0, by_url.stdout + by_url.stderr[-2000:]
