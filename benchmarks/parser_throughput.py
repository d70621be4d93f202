"""Control-message parser throughput on the same stream: the C++ firmware core (host build, one
call per buffer, so the loop itself is measured), the Python host decoder (roar.protocol, events
and all), the portable parser it wraps (roar_wire) on CPython, and the same portable parser on
MicroPython (the official WebAssembly runtime on Node.js; a board runs it slower still)."""

import time

from pathlib import Path

from roar.protocol import StreamDecoder, encode
from roar_sim.emulators import micropython
from roar_sim.core.car import ControlParser
from roar_wire import control

TITLE = "parser throughput (messages/s)"


def stream(n_messages: int) -> bytes:
    return b"".join(encode(1000 + (i * 7) % 1001, 2000 - (i * 13) % 1001) + b"\n" for i in range(n_messages))


def best_rate(fn, n_messages: int, repeats: int = 5) -> float:
    best = float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        got = fn()
        best = min(best, time.perf_counter() - start)
        assert got == n_messages, f"parser found {got} of {n_messages} messages"
    return n_messages / best


def portable(data: bytes) -> int:
    parser, count = control.Parser(), 0
    feed, ok = parser.feed, control.OK
    for byte in data:
        count += feed(byte) == ok
    return count


def on_micropython() -> float | None:
    """[messages/s] of the portable parser under MicroPython, or None when it cannot run here."""
    if micropython.available():
        return None
    result = micropython.run(Path(__file__).with_name("micropython_decoder.py"), micropython.portable_files())
    if result.returncode:
        raise RuntimeError(result.stderr.strip().splitlines()[-1])
    n, seconds = result.stdout.split()
    return int(n) / float(seconds)


def measure() -> dict[str, float]:
    big, small = 500_000, 20_000
    cpp_data, py_data = stream(big), stream(small)
    cpp = best_rate(lambda: ControlParser().count(cpp_data), big)
    py = best_rate(lambda: len(StreamDecoder().feed(py_data)), small, repeats=3)
    wire = best_rate(lambda: portable(py_data), small, repeats=3)
    return {"cpp": cpp, "python": py, "portable": wire, "micropython": on_micropython()}


def run() -> None:
    r = measure()
    print(f"C++ core (firmware parser, host build): {r['cpp']:>14,.0f} messages/s")
    print(f"Python host decoder (roar.protocol):    {r['python']:>14,.0f} messages/s")
    print(f"portable parser (roar_wire), CPython:   {r['portable']:>14,.0f} messages/s")
    if r["micropython"] is None:
        print(f"portable parser, MicroPython:           skipped ({micropython.available()})")
    else:
        print(f"portable parser, MicroPython (wasm):    {r['micropython']:>14,.0f} messages/s")
    print(f"ratio C++ / host decoder:               {r['cpp'] / r['python']:>14.1f} x")
    if r["micropython"]:
        print(f"ratio CPython / MicroPython (portable):  {r['portable'] / r['micropython']:>13.1f} x")
