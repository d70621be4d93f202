"""`roar ports`: list the serial ports, marking the ones that look like a car's board."""

from __future__ import annotations

from roar.cli.sdk import ArgumentParser

# USB vendor IDs of boards and USB-serial chips that cars use.
KNOWN_VIDS = {0x2341: "Arduino", 0x2A03: "Arduino", 0x1A86: "CH340 (Nano clone / ESP32)",
              0x10C4: "CP210x (ESP32)", 0x0403: "FTDI", 0x0483: "STM32", 0x303A: "Espressif"}


def parser() -> ArgumentParser:
    return ArgumentParser(prog="roar ports", description="List serial ports, marking likely car boards.")


def main(argv: list[str]) -> int:
    from serial.tools import list_ports

    parser().parse_args(argv)
    found = sorted(list_ports.comports(), key=lambda p: p.device)
    if not found:
        print("no serial ports found (is the car plugged in? on Linux, is your user in the dialout group?)")
        return 1
    for p in found:
        hint = KNOWN_VIDS.get(p.vid or -1, "")
        print(f"{p.device:24} {p.description or ''}" + (f"  [{hint}]" if hint else ""))
    print(f"\ndrive one with: roar drive serial://{found[0].device}")
    return 0
