"""Flash and RAM per target, built offline: the shared core alone for each microcontroller,
and the whole firmware where this machine can link it (classic Nano, AnyFC F7 IARRC controller
without FreeRTOS: its SysTick task dispatcher).

    python -m roar_sim.toolchains.sizes
"""

from __future__ import annotations

import subprocess
import sys

from roar_sim.toolchains import arm, avr
from roar_sim.toolchains.native import CROSS_TARGETS, CoreBuildError, cross_compile

SIZE_TOOLS = {"atmega328p": "avr-size", "cortex-m4f": "arm-none-eabi-size", "cortex-m7": "arm-none-eabi-size"}
CHIPS = {"atmega328p": ("ATmega328P (Nano)", avr.FLASH_BYTES, avr.RAM_BYTES),
         "cortex-m4f": ("nRF52840 (Nano 33 BLE)", 1024 * 1024, 256 * 1024),
         "cortex-m7": ("STM32F745 (AnyFC F7)", arm.FLASH_BYTES, arm.RAM_BYTES)}


def core_size(target: str) -> tuple[int, int]:
    """(flash, RAM) bytes of the core's objects for a target: text + data, data + bss."""
    objects = cross_compile(target)
    out = subprocess.run([SIZE_TOOLS[target], "-t", *map(str, objects)], capture_output=True, text=True,
                         check=True).stdout.splitlines()[-1].split()
    text, data, bss = int(out[0]), int(out[1]), int(out[2])
    return text + data, data + bss


def rows() -> list[tuple[str, str, int | None, int | None, str]]:
    """(chip, what, flash, RAM, note) for every target; None sizes with the reason in note."""
    result = []
    for target in CROSS_TARGETS:
        chip = CHIPS[target][0]
        try:
            flash, ram = core_size(target)
            result.append((chip, "core, unlinked objects", flash, ram, ""))
        except CoreBuildError as e:
            result.append((chip, "core, unlinked objects", None, None, str(e)))
    for chip, what, build, tool in (("ATmega328P (Nano)", "whole firmware", avr.build, "avr-size"),
                                    ("STM32F745 (AnyFC F7)", "IARRC controller (SysTick build)", arm.build,
                                     "arm-none-eabi-size")):
        try:
            flash, ram = avr.sizes(build(), tool)
            result.append((chip, what, flash, ram, ""))
        except CoreBuildError as e:
            result.append((chip, what, None, None, str(e)))
    return result


def run() -> None:
    budgets = {chip: (flash, ram) for chip, flash, ram in CHIPS.values()}
    print(f"  {'chip':24} {'what':24} {'flash':>16} {'RAM':>16}")
    for chip, what, flash, ram, note in rows():
        if flash is None:
            print(f"  {chip:24} {what:24} skipped: {note}")
            continue
        fb, rb = budgets[chip]
        print(f"  {chip:24} {what:24} {flash:>7} B {100 * flash / fb:5.1f} % {ram:>7} B {100 * ram / rb:5.1f} %")


TITLE = "firmware size per target (flash, RAM; % of the chip)"


def main() -> int:
    run()
    return 0


if __name__ == "__main__":
    sys.exit(main())
