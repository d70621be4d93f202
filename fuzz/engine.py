"""Running a target, C++ (libFuzzer) or Python (atheris, which is libFuzzer too), on its stored
corpus: for a while (growing and minimising the corpus, or only checking), or over the corpus
alone (every stored input once)."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

from fuzz import python_targets, seeds

ROOT = Path(__file__).resolve().parent.parent
CORPUS = ROOT / "fuzz" / "corpus"
CRASHES = ROOT / "build" / "fuzz" / "crashes"
RSS_LIMIT_MB = 2048
TIMEOUT_S = 10  # [s] one input taking longer is a hang, reported as a crash
SAN_ENV = {"ASAN_OPTIONS": "detect_leaks=1:abort_on_error=1", "UBSAN_OPTIONS": "print_stacktrace=1:halt_on_error=1"}
PY_PREFIX = "py_"  # Python targets' names: py_ + python_targets.TARGETS' keys


def python_names() -> list[str]:
    return [PY_PREFIX + n for n in python_targets.TARGETS]


def atheris_missing() -> str | None:
    try:
        import atheris  # noqa: F401
    except ImportError:
        return "atheris is not installed: pip install atheris (roar-platform[dev])"
    return None


def command(name: str, built: dict[str, Path]) -> list[str]:
    """How to start the target: its executable (C++), or for a Python target a script that runs
    it under this Python (libFuzzer's -merge starts its argv[0] again, so that must be one)."""
    if not name.startswith(PY_PREFIX):
        return [str(built[name])]
    script = ROOT / "build" / "fuzz" / name
    script.parent.mkdir(parents=True, exist_ok=True)
    text = (f'#!/bin/sh\ncd "{ROOT}" && ROAR_FUZZ_SELF="$0" exec "{sys.executable}" -m fuzz.python_targets '
            f'{name[len(PY_PREFIX):]} "$@"\n')
    if not script.exists() or script.read_text() != text:
        script.write_text(text)
        script.chmod(0o755)
    return [str(script)]


@dataclass
class Run:
    target: str
    ok: bool
    executions: int
    exec_per_s: int
    corpus: int  # inputs in the stored corpus after the run
    log: str  # the end of the fuzzer's output: the crash and the input saved, when not ok


EXECUTED = re.compile(r"stat::number_of_executed_units:\s*(\d+)")
DONE = re.compile(r"#(\d+)\s+DONE .*?exec/s: (\d+)")


def run(name: str, cmd: list[str], seconds: float, grow: bool = False, corpus: Path | None = None,
        crashes: Path | None = None) -> Run:
    """The target for `seconds` on its stored corpus plus the inputs it makes. grow: the corpus
    is then minimised (-merge) over the old and the new inputs; otherwise the new ones are
    thrown away. A crash, a sanitizer report, an invariant broken or a hang: ok is False, and
    the input is in build/fuzz/crashes/NAME/ (and the end of the output in Run.log)."""
    stored = corpus or CORPUS / name
    stored.mkdir(parents=True, exist_ok=True)
    crashes = crashes or CRASHES / name
    crashes.mkdir(parents=True, exist_ok=True)
    env = {**os.environ, **SAN_ENV, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    limits = [f"-timeout={TIMEOUT_S}", f"-rss_limit_mb={RSS_LIMIT_MB}"]
    with tempfile.TemporaryDirectory() as scratch:
        new = Path(scratch) / "new"
        new.mkdir()
        old = Path(scratch) / "old"  # a copy: libFuzzer replaces inputs it reduces where it found them
        shutil.copytree(stored, old)
        r = subprocess.run([*cmd, f"-max_total_time={max(1, round(seconds))}", *limits, "-print_final_stats=1",
                            f"-artifact_prefix={crashes}/", str(new), str(old)],
                           capture_output=True, text=True, env=env, cwd=ROOT)
        log = r.stderr[-4000:]
        ok = r.returncode == 0
        if ok and grow:
            merged = Path(scratch) / "merged"
            merged.mkdir()
            m = subprocess.run([*cmd, "-merge=1", *limits, str(merged), str(old), str(new)],
                               capture_output=True, text=True, env=env, cwd=ROOT)
            ok = m.returncode == 0
            log += m.stderr[-1000:]
            if ok and any(merged.iterdir()):
                shutil.rmtree(stored)
                shutil.copytree(merged, stored)
                seeds.write()  # seeds and regression inputs stay, whatever the minimising kept
    executed = EXECUTED.search(r.stderr)
    done = DONE.search(r.stderr)
    executions = int(executed.group(1)) if executed else int(done.group(1)) if done else 0
    return Run(name, ok, executions, int(done.group(2)) if done else round(executions / max(seconds, 1e-9)),
               sum(1 for _ in stored.iterdir()), log)
