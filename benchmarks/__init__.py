"""Benchmarks: `make bench` runs every module listed in benchmarks.__main__ and prints ratios
measured in one run (never used as pass/fail thresholds in tests)."""

import multiprocessing
from concurrent.futures import ProcessPoolExecutor

WORKERS = 2  # two runs at once: this machine's cores


def pool(workers: int = WORKERS) -> ProcessPoolExecutor:
    """Processes for runs side by side, each a fresh interpreter (forkserver): `make bench` runs
    every benchmark in one process, and a worker forked from it after the earlier ones (PyBullet's,
    Numba's and torch's threads) died abruptly in lane_anywhere's first race."""
    return ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("forkserver"))
