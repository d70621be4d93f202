"""`roar key`: the signing key (roar.signing) in your key file and in a car.

    roar key new                         a new key in your key file (~/.config/roar/key)
    roar key set serial:///dev/ttyACM0   put it in the car (making one first if you have none)
    roar key show [URL]                  its fingerprint, and the car's
    roar key clear serial:///dev/ttyACM0 the car takes unsigned messages again

A key is set or cleared over the car's USB serial link only (the car refuses KEY lines on BLE,
Wi-Fi and its radio link), so only someone holding the car can change it.
"""

from __future__ import annotations

import time
from pathlib import Path

from roar.cli.sdk import ArgumentParser, UserError, path_option
from roar.protocol import spec
from roar.signing import SigningError, default_path, new_key, read_key_file, write_key_file
from roar.transports import TransportError, open_url, parse_url
from roar_wire import signing as wire

ANSWER_WAIT_S = 0.5  # [s] for the car's KEY line before asking again
ANSWER_TIMEOUT_S = 5.0  # [s] in all (a Nano resets when its port opens and boots in ~2 s)
SERIAL_SCHEMES = ("serial", "sim")  # links whose bytes reach the car's serial port


def parser() -> ArgumentParser:
    p = ArgumentParser(prog="roar key",
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
    return p


def main(argv: list[str]) -> int:
    args = parser().parse_args(argv)
    if args.url is not None and not args.url.strip():
        raise UserError("the car's URL is empty: give it as serial:///dev/ttyACM0")
    if args.action in ("set", "clear") and not args.url:
        raise UserError(f"roar key {args.action} needs the car's URL, e.g. serial:///dev/ttyACM0")
    path = Path(args.file) if args.file else default_path()
    try:
        return ACTIONS[args.action](args, path)
    except SigningError as e:
        raise UserError(str(e)) from None


def _new(args, path: Path) -> int:
    if path.exists() and not args.force:
        raise UserError(f"{path} already holds a key ({wire.fingerprint(read_key_file(path))}); "
                        f"--force replaces it (cars with the old key then refuse you until you set it again)")
    key_bytes = new_key()
    write_key_file(path, key_bytes)
    print(f"new key {wire.fingerprint(key_bytes)} in {path}; put it in a car with: roar key set URL")
    return 0


def _set(args, path: Path) -> int:
    _check_serial(args.url, keeps=True)
    if not path.exists():
        write_key_file(path, new_key())
        print(f"made a new key in {path}")
    key_bytes = read_key_file(path)
    answer = _ask_car(args.url, f"{spec.SIGNED_KEY_COMMAND} {key_bytes.hex()}")
    want = wire.fingerprint(key_bytes)
    if answer != want:
        raise UserError(f"{args.url} answered KEY {answer}, not {want}: the key was not stored")
    print(f"{args.url} now takes only messages signed with key {want}; every Vehicle (and roar command) "
          f"signs with {path} from now on")
    return 0


def _show(args, path: Path) -> int:
    mine = wire.fingerprint(read_key_file(path)) if path.exists() else None
    print(f"your key: {mine} ({path})" if mine else f"your key: none ({path} does not exist; roar key new)")
    if args.url:
        car = _ask_car(args.url, f"{spec.SIGNED_KEY_COMMAND} ?", read_only=True)
        match = "" if car == spec.SIGNED_KEY_NONE else " (yours)" if car == mine else " (not yours)"
        print(f"{args.url}: {car}{match}")
    return 0


def _clear(args, path: Path) -> int:
    _check_serial(args.url, keeps=True)
    answer = _ask_car(args.url, f"{spec.SIGNED_KEY_COMMAND} -")
    if answer != spec.SIGNED_KEY_NONE:
        raise UserError(f"{args.url} answered KEY {answer}: the key was not cleared")
    print(f"{args.url} has no key: it takes unsigned messages from anyone again")
    return 0


def _check_serial(url: str, keeps: bool = False) -> None:
    """keeps: the key must outlive the command (set, clear): a simulated car keeps it only in a file."""
    scheme = url.split("://", 1)[0].lower()
    if scheme not in SERIAL_SCHEMES:
        raise UserError(f"a car's key is set over its USB serial link only (serial://PORT), not {scheme}://")
    if keeps and scheme == "sim":
        try:
            options = parse_url(url)[2]
        except TransportError as e:
            raise UserError(str(e)) from None
        if "eeprom" not in options:
            raise UserError("a simulated car keeps its key only in a file, and this one would lose it when the "
                            "command ends: give one, sim://?eeprom=FILE")


def _ask_car(url: str, line: str, read_only: bool = False) -> str:
    """Send one KEY line on the car's serial link; the word after KEY in its answer. read_only:
    the question changes nothing the car keeps (Transport.read_only)."""
    _check_serial(url)
    try:
        link = open_url(url)
        link.read_only = read_only
        link.open()
    except TransportError as e:
        raise UserError(str(e)) from None
    try:
        deadline = time.monotonic() + ANSWER_TIMEOUT_S
        while time.monotonic() < deadline:
            link.write(f"\n{line}\n".encode("ascii"))
            asked = time.monotonic()
            while time.monotonic() - asked < ANSWER_WAIT_S:
                for reply in link.read_lines():
                    words = reply.split()
                    if len(words) == 2 and words[0] == spec.SIGNED_KEY_COMMAND:
                        return words[1]
                    if words[:2] == [spec.SERIAL_REPLY_ERROR, "nokey"]:
                        raise UserError(f"{url} could not keep the key: it has no storage for one, "
                                        f"or it is full until the car is reset (its key is unchanged)")
                time.sleep(0.02)
        raise UserError(f"{url} did not answer {line.split()[0]} in {ANSWER_TIMEOUT_S:g} s: "
                        f"is its firmware recent enough to take keys?")
    finally:
        link.close()


ACTIONS = {"new": _new, "set": _set, "show": _show, "clear": _clear}
