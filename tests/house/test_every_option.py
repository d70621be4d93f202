"""Every option of every `roar` command, and every option of every car URL, given NaN, an
infinity, 0, a negative number, a huge one, nothing and a word: each ends in one line (`roar
COMMAND: error: ...`, exit status 1) or a documented result -- never a traceback, never a hang.

The options are read from the commands' own parsers (a new option is tried without anyone listing
it); a value that is valid runs the command (with a short run around it: a simulated race of one
lap, a server for half a second) and must be in RUNS below, which says what it means. A run is
cut after GUARD_S, as by Ctrl-C (status 130): only the documented long runs may get there."""

import argparse
import ast
import functools
import io
import signal
from pathlib import Path

import numpy as np
import pytest

from roar import TransportError, Vehicle
from roar.cli import main as roar
from roar.cli.sdk import ExitStatus, UserError
from roar.cli.main import commands as roar_commands

# a run keeps to the wall clock (realtime: one at a time under xdist, conftest); a value its
# parser refuses is checked beside the other tests (CASES)

pytest.importorskip("pybullet", reason="pip install pybullet (make setup installs it)")

VALUES = ["nan", "inf", "-inf", "0", "-1", "1e308", "99999999999999999999", "", "fast"]
GUARD_S = 20.0  # [s] longer than any documented short run below takes on a busy machine
UNTIL_STOPPED_S = 2.0  # [s] a documented run "until Ctrl-C" gets this long, then the guard's Ctrl-C

# command -> the arguments of a short, valid run to which one option with one value is added;
# {tmp} is the test's folder, {frames} a folder with one recorded frame, {recording} an MCAP recording
BASE = {
    "send": ["loop://", "--for", "0.1"],
    "drive": ["loop://"],
    "record": ["loop://", "--out", "{tmp}/run.mcap", "--for", "0.1"],
    "replay": ["{recording}"],
    "dataset": ["{recording}", "--out", "{tmp}/tub"],
    "calibrate": ["loop://", "--file", "{tmp}/calibration.toml"],
    "key": ["show", "serial:///dev/roar-none", "--file", "{tmp}/key"],  # (no car there: one line, after the key file)
    "web": ["loop://", "--port", "18887", "--for", "0.3"],
    "ros2": ["loop://", "--for", "0.3"],
    "ros2 --bag": ["--bag", "{recording}", "--out", "{tmp}/bag"],
    "ros2 --localize-bag": ["--localize-bag", "{tmp}/no_bag", "--map", "oval"],  # (no bag there: one line, after the options)
    "scan": ["--timeout", "0.1"],
    "ports": [],
    "stream": ["udp://127.0.0.1", "--seconds", "0.3"],
    "vision": ["{frames}", "--out", "{tmp}/vision"],
    "race": ["--laps", "1"],
    "sim": ["--laps", "1"],
    "sim --stream": ["--stream", "--seconds", "0.3"],
    "step-response": ["--seconds", "1"],
    "sweep": ["--serial", "--track", "oval", "--k-dd", "0.5", "--margin", "0.9", "--laps", "1", "--out", "{tmp}/sweep"],
    "platoon": ["--seconds", "2"],
    "limits": ["esc"],
    "track": ["oval"],
    "world": ["tunnel:1"],
    "challenge": ["tunnel:3", "--to", "2", "--oracle"],
    "fit": ["{recording}", "--out", "{tmp}/car.toml"],  # (not a test drive: one line, after the options)  # 2 m: 4 s a run (3 m took 14, backing up)
}

# (command, option, value) that is valid: what it does. Everything else must be refused in one line.
RUNS = {
    ("send", "--throttle", "0"): "neutral for the run",
    ("send", "--throttle", "-1"): "full reverse",
    ("send", "--steering", "0"): "straight",
    ("send", "--steering", "-1"): "full left",
    ("send", "--speed", "0"): "zero speed (a car with a speed controller; loop:// has none: one line)",
    ("send", "--speed", "-1"): "1 m/s backwards",
    ("ros2", "--domain", "0"): "ROS domain 0",
    ("ros2", "--camera", "0"): "no camera topics",
    ("race", "--boxes", "0"): "no boxes",
    ("race", "--seconds", "inf"): "no time limit: the race ends after its lap",
    ("race", "--start-lights", "0"): "start lights drawn from seed 0 (needs --driver lane: one line)",
    ("race", "--start-lights", "-1"): "seed -1 (needs --driver lane: one line)",
    ("race", "--start-lights", "99999999999999999999"): "a seed (needs --driver lane: one line)",
    ("vision", "--ahead", "0"): "a camera over the rear axle",
    ("vision", "--ahead", "-1"): "a camera behind the rear axle",
    ("vision", "--pitch", "0"): "a level camera",
    ("vision", "--pitch", "-1"): "a camera tilted 1 deg up",
    ("sim --stream", "--seconds", "0"): "until Ctrl-C",
    ("stream", "--seconds", "0"): "until Ctrl-C",
    ("sim --stream", "--host", "0"): "0 is 0.0.0.0 to the resolver: every interface",
    ("sim --stream", "--push", "0"): "0 is 0.0.0.0 to the resolver: this machine",
    ("platoon", "--speed", "0"): "a leader that stands still",
    ("challenge", "--cone-penalty", "0"): "cones cost nothing",
    ("challenge", "--marker-bonus", "0"): "markers are worth nothing: never pursued",
    ("challenge", "--latency", "0"): "camera frames on time",
    ("challenge", "--seed", "0"): "noise and samples from seed 0",
    ("challenge", "--seed", "99999999999999999999"): "a seed",
    ("calibrate", "--file", "0"): "a calibration file named 0",
    ("calibrate", "--file", "-1"): "a calibration file named -1",
    ("calibrate", "--file", "fast"): "a calibration file named fast",
    ("calibrate", "--file", "inf"): "a calibration file named inf",
    ("calibrate", "--file", "nan"): "a calibration file named nan",
    ("calibrate", "--file", "-inf"): "a calibration file named -inf",
    ("calibrate", "--file", "1e308"): "a calibration file named 1e308",
    ("calibrate", "--file", "99999999999999999999"): "a calibration file named 999...",
}
# names and paths: any word is a name (a file to write, a folder): a run, if it is writable
NAMES = {"--out", "--plot", "--video", "--record", "--file", "--calibration", "--log", "--record-dir"}
# ... so "nan", "inf", "0" or "1e308" each name a file as "fast" does: a name option is tried with a word,
# nothing, and a word that starts like an option (each value a whole run: the race's took 2-4 s)
NAME_VALUES = ["-1", "", "fast"]


@functools.cache
def commands() -> dict[str, tuple[list[str], argparse.ArgumentParser]]:
    """name -> (the flags that select its parser, the parser), for every installed command."""
    found = {}
    for name, command in roar_commands().items():
        for flags, sub in command.parsers().items():
            found[" ".join((name, *flags))] = (list(flags), sub)
    return found


def options(parser: argparse.ArgumentParser) -> list[tuple[str, argparse.Action]]:
    """The options that take a value, and the positionals: (how it is given, the action)."""
    found = []
    for action in parser._actions:
        if isinstance(action, (argparse._HelpAction, argparse._VersionAction)) or action.nargs == 0:
            continue
        found.append((action.option_strings[-1] if action.option_strings else action.dest, action))
    return found


def _replaced(argv: list[str], option: str, value: str) -> list[str]:
    i = argv.index(option)
    return [*argv[:i + 1], value, *argv[i + 2:]]


def _positional_replaced(base: list[str], flags: list[str], position: int, value: str) -> list[str]:
    """base with its position-th positional argument (after the selecting flags) given `value`."""
    def is_value(i: int) -> bool:  # the value of the option before it
        return i > 0 and base[i - 1].startswith("--") and base[i - 1] not in flags

    positionals = [i for i, a in enumerate(base) if not a.startswith("-") and not is_value(i)]
    out = list(base)
    out[positionals[position]] = value
    return out


def command_argv(command: str, option: str, value: str, tmp, frames, recording) -> list[str]:
    """The arguments (after `roar NAME`) of the command's short run with `option` given `value`."""
    flags, parser = commands()[command]
    base = [a.format(tmp=tmp, frames=frames, recording=recording) for a in BASE[command]]
    if dict(options(parser))[option].option_strings:
        return [*base, option, value] if option not in base else _replaced(base, option, value)
    position = [o for o, a in options(parser) if not a.option_strings].index(option)  # a positional: its
    return _positional_replaced(base, flags, position, value)  # value in the base run replaced


def refused_by_its_parser(command: str, option: str, value: str) -> bool:
    """The value is refused before the command runs anything: such a case keeps to no clock (it
    runs beside the others); a run, or a refusal that comes after one starts, keeps to the wall
    clock with the realtime tests."""
    argv = command_argv(command, option, value, "/nonexistent", "/nonexistent", "/nonexistent/run.mcap")
    flags, parser = commands()[command]
    try:
        parser.parse_args([a for a in argv if a not in flags])  # as roar.cli.sdk.Command.parse_args
    except UserError:
        return True
    return False


CASES = [pytest.param(command, option, value, id=f"{command}-{option}-{value or 'empty'}",
                      marks=() if refused_by_its_parser(command, option, value) else pytest.mark.realtime)
         for command, (_, parser) in commands().items()
         for option, _ in options(parser) for value in (NAME_VALUES if option in NAMES else VALUES)]


def test_every_command_has_a_short_run_to_try_options_on():
    assert set(BASE) == set(commands())


@pytest.fixture(scope="module")
def frames(tmp_path_factory):
    folder = tmp_path_factory.mktemp("frames")
    np.save(folder / "a.npy", np.full((240, 320, 3), 90, np.uint8))
    return folder


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    from roar.recorder import Recorder

    path = tmp_path_factory.mktemp("recording") / "run.mcap"
    with Recorder(path, {"car": "loop://"}) as rec:
        rec.control(b"(1500,1500)\n", 0)
        rec.image(np.zeros((8, 8, 3), np.uint8), 1)
    return path


class Guard:
    """After `seconds`, a Ctrl-C: SIGINT, to whatever handler the run installed (asyncio.run's cancels
    its main task); then, every AGAIN_S while it has not ended, a second Ctrl-C raised where the run
    is (a hang becomes status 130). A KeyboardInterrupt raised inside an event loop at first would
    be harsher than a Ctrl-C: it can land between the loop taking a task's wake-up and running it,
    and asyncio.run's clean-up then waits for that task for ever."""

    AGAIN_S = 5.0  # [s]

    def __init__(self, seconds: float, again_s: float = AGAIN_S) -> None:
        self.seconds, self.again_s, self.fired = seconds, again_s, 0

    def __enter__(self):
        self.previous = signal.signal(signal.SIGALRM, self._fire)
        signal.setitimer(signal.ITIMER_REAL, self.seconds, self.again_s)
        return self

    def _fire(self, signum, frame):
        self.fired += 1
        if self.fired == 1:
            signal.raise_signal(signal.SIGINT)
        else:
            raise KeyboardInterrupt

    def __exit__(self, *exc):
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, self.previous)


def test_the_guard_stops_a_run_as_ctrl_c_does_then_again_where_it_hangs():
    import time

    heard = []

    def ctrl_c(signum, frame):  # what a run's own SIGINT handler (asyncio.run's) would hear
        heard.append(signum)
        raise KeyboardInterrupt

    def run_until_stopped(sigint_handler, again_s=Guard.AGAIN_S) -> Guard:
        previous = signal.signal(signal.SIGINT, sigint_handler)
        try:
            with pytest.raises(KeyboardInterrupt), Guard(0.1, again_s) as guard:
                while True:
                    time.sleep(0.01)
        finally:
            signal.signal(signal.SIGINT, previous)
        return guard

    assert run_until_stopped(ctrl_c).fired == 1 and heard == [signal.SIGINT]
    start = time.monotonic()
    assert run_until_stopped(lambda *_: None, again_s=0.2).fired == 2  # a run that ignores Ctrl-C still ends
    assert time.monotonic() - start < 4.0


@pytest.mark.parametrize("command, option, value", CASES)
def test_a_bad_value_is_one_line_or_a_documented_run(command, option, value, tmp_path, frames, recording, capsys,
                                                    monkeypatch):
    monkeypatch.setattr("sys.stdin", io.StringIO(""))  # nobody types: an interactive command reads its end
    monkeypatch.chdir(tmp_path)  # files and folders a valid value names land here
    name = command.split()[0]
    argv = command_argv(command, option, value, tmp_path, frames, recording)
    key = (command, option, value)
    with Guard(UNTIL_STOPPED_S if "until Ctrl-C" in RUNS.get(key, "") else GUARD_S):
        status = roar([name, *argv])
    out, err = capsys.readouterr()
    assert "Traceback" not in err + out, err
    if status == ExitStatus.ERROR:
        last = err.strip().splitlines()[-1] if err.strip() else ""
        assert last.startswith(f"roar {name}: error: "), (argv, err)
        return
    if key in RUNS or (option in NAMES and value not in ("",)):
        until_stopped = "until Ctrl-C" in RUNS.get(key, "")
        assert (status == ExitStatus.INTERRUPTED) == until_stopped, (argv, status, out, err)
        return
    pytest.fail(f"roar {name} {' '.join(argv)}: accepted {value!r} for {option} (status {status}) -- refuse it "
                f"in one line, or document the run in RUNS\n{out}\n{err}")


# --- car URLs -----------------------------------------------------------------------------------

# scheme -> a URL that reaches nothing quickly (or opens at once), to which one option is added
URL_BASE = {
    "sim": "sim://",
    "serial": "serial:///dev/roar-nonexistent",
    "ble": "ble://ROAR-nonexistent",
    "http": "http://127.0.0.1:1",
    "udp": "udp://127.0.0.1",
    "loop": "loop://",
}
# (scheme, option, value) that opens a car: what it means
URL_RUNS = {
    ("loop", "fail_after", "0"): "the first write cuts the link",
    ("loop", "fail_after", "-1"): "never cut",
    ("loop", "fail_after", "99999999999999999999"): "cut after that many writes: never, in practice",
    ("sim", "gui", "0"): "no window",
    ("sim", "trace", "0"): "a trace file named 0",
    ("sim", "trace", "-1"): "a trace file named -1",
    ("sim", "trace", "nan"): "a trace file named nan",
    ("sim", "trace", "inf"): "a trace file named inf",
    ("sim", "trace", "-inf"): "a trace file named -inf",
    ("sim", "trace", "1e308"): "a trace file named 1e308",
    ("sim", "trace", "99999999999999999999"): "a trace file named 999...",
    ("sim", "trace", "fast"): "a trace file named fast",
    ("udp", "push", "0"): "asks for frames (push=0 is the default)",
    **{("sim", "eeprom", v): f"the board's EEPROM kept in a file named {v}"
       for v in ("0", "-1", "nan", "inf", "-inf", "1e308", "99999999999999999999", "fast")},
}


def url_options(scheme: str) -> list[str]:
    """The query options a scheme's transport takes, read from its source (pop_option and
    pop_number calls): an option added there is tried here without being listed."""
    from importlib import import_module

    from roar.transports import registry

    registry._load_entry_points()
    entry = registry._REGISTRY[scheme]
    module = import_module(entry.split(":")[0] if isinstance(entry, str) else entry.__module__)
    calls = [n for n in ast.walk(ast.parse(Path(module.__file__).read_text())) if isinstance(n, ast.Call)]
    return sorted({c.args[1].value for c in calls if getattr(c.func, "id", None) in ("pop_option", "pop_number")
                   and len(c.args) > 1 and isinstance(c.args[1], ast.Constant)})


URL_CASES = [(scheme, option, value) for scheme in URL_BASE for option in url_options(scheme) for value in VALUES]


def test_every_scheme_has_a_url_to_try_options_on():
    from roar.transports.registry import schemes

    assert set(URL_BASE) == set(schemes())
    assert len(URL_CASES) >= 9 * 10  # the options were found


@pytest.mark.realtime
@pytest.mark.parametrize("scheme, option, value", URL_CASES, ids=[f"{s}-{o}-{v or 'empty'}" for s, o, v in URL_CASES])
def test_a_bad_url_option_is_one_line_or_a_documented_car(scheme, option, value, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # files a valid value names land here
    base = URL_BASE[scheme]
    url = f"{base}{'&' if '?' in base else '?'}{option}={value}"
    with Guard(GUARD_S):
        try:
            car = Vehicle(url)
        except (TransportError, ValueError) as e:
            message = str(e)
            assert message and "\n" not in message and "Traceback" not in message, message
            return
    car.close()
    assert (scheme, option, value) in URL_RUNS, f"{url} opened: refuse {value!r} for {option} in one line, " \
                                                f"or document it in URL_RUNS"


def test_every_default_output_goes_under_out():
    """What a command writes without being told where (plots, tables, frames) lands in out/,
    never in the folder the user happens to be in."""
    defaults = {(command, option): action.default for command, (_, parser) in commands().items()
                for option, action in options(parser) if isinstance(action.default, Path)}
    assert defaults  # there are some
    for (command, option), default in defaults.items():
        assert default.parts[0] == "out", f"roar {command} {option} defaults to {default}"
