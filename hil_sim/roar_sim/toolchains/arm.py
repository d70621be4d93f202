"""Offline builds with Debian's arm-none-eabi-gcc:

* the AnyFC F7 (STM32F745) IARRC controller: firmware/stm32_freertos + firmware/core ->
  build/arm/anyfc_f7/roar_anyfc_f7.elf, linked with our own startup code and linker script, so
  the board glue is proven to compile and link here;
* the same glue built for QEMU's netduinoplus2 (STM32F405, Cortex-M4): build_iarrc_emulated();
* test images for QEMU's netduinoplus2 that run pieces of that glue:
  hil_sim/stm32/clock_probe.cpp (the board's clock source; see roar_sim.emulators.qemu) and
  hil_sim/stm32/sbus_bench.cpp (the SBUS decoder's cost on a Cortex-M4).

    python -m roar_sim.toolchains.arm      prints the ELF path and its flash/RAM use
"""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

from roar_sim.toolchains import build_lock, stale
from roar_sim.toolchains.avr import sizes
from roar_sim.toolchains.native import (CORE, CROSS_TARGETS, EMBEDDED_FLAGS, ROOT, CoreBuildError,
                                 core_sources, run_build)

BOARD = ROOT / "firmware" / "stm32_freertos"
ELF = ROOT / "build" / "arm" / "anyfc_f7" / "roar_anyfc_f7.elf"
FLASH_BYTES, RAM_BYTES = 1024 * 1024, 320 * 1024  # STM32F745VG
EMULATOR = ROOT / "hil_sim" / "stm32"
CLOCK_PROBE = ROOT / "build" / "arm" / "netduinoplus2" / "clock_probe.elf"
SBUS_BENCH = ROOT / "build" / "arm" / "netduinoplus2" / "sbus_bench.elf"
IARRC_EMULATED = ROOT / "build" / "arm" / "netduinoplus2" / "iarrc.elf"
TASK_BENCH = ROOT / "build" / "arm" / "netduinoplus2" / "task_bench.elf"


def _link(target: str, sources: list[Path], linker_script: Path, elf: Path, what: str,
          defines: tuple[str, ...] = (), c_sources: tuple[Path, ...] = (), includes: tuple[Path, ...] = ()) -> Path:
    """Build `elf` (if stale: older than a source, a header or the linker script) and return it."""
    cxx, flags, packages = CROSS_TARGETS[target]
    if not shutil.which(cxx):
        raise CoreBuildError(f"{cxx} not found: apt-get install {packages}")
    core = core_sources()
    headers = [h for d in (CORE / "include", BOARD, *includes) for h in sorted(Path(d).rglob("*.h"))]
    with build_lock(elf):
        if not stale(elf, [*sources, *core, *c_sources, *headers, linker_script, Path(__file__)]):
            return elf
        common = [*(f"-D{d}" for d in defines), "-I", str(CORE / "include"), "-I", str(BOARD),
                  *(f"-I{i}" for i in includes)]
        objects = []
        for c in c_sources:  # C code that is not ours (the FreeRTOS kernel): its own flags, no -Werror
            obj = elf.parent / "c" / (c.stem + ".o")
            obj.parent.mkdir(exist_ok=True)
            run_build([cxx.replace("g++", "gcc"), *[f for f in flags if not f.startswith("-std=")], "-Os",
                       "-ffunction-sections", "-fdata-sections", *common, "-c", str(c), "-o", str(obj)],
                      f"{what}: {c.name} failed")
            objects.append(obj)
        tmp = elf.with_name(elf.name + ".tmp")
        run_build([cxx, *flags, *EMBEDDED_FLAGS, *common, "-fno-threadsafe-statics", "-nostartfiles", "-nostdlib",
                   "-Wl,--gc-sections", "-T", str(linker_script), *map(str, sources + core + objects), "-o", str(tmp),
                   "-lc", "-lgcc"], f"{what} build failed")
        tmp.replace(elf)
    return elf


def build() -> Path:
    return _link("cortex-m7", sorted(BOARD.glob("*.cpp")), BOARD / "stm32f745.ld", ELF, "AnyFC F7")


def build_clock_probe() -> Path:
    """The board's clock_source.cpp (and startup.cpp) in a test image for the emulated STM32F405."""
    sources = [EMULATOR / "clock_probe.cpp", BOARD / "clock_source.cpp", BOARD / "startup.cpp"]
    return _link("cortex-m4f", sources, EMULATOR / "stm32f405.ld", CLOCK_PROBE, "STM32F405 clock probe")


def build_sbus_bench() -> Path:
    """The core's SBUS decoder timed in the emulated STM32F405 (hil_sim/stm32/sbus_bench.cpp)."""
    sources = [EMULATOR / "sbus_bench.cpp", BOARD / "startup.cpp"]
    return _link("cortex-m4f", sources, EMULATOR / "stm32f405.ld", SBUS_BENCH, "STM32F405 SBUS bench")


def build_task_bench() -> Path:
    """The IARRC task bodies timed in the emulated STM32F405 (hil_sim/stm32/task_bench.cpp)."""
    sources = [EMULATOR / "task_bench.cpp", BOARD / "startup.cpp"]
    return _link("cortex-m4f", sources, EMULATOR / "stm32f405.ld", TASK_BENCH, "STM32F405 task bench")


FREERTOS_ELF = ROOT / "build" / "arm" / "anyfc_f7_freertos" / "roar_anyfc_f7.elf"
FREERTOS_SOURCES = ("tasks.c", "list.c", "queue.c", "stream_buffer.c", "portable/GCC/ARM_CM7/r0p1/port.c")


def build_freertos(kernel: Path) -> Path:
    """The AnyFC F7 firmware as PlatformIO builds it (ROAR_FREERTOS), linked against a FreeRTOS-
    Kernel checkout at `kernel` (the version platformio.ini names); FreeRTOS is never in this
    repository, so this runs where a checkout is given (ROAR_FREERTOS_KERNEL)."""
    if not (kernel / "tasks.c").exists():
        raise CoreBuildError(f"{kernel}: not a FreeRTOS-Kernel checkout (no tasks.c)")
    return _link("cortex-m7", sorted(BOARD.glob("*.cpp")), BOARD / "stm32f745.ld", FREERTOS_ELF,
                 "AnyFC F7 (FreeRTOS)", defines=("ROAR_FREERTOS=1",),
                 c_sources=tuple(kernel / s for s in FREERTOS_SOURCES),
                 includes=(kernel / "include", kernel / "portable" / "GCC" / "ARM_CM7" / "r0p1"))


def build_iarrc_emulated() -> Path:
    """The AnyFC F7's own glue (firmware/stm32_freertos) for the emulated STM32F405: F4 USART
    registers, SysTick as the clock, fixed encoder/battery/gyro stand-ins, the SysTick task
    dispatcher (see roar_sim.emulators.qemu.EmulatedIarrc)."""
    return _link("cortex-m4f", sorted(BOARD.glob("*.cpp")), EMULATOR / "stm32f405.ld", IARRC_EMULATED,
                 "STM32F405 IARRC controller", defines=("ROAR_STM32F4=1", "ROAR_EMULATOR=1"))


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
