"""Offline build of the AnyFC F7 (STM32F745) skeleton with Debian's arm-none-eabi-gcc:
firmware/stm32_freertos + firmware/core -> build/arm/anyfc_f7/roar_anyfc_f7.elf, linked with our
own startup code and linker script, so the board glue is proven to compile and link here.

    python -m roar_sim.arm_build      prints the ELF path and its flash/RAM use
"""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

from roar_sim.avr_build import sizes
from roar_sim.core_build import (CORE, CROSS_TARGETS, EMBEDDED_FLAGS, HOST_ONLY_SOURCES, ROOT, CoreBuildError,
                                 core_sources, run_build)

BOARD = ROOT / "firmware" / "stm32_freertos"
ELF = ROOT / "build" / "arm" / "anyfc_f7" / "roar_anyfc_f7.elf"
FLASH_BYTES, RAM_BYTES = 1024 * 1024, 320 * 1024  # STM32F745VG


def build() -> Path:
    cxx, flags, packages = CROSS_TARGETS["cortex-m7"]
    if not shutil.which(cxx):
        raise CoreBuildError(f"{cxx} not found: apt-get install {packages}")
    sources = sorted(BOARD.glob("*.cpp")) + [p for p in core_sources() if p.name not in HOST_ONLY_SOURCES]
    ELF.parent.mkdir(parents=True, exist_ok=True)
    run_build([cxx, *flags, *EMBEDDED_FLAGS, "-fno-threadsafe-statics", "-nostartfiles", "-nostdlib",
               "-Wl,--gc-sections", "-T", str(BOARD / "stm32f745.ld"), "-I", str(CORE / "include"),
               *map(str, sources), "-o", str(ELF), "-lc", "-lgcc"], "AnyFC F7 build failed")
    return ELF


def main() -> int:
    try:
        elf = build()
    except CoreBuildError as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    flash, ram = sizes(elf, "arm-none-eabi-size")
    print(f"{elf.relative_to(ROOT)}: flash {flash} B, RAM {ram} B")
    return 0


if __name__ == "__main__":
    sys.exit(main())
