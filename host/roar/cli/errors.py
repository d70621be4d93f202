"""How every `roar` command ends: one table of exit statuses, one error boundary that turns the
library's errors and bad options into one line on stderr, and Ctrl-C (SIGINT) and SIGTERM into
an orderly end, whichever way they are sent. The `roar` entry point and each command run as
`python -m ...` go through it; every command's parser is ArgumentParser, whose --help ends with
the table."""

from __future__ import annotations

import argparse
import os
import signal
import sys
import threading
from collections.abc import Callable
from pathlib import Path
from enum import IntEnum

from roar.checks import MAX_WAIT_S, number
from roar.errors import RoarError


class ExitStatus(IntEnum):  # what each means: EXIT_MEANINGS
    OK = 0
    ERROR = 1
    SHORT = 2
    TARGETS_MISSED = 3
    INTERRUPTED = 130  # 128 + SIGINT, as the shell reports it
    BROKEN_PIPE = 141  # 128 + SIGPIPE
    TERMINATED = 143  # 128 + SIGTERM


EXIT_MEANINGS = {  # the one table: every command's --help ends with it, host/README.md shows it
    ExitStatus.OK: "done",
    ExitStatus.ERROR: "bad input (an option, a file, a URL) or something that could not start: one line on stderr",
    ExitStatus.SHORT: "it ran but fell short: a race with fewer laps, failed sweep runs, a platoon that broke up",
    ExitStatus.TARGETS_MISSED: "a measurement missed its targets (roar step-response)",
    ExitStatus.INTERRUPTED: "Ctrl-C (SIGINT), however it was sent; the car is left at neutral",
    ExitStatus.BROKEN_PIPE: "the reader of its output went away (roar ... | head)",
    ExitStatus.TERMINATED: "SIGTERM; ends as on Ctrl-C",
}
EXIT_STATUSES = "exit status (every roar command):\n" + "\n".join(
    f"  {int(status):3}  {meaning}" for status, meaning in EXIT_MEANINGS.items())


class UserError(RoarError):
    """A one-line message for the user about a command's input; exit status 1."""


class Terminated(KeyboardInterrupt):
    """SIGTERM: the command ends as on Ctrl-C (what cleans up on one cleans up on the other)."""


def stopped_status(e: KeyboardInterrupt) -> ExitStatus:
    """The exit status of a command ended by Ctrl-C (130) or SIGTERM (143)."""
    return ExitStatus.TERMINATED if isinstance(e, Terminated) else ExitStatus.INTERRUPTED


class ArgumentParser(argparse.ArgumentParser):
    """argparse as every roar command uses it: a bad option is a UserError (one line, exit status
    1, through the error boundary; --help shows the usage), and --help ends with the exit statuses."""

    def __init__(self, *args, **kwargs) -> None:
        epilog = kwargs.get("epilog")
        kwargs["epilog"] = f"{epilog}\n{EXIT_STATUSES}" if epilog else EXIT_STATUSES
        kwargs.setdefault("formatter_class", argparse.RawDescriptionHelpFormatter)
        super().__init__(*args, **kwargs)

    def error(self, message: str) -> None:
        raise UserError(message)


def number_option(low: float, high: float, unit: str = "", low_open: bool = False) -> Callable[[str], float]:
    """An argparse type: a finite number in low..high (above low when low_open), else the option's
    one-line error ("argument --timeout: must be a finite number more than 0 and at most 60 s,
    got '0'")."""
    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            value = text  # not a number: refused below, shown as typed
        try:
            return number("", value, low, high, unit, low_open, given=text)
        except ValueError as e:
            raise argparse.ArgumentTypeError(str(e)) from None
    return parse


def port_option(text: str) -> int:
    """An argparse type: a TCP port, a whole number 1..65535."""
    if not text.strip().isdigit() or not 1 <= int(text) <= 65535:
        raise argparse.ArgumentTypeError(f"must be a port, a whole number 1..65535, got {text!r}")
    return int(text)


def add_foxglove_option(p: argparse.ArgumentParser, what: str = "the channels", when: str = "") -> None:
    """--foxglove [PORT]: serve a recording's channels live (roar.recorder.FOXGLOVE_PORT by default)."""
    from roar.recorder import FOXGLOVE_PORT

    p.add_argument("--foxglove", nargs="?", const=FOXGLOVE_PORT, type=port_option, default=None, metavar="PORT",
                   help=f"{when}serve {what} live over the Foxglove WebSocket protocol on 127.0.0.1 (default port "
                        f"{FOXGLOVE_PORT}; in Foxglove: Open connection, ws://127.0.0.1:PORT)")


def path_option(text: str) -> Path:
    """An argparse type: a file or folder name, not an empty one (which would mean "here")."""
    if not text.strip():
        raise argparse.ArgumentTypeError("is empty: give a file or folder name")
    return Path(text)


seconds_option = number_option(0, MAX_WAIT_S, "s (0: until Ctrl-C)")  # a run's duration


def run_command(prog: str, command: Callable[..., int], *args) -> int:
    """command(*args) -> its exit status; the library's errors (and ValueErrors: bad values) as
    "PROG: error: MESSAGE" on one line with status 1, Ctrl-C as 130, SIGTERM as 143, a closed
    stdout as 141. Ctrl-C ends a command even when it was started with SIGINT ignored (a shell
    script's `roar ... &`): Ctrl-C ends everything at once."""
    in_main = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGTERM, _terminate) if in_main else None
    ignored = in_main and signal.getsignal(signal.SIGINT) == signal.SIG_IGN
    if ignored:
        signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        return int(command(*args))
    except KeyboardInterrupt as e:  # Ctrl-C or SIGTERM
        print(file=sys.stderr)
        return stopped_status(e)
    except BrokenPipeError:  # say nothing more: nobody reads
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return ExitStatus.BROKEN_PIPE
    except (RoarError, ValueError) as e:
        print(f"{prog}: error: {e}", file=sys.stderr)
        return ExitStatus.ERROR
    finally:
        if in_main:
            signal.signal(signal.SIGTERM, previous)
        if ignored:
            signal.signal(signal.SIGINT, signal.SIG_IGN)


def _terminate(signum, frame) -> None:
    raise Terminated
