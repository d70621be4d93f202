"""Offline build of the classic Nano firmware (ATmega328P, 16 MHz) with Debian's avr-gcc and
Arduino AVR core: firmware/arduino_ble + firmware/core -> build/avr/nano/roar_nano.elf (and .hex).
PlatformIO builds the same sources for users with internet (platformio.ini, env nanoatmega328).

    python -m roar_sim.toolchains.avr [--force]      prints the ELF path and its flash/RAM use
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from roar_sim.toolchains import build_lock, stale
from roar_sim.toolchains.native import CORE, ROOT, CoreBuildError, core_sources, run_build

ARDUINO_AVR = Path("/usr/share/arduino/hardware/arduino/avr")
ARDUINO_CORE = ARDUINO_AVR / "cores" / "arduino"
NANO_VARIANT = ARDUINO_AVR / "variants" / "eightanaloginputs"
BOARD_SOURCES = ROOT / "firmware" / "arduino_ble"
OUT = ROOT / "build" / "avr" / "nano"
ELF = OUT / "roar_nano.elf"
# Test builds of the same firmware. "hang": the loop hangs for good once the car outputs
# throttle 1777 us, as a firmware bug would; the suite proves the hardware watchdog with it.
HANG_THROTTLE_US = 1777  # [us]
TEST_VARIANTS = {"hang": [f"-DROAR_TEST_HANG_ON_THROTTLE_US={HANG_THROTTLE_US}"]}
PACKAGES = "gcc-avr avr-libc binutils-avr arduino-core-avr"
MCU, F_CPU = "atmega328p", 16_000_000  # [Hz]
FLASH_BYTES, RAM_BYTES = 30_720, 2_048  # ATmega328P with the Nano's 2 KB bootloader

DEFINES = [f"-mmcu={MCU}", f"-DF_CPU={F_CPU}L", "-DARDUINO=10819", "-DARDUINO_AVR_NANO", "-DARDUINO_ARCH_AVR"]
COMMON = ["-g", "-Os", "-ffunction-sections", "-fdata-sections", "-flto"]
C_FLAGS = ["-std=gnu11", "-fno-fat-lto-objects", *COMMON]
# The Arduino core as Debian ships it (1.8.7) needs DECIMAL_DIG, which gcc-avr 5.4 defines for C only.
CORE_CXX_FLAGS = ["-std=gnu++11", "-fpermissive", "-fno-exceptions", "-fno-threadsafe-statics",
                  "-DDECIMAL_DIG=__DECIMAL_DIG__", *COMMON]
OUR_CXX_FLAGS = ["-std=gnu++1z", "-fno-exceptions", "-fno-rtti", "-fno-threadsafe-statics", "-Wall", "-Wextra",
                 "-Werror", "-DDECIMAL_DIG=__DECIMAL_DIG__", *COMMON]
ASM_FLAGS = ["-g", "-x", "assembler-with-cpp", "-flto"]


def available() -> str | None:
    """None when the toolchain and the Arduino core are installed, else what to install."""
    if not shutil.which("avr-g++") or not (ARDUINO_CORE / "Arduino.h").exists():
        return f"the Nano build needs: apt-get install {PACKAGES}"
    return None


def _run(cmd: list[str], what: str) -> None:
    run_build(cmd, f"Nano build failed ({what})")


def _arduino_core() -> Path:
    """Debian's Arduino core as a static library, built once."""
    lib = ROOT / "build" / "avr" / "arduino_core.a"
    with build_lock(lib):
        if not lib.exists():
            _build_arduino_core(lib)
    return lib


def _build_arduino_core(lib: Path) -> None:
    obj_dir = lib.parent / "arduino_core"
    obj_dir.mkdir(parents=True, exist_ok=True)
    inc = ["-I", str(ARDUINO_CORE), "-I", str(NANO_VARIANT)]
    objects = []
    for src in sorted(ARDUINO_CORE.iterdir()):
        obj = obj_dir / (src.name + ".o")
        if src.suffix == ".c":
            _run(["avr-gcc", "-c", *C_FLAGS, *DEFINES, *inc, str(src), "-o", str(obj)], src.name)
        elif src.suffix == ".cpp":
            _run(["avr-g++", "-c", *CORE_CXX_FLAGS, *DEFINES, *inc, str(src), "-o", str(obj)], src.name)
        elif src.suffix == ".S":
            _run(["avr-gcc", "-c", *ASM_FLAGS, *DEFINES, *inc, str(src), "-o", str(obj)], src.name)
        else:
            continue
        objects.append(str(obj))
    fd, tmp = tempfile.mkstemp(suffix=".a", dir=lib.parent)
    os.close(fd)
    os.unlink(tmp)
    _run(["avr-gcc-ar", "rcs", tmp, *objects], "archive")
    os.replace(tmp, lib)


def our_sources() -> list[Path]:
    return core_sources() + sorted(BOARD_SOURCES.glob("*.cpp"))


def build(force: bool = False, variant: str | None = None) -> Path:
    """Build (if stale) the Nano ELF, or one of its TEST_VARIANTS, and return its path."""
    missing = available()
    if missing:
        raise CoreBuildError(missing)
    out = OUT if variant is None else OUT.with_name(f"nano-{variant}")
    elf = out / ELF.name
    defines = DEFINES + TEST_VARIANTS.get(variant, [])
    inputs = our_sources() + sorted(BOARD_SOURCES.glob("*.h")) + sorted((CORE / "include").rglob("*.h"))
    with build_lock(elf):
        if force or stale(elf, inputs):
            _build_nano(out, elf, defines)
    return elf


def _build_nano(out: Path, elf: Path, defines: list[str]) -> None:
    core_lib = _arduino_core()
    obj_dir = out / "obj"
    obj_dir.mkdir(parents=True, exist_ok=True)
    inc = ["-I", str(CORE / "include"), "-I", str(BOARD_SOURCES), "-I", str(ARDUINO_CORE), "-I", str(NANO_VARIANT)]
    objects = []
    for src in our_sources():
        obj = obj_dir / (src.parent.name + "_" + src.stem + ".o")
        _run(["avr-g++", "-c", *OUR_CXX_FLAGS, *defines, *inc, str(src), "-o", str(obj)], src.name)
        objects.append(str(obj))
    fd, tmp = tempfile.mkstemp(suffix=".elf", dir=out)
    os.close(fd)
    _run(["avr-gcc", "-Os", "-g", "-flto", "-fuse-linker-plugin", "-Wl,--gc-sections", f"-mmcu={MCU}", "-o", tmp,
          *objects, str(core_lib), "-lm"], "link")
    os.replace(tmp, elf)
    _run(["avr-objcopy", "-O", "ihex", "-R", ".eeprom", str(elf), str(elf.with_suffix(".hex"))], "hex")


BENCH_SOURCE = ROOT / "hil_sim" / "avr" / "parser_bench.cpp"
BENCH_ELF = ROOT / "build" / "avr" / "parser_bench.elf"
BENCH_MESSAGES = 60  # messages per timed run in parser_bench.cpp
BENCH_SBUS_FRAMES = 10  # SBUS frames in its fourth timed run
BENCH_MACS, BENCH_MAC_BYTES = 10, 33  # signed messages of so many bytes in its fifth (a sixth pulse: all taken)


def build_parser_bench() -> Path:
    """The benchmark firmware (no Arduino core): the core's parser timed on the emulated chip."""
    missing = available()
    if missing:
        raise CoreBuildError(missing)
    sources = [BENCH_SOURCE] + core_sources()
    with build_lock(BENCH_ELF):
        if stale(BENCH_ELF, [*sources, *sorted((CORE / "include").rglob("*.h")), Path(__file__)]):
            tmp = BENCH_ELF.with_name(BENCH_ELF.name + ".tmp")
            _run(["avr-g++", *OUR_CXX_FLAGS, *DEFINES, "-I", str(CORE / "include"), *map(str, sources),
                  "-fuse-linker-plugin", "-Wl,--gc-sections", "-o", str(tmp)], "parser bench")
            tmp.replace(BENCH_ELF)
    return BENCH_ELF


def sizes(elf: Path, size_tool: str = "avr-size") -> tuple[int, int]:
    """(flash, RAM) bytes used: text + data, and data + bss."""
    out = subprocess.run([size_tool, "-A", str(elf)], capture_output=True, text=True, check=True).stdout
    sections = {m[1]: int(m[2]) for m in re.finditer(r"^(\.\w+)\s+(\d+)", out, re.M)}
    data, bss = sections.get(".data", 0), sections.get(".bss", 0)
    return sections.get(".text", 0) + data, data + bss


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Build the classic Nano firmware offline.")
    parser.add_argument("--force", action="store_true", help="rebuild even when up to date")
    args = parser.parse_args(argv)
    try:
        elf = build(args.force)
    except CoreBuildError as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    flash, ram = sizes(elf)
    print(f"{elf.relative_to(ROOT)}: flash {flash} B ({100 * flash / FLASH_BYTES:.0f} %), "
          f"RAM {ram} B ({100 * ram / RAM_BYTES:.0f} %)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
