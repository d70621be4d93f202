"""Test images for the STM32 boards run in QEMU's netduinoplus2 machine (STM32F405, Cortex-M4;
Debian's qemu-system-arm has no STM32F7). An image reports over semihosting (QEMU writes those
lines to its stderr) and ends with SYS_EXIT_EXTENDED, whose code becomes QEMU's exit status.

    result = run(arm_build.build_clock_probe())
    result.returncode, result.lines            # 0, ["clock timer2", "advanced_us 1234", ...]
"""

from __future__ import annotations

import shutil
import subprocess
from dataclasses import dataclass
from pathlib import Path

QEMU = "qemu-system-arm"
PACKAGE = "qemu-system-arm"
TIMEOUT_S = 30.0  # [s] wall time for one image


@dataclass(frozen=True)
class Result:
    returncode: int
    lines: list[str]

    def value(self, key: str) -> str:
        """The rest of the first line that starts with `key `."""
        return next(line.split(" ", 1)[1] for line in self.lines if line.startswith(key + " "))


def available() -> str | None:
    """None when QEMU can run the images here, else what to install."""
    return None if shutil.which(QEMU) else f"the STM32 emulator needs: apt-get install {PACKAGE}"


def run(elf: Path, timeout_s: float = TIMEOUT_S) -> Result:
    proc = subprocess.run([QEMU, "-M", "netduinoplus2", "-nographic", "-monitor", "none", "-serial", "null",
                           "-semihosting-config", "enable=on,target=native", "-icount", "shift=0",
                           "-kernel", str(elf)], capture_output=True, text=True, timeout=timeout_s)
    return Result(proc.returncode, proc.stderr.splitlines())
