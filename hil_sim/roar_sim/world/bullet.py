"""PyBullet, imported without the "pybullet build time: ..." line its C module prints on stderr
at import, which would otherwise land in every command's output (even `roar race --help`)."""

from __future__ import annotations

import contextlib
import ctypes
import os
import sys

_LIBC = ctypes.CDLL(None)


@contextlib.contextmanager
def silenced(fds: tuple[int, ...] = (2,)):
    """What C code writes to these file descriptors (stderr by default) goes nowhere meanwhile."""
    sys.stdout.flush()
    sys.stderr.flush()
    saved = [os.dup(fd) for fd in fds]
    devnull = os.open(os.devnull, os.O_WRONLY)
    for fd in fds:
        os.dup2(devnull, fd)
    try:
        yield
    finally:
        _LIBC.fflush(None)  # what C code wrote meanwhile and its stdio still holds goes nowhere too
        for fd, copy in zip(fds, saved):
            os.dup2(copy, fd)
            os.close(copy)
        os.close(devnull)


with silenced():
    import pybullet as pb  # noqa: F401 (what this module gives: pb)
