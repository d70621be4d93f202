"""Build, at `make setup`, the native programs the suite's tests would otherwise build on first
use: the firmware core for this machine (roar_sim.toolchains.native: the library as the simulator
loads it and sanitized, the core's own test program plain, sanitized and thread-sanitized) and
the libFuzzer targets (fuzz/native.py). Each is built only where its sources changed, as the
tests' own calls do. In a fresh checkout the suite built them beside the other tests (~50 CPU-s of
a two-core machine's suite). A toolchain that is missing is said and skipped: the tests that need
it skip saying the same.

    .venv/bin/python scripts/build_ahead.py
"""

from __future__ import annotations

import concurrent.futures
import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # fuzz/ is the repository's, not a package's

from roar_sim import CoreBuildError  # noqa: E402
from roar_sim.toolchains import native  # noqa: E402

CORE_BUILDS = [("library", "release"), ("library", "sanitize"),
               ("native_test", "release"), ("native_test", "sanitize"), ("native_test", "thread")]


def main() -> int:
    start = time.perf_counter()
    try:
        native.compiler()
    except CoreBuildError as e:
        print(f"build_ahead: the core's host builds skipped: {e}")
    else:
        with concurrent.futures.ThreadPoolExecutor(os.cpu_count() or 1) as pool:  # one compiler call each
            for built in [pool.submit(native.build, target, variant) for target, variant in CORE_BUILDS]:
                built.result()
    from fuzz import native as fuzz_targets

    why_not = fuzz_targets.missing()
    if why_not:
        print(f"build_ahead: the fuzz targets skipped: {why_not}")
    else:
        fuzz_targets.build()
    print(f"build_ahead: the native builds are current ({time.perf_counter() - start:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
