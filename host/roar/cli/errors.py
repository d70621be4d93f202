"""How every `roar` command ends: one exit-status table, and one error boundary that turns the
library's errors into one line on stderr, Ctrl-C into 130 and a closed pipe into 141. The
`roar` entry point and each command run as `python -m ...` go through it."""

from __future__ import annotations

import os
import sys
from collections.abc import Callable
from enum import IntEnum

from roar.errors import RoarError


class ExitStatus(IntEnum):
    OK = 0
    ERROR = 1  # bad input, or something that could not start: one line on stderr says why
    SHORT = 2  # the command ran but fell short (a race with fewer laps, failed sweep runs, a platoon that broke up)
    TARGETS_MISSED = 3  # a measurement that missed its targets (roar step-response)
    INTERRUPTED = 130  # Ctrl-C, as the shell reports it
    BROKEN_PIPE = 141  # the reader of stdout went away (`roar ... | head`)


class UserError(RoarError):
    """A one-line message for the user about a command's input; exit status 1."""


def run_command(prog: str, command: Callable[..., int], *args) -> int:
    """command(*args) -> its exit status; the library's errors (and ValueErrors: bad values) as
    "PROG: error: MESSAGE" on one line with status 1, Ctrl-C as 130, a closed stdout as 141."""
    try:
        return int(command(*args))
    except KeyboardInterrupt:
        print(file=sys.stderr)
        return ExitStatus.INTERRUPTED
    except BrokenPipeError:  # say nothing more: nobody reads
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return ExitStatus.BROKEN_PIPE
    except (RoarError, ValueError) as e:
        print(f"{prog}: error: {e}", file=sys.stderr)
        return ExitStatus.ERROR
