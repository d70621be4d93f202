"""Builds of the firmware with this machine's compilers, no PlatformIO: the core for the host
(native), the classic Nano's image (avr), the AnyFC F7's and the QEMU test images (arm), and what
each image costs in flash and RAM (sizes).

Builds are shared by every process on the machine (the suite's parallel workers among them): each
output is built under build_lock(output), so a second process waits for the first and then finds
the output fresh, and written whole (a temporary name, then renamed), so a program running the old
one never sees half a file."""

from __future__ import annotations

import fcntl
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path


@contextmanager
def build_lock(output: Path) -> Iterator[None]:
    """Held while `output` is checked and built: one process at a time builds it (an advisory
    lock on a file beside it, released when the process ends, however it ends)."""
    output.parent.mkdir(parents=True, exist_ok=True)
    with open(output.parent / f".{output.name}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        yield


def stale(output: Path, inputs: list[Path]) -> bool:
    """Whether output is missing or older than any of its inputs."""
    return not output.exists() or output.stat().st_mtime < max(p.stat().st_mtime for p in inputs)
