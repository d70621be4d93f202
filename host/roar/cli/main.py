"""`roar`: one command for cars on USB serial, Bluetooth LE, Wi-Fi or in the simulator.

A car is named by a URL:
"""

from __future__ import annotations

import argparse
import logging
import math
import sys
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

from roar.calibration import default_path
from roar.cli import plugins
from roar.checks import MAX_SCAN_S
from roar.cli.errors import (ArgumentParser, UserError, add_foxglove_option, number_option, path_option, port_option,
                             run_command, seconds_option)
from roar.transports.registry import url_help
from roar.vision.geometry import SIMULATED_CAR_CAMERA

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
  roar calibrate ble://                  set trim and end-points, saved for next time
  roar key set serial:///dev/ttyACM0     only you drive it from now on (signed messages)
  roar <command> --help                  more about one command
"""


def _add_url(p: argparse.ArgumentParser) -> None:
    p.add_argument("url", metavar="URL", help="the car: sim://, serial:///dev/ttyUSB0, ble://NAME (see `roar --help`)")


def _add_calibration(p: argparse.ArgumentParser) -> None:
    p.add_argument("--calibration", type=path_option, metavar="TOML",
                   help=f"calibration file (default: {default_path()} if it exists)")


def _add_log(p: argparse.ArgumentParser) -> None:
    p.add_argument("--log", type=path_option, metavar="MCAP",
                   help="record the run into this MCAP file (every message sent and line received, the state)")


def _listen_address(text: str) -> str:
    """An argparse type: an IP address to listen on (or localhost), not a name to look up."""
    import ipaddress

    if text != "localhost":
        try:
            ipaddress.ip_address(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be an IP address such as 127.0.0.1 or 0.0.0.0, got {text!r}") from None
    return text


def build_parser() -> argparse.ArgumentParser:
    parser = ArgumentParser(prog="roar", description=__doc__ + url_help(), epilog=EXAMPLES)
    parser.add_argument("-v", "--verbose", action="store_true", help="log what the library does")
    parser.add_argument("--version", action="version", version=f"roar {_version()}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)

    p = sub.add_parser("send", help="hold one command for a while, then stop",
                       description="Send throttle and steering (each -1..1) for some seconds, then neutral; "
                                   "or, to a car with a speed controller (READY 2), speed and steering.")
    _add_url(p)
    how = p.add_mutually_exclusive_group()
    how.add_argument("--throttle", type=float, default=None, help="-1 (full reverse) .. 1 (full forward); default 0")
    how.add_argument("--speed", type=float, default=None, metavar="M/S",
                     help="the speed to hold [m/s], on a car with a speed controller (e.g. sim://?robot=iarrc)")
    p.add_argument("--steering", type=float, default=0.0, help="-1 (full left) .. 1 (full right); default 0")
    p.add_argument("--for", dest="seconds", type=float, default=1.0, metavar="SECONDS",
                   help="how long to hold it (default 1 s, at most 3600)")
    _add_calibration(p)
    _add_log(p)

    p = sub.add_parser("drive", help="drive with the keyboard",
                       description="Keyboard teleop: W/S or Up/Down change throttle by 0.1, A/D or Left/Right "
                                   "steer by 0.2, space stops, Q quits. Neutral is sent on exit.")
    _add_url(p)
    _add_calibration(p)
    _add_log(p)

    p = sub.add_parser("record", help="record a car into an MCAP file while you drive it",
                       description="Drive with the keyboard (as `roar drive`) while everything is recorded into an "
                                   "MCAP file: every control message as sent (its text and what the car's parser "
                                   "makes of it), every line the car sends, and the car's state and pose, in "
                                   "Foxglove's own message types where one fits. Open the file in Foxglove, or "
                                   "read it with `roar replay`. With --for, no keyboard: the car is held at "
                                   "neutral and listened to for that long (its boot lines, telemetry).")
    _add_url(p)
    p.add_argument("--out", type=path_option, required=True, metavar="MCAP", help="the file to write (replaced)")
    p.add_argument("--for", dest="seconds", type=number_option(0, 3600, "s", low_open=True), default=None,
                   metavar="SECONDS", help="listen at neutral this long instead of driving with the keyboard")
    add_foxglove_option(p, when="also ")
    _add_calibration(p)

    p = sub.add_parser("replay", help="what an MCAP recording holds",
                       description="Summarise a recording (`roar record`, `--log`, Vehicle(record=...)): its "
                                   "duration, clock and car, and per channel the message count, rate and the "
                                   "longest gap, so a stalled sensor or link shows at a glance. --plot draws it; "
                                   "--to URL plays its commands to a car (the simulator, or a real one after you "
                                   "confirm) through the library, which re-sends them and ends at neutral.")
    p.add_argument("file", type=path_option, metavar="MCAP", help="the recording")
    p.add_argument("--plot", type=path_option, metavar="PNG", help="draw the path, the speed and the commands")
    p.add_argument("--to", metavar="URL", help="play the recorded commands to this car at their recorded times "
                                               "(a real car asks first; the failsafe rules hold as ever)")
    p.add_argument("--yes", action="store_true", help="with --to a real car: do not ask")

    p = sub.add_parser("dataset", help="camera frames and commands of a recording, for imitation learning",
                       description="Turn a recording's camera frames, each with the command the car was driving "
                                   "by when it was taken, into a dataset: a DonkeyCar tub v2 (--format donkey: "
                                   "DonkeyCar's own trainer reads it) or one .npz of arrays (--format npz: "
                                   "images, angle, throttle, t_s; examples/dataset_npz.py loads it for PyTorch). "
                                   "Angle and throttle are the pulses as fractions of their range, -1..1.")
    p.add_argument("file", type=path_option, metavar="MCAP", help="the recording (with camera frames)")
    p.add_argument("--format", choices=["donkey", "npz"], default="donkey", help="default donkey")
    p.add_argument("--out", type=path_option, required=True, metavar="PATH", help="the tub's folder, or the .npz")

    p = sub.add_parser("web", help="drive and watch a car from a browser (phone or laptop)",
                       description="Serve a page that drives the car (on-screen joystick, keys, gamepad; a "
                                   "max-throttle limit; a stop button) and shows its camera, state and link, "
                                   "with rolling plots; record on/off, and an autopilot on the simulator. One "
                                   "page drives, others watch until they press Drive. The car goes to neutral "
                                   "when the driver's page is hidden, closed, loses its socket or is silent "
                                   "for 250 ms. Bound to 127.0.0.1 unless --host says otherwise; then a "
                                   "token is needed, printed in the URL.")
    p.add_argument("url", metavar="URL", nargs="?", default="sim://",
                   help="the car (default sim://, the simulator: sim://oval gives it a track to follow)")
    p.add_argument("--host", type=_listen_address, default="127.0.0.1",
                   help="the IP address to listen on (default 127.0.0.1; 0.0.0.0: every interface, with a token)")
    p.add_argument("--port", type=port_option, default=8887, help="default 8887")
    p.add_argument("--record-dir", type=path_option, default=Path("out/web"), metavar="DIR",
                   help="where the record button writes its MCAP files (default out/web)")
    p.add_argument("--max-speed", type=number_option(0.1, 10, "m/s"), default=2.0, metavar="M/S",
                   help="full stick on a car driven by speed (the IARRC car; default 2)")
    p.add_argument("--for", dest="seconds", type=number_option(0, 86400, "s", low_open=True), default=None,
                   metavar="SECONDS", help="stop serving after this long (default: Ctrl-C)")
    _add_calibration(p)

    p = sub.add_parser("calibrate", help="set trim and end-points interactively",
                       description="Walk through steering and throttle trim and end-points with the car "
                                   "holding each pulse as you type it; saves a calibration file.")
    _add_url(p)
    p.add_argument("--file", type=path_option, default=None, metavar="TOML",
                   help=f"where to save (default: {default_path()})")

    p = sub.add_parser("key", help="signed control: only the holder of the key drives the car",
                       description="Signed control (off until you set a key). `roar key set URL` puts your key "
                                   "(made if you have none) into the car over its USB serial link; the car then "
                                   "acts only on messages signed with it and refuses the rest (unsigned, forged, "
                                   "replayed), and every Vehicle and roar command signs with your key file. "
                                   "Keys are set and cleared over USB serial only.")
    p.add_argument("action", choices=("new", "set", "show", "clear"),
                   help="new: a new key in your key file; set URL: put it in the car; show [URL]: the "
                        "fingerprints of yours and the car's; clear URL: the car takes unsigned messages again")
    p.add_argument("url", metavar="URL", nargs="?", default=None, help="the car, on its serial link (serial://PORT)")
    p.add_argument("--file", type=path_option, default=None, metavar="KEYFILE",
                   help="the key file (default: ~/.config/roar/key)")
    p.add_argument("--force", action="store_true", help="new: replace the key in the key file")

    p = sub.add_parser("scan", help="list Bluetooth LE cars nearby",
                       description="Scan for cars advertising the ROAR service (or every device with --all).")
    p.add_argument("--timeout", type=number_option(0, MAX_SCAN_S, "s", low_open=True), default=5.0, metavar="SECONDS",
                   help="how long to listen (default 5)")
    p.add_argument("--all", action="store_true", help="list every device, not only ROAR cars")

    sub.add_parser("ports", help="list serial ports", description="List serial ports, marking likely car boards.")

    p = sub.add_parser("stream", help="show a car's camera, depth and state streams (UDP)",
                       description="Receive the camera, depth and state streams of a car's phone (ROAR's UDP "
                                   "chunked format; `roar sim --stream` for the simulated car), show them in a "
                                   "window (or PNGs without a display), and print frames/s, latency and loss "
                                   "once a second.")
    p.add_argument("url", metavar="URL", help="udp://HOST, the phone (udp://127.0.0.1 for `roar sim --stream`)")
    p.add_argument("--seconds", type=seconds_option, default=0.0, metavar="S", help="stop after this long (default: Ctrl-C)")
    p.add_argument("--push", action="store_true",
                   help="listen on ports 8001-8003 for pushed frames instead of asking for each with 'ack'")
    p.add_argument("--out", type=path_option, default=None, metavar="DIR",
                   help="write PNGs here (one a second, and the last) instead of opening a window")
    p.add_argument("--log", type=path_option, metavar="MCAP",
                   help="record every frame (camera JPEG, depth, state) and each second's figures into this MCAP file")

    p = sub.add_parser("vision", help="lane detection and obstacles over a folder of recorded frames",
                       description="Run the car's perception over recorded frames (a real car's or the "
                                   "simulator's): lane lines in every image (PNG/JPEG, or RGB .npy) in name "
                                   "order, and the ground-plane occupancy grid where a NAME_depth.npy (metres) "
                                   "lies beside it. Writes a debug view per frame, optionally a video, and "
                                   "prints offset, heading and the nearest obstacle per frame. The camera is the "
                                   "simulated car's unless --fov/--height/--ahead/--pitch say otherwise.")
    p.add_argument("folder", type=path_option, metavar="FOLDER|MCAP",
                   help="the recorded frames: a folder (roar race --frames), or a recording's camera frames")
    p.add_argument("--out", type=path_option, default=Path("out/vision"), metavar="DIR",
                   help="where the debug views go (default: out/vision)")
    p.add_argument("--video", type=path_option, default=None, metavar="MP4", help="also write the lane views as a video")
    p.add_argument("--fps", type=float, default=10.0, help="the video's frame rate (default 10)")
    cam = SIMULATED_CAR_CAMERA
    p.add_argument("--fov", type=float, default=cam.fov_deg, metavar="DEG",
                   help=f"vertical field of view (default {cam.fov_deg:g})")
    p.add_argument("--height", type=float, default=cam.z_m, metavar="M",
                   help=f"camera above the floor (default {cam.z_m:g})")
    p.add_argument("--ahead", type=float, default=cam.x_m, metavar="M",
                   help=f"camera ahead of the car's reference point, the rear axle (default {cam.x_m:g})")
    p.add_argument("--pitch", type=float, default=math.degrees(cam.pitch_rad), metavar="DEG",
                   help=f"tilted down from level (default {math.degrees(cam.pitch_rad):.2f})")

    # Commands of other packages (the simulator's race and sim): each parses its own arguments
    # (main() hands them over), so they are listed here for --help only.
    installed = plugins.installed()
    for name in sorted(set(installed) | set(plugins.EXTRA_COMMANDS)):
        help_text = installed[name].load().help if name in installed else f"(not installed) {plugins.missing_message(name)}"
        sub.add_parser(name, help=help_text, add_help=False)
    return parser


def _version() -> str:
    try:
        return version("roar-platform")
    except PackageNotFoundError:
        return "unknown (not installed)"


def _plugin_call(argv: list[str]) -> tuple[list[str], list[str]] | None:
    """(roar's own arguments up to the command, the command's arguments) when the command is a
    plug-in's, else None."""
    names = set(plugins.installed()) | set(plugins.EXTRA_COMMANDS)
    for i, token in enumerate(argv):
        if not token.startswith("-"):
            return (argv[:i + 1], argv[i + 1:]) if token in names else None
    return None


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    plugin_call = _plugin_call(argv)
    command = next((a for a in argv if not a.startswith("-")), None)
    return run_command(f"roar {command}" if command else "roar", _main, argv, plugin_call)


def _main(argv: list[str], plugin_call: tuple[list[str], list[str]] | None) -> int:
    args = build_parser().parse_args(plugin_call[0] if plugin_call else argv)
    logging.basicConfig(level=logging.INFO if args.verbose else logging.WARNING, format="roar: %(message)s")
    return _run(args, plugin_call[1] if plugin_call else None)


def _run(args: argparse.Namespace, plugin_argv: list[str] | None) -> int:
    """One command: ours (roar.cli.commands), or a plug-in's with its own arguments."""
    if plugin_argv is None:
        from roar.cli import commands

        return getattr(commands, args.command)(args)
    installed = plugins.installed()
    if args.command not in installed:
        raise UserError(plugins.missing_message(args.command))
    try:
        return installed[args.command].load().main(plugin_argv)
    except ImportError as e:  # the plug-in is there but an extra it needs is not
        raise UserError(plugins.missing_message(args.command, e.name)) from None


if __name__ == "__main__":
    sys.exit(main())
