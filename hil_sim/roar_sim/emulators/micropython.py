"""Real MicroPython for the suite: programs run in the official MicroPython WebAssembly runtime
(npm @micropython/micropython-webassembly-pyscript, pinned in hil_sim/micropython/) on Node.js,
with files of this repository copied into its filesystem first (hil_sim/micropython/run.mjs).

    result = run(program_path, {**portable_files(), "/data.json": path})
    result.returncode, result.stdout, result.stderr

The runtime has no `machine`, `bluetooth`, `network` or `socket`: board programs get the
stand-ins of hil_sim/micropython/standins/ (see firmware/micropython/README.md); what each board
holds is firmware/micropython/board_files.py's list, the one `make deploy` uses.
"""

from __future__ import annotations

import importlib.util
import json
import shutil
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

from roar_sim.toolchains.native import ROOT


def _board_layout():
    """firmware/micropython/board_files.py: what each board holds, as `make deploy` puts it there."""
    path = ROOT / "firmware" / "micropython" / "board_files.py"
    spec = importlib.util.spec_from_file_location("board_files", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


layout = _board_layout()
BOARD_NAMES, build, deployed_files, mpy_cross, portable_files = (
    layout.BOARD_NAMES, layout.build, layout.deployed_files, layout.mpy_cross, layout.portable_files)
RUNNER_DIR = ROOT / "hil_sim" / "micropython"
RUNTIME = RUNNER_DIR / "node_modules" / "@micropython" / "micropython-webassembly-pyscript" / "micropython.mjs"
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


def board_files(board: str, standins: bool = True) -> dict[str, Path]:
    """Everything one board holds, where it holds it, as source, without its main.py (the
    suite's program runs instead), and the stand-ins of the hardware modules under /lib."""
    files = layout.library()
    files.update({t: p for t, p in layout.own(board).items() if t != "/main.py"})
    if standins:
        files.update({f"/lib/{p.name}": p for p in sorted(STANDINS.glob("*.py"))})
    return files


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
