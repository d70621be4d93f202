"""The real Nano firmware (build/avr/nano/roar_nano.elf) running in simavr, driven from Python
through the C harness hil_sim/avr/avr_harness.c (libsimavr): bytes into UART0, RC pulses into
D3/D4, pulse widths measured on D5/D6 with the emulated cycle counter (1/16 us resolution).

    with EmulatedNano() as nano:                 # lockstep: emulated time moves only in run()
        nano.write(b"(1500,1500)")
        nano.run(0.2)
        nano.pulses("D5")                  # [(rise_s, width_us), ...]
        nano.lines()                       # [(t_s, "READY 1"), (t_s, "ARMED")]

    EmulatedNano.serve_pty(seconds)              # real time, UART0 on a pty: (process, "/dev/pts/N")
"""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

from roar_sim.toolchains import avr
from roar_sim.toolchains.native import ROOT, CoreBuildError

HARNESS_SRC = ROOT / "hil_sim" / "avr" / "avr_harness.c"
HARNESS = ROOT / "build" / "avr" / "avr_harness"
SIMAVR_PACKAGES = "simavr libsimavr-dev libsimavrparts1 libelf-dev"
F_CPU = avr.F_CPU  # [Hz]
CYCLES_PER_US = F_CPU // 1_000_000


def available() -> str | None:
    """None when the Nano firmware and the emulator can be built here, else what to install."""
    missing = avr.available()
    if missing:
        return missing
    if not Path("/usr/include/simavr/sim_avr.h").exists() or not shutil.which("cc"):
        return f"the AVR emulator needs: apt-get install {SIMAVR_PACKAGES}"
    return None


def build_harness() -> Path:
    if HARNESS.exists() and HARNESS.stat().st_mtime >= HARNESS_SRC.stat().st_mtime:
        return HARNESS
    HARNESS.parent.mkdir(parents=True, exist_ok=True)
    tmp = HARNESS.with_name(HARNESS.name + f".{os.getpid()}")
    proc = subprocess.run(["cc", "-O2", "-Wall", "-Werror", "-o", str(tmp), str(HARNESS_SRC),
                           "-I/usr/include/simavr", "-I/usr/include/simavr/parts", "-lsimavr", "-lsimavrparts", "-lm"],
                          capture_output=True, text=True)
    if proc.returncode != 0:
        raise CoreBuildError(f"simavr harness build failed: {proc.stderr.strip()[:300]}")
    os.replace(tmp, HARNESS)
    return HARNESS


class EmulatedNano:
    def __init__(self, elf: Path | None = None) -> None:
        missing = available()
        if missing:
            raise CoreBuildError(missing)
        self.elf = elf or avr.build()
        self._proc = subprocess.Popen([str(build_harness()), str(self.elf)], stdin=subprocess.PIPE,
                                      stdout=subprocess.PIPE, text=True, bufsize=1)
        self.cycle = 0
        self._pulses: dict[str, list[tuple[int, int]]] = {}  # pin -> [(rise_cycle, width_cycles)]
        self._lines: list[tuple[int, str]] = []
        self.sent_at: list[int] = []  # cycle at which each write() had fully entered the UART

    # --- driving ---------------------------------------------------------------------------

    def write(self, data: bytes) -> None:
        self._command(f"send {data.hex()}")

    def rc(self, pin: int, width_us: int | None) -> None:
        """50 Hz RC pulses of width_us into D3 (throttle) or D4 (steering); None switches off."""
        self._command(f"rc {pin} {width_us or 0}")

    def eeprom(self, data: bytes | None = None) -> bytes:
        """Write data into the EEPROM from address 0 (as a previous run left it); returns the
        first 64 bytes of the EEPROM now."""
        if data is not None:
            self._command(f"eeprom {bytes(data).hex()}")
        self._command("eeprom?")
        for line in self._proc.stdout:  # (simavr's own log lines may come first)
            if line.startswith("E "):
                return bytes.fromhex(line[2:].strip())
        raise CoreBuildError(f"the AVR emulator stopped (exit {self._proc.wait()})")

    def reset(self) -> None:
        """Reset the chip (its EEPROM stays, as through a power cycle)."""
        self._command("reset")

    def run(self, seconds: float) -> None:
        self._command(f"run {int(round(seconds * 1e6))}")
        for line in self._proc.stdout:
            kind, _, rest = line.rstrip("\n").partition(" ")
            if kind == "P":
                pin, rise, width = rest.split()
                self._pulses.setdefault(pin, []).append((int(rise), int(width)))
            elif kind == "U":
                cycle, _, text = rest.partition(" ")
                self._lines.append((int(cycle), text))
            elif kind == "S":
                self.sent_at.append(int(rest))
            elif kind == "T":
                self.cycle = int(rest)
                return
        raise CoreBuildError(f"the AVR emulator stopped (exit {self._proc.wait()})")

    def _command(self, text: str) -> None:
        self._proc.stdin.write(text + "\n")
        self._proc.stdin.flush()

    # --- what was measured -----------------------------------------------------------------

    @property
    def time_s(self) -> float:
        return self.cycle / F_CPU

    def pulses(self, pin: str, since_s: float = 0.0) -> list[tuple[float, float]]:
        """(rise [s], width [us]) of every complete pulse on pin ("D5", "D6", "B5") since since_s."""
        start = since_s * F_CPU
        return [(r / F_CPU, w / CYCLES_PER_US) for r, w in self._pulses.get(pin, []) if r >= start]

    def pulse_cycles(self, pin: str) -> list[tuple[int, int]]:
        return list(self._pulses.get(pin, []))

    def lines(self, since_s: float = 0.0) -> list[tuple[float, str]]:
        start = since_s * F_CPU
        return [(c / F_CPU, text) for c, text in self._lines if c >= start]

    def close(self) -> None:
        if self._proc.poll() is None:
            try:
                self._command("quit")
                self._proc.wait(timeout=5)
            except (BrokenPipeError, subprocess.TimeoutExpired):
                self._proc.kill()
                self._proc.wait()
        for stream in (self._proc.stdin, self._proc.stdout):
            stream.close()

    def __enter__(self) -> EmulatedNano:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    @staticmethod
    def serve_pty(seconds: float, elf: Path | None = None) -> tuple[subprocess.Popen, str]:
        """Start the emulated Nano in real time with UART0 on a pty; returns (process, pty path).
        The process prints P/U lines as they happen and exits after `seconds`."""
        missing = available()
        if missing:
            raise CoreBuildError(missing)
        proc = subprocess.Popen([str(build_harness()), str(elf or avr.build()), "--pty", str(seconds)],
                                stdout=subprocess.PIPE, text=True, bufsize=1)
        for line in proc.stdout:
            if line.startswith("PTY "):
                return proc, line.split()[1]
        proc.wait()
        raise CoreBuildError("the AVR emulator did not announce its pty")


def parser_bench_pulses(seconds: float) -> list[tuple[int, int]]:
    """Run the benchmark firmware (hil_sim/avr/parser_bench.cpp) for `seconds` of emulated time:
    (rise cycle, width in cycles) of each of its timed runs, marked on B5, in order."""
    with EmulatedNano(avr.build_parser_bench()) as bench:
        bench.run(seconds)
        return bench.pulse_cycles("B5")
