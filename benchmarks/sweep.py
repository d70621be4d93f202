"""Ray sweep: the default grid of `roar sweep` (16 two-lap races of the figure-eight, K_dd x speed
margin) on a local Ray with 2 workers against the same 16 runs one after another here, in the
same run (target >= 1.7x faster). Ray's start is timed apart: a cluster is started once and then
takes sweep after sweep."""

import tempfile
import time
from pathlib import Path

TITLE = "Ray sweep, 16 runs on 2 workers"
WORKERS = 2


def run() -> None:
    from roar_sim.sweep import DEFAULT_K_DD_S, DEFAULT_MARGINS, Table, grid, parse_values, start_ray, sweep

    runs = grid(["figure-eight"], parse_values(DEFAULT_K_DD_S, "k-dd", 0, 9), parse_values(DEFAULT_MARGINS, "margin", 0, 9))
    with tempfile.TemporaryDirectory() as tmp:
        start = time.perf_counter()
        serial = sweep(runs, Table(Path(tmp) / "serial.csv"), serial=True)
        serial_s = time.perf_counter() - start
        start = time.perf_counter()
        ray = start_ray(None, WORKERS)
        started_s = time.perf_counter() - start
        try:
            start = time.perf_counter()
            parallel = sweep(runs, Table(Path(tmp) / "ray.csv"))
            ray_s = time.perf_counter() - start
        finally:
            ray.shutdown()
    same = "identical" if parallel == serial else "DIFFERENT"
    print(f"  serial {serial_s:.1f} s; on Ray {ray_s:.1f} s = {serial_s / ray_s:.2f}x faster (target >= 1.7); "
          f"with Ray's start ({started_s:.1f} s) {serial_s / (ray_s + started_s):.2f}x; tables {same}")
