"""Test images for the STM32 boards run in QEMU's netduinoplus2 machine (STM32F405, Cortex-M4;
Debian's qemu-system-arm has no STM32F7). An image reports over semihosting (QEMU writes those
lines to its stderr) and ends with SYS_EXIT_EXTENDED, whose code becomes QEMU's exit status.

    result = run(arm.build_clock_probe())
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
CALIBRATION_INSTRUCTIONS = 2 * 100_000  # the bench images' calibration loop: 100,000 x (subs, bne)


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


def instructions(result: Result, ticks: int | str) -> float:
    """A bench image's SysTick count (or the value of that key) in instructions, by its
    calibration loop."""
    ticks = int(result.value(ticks)) if isinstance(ticks, str) else ticks
    return ticks / (int(result.value("calibration_ticks")) / CALIBRATION_INSTRUCTIONS)


def task_instructions(result: Result) -> dict[str, float]:
    """{task name: worst instructions} from the task bench image (arm.build_task_bench()),
    whose lines read "task NAME TICKS"."""
    rows = [line.split() for line in result.lines if line.startswith("task ")]
    return {name: instructions(result, int(ticks)) for _, name, ticks in rows}


class EmulatedIarrc:
    """The AnyFC F7's IARRC controller (arm.build_iarrc_emulated()) running in QEMU, its
    USARTs on Unix sockets: USART1 the vision computer, USART3 the Bluetooth module, USART6 the
    SBUS receiver. QEMU waits for each socket's client at start, so nothing the board prints at
    boot is lost. Lines it writes are collected by a reader thread per port.

        with EmulatedIarrc(elf, tmp_dir) as board:
            board.wait_line("host", lambda l: l == "READY 2")
            board.send("sbus", frame); board.send("host", b"[1000,1500]")
    """

    PORTS = ("host", "link", "sbus")
    _USART = {"host": 1, "link": 3, "sbus": 6}  # -serial arguments map to USART1..6 in order

    def __init__(self, elf: Path, directory: Path) -> None:
        import threading

        self._paths = {name: directory / f"{name}.sock" for name in self.PORTS}
        serial = []
        for usart in range(1, 7):
            name = next((n for n, u in self._USART.items() if u == usart), None)
            serial += ["-serial", f"chardev:{name}" if name else "null"]
        chardevs = []
        for name, path in self._paths.items():
            chardevs += ["-chardev", f"socket,id={name},path={path},server=on,wait=on"]
        self.proc = subprocess.Popen([QEMU, "-M", "netduinoplus2", "-nographic", "-monitor", "none", *chardevs,
                                      *serial, "-semihosting-config", "enable=on,target=native",
                                      "-icount", "shift=0", "-kernel", str(elf)],
                                     stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        self._socks = {name: self._connect(path) for name, path in self._paths.items()}
        self.lines: dict[str, list[str]] = {name: [] for name in self.PORTS}
        self._lock = threading.Condition()
        self._readers = [threading.Thread(target=self._read, args=(name,), daemon=True) for name in ("host", "link")]
        for t in self._readers:
            t.start()

    def _connect(self, path: Path):
        import socket
        import time

        deadline = time.monotonic() + TIMEOUT_S
        while True:
            s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
            try:
                s.connect(str(path))
                return s
            except OSError:
                s.close()
                if time.monotonic() > deadline or self.proc.poll() is not None:
                    raise RuntimeError(f"QEMU did not open {path.name}: {self.proc.stderr.read().decode()[-300:]}")
                time.sleep(0.02)

    def _read(self, name: str) -> None:
        partial = b""
        sock = self._socks[name]
        while True:
            try:
                data = sock.recv(4096)
            except OSError:
                return
            if not data:
                return
            *done, partial = (partial + data).split(b"\n")
            with self._lock:
                self.lines[name] += [line.decode("ascii", "replace") for line in done]
                self._lock.notify_all()

    def send(self, port: str, data: bytes) -> None:
        self._socks[port].sendall(data)

    def wait_line(self, port: str, match, timeout_s: float = 5.0, since: int = 0) -> str | None:
        """The first line on port (from index `since`) for which match(line) is true, or None."""
        def found():
            return next((line for line in self.lines[port][since:] if match(line)), None)

        with self._lock:
            self._lock.wait_for(found, timeout_s)
            return found()

    def close(self) -> None:
        for s in self._socks.values():
            s.close()
        if self.proc.poll() is None:
            self.proc.kill()
        self.proc.wait()
        self.proc.stderr.close()

    def __enter__(self) -> "EmulatedIarrc":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
