"""This machine's share of work across processes (the vector environment's, a sweep's)."""

from __future__ import annotations

import multiprocessing
import os


def cores() -> list[int]:
    """The cores this process may run on."""
    return sorted(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else list(range(os.cpu_count() or 1))


def fork_context():
    """Processes forked from this one (they start in milliseconds, with its imports), where the
    platform forks; spawned elsewhere."""
    return multiprocessing.get_context("fork" if "fork" in multiprocessing.get_all_start_methods() else "spawn")
