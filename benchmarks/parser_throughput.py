"""Control-message parser throughput: the C++ firmware core (host build, one ctypes call per
buffer, so the loop itself is measured) against the Python host decoder, on the same stream."""

import time

from roar.protocol import StreamDecoder, encode
from roar_sim.firmware_core import Parser

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


def measure() -> dict[str, float]:
    big, small = 500_000, 20_000
    cpp_data, py_data = stream(big), stream(small)
    cpp = best_rate(lambda: Parser().count(cpp_data), big)
    py = best_rate(lambda: len(StreamDecoder().feed(py_data)), small, repeats=3)
    return {"cpp": cpp, "python": py, "ratio": cpp / py}


def run() -> None:
    r = measure()
    print(f"C++ core (firmware parser, host build): {r['cpp']:>14,.0f} messages/s")
    print(f"Python host decoder:                    {r['python']:>14,.0f} messages/s")
    print(f"ratio C++ / Python:                     {r['ratio']:>14.1f} x")
