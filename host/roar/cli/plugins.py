"""`roar` commands that other packages add (the simulator adds `race`, `sim` and more), through the
"roar.commands" entry point group: name = the command, value = "module:object", where the
object is a Command. Loading one must be cheap: import heavy modules inside main()."""

from __future__ import annotations

from dataclasses import dataclass
from importlib.metadata import EntryPoint, entry_points
from typing import Callable

GROUP = "roar.commands"
# Commands this project's extras provide, so a base install can say what to install.
EXTRA_COMMANDS = {"limits": "sim", "platoon": "sim", "race": "sim", "sim": "sim", "step-response": "sim",
                  "sweep": "sweep"}


@dataclass(frozen=True)
class Command:
    help: str  # one line for `roar --help`
    main: Callable[[list[str]], int]  # the command's own arguments -> exit status
    # the command's argument parsing alone, without running it (argparse's SystemExit on bad
    # arguments): how the docs' command lines are checked against the commands
    parse_args: Callable[[list[str]], object] | None = None


def installed() -> dict[str, EntryPoint]:
    return {ep.name: ep for ep in entry_points(group=GROUP)}


def missing_message(name: str, module: str | None = None) -> str:
    what = f"needs {module}" if module else "is not installed"
    extra = EXTRA_COMMANDS.get(name)
    return f"roar {name} {what}: pip install 'roar-platform[{extra}]'" if extra else f"roar {name} {what}"
