# Runs under MicroPython (benchmarks/parser_throughput.py): the portable parser (roar_wire) on
# the same stream as the other parsers; prints "<messages> <best seconds>".
import time

from roar_wire import control

N = 20000
data = b"".join(control.encode(1000 + (i * 7) % 1001, 2000 - (i * 13) % 1001) + b"\n" for i in range(N))
best = None
for _ in range(3):
    parser = control.Parser()
    feed, ok = parser.feed, control.OK
    start = time.ticks_us()
    count = 0
    for byte in data:
        if feed(byte) == ok:
            count += 1
    took = time.ticks_diff(time.ticks_us(), start)
    assert count == N, count
    best = took if best is None else min(best, took)
print(N, best / 1e6)
