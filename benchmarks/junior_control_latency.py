"""The simulated Junior's control latency: a client sends the control route at 50 requests/s
over one kept-alive loopback connection, as the http:// transport does, alternating two wheel
duties; the latency of a request is from just before it is sent to when the firmware's L298N
outputs in the simulator (the Junior robot's pins, which the motor model reads) first carry its duty.
Target: p99 <= 5 ms."""

import http.client
import time

import numpy as np

from roar.junior import query_for
from roar_sim.links.junior_http import InBackground

TITLE = "Junior HTTP control request -> duty on the simulated pins"
REQUESTS = 500  # 10 s at 50 Hz
PERIOD_S = 0.02  # [s]
DUTIES = (0.3, 0.6)
TARGET_P99_MS = 5.0


def measure() -> np.ndarray:
    """[ms] each request's latency."""
    with InBackground(render_workers=0) as junior:
        sim = junior.server.sim
        host, port = junior.urls.control_url.removeprefix("http://").rsplit(":", 1)
        conn = http.client.HTTPConnection(host, int(port), timeout=5)
        sent = []
        sim.pin_log = []
        next_t = time.perf_counter()
        for i in range(REQUESTS):
            duty = DUTIES[i % 2]
            t0 = time.perf_counter()
            conn.request("GET", "/?" + query_for(duty, duty))
            conn.getresponse().read()
            sent.append((t0, round(duty * 1000)))
            next_t += PERIOD_S
            time.sleep(max(0.0, next_t - time.perf_counter()))
        time.sleep(0.05)
        changes, sim.pin_log = sim.pin_log, None
        conn.close()
    latencies = []
    for t0, permille in sent:
        applied = next(t for _, t, left, right in changes if t >= t0 and left.duty == right.duty == permille)
        latencies.append((applied - t0) * 1e3)
    return np.array(latencies)


def run() -> None:
    ms = measure()
    p50, p99 = np.percentile(ms, [50, 99])
    print(f"requests:  {len(ms)} at {1 / PERIOD_S:.0f}/s over one kept-alive connection")
    print(f"latency:   p50 {p50:5.2f} ms   p99 {p99:5.2f} ms   max {ms.max():5.2f} ms   (target p99 <= {TARGET_P99_MS:g})")
