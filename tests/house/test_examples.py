"""The README's promise: a short script drives the simulated car, and the same script drives a
car on a serial port by changing only the URL (here the simulated car behind a real pty)."""

import csv
import math
import subprocess
import sys
import time

import numpy as np
import pytest

from conftest import ROOT, wait_for


CIRCLE = ROOT / "examples" / "circle.py"
WHEEL_CIRCUMFERENCE_M = 2 * math.pi * 0.05  # [m] racecar.urdf
ENCODER_COUNTS_PER_REV = 1024


def test_the_example_is_short():
    lines = [line for line in CIRCLE.read_text().splitlines() if line.strip()]
    assert len(lines) <= 15


@pytest.mark.realtime  # keeps to the wall clock: one at a time under xdist (conftest)
def test_the_same_script_drives_the_simulator_and_a_serial_car(tmp_path, pty_car):
    trace = tmp_path / "circle.csv"
    # Both at once: the in-process simulator at 4x, and the serial car in real time.
    sim = subprocess.Popen([sys.executable, str(CIRCLE), f"sim://?speedup=4&trace={trace}"], cwd=ROOT,
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    serial = subprocess.Popen([sys.executable, str(CIRCLE), f"serial://{pty_car.path}"], cwd=ROOT,
                              stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    driving = []  # the serial car's positions while the script drives it (after neutral it coasts straight)
    try:
        assert wait_for(lambda: pty_car.sim.outputs.throttle_us > 1500, timeout_s=10)
        assert pty_car.sim.outputs.steering_us == 2000
        while serial.poll() is None:
            outputs, state = pty_car.sim.outputs, pty_car.sim.state()
            if outputs.throttle_us > 1500 and outputs.steering_us == 2000:
                driving.append((state.x, state.y))
            time.sleep(0.1)
        sim_out, sim_err = sim.communicate(timeout=60)
        _, serial_err = serial.communicate(timeout=60)
    finally:
        for p in (sim, serial):
            if p.poll() is None:
                p.kill()
                p.communicate()
    assert sim.returncode == 0, sim_err
    assert serial.returncode == 0, serial_err
    # it says what it does, then that it is done
    assert sim_out.splitlines() == [f"driving in circles on sim://?speedup=4&trace={trace} for 12 s (Ctrl-C stops)",
                                    "done: neutral sent, the car stops"]

    # Simulator: up to 48 s of simulated circles, staying on one circle round one centre. The rows
    # where it turns: after neutral the car coasts straight until the process ends (under load, for
    # simulated seconds at speedup 4).
    with trace.open() as f:
        rows = [(float(r["t_s"]), float(r["x_m"]), float(r["y_m"]), float(r["yaw_rad"])) for r in csv.DictReader(f)]
    t, yaw = (np.array([r[i] for r in rows]) for i in (0, 3))
    turning = np.flatnonzero(np.abs(np.diff(np.unwrap(yaw)) / np.maximum(np.diff(t), 1e-6)) > 0.5)  # [rad/s]
    assert t[turning[-1]] - t[turning[0]] > 20.0  # [s] of circles, of the 48 s simulated
    circling = rows[turning[0]:turning[-1] + 1]
    xs, ys = zip(*[(x, y) for _, x, y, _ in circling[len(circling) // 4:]])
    cx, cy = (max(xs) + min(xs)) / 2, (max(ys) + min(ys)) / 2
    radii = [math.hypot(x - cx, y - cy) for x, y in zip(xs, ys)]
    assert 0.5 < min(radii) and max(radii) < 1.2 and max(radii) - min(radii) < 0.1
    assert cy < 0  # full right lock: the circle lies to the car's right (it starts facing +x)

    # Serial: the car drove about 12 s worth of circle and was left at neutral.
    assert wait_for(lambda: pty_car.sim.outputs.throttle_us == 1500)
    state = pty_car.sim.state()
    driven_m = abs(state.encoder_counts) / ENCODER_COUNTS_PER_REV * WHEEL_CIRCUMFERENCE_M
    assert driven_m > 4.0  # more than one lap of a ~0.8 m radius circle
    radius = (max(radii) + min(radii)) / 2  # the same car and commands: the same circle as in the simulator
    # Through the start, centre to the right; the first quarter is the car getting up to speed.
    assert len(driving) > 50
    off_circle_m = [abs(math.hypot(x, y + radius) - radius) for x, y in driving[len(driving) // 4:]]
    assert max(off_circle_m) < 0.15


def test_the_ppo_training_example_trains_the_same_policy_from_the_same_seed_and_drives_it(tmp_path):
    """examples/train_ppo.py, one rollout and update: the same seed trains the same policy (its
    printed fingerprint) on RaceVecEnv's 2 processes and in SB3's SubprocVecEnv (a process per
    environment), another seed another; the saved model drives an episode. (Stepped in lockstep,
    as Race-v0 is: it keeps to no clock, and runs beside the other tests.)"""
    import re

    import pytest

    pytest.importorskip("stable_baselines3", reason="pip install 'roar-platform[rl]' (make setup installs it)")
    example = ROOT / "examples" / "train_ppo.py"

    def policy(*options: str) -> str:
        out = tmp_path / "-".join(options).replace("--", "")
        trained = subprocess.run([sys.executable, str(example), "--steps", "384", "--envs", "3", "--out", str(out),
                                  *options], capture_output=True, text=True, timeout=300)
        assert trained.returncode == 2, trained.stderr[-2000:]  # short of its laps: the commands' convention
        assert (out / "model.zip").exists() and (out / "normalise.pkl").exists()
        assert "did not reach 2 laps/episode on oval" in trained.stdout  # 384 steps: far from it
        return re.search(r"policy ([0-9a-f]{16}) \(seed", trained.stdout).group(1)

    first = policy("--seed", "0", "--workers", "2")
    assert policy("--seed", "0", "--vec", "subproc") == first
    assert policy("--seed", "1", "--workers", "2") != first
    assert policy("--seed", "0", "--workers", "2", "--randomize") != first  # other cars, another policy
    model = tmp_path / "seed-0-workers-2" / "model.zip"
    driven = subprocess.run([sys.executable, str(example), "--drive", str(model), "--car-profile", "f1tenth"],
                            capture_output=True, text=True, timeout=300)
    assert driven.returncode == 0, driven.stderr[-2000:]
    assert re.search(r"drove -?[0-9.]+ m = -?[0-9.]+ laps of oval in [0-9.]+ s \((hit a wall|time up)\)",
                     driven.stdout), driven.stdout
    bad = subprocess.run([sys.executable, str(example), "--track", "nowhere", "--steps", "64"],
                         capture_output=True, text=True, timeout=300)
    assert bad.returncode == 1 and "train_ppo:" in bad.stderr and "Traceback" not in bad.stderr, bad.stderr
    bad = subprocess.run([sys.executable, str(example), "--car-profile", "nope", "--randomize", "--steps", "64"],
                         capture_output=True, text=True, timeout=300)
    assert bad.returncode == 1 and bad.stderr.strip() == "train_ppo: no car profile 'nope': use f1tenth, iarrc, roar " \
        "or a .toml file", bad.stderr

