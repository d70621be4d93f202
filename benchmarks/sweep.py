"""Sweeps on this machine's cores: the default grid of `roar sweep` (16 two-lap races of the
figure-eight, K_dd x speed margin) on 2 local processes (the default), against the same 16 runs
one after another here, in the same run (target >= 1.7x faster, counting everything the sweep
does, its processes' start included; the serial time is the mean of a run before and one after).
Then 64 runs of the figure-eight (8 K_dd x 8 margins) on the processes to show the start cost
amortised (a run's time against the serial 16's), and a local Ray on the 16 for reference, its
start timed apart. (Sweeps over seeded random tracks, `--track random:1-16`, run the same way;
the suite sweeps random:1-3.)"""

import tempfile
import time
from pathlib import Path

TITLE = "sweeps, 16 and 64 runs on 2 workers"
WORKERS = 2
TARGET = 1.7  # [x] faster than one race after another


def run() -> None:
    from roar_sim.runs.sweep import DEFAULT_K_DD_S, DEFAULT_MARGINS, Table, grid, parse_values, start_ray, sweep

    k_dd, margins = parse_values(DEFAULT_K_DD_S, "k-dd", 0, 9), parse_values(DEFAULT_MARGINS, "margin", 0, 9)
    runs16 = grid(["figure-eight"], k_dd, margins)
    runs64 = grid(["figure-eight"], parse_values("0.2:0.9:8", "k-dd", 0, 9), parse_values("0.65:1:8", "margin", 0, 9))
    with tempfile.TemporaryDirectory() as tmp:
        def timed(name: str, runs, **how) -> tuple[float, list]:
            table = arrivals(Table)(Path(tmp) / f"{name}.csv")
            start = table.started = time.perf_counter()
            rows = sweep(runs, table, **how)
            return time.perf_counter() - start, rows, table

        before_s, serial, _ = timed("before", runs16, serial=True)
        local_s, local, table = timed("local", runs16, workers=WORKERS)
        after_s, _, _ = timed("after", runs16, serial=True)
        serial_s = (before_s + after_s) / 2  # before and after: this machine's speed drifts
        big_local_s, _, _ = timed("big-local", runs64, workers=WORKERS)
        ray_s = ray_start_s = None
        try:
            start = time.perf_counter()
            ray = start_ray(None, WORKERS)
            ray_start_s = time.perf_counter() - start
            try:
                ray_s, on_ray, _ = timed("ray", runs16, ray=True)  # (without ray=True: local processes)
            finally:
                ray.shutdown()
        except Exception as e:  # noqa: BLE001 -- Ray is the reference only
            print(f"  (Ray reference skipped: {e})")
    same = "identical" if local == serial else "DIFFERENT"
    print(f"  16 runs: serial {serial_s:.1f} s (before {before_s:.1f}, after {after_s:.1f}); on {WORKERS} local "
          f"processes {local_s:.1f} s, start and all = {serial_s / local_s:.2f}x faster (target >= {TARGET}); "
          f"tables {same}")
    print(f"  64 runs: on {WORKERS} local processes {big_local_s:.1f} s = {big_local_s / 64:.3f} s a run, against "
          f"{serial_s / 16:.3f} s a run serially ({serial_s / 16 / (big_local_s / 64):.2f}x) and {local_s / 16:.3f} s "
          f"for 16 on the processes")
    if ray_s is not None:
        print(f"  a local Ray for reference, 16 runs: {ray_s:.1f} s = {serial_s / ray_s:.2f}x, but {ray_start_s:.1f} s "
              f"to start it: {serial_s / (ray_s + ray_start_s):.2f}x counting that; tables "
              f"{'identical' if on_ray == serial else 'DIFFERENT'}")
    if serial_s / local_s < TARGET:
        first_s = table.arrivals_s[WORKERS - 1]
        steady_s = (table.arrivals_s[-1] - first_s) / max(1, len(table.arrivals_s) - WORKERS)
        per_race_s = serial_s / len(runs16)
        print(f"  shortfall: {local_s - serial_s / TARGET:.2f} s over the target's. Each process's first result "
              f"after {first_s:.1f} s (a race here takes {per_race_s:.2f} s); then a result every {steady_s:.2f} s = "
              f"{per_race_s / steady_s:.2f} races at once on {WORKERS} processes; the last races leave a core idle "
              f"while the slowest finishes")


def arrivals(table_class):
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
