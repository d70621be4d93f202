"""`roar` commands that other packages add (the simulator adds `race`, `sim` and more), through the
"roar.commands" entry point group: name = the command, value = "module:object", where the
object is a Command. Loading one must be cheap: import heavy modules inside main()."""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from importlib.metadata import EntryPoint, entry_points
from typing import Callable

GROUP = "roar.commands"
# Commands this project's extras provide, so a base install can say what to install.
EXTRA_COMMANDS = {"limits": "sim", "platoon": "sim", "race": "sim", "sim": "sim", "step-response": "sim",
                  "sweep": "sweep", "track": "sim", "world": "sim"}


@dataclass(frozen=True)
class Command:
    help: str  # one line for `roar --help`
    main: Callable[[list[str]], int]  # the command's own arguments -> exit status
    # the command's argument parsers, without running it: {flags that select it: parser}; () for
    # the command's own, ("--stream",) for `roar sim --stream`'s. How the docs' command lines
    # are checked against the commands, and how the suite tries every option with bad values.
    parsers: Callable[[], dict[tuple[str, ...], argparse.ArgumentParser]] | None = None

    def parse_args(self, argv: list[str]) -> argparse.Namespace:
        """argv parsed as main() would (the parser its flags select), without running anything;
        a bad argument raises as the parser does (roar.cli.errors.UserError)."""
        if self.parsers is None:
            raise TypeError("this command does not expose its parsers")
        parsers = self.parsers()
        flags = max((f for f in parsers if all(flag in argv for flag in f)), key=len)
        return parsers[flags].parse_args([a for a in argv if a not in flags])


def installed() -> dict[str, EntryPoint]:
    return {ep.name: ep for ep in entry_points(group=GROUP)}


def missing_message(name: str, module: str | None = None) -> str:
    what = f"needs {module}" if module else "is not installed"
    extra = EXTRA_COMMANDS.get(name)
    return f"roar {name} {what}: pip install 'roar-platform[{extra}]'" if extra else f"roar {name} {what}"
