"""The `roar` subcommands; each takes the parsed arguments and returns the exit status."""

from __future__ import annotations

import math
import sys
import time

from roar.checks import printable
from roar.cli.errors import UserError
from roar.protocol import spec
from roar.user_files import unusable_folder, unwritable
from roar.vehicle import Vehicle

MAX_SEND_S = 3600.0  # [s]
# [s] how long to wait at the end for any reply: a classic Nano resets when its port opens and
# takes about 2 s to boot and answer
REPLY_GRACE_S = 3.0

# USB vendor IDs of boards and USB-serial chips that cars use.
KNOWN_VIDS = {0x2341: "Arduino", 0x2A03: "Arduino", 0x1A86: "CH340 (Nano clone / ESP32)",
              0x10C4: "CP210x (ESP32)", 0x0403: "FTDI", 0x0483: "STM32", 0x303A: "Espressif"}


def _vehicle(args, record=None) -> Vehicle:
    return Vehicle(args.url, calibration=getattr(args, "calibration", None),
                   record=record if record is not None else getattr(args, "log", None))


def key(args) -> int:
    from roar.cli.keys import key as run

    if args.url is not None and not args.url.strip():
        raise UserError("the car's URL is empty: give it as serial:///dev/ttyACM0")
    if args.action in ("set", "clear") and not args.url:
        raise UserError(f"roar key {args.action} needs the car's URL, e.g. serial:///dev/ttyACM0")
    return run(args)


def send(args) -> int:
    if not 0 < args.seconds <= MAX_SEND_S:
        raise UserError(f"--for must be more than 0 and at most {MAX_SEND_S:g} s, got {args.seconds:g}")
    with _vehicle(args) as car:
        if args.speed is not None:
            car.drive(speed=args.speed, steering=args.steering)
            what = f"{args.speed:g} m/s, steering {args.steering:g}"
        else:
            car.drive(args.throttle or 0.0, args.steering)
            what = "({},{})".format(*car.pulses_us())
        print(f"sending {what} to {args.url} for {args.seconds:g} s", flush=True)
        time.sleep(args.seconds)
        car.stop()
        silent = car.transport.replies and car.wait_for(timeout_s=REPLY_GRACE_S, since=0.0) is None
        link_ok = car.connected
        lines = [r for r in car.replies if not r.startswith(spec.TELEMETRY_REPLY)]  # telemetry is summed up below
        replies = ", ".join(printable(r) for r in lines[-5:]) or ("none" if car.transport.replies
                                                                 else "none (this link has none)")
        state = car.state()
        if state.battery_v is not None:
            replies += f"; battery {state.battery_v:.2f} V, driven {state.distance_m:.2f} m, mode {state.mode}"
    if silent:
        raise UserError(f"no reply from a car on {args.url} (no READY, ARMED or FAILSAFE line in "
                        f"{args.seconds + REPLY_GRACE_S:g} s): is a ROAR car running there?")
    stopped = "zero speed" if args.speed is not None else "neutral"
    if link_ok:
        print(f"done, {stopped} sent; link ok; car replies: {replies}")
    else:  # nothing could be sent at the end: say so, and what stops the car
        print(f"link down: {printable(car.link_error, 200)}; {stopped} could not be sent (the car's failsafe stops "
              f"it when commands stop coming); car replies: {replies}")
    return 0 if car.errors == 0 and link_ok else 1


def stream(args) -> int:
    from roar.cli.stream_view import run

    return run(args.url, args.seconds, args.push, args.out, args.log)


def vision(args) -> int:
    if not (1 <= args.fov < 180 and 0 < args.height <= 5 and -5 <= args.ahead <= 5 and -45 <= args.pitch <= 89
            and 0.1 <= args.fps <= 120):
        raise UserError("want --fov 1..179 deg, --height 0..5 m, --ahead -5..5 m, --pitch -45..89 deg, --fps 0.1..120")
    for option, problem in (("--out", unusable_folder(args.out)),
                            ("--video", args.video is not None and unwritable(args.video))):
        if problem:
            raise UserError(f"{option} {problem}")
    try:
        from roar.cli.vision_frames import run
        from roar.vision.geometry import CameraPreset

        camera = CameraPreset(args.fov, args.ahead, args.height, math.radians(args.pitch))
        return run(args.folder, args.out, args.video, args.fps, camera)
    except ImportError as e:
        raise UserError(f"roar vision needs {e.name}: pip install 'roar-platform[vision]'") from None


def drive(args) -> int:
    from roar.cli.teleop import run

    with _vehicle(args) as car:
        return run(car)


def record(args) -> int:
    from roar.cli.teleop import run

    if args.seconds is None and not sys.stdin.isatty():  # before the car is opened and the file made
        raise UserError("roar record drives with the keyboard: run it in a terminal, or give --for SECONDS")
    from roar.recorder import Recorder

    recorder = Recorder(args.out, {"car": args.url, "command": " ".join(sys.argv)},
                        simulated=args.url.split(":", 1)[0].lower() == "sim", serve_port=args.foxglove)
    if args.foxglove is not None:
        print(f"serving the channels live: Foxglove, Open connection, ws://127.0.0.1:{args.foxglove}", flush=True)
    try:
        car = _vehicle(args, record=recorder)
    except BaseException:
        recorder.close()
        raise
    with car:
        if args.seconds is None:
            status = run(car)
        else:
            print(f"recording {args.url} at neutral for {args.seconds:g} s into {args.out}", flush=True)
            time.sleep(args.seconds)
            status = 0
    print(f"recorded {car.recorder.messages} messages into {args.out} (open it in Foxglove, or `roar replay "
          f"{args.out}`)")
    return status


def replay(args) -> int:
    from roar.replay import commands, play, plot, summary
    from roar.user_files import unwritable

    if args.plot is not None and unwritable(args.plot):
        raise UserError(f"--plot {unwritable(args.plot)}")
    print(summary(args.file), flush=True)
    if args.plot is not None:
        plot(args.file, args.plot)
        print(f"plot: {args.plot}")
    if args.to is None:
        return 0
    todo = commands(args.file)
    if not todo:
        raise UserError(f"{args.file}: no control messages to play")
    scheme = args.to.split(":", 1)[0].lower()
    if scheme not in ("sim", "loop") and not args.yes:
        if not sys.stdin.isatty():
            raise UserError(f"--to {args.to} drives a real car: run in a terminal to confirm, or add --yes")
        answer = input(f"play {len(todo)} commands over {todo[-1][0]:.1f} s to {args.to}? the car will move "
                       f"(type yes): ")
        if answer.strip().lower() != "yes":
            print("not played")
            return 1
    with Vehicle(args.to, calibration=None) as car:
        played = play(args.file, car)
    print(f"played {played} commands to {args.to} over {todo[-1][0]:.1f} s; neutral sent")
    return 0


def calibrate(args) -> int:
    from roar.calibration import default_path
    from roar.cli.calibrate import run

    path = args.file or default_path()
    problem = unwritable(path)  # before the walk-through, not after it
    if problem:
        raise UserError(f"--file {problem}")
    with Vehicle(args.url, calibration=None) as car:
        return run(car, path, sys.stdin, sys.stdout)


def scan(args) -> int:
    try:
        from roar.transports.ble import scan as ble_scan
    except ImportError as e:
        raise UserError(f"roar scan needs {e.name}: pip install 'roar-platform[ble]'") from None

    print(f"scanning for {args.timeout:g} s ...", file=sys.stderr, flush=True)
    found = ble_scan(args.timeout, only_cars=not args.all)
    if not found:
        print("no cars found" + ("" if args.all else " (is the car powered? try --all)"))
        return 1
    print(f"{'NAME':24} {'ADDRESS':20} RSSI")
    for dev in found:
        print(f"{printable(dev.name or '?', 24):24} {dev.address:20} {dev.rssi if dev.rssi is not None else '?'}")
    print(f"\ndrive one with: roar drive 'ble://{printable(found[0].name or found[0].address)}'")
    return 0


def ports(args) -> int:
    from serial.tools import list_ports

    found = sorted(list_ports.comports(), key=lambda p: p.device)
    if not found:
        print("no serial ports found (is the car plugged in? on Linux, is your user in the dialout group?)")
        return 1
    for p in found:
        hint = KNOWN_VIDS.get(p.vid or -1, "")
        print(f"{p.device:24} {p.description or ''}" + (f"  [{hint}]" if hint else ""))
    print(f"\ndrive one with: roar drive serial://{found[0].device}")
    return 0


def dataset(args) -> int:
    from roar.dataset import write_donkey, write_npz
    from roar.user_files import unusable_folder, unwritable

    problem = unusable_folder(args.out) if args.format == "donkey" else unwritable(args.out)
    if problem:
        raise UserError(f"--out {problem}")
    count = (write_donkey if args.format == "donkey" else write_npz)(args.file, args.out)
    print(f"{count} frames with their commands into {args.out} ({args.format})")
    return 0


def web(args) -> int:
    """Serve the browser controller for the car until Ctrl-C (or --for); neutral at the end."""
    try:
        from roar.web.server import WebServer
        import websockets  # noqa: F401  (the page's socket)
    except ImportError as e:
        raise UserError(f"roar web needs {e.name}: pip install 'roar-platform[web]'") from None
    with _vehicle(args) as car:
        server = WebServer(car, host=args.host, port=args.port, record_dir=args.record_dir,
                           max_speed_m_s=args.max_speed)
        server.start()
        try:
            where = "" if server.loopback else " (anyone with this URL can drive: its token is the key)"
            print(f"roar web: open {server.url}{where}; Ctrl-C ends (the car goes to neutral)", flush=True)
            if server.lan_url:
                print(f"roar web: from another machine (a phone on this network): {server.lan_url}", flush=True)
            end = None if args.seconds is None else time.monotonic() + args.seconds
            while server.serving and (end is None or time.monotonic() < end):
                time.sleep(0.1)
        finally:
            server.stop()
    print(f"served {server.pages_served} page(s); {server.ignored_total()} message(s) ignored, "
          f"{sum(server.refused.values())} request(s) refused; the car was left at neutral")
    return 0
