"""The libFuzzer targets (fuzz/targets/*.cpp): built with clang, ASan and UBSan against the
core's sources and the host board's C ABI, and run for a while on their stored corpus."""

from __future__ import annotations

import concurrent.futures
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

from roar_sim.toolchains import build_lock, stale

ROOT = Path(__file__).resolve().parent.parent
TARGETS_DIR = ROOT / "fuzz" / "targets"
BUILD = ROOT / "build" / "fuzz"
CORE = ROOT / "firmware" / "core"
HOST = ROOT / "firmware" / "host"
CLANG = ("clang++-14", "clang++")  # Debian's clang 14 with its libFuzzer runtime (libclang-rt-14-dev)
PACKAGES = "clang-14 libclang-rt-14-dev"
SANITIZE = ["-fsanitize=address,undefined", "-fno-sanitize-recover=all", "-fno-omit-frame-pointer"]
FLAGS = ["-std=c++17", "-O1", "-g", "-Wall", "-Wextra", "-Werror", f"-I{CORE / 'include'}", f"-I{HOST}"]


class FuzzBuildError(RuntimeError):
    """clang is missing or a target does not build; str() is one line."""


def targets() -> list[str]:
    return sorted(p.stem for p in TARGETS_DIR.glob("*.cpp"))


def compiler() -> str | None:
    return next((c for c in CLANG if shutil.which(c)), None)


def missing() -> str | None:
    """Why the targets cannot be built here (with what to install), or None."""
    cxx = compiler()
    if cxx is None:
        return f"clang is not installed: apt install {PACKAGES}"
    with tempfile.TemporaryDirectory() as tmp:
        probe = Path(tmp) / "probe.cpp"
        probe.write_text('#include <stdint.h>\n#include <stddef.h>\nextern "C" int LLVMFuzzerTestOneInput('
                         'const uint8_t*, size_t) { return 0; }\n')
        r = subprocess.run([cxx, "-fsanitize=fuzzer,address,undefined", str(probe), "-o", str(Path(tmp) / "probe")],
                           capture_output=True, text=True)
        if r.returncode != 0:
            return f"clang cannot link a libFuzzer target (its runtime is missing): apt install {PACKAGES}"
    return None


def _sources() -> list[Path]:
    return sorted((CORE / "src").glob("*.cpp")) + [HOST / "c_api.cpp", HOST / "memory_boards.cpp"]


def _compile(cxx: str, source: Path, obj: Path, extra: list[str]) -> None:
    headers = [*(CORE / "include" / "roar").glob("*.h"), HOST / "c_api.h", HOST / "memory_boards.h",
               TARGETS_DIR / "harness.h"]
    if not stale(obj, [source, *headers]):
        return
    r = subprocess.run([cxx, *FLAGS, *SANITIZE, *extra, "-c", str(source), "-o", str(obj)],
                       capture_output=True, text=True)
    if r.returncode != 0:
        first = next((line for line in r.stderr.splitlines() if "error" in line), r.stderr.strip()[:200])
        raise FuzzBuildError(f"{source.name}: {first}")


def build(names: list[str] | None = None, jobs: int | None = None) -> dict[str, Path]:
    """Build the targets (all by default) into build/fuzz; name -> executable. Only what changed
    is compiled again."""
    problem = missing()
    if problem:
        raise FuzzBuildError(problem)
    with build_lock(BUILD / "targets"):  # one process builds, others (the suite's workers) wait and find it built
        return _build(compiler(), names or targets(), jobs or os.cpu_count() or 1)


def _build(cxx: str, names: list[str], jobs: int) -> dict[str, Path]:
    objects = BUILD / "obj"
    objects.mkdir(parents=True, exist_ok=True)
    core = [(s, objects / f"{s.stem}.o", ["-fsanitize=fuzzer-no-link"]) for s in _sources()]
    mains = [(TARGETS_DIR / f"{n}.cpp", objects / f"target_{n}.o", ["-fsanitize=fuzzer-no-link"]) for n in names]
    with concurrent.futures.ThreadPoolExecutor(jobs) as pool:
        for f in [pool.submit(_compile, cxx, s, o, e) for s, o, e in core + mains]:
            f.result()
    built = {}
    for name in names:
        exe = BUILD / name
        parts = [o for _, o, _ in core] + [objects / f"target_{name}.o"]
        if stale(exe, parts):
            r = subprocess.run([cxx, "-fsanitize=fuzzer", *SANITIZE, *map(str, parts), "-o", str(exe)],
                               capture_output=True, text=True)
            if r.returncode != 0:
                raise FuzzBuildError(f"{name}: link failed: {r.stderr.strip().splitlines()[-1]}")
        built[name] = exe
    return built
