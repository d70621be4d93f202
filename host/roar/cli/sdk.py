"""What every `roar` command is made of, ours and the plug-ins' (the simulator's race, sim, ...):
the kit a package uses to add a command to `roar`.

A command is a module with its arguments and its run:

    def parser() -> ArgumentParser: ...       # prog "roar NAME"; --help ends with the exit statuses
    def main(argv: list[str]) -> int: ...      # parse argv, run, return an ExitStatus

and one Command naming it, kept in a light module (importing it must not import the command's
own heavy modules): `roar` lists ours in roar.cli.main.BUILT_IN, a package adds its own through
the "roar.commands" entry point group (name = the command, value = "module:Command object").

How every command ends: one table of exit statuses, one error boundary (run_command) that turns
the library's errors and bad options into one line on stderr, and Ctrl-C (SIGINT) and SIGTERM
into an orderly end, whichever way they are sent. Options that many commands share (a car's
URL, a calibration file, a log, a duration, a port) are here too, so they read alike."""

from __future__ import annotations

import argparse
import importlib
import os
import re
import signal
import sys
import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from enum import IntEnum
from pathlib import Path

from roar.checks import MAX_WAIT_S, number
from roar.errors import RoarError, UserError


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


class Terminated(KeyboardInterrupt):
    """SIGTERM: the command ends as on Ctrl-C (what cleans up on one cleans up on the other)."""


def stopped_status(e: KeyboardInterrupt) -> ExitStatus:
    """The exit status of a command ended by Ctrl-C (130) or SIGTERM (143)."""
    return ExitStatus.TERMINATED if isinstance(e, Terminated) else ExitStatus.INTERRUPTED


NEGATIVE_NUMBER = re.compile(r"^-(\d+\.?\d*|\.\d+)(e[+-]?\d+)?$|^-(inf|infinity|nan)$", re.I)


class ArgumentParser(argparse.ArgumentParser):
    """argparse as every roar command uses it: a bad option is a UserError (one line, exit status
    1, through the error boundary; --help shows the usage), and --help ends with the exit statuses."""

    def __init__(self, *args, **kwargs) -> None:
        epilog = kwargs.get("epilog")
        kwargs["epilog"] = f"{epilog}\n{EXIT_STATUSES}" if epilog else EXIT_STATUSES
        kwargs.setdefault("formatter_class", argparse.RawDescriptionHelpFormatter)
        super().__init__(*args, **kwargs)
        # argparse reads "-1e308" and "-inf" as options ("expected one argument"): every negative
        # number is a value, so the option's own check says what is wrong with it
        self._negative_number_matcher = NEGATIVE_NUMBER

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


def int_option(low: int, high: int) -> Callable[[str], int]:
    """An argparse type: a whole number in low..high, else the option's one-line error."""
    def parse(text: str) -> int:
        digits = text.strip()
        if not digits.lstrip("-").isdigit() or not low <= int(digits) <= high:
            raise argparse.ArgumentTypeError(f"must be a whole number {low}..{high}, got {text!r}")
        return int(digits)
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


def seed_option(text: str) -> int:
    """An argparse type: a seed, a whole number 0..10^18 (numpy's generators take no negative seed)."""
    from roar.tracks.seeds import MAX_SEED

    if not text.strip().isdigit() or int(text) > MAX_SEED:
        raise argparse.ArgumentTypeError(f"must be a whole number 0..10^18, got {text!r}")
    return int(text)


def listen_address(text: str) -> str:
    """An argparse type: an IP address to listen on (or localhost), not a name to look up."""
    import ipaddress

    if text != "localhost":
        try:
            ipaddress.ip_address(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be an IP address such as 127.0.0.1 or 0.0.0.0, got {text!r}") from None
    return text


def add_url(p: argparse.ArgumentParser) -> None:
    """The car, as a URL: the first argument of most commands."""
    p.add_argument("url", metavar="URL", help="the car: sim://, serial:///dev/ttyUSB0, ble://NAME (see `roar --help`)")


def add_calibration_option(p: argparse.ArgumentParser) -> None:
    from roar.calibration import default_path

    p.add_argument("--calibration", type=path_option, metavar="TOML",
                   help=f"calibration file (default: {default_path()} if it exists)")


def add_log_option(p: argparse.ArgumentParser) -> None:
    p.add_argument("--log", type=path_option, metavar="MCAP",
                   help="record the run into this MCAP file (every message sent and line received, the state)")


def open_vehicle(args: argparse.Namespace, record=None):
    """The Vehicle of a command's URL, with its --calibration and --log where it has them."""
    from roar.vehicle import Vehicle

    return Vehicle(args.url, calibration=getattr(args, "calibration", None),
                   record=record if record is not None else getattr(args, "log", None))


@dataclass(frozen=True)
class Command:
    """One `roar` command: its line in `roar --help` and the module that holds its parser() and
    main(argv), imported only when the command runs or its arguments are checked."""

    help: str  # one line for `roar --help`
    module: str  # "package.module": its parser() and main(argv)
    main_name: str = "main"  # the module's main(argv), where one module holds two commands
    parser_name: str = "parser"  # ... and its parser()
    # the command's other parsers, selected by flags ({("--stream",): parser} for `roar sim
    # --stream`, which has options of its own); the module's parser() is the one for ()
    variants: Callable[[], dict[tuple[str, ...], argparse.ArgumentParser]] | None = field(default=None)

    def main(self, argv: list[str]) -> int:
        return getattr(importlib.import_module(self.module), self.main_name)(argv)

    def parsers(self) -> dict[tuple[str, ...], argparse.ArgumentParser]:
        """{the flags that select it: parser}: how the docs' command lines are checked against the
        commands, and how the suite tries every option with bad values."""
        own = getattr(importlib.import_module(self.module), self.parser_name)()
        return {(): own, **(self.variants() if self.variants else {})}

    def parse_args(self, argv: list[str]) -> argparse.Namespace:
        """argv parsed as main() would (the parser its flags select), without running anything;
        a bad argument raises as the parser does (UserError)."""
        parsers = self.parsers()
        flags = max((f for f in parsers if all(flag in argv for flag in f)), key=len)
        return parsers[flags].parse_args([a for a in argv if a not in flags])


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
