"""Reinforcement learning's wall time: examples/train_ppo.py (PPO, 4 environments, seed 0) until
the last 20 episodes average two laps of the oval, on RaceVecEnv (this machine's cores) and on
SB3's SubprocVecEnv (a process per environment) for reference. The same seed gives the same
policy on both (the fingerprints must match): only the wall time differs. No target in the issue;
RaceVecEnv is expected to be faster than SubprocVecEnv (ratio > 1)."""

import re
import subprocess
import sys
import tempfile
from pathlib import Path

TITLE = "PPO training to two laps per episode (examples/train_ppo.py)"
EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "train_ppo.py"
LAPS = 2.0  # the fixed reward: laps per 30 s episode, averaged over 20 episodes
TIMEOUT_S = 1800  # [s] one training


def without_rl() -> bool:
    """Whether stable-baselines3 is missing (said in one line: the benchmark is skipped)."""
    try:
        import stable_baselines3  # noqa: F401
    except ImportError:
        print("  skipped: pip install 'roar-platform[rl]' (stable-baselines3, PyTorch)")
        return True
    return False


def failure(done: subprocess.CompletedProcess) -> str:
    """Why a run of the example failed: its last line on stderr."""
    return (done.stderr.strip().splitlines() or ["no output"])[-1]


def train(vec: str, out: Path, extra: list[str] = (), laps: float = LAPS) -> tuple[str, int, float, str] | str:
    """(verdict, steps, wall seconds, policy fingerprint), or why it failed; extra: more options."""
    done = subprocess.run([sys.executable, str(EXAMPLE), "--until-laps", str(laps), "--vec", vec, "--out", str(out),
                           *extra], capture_output=True, text=True, timeout=TIMEOUT_S)
    found = re.search(r"^(reached|did not reach) .* after (\d+) steps, (\d+) s .*policy ([0-9a-f]+)", done.stdout,
                      re.S | re.M)
    if done.returncode not in (0, 2) or not found:  # 2: stopped short of the laps, a verdict too
        return failure(done)
    return found.group(1), int(found.group(2)), float(found.group(3)), found.group(4)


def run() -> None:
    if without_rl():
        return
    with tempfile.TemporaryDirectory() as tmp:
        results = {vec: train(vec, Path(tmp) / vec) for vec in ("race", "subproc")}
    for vec, name in (("race", "RaceVecEnv"), ("subproc", "SubprocVecEnv")):
        result = results[vec]
        if isinstance(result, str):
            print(f"  {name}: failed: {result}")
            continue
        verdict, steps, wall_s, policy = result
        print(f"  {name}: {verdict} {LAPS:g} laps/episode after {steps:,} steps in {wall_s:.0f} s "
              f"({steps / wall_s:,.0f} steps/s, PPO's updates included); policy {policy}")
    ours, theirs = results["race"], results["subproc"]
    if isinstance(ours, tuple) and isinstance(theirs, tuple):
        same = "the same policy" if ours[3] == theirs[3] else "DIFFERENT policies (they must be the same)"
        print(f"  RaceVecEnv {theirs[2] / ours[2]:.2f}x SubprocVecEnv's speed to the same reward; {same}")
