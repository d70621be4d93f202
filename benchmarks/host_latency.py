"""Host library over a serial pty: API call -> bytes on the wire latency (p50/p99), and the
sustained command rate when a program calls drive() as fast as it can. The far end of the pty
is a reader thread that timestamps each complete message (no car: this measures the library)."""

import os
import select
import statistics
import termios
import threading
import time
import tty

from roar import Vehicle
from roar.protocol import encode, spec

TITLE = "host library over a serial pty"
LATENCY_SAMPLES = 400
RATE_SECONDS = 2.0  # [s]
BITS_PER_BYTE = 10  # 8N1


class WireReader:
    """Timestamps every complete message arriving on the pty's far end."""

    def __init__(self, fd: int) -> None:
        self.fd, self.arrivals, self._buffer = fd, [], b""
        self._running = True
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while self._running:
            if select.select([self.fd], [], [], 0.05)[0]:
                self._buffer += os.read(self.fd, 4096)
                now = time.perf_counter()
                *messages, self._buffer = self._buffer.split(spec.CONTROL_END_CHAR.encode())
                self.arrivals += [(now, m + spec.CONTROL_END_CHAR.encode()) for m in messages]

    def stop(self) -> None:
        self._running = False
        self._thread.join()


def _percentile(values, q):
    return statistics.quantiles(values, n=100)[q - 1]


def run() -> None:
    master, slave = os.openpty()
    tty.setraw(slave, termios.TCSANOW)
    reader = WireReader(master)
    try:
        with Vehicle(f"serial://{os.ttyname(slave)}") as car:
            time.sleep(0.1)
            latencies = []
            for i in range(LATENCY_SAMPLES):
                throttle = 0.1 + 0.4 * (i % 2)  # alternate, so every call is a new command
                expected = car.calibration.message(throttle, 0.0)
                seen = len(reader.arrivals)
                t0 = time.perf_counter()
                car.drive(throttle, 0.0)
                while True:
                    hit = [t for t, m in reader.arrivals[seen:] if m == expected]
                    if hit:
                        latencies.append(hit[0] - t0)
                        break
                    time.sleep(0.0001)
                time.sleep(0.004)
            seen = len(reader.arrivals)
            calls, start = 0, time.perf_counter()
            while time.perf_counter() - start < RATE_SECONDS:
                car.drive((calls % 200) / 200, 0.0)
                calls += 1
            elapsed = time.perf_counter() - start
            delivered = len(reader.arrivals) - seen
    finally:
        reader.stop()
        os.close(master)
        os.close(slave)
    ms = [x * 1e3 for x in latencies]
    message_bytes = len(encode(1500, 1500))
    line_capacity = spec.SERIAL_BAUD / BITS_PER_BYTE / message_bytes
    rate = delivered / elapsed
    print(f"  drive() -> bytes on the pty: p50 {_percentile(ms, 50):.2f} ms, p99 {_percentile(ms, 99):.2f} ms "
          f"({len(ms)} calls)")
    print(f"  sustained: {calls / elapsed:,.0f} drive() calls/s, {rate:,.0f} commands/s on the wire "
          f"(latest wins; the link's floor is one per 2 ms)")
    print(f"  ratio to a real {spec.SERIAL_BAUD}-baud line ({line_capacity:,.0f} msg/s of {message_bytes} bytes): "
          f"{rate / line_capacity:.2f}")
    print(f"  ratio to the keep-alive rate ({1e6 / spec.TIMING_HOST_SEND_PERIOD_US:.0f} Hz): "
          f"{rate / (1e6 / spec.TIMING_HOST_SEND_PERIOD_US):.1f}x")
