"""`roar`: one command for cars on USB serial, Bluetooth LE, Wi-Fi or in the simulator.

A car is named by a URL:
"""

from __future__ import annotations

import logging
import signal
import sys
import threading
from importlib.metadata import EntryPoint, PackageNotFoundError, entry_points, version

from roar.cli.sdk import ArgumentParser, Command, UserError, run_command
from roar.transports.registry import url_help

EXAMPLES = """examples:
  roar race --track figure-eight         the autopilot laps the simulated car against the physical limit
  roar race --robot junior               ... or the ROAR Junior (robots: esc, iarrc, junior)
  roar sim --serial                      the simulated car as a serial port (prints its path)
  roar send sim:// --throttle 0.3 --steering 0.5 --for 5
  roar send "sim://?robot=iarrc" --speed 1.5 --for 3
  roar drive serial:///dev/ttyUSB0       drive with the keyboard
  roar record sim://oval --out run.mcap  drive with the keyboard, everything recorded (open it in Foxglove)
  roar replay run.mcap                   what a recording holds: duration, channels, rates, gaps
  roar dataset run.mcap --out tub        its camera frames and commands as a DonkeyCar tub
  roar web sim://oval                    drive from a browser: http://127.0.0.1:8887
  roar ros2 sim://oval                   the car as a ROS 2 node: /drive in, /odom, /scan, /tf out
  roar calibrate ble://                  set trim and end-points, saved for next time
  roar key set serial:///dev/ttyACM0     only you drive it from now on (signed messages)
  roar <command> --help                  more about one command
"""

def _ros2_variants():
    from roar.cli.ros2 import variants

    return variants()


# roar's own commands: one module each under roar.cli, with its parser() and main(argv)
BUILT_IN = {
    "send": Command("hold one command for a while, then stop", "roar.cli.send"),
    "drive": Command("drive with the keyboard", "roar.cli.drive"),
    "record": Command("record a car into an MCAP file while you drive it", "roar.cli.record"),
    "replay": Command("what an MCAP recording holds", "roar.cli.replay"),
    "dataset": Command("camera frames and commands of a recording, for imitation learning", "roar.cli.dataset"),
    "web": Command("drive and watch a car from a browser (phone or laptop)", "roar.cli.web"),
    "ros2": Command("serve the car as a ROS 2 node (/drive, /cmd_vel in; /odom, /scan, /tf out); --bag: a rosbag2",
                    "roar.cli.ros2", variants=_ros2_variants),
    "calibrate": Command("set trim and end-points interactively", "roar.cli.calibrate"),
    "key": Command("signed control: only the holder of the key drives the car", "roar.cli.key"),
    "scan": Command("list Bluetooth LE cars nearby", "roar.cli.scan"),
    "ports": Command("list serial ports", "roar.cli.ports"),
    "stream": Command("show a car's camera, depth and state streams (UDP)", "roar.cli.stream"),
    "vision": Command("lane detection and obstacles over a folder of recorded frames", "roar.cli.vision"),
}
# Commands other packages add through the "roar.commands" entry point group (name = the command,
# value = "module:Command object"; roar.cli.sdk); the ones this project's extras provide are
# named here, so a base install can say what to install.
PLUGIN_GROUP = "roar.commands"
EXTRA_COMMANDS = {"challenge": "sim", "fit": "sim", "limits": "sim", "platoon": "sim", "race": "sim", "sim": "sim",
                  "step-response": "sim", "sweep": "sweep", "track": "sim", "world": "sim"}


def plugins() -> dict[str, EntryPoint]:
    """The installed packages' commands, by name (not loaded)."""
    return {ep.name: ep for ep in entry_points(group=PLUGIN_GROUP) if ep.name not in BUILT_IN}


def commands() -> dict[str, Command]:
    """Every command this installation has, ours and the plug-ins', loaded (cheap: each names
    its module, imported only when it runs)."""
    return {**BUILT_IN, **{name: ep.load() for name, ep in plugins().items()}}


def missing_message(name: str, module: str | None = None) -> str:
    what = f"needs {module}" if module else "is not installed"
    extra = EXTRA_COMMANDS.get(name)
    return f"roar {name} {what}: pip install 'roar-platform[{extra}]'" if extra else f"roar {name} {what}"


def parser() -> ArgumentParser:
    """roar's own options and the command's name; each command parses the rest itself."""
    p = ArgumentParser(prog="roar", description=__doc__ + url_help(), epilog=EXAMPLES)
    p.add_argument("-v", "--verbose", action="store_true", help="log what the library does")
    p.add_argument("--version", action="version", version=f"roar {_version()}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", required=True)
    installed = plugins()
    for name in [*BUILT_IN, *sorted(set(installed) | set(EXTRA_COMMANDS))]:
        if name in BUILT_IN:
            help_text = BUILT_IN[name].help
        elif name in installed:
            help_text = installed[name].load().help
        else:
            help_text = f"(not installed) {missing_message(name)}"
        sub.add_parser(name, help=help_text, add_help=False)
    return p


def _version() -> str:
    try:
        return version("roar-platform")
    except PackageNotFoundError:
        return "unknown (not installed)"


def main(argv: list[str] | None = None) -> int:
    from_command_line = argv is None
    argv = sys.argv[1:] if argv is None else list(argv)
    command = next((a for a in argv if not a.startswith("-")), None)
    status = run_command(f"roar {command}" if command else "roar", _main, argv)
    if from_command_line and threading.current_thread() is threading.main_thread():
        # it has ended: a Ctrl-C while the interpreter shuts down (its threads, its atexit) must
        # not turn the status it reports (130 for the Ctrl-C that ended it) into a death by SIGINT
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        # CPython 3.11 marks a KeyboardInterrupt that left any exec() of a string (scipy runs
        # `exec("from numpy import *")` on import) as unhandled, and `python -m roar.cli` then dies
        # by SIGINT after the status was set, whatever caught it; an exec() that ends well unmarks it
        exec("")
    return status


def _main(argv: list[str]) -> int:
    """roar's options up to the command's name, then the command with the rest."""
    at = next((i for i, a in enumerate(argv) if not a.startswith("-")), len(argv))
    args = parser().parse_args(argv[:at + 1])
    logging.basicConfig(level=logging.INFO if args.verbose else logging.WARNING, format="roar: %(message)s")
    rest = argv[at + 1:]
    if args.command in BUILT_IN:
        return BUILT_IN[args.command].main(rest)
    installed = plugins()
    if args.command not in installed:
        raise UserError(missing_message(args.command))
    try:
        return installed[args.command].load().main(rest)
    except ImportError as e:  # the plug-in is there but an extra it needs is not
        raise UserError(missing_message(args.command, e.name)) from None


if __name__ == "__main__":
    sys.exit(main())
