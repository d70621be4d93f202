"""`roar scan`: list the Bluetooth LE cars nearby (or every device with --all)."""

from __future__ import annotations

import sys

from roar.checks import MAX_SCAN_S, printable
from roar.cli.sdk import ArgumentParser, UserError, number_option


def parser() -> ArgumentParser:
    p = ArgumentParser(prog="roar scan",
                       description="Scan for cars advertising the ROAR service (or every device with --all).")
    p.add_argument("--timeout", type=number_option(0, MAX_SCAN_S, "s", low_open=True), default=5.0, metavar="SECONDS",
                   help="how long to listen (default 5)")
    p.add_argument("--all", action="store_true", help="list every device, not only ROAR cars")
    return p


def main(argv: list[str]) -> int:
    args = parser().parse_args(argv)
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
