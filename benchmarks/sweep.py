"""Ray sweep: the default grid of `roar sweep` (16 two-lap races of the figure-eight, K_dd x speed
margin) on a local Ray with 2 workers against the same 16 runs one after another here, in the
same run (target >= 1.7x faster; the serial time is the mean of a run before and one after).
Ray's start is timed apart: a cluster is started once and then takes sweep after sweep."""

import tempfile
import time
from pathlib import Path

TITLE = "Ray sweep, 16 runs on 2 workers"
WORKERS = 2
TARGET = 1.7  # [x] faster than one race after another


def run() -> None:
    from roar_sim.runs.sweep import DEFAULT_K_DD_S, DEFAULT_MARGINS, Table, grid, parse_values, start_ray, sweep

    runs = grid(["figure-eight"], parse_values(DEFAULT_K_DD_S, "k-dd", 0, 9), parse_values(DEFAULT_MARGINS, "margin", 0, 9))
    with tempfile.TemporaryDirectory() as tmp:
        def serial_s(name: str) -> tuple[float, list]:
            start = time.perf_counter()
            rows = sweep(runs, Table(Path(tmp) / name), serial=True)
            return time.perf_counter() - start, rows

        before_s, serial = serial_s("before.csv")
        start = time.perf_counter()
        ray = start_ray(None, WORKERS)
        started_s = time.perf_counter() - start
        try:
            table = timed(Table)(Path(tmp) / "ray.csv")
            start = table.started = time.perf_counter()
            parallel = sweep(runs, table)
            ray_s = time.perf_counter() - start
        finally:
            ray.shutdown()
        after_s, _ = serial_s("after.csv")
    serial_s = (before_s + after_s) / 2  # before and after: this machine's speed drifts
    same = "identical" if parallel == serial else "DIFFERENT"
    print(f"  serial {serial_s:.1f} s (before {before_s:.1f}, after {after_s:.1f}); on Ray {ray_s:.1f} s = "
          f"{serial_s / ray_s:.2f}x faster (target >= {TARGET}); with Ray's start ({started_s:.1f} s) "
          f"{serial_s / (ray_s + started_s):.2f}x; tables {same}")
    if serial_s / ray_s < TARGET:
        arrivals = table.arrivals_s
        per_race_s = serial_s / len(runs)
        first_s = arrivals[WORKERS - 1]  # each worker's first race done
        steady_s = (arrivals[-1] - first_s) / max(1, len(arrivals) - WORKERS)  # then one result every ...
        print(f"  shortfall: {ray_s - serial_s / TARGET:.2f} s of Ray time over the target's. The workers' first "
              f"races took {first_s:.1f} s against {per_race_s:.2f} s a race here (each worker imports the "
              f"simulator and builds its world first: {first_s - per_race_s:.1f} s); after them a result every "
              f"{steady_s:.2f} s = {per_race_s / steady_s:.2f} races at once on {WORKERS} workers")



def timed(table_class):
    """The results table, noting when each row arrives [s after `started`]."""

    class Timed(table_class):
        started = 0.0

        def __init__(self, path: Path) -> None:
            super().__init__(path)
            self.arrivals_s: list[float] = []

        def add(self, row: dict) -> None:
            self.arrivals_s.append(time.perf_counter() - self.started)
            super().add(row)

    return Timed
