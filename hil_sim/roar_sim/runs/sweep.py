"""Parameter sweeps: race the simulated car for every point of a grid of autopilot parameters x
tracks -- on this machine's cores by default (a process per core, each taking race after race),
as Ray tasks on a Ray cluster with --address (or a local Ray with --ray) -- and keep the results
in a CSV table and a plot.

    roar sweep [--track figure-eight] [--k-dd 0.2,0.4,0.6,0.8] [--margin 0.85:1:4] [--laps 2]
               [--robot esc|iarrc|junior] [--out out/sweep] [--workers N]
               [--address HOST:PORT | auto | --ray | --serial]

A list is `a,b,c`; `lo:hi:n` is n values from lo to hi; tracks may be a seed range,
`random:1-16` (so that a tuning generalises over tracks nobody tuned for). Each run is one race
(`roar race --track T --k-dd K --margin M --laps L`); the simulation is in lockstep, so a run's
result does not depend on where or beside what it ran: the table from the processes or Ray equals
the table from --serial.

The local processes are forked from this one, so they start in milliseconds with the simulator
already imported (a local Ray took 5 s to start here, as long as 7 of the 16 default races).

Results go to OUT/results.csv (a row per run, in grid order) and OUT/sweep.png (per track, the
best lap over the physical-limit lap for each K_dd and margin). Rows are written as runs finish:
run the same command again after an interruption or a failure and only the runs not yet in the
table (and the failed ones) run. A run that fails -- an exception, a worker process that dies --
becomes a row with status `failed` and the reason; the other runs go on.

A cluster: `ray start --head` on one machine, `ray start --address HEAD:6379` on the others,
each with roar-platform[sweep] installed; here RAY_AUTH_MODE=token and the cluster's token (Ray's
token authentication, on by default), then --address HEAD:6379.

Exit status: 0 when every run finished (a race with fewer laps than asked is a result, status
`incomplete`); 1 for bad input or a Ray that cannot start; 2 when some runs failed; 130 on Ctrl-C
(the finished runs are kept).
"""

from __future__ import annotations

import argparse
import atexit
import csv
import logging
import math
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterable, Sequence
from contextlib import closing, contextmanager, suppress
from dataclasses import dataclass
from pathlib import Path

from roar.checks import printable, shown
from roar.cli.errors import ArgumentParser, ExitStatus, path_option, run_command, stopped_status
from roar.errors import RoarError
from roar.tracks.names import FORMS
from roar.user_files import unusable_folder
from roar_sim import robots
from roar_sim.runs.processes import cores, fork_context
from roar_sim.world import plotting

COLUMNS = ("track", "robot", "k_dd_s", "margin", "laps", "status", "laps_done", "best_lap_s", "limit_lap_s",
           "best_ratio", "wall_contacts", "max_cross_track_m", "error")
DEFAULT_K_DD_S = "0.2,0.4,0.6,0.8"  # [s] pure pursuit's look-ahead per m/s
DEFAULT_MARGINS = "0.85,0.9,0.95,1.0"  # fractions of the car's limits
DEFAULT_TRACKS = "figure-eight"
MAX_RUNS = 10_000  # a grid larger than this is a typo
MAX_DAMAGED_SHOWN = 5  # damaged table rows reported one per line; the rest counted
RAY_STOP_S = 0.1  # [s] for the local Ray's processes to end after SIGTERM, before SIGKILL
RAY_GOODBYE_S = 0.3  # [s] for the driver's goodbye to the local Ray after Ctrl-C, before it is killed
WAIT_SLICE_S = 0.1  # [s] longest wait for Ray results without looking for Ctrl-C
CONNECT_TIMEOUT_S = 5.0  # [s] for a Ray cluster's address to answer


class SweepError(RoarError):
    """Bad input for a sweep or a Ray that cannot start: one line for the user."""


@dataclass(frozen=True)
class Run:
    """One point of the grid: a race of `laps` laps of `track` by `robot` at `margin` of its
    limits, steering by pure pursuit with look-ahead k_dd_s [s] per m/s."""

    track: str
    k_dd_s: float
    margin: float
    laps: int = 2
    robot: str = "esc"

    @property
    def key(self) -> tuple:
        return self.track, self.robot, self.k_dd_s, self.margin, self.laps


def grid(tracks: Sequence[str], k_dd_s: Sequence[float], margins: Sequence[float], laps: int = 2,
         robot: str = "esc") -> list[Run]:
    """Every combination, tracks outermost, then K_dd, then margin."""
    return [Run(t, k, m, laps, robot) for t in tracks for k in k_dd_s for m in margins]


def parse_values(text: str, name: str, low: float, high: float) -> list[float]:
    """`a,b,c` or `lo:hi:n` (n evenly spaced values, both ends included), each within
    [low, high], rounded to 6 decimals; SweepError with a one-line reason otherwise."""
    try:
        if ":" in text:
            lo, hi, n = text.split(":")
            count = int(n)
            if not 1 <= count <= 100:
                raise SweepError(f"--{name} {text}: the count after the second ':' must be 1..100")
            a, b = float(lo), float(hi)
            values = [a] if count == 1 else [a + (b - a) * i / (count - 1) for i in range(count)]
        else:
            values = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise SweepError(f"--{name} {text!r}: give numbers as a,b,c or lo:hi:n") from None
    values = [round(v, 6) for v in values]
    if not values:
        raise SweepError(f"--{name}: no values")
    bad = [v for v in values if not (math.isfinite(v) and low <= v <= high)]
    if bad:
        raise SweepError(f"--{name} {bad[0]:g} is outside {low:g}..{high:g}")
    return list(dict.fromkeys(values))  # each once, in the order given


def race_run(run: Run) -> dict:
    """Race one grid point in this process; the result row (without `error`)."""
    from roar_sim.runs.race import race
    from roar.tracks import get

    track = get(run.track)
    result = race(track, run.laps, margin=run.margin, robot=run.robot, k_dd_s=run.k_dd_s)
    done = len(result.lap_times_s)
    return {**_run_columns(run), "status": "ok" if done >= run.laps else "incomplete", "laps_done": done,
            "best_lap_s": min(result.lap_times_s) if done else "", "limit_lap_s": result.limit_lap_s,
            "best_ratio": result.best_ratio if done else "", "wall_contacts": result.wall_contacts,
            "max_cross_track_m": result.max_cross_track_m, "error": ""}


def attempt(fn: Callable[[Run], dict], run: Run) -> dict:
    """fn(run), or a `failed` row saying why in one line: the same in a Ray worker and here."""
    try:
        return fn(run)
    except Exception as e:  # noqa: BLE001 -- any failure of one run is reported, the sweep goes on
        return failed_row(run, f"{type(e).__name__}: {str(e).strip().splitlines()[0] if str(e).strip() else ''}")


def failed_row(run: Run, why: str) -> dict:
    return {**_run_columns(run), "status": "failed", "laps_done": 0, "best_lap_s": "", "limit_lap_s": "",
            "best_ratio": "", "wall_contacts": "", "max_cross_track_m": "", "error": why.replace("\n", " ")}


def _run_columns(run: Run) -> dict:
    return {"track": run.track, "robot": run.robot, "k_dd_s": run.k_dd_s, "margin": run.margin, "laps": run.laps}


class Table:
    """The results CSV: rows by run key, written as runs finish (so an interruption keeps them),
    in grid order at the end. The file is only ever replaced whole (a new file, renamed over it),
    so it never holds half a table; a row that does not read back (cut short, a field that is not
    a number, a status the tool does not write) is `damaged`: set aside in results.damaged.csv and
    run again."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.rows: dict[tuple, dict] = {}
        self.damaged: list[tuple[int, str, list[str]]] = []  # (line number, what is wrong, its fields)
        if path.exists():
            self._load()

    @property
    def damaged_path(self) -> Path:
        return self.path.with_name(self.path.stem + ".damaged.csv")

    def _load(self) -> None:
        try:
            with self.path.open(newline="", encoding="utf-8") as f:
                reader = csv.reader(f)
                header = next(reader, None)
                if header is not None and tuple(header) != COLUMNS:
                    raise SweepError(f"{self.path} is not a sweep results table (its columns differ): "
                                     f"move it away or give another --out")
                for fields in reader:
                    if not fields:
                        continue
                    problem = row_problem(fields)
                    if problem:
                        self.damaged.append((reader.line_num, problem, fields))
                    else:
                        row = dict(zip(COLUMNS, fields))
                        self.rows[_key(row)] = row
        except (OSError, UnicodeDecodeError, csv.Error) as e:
            raise SweepError(f"{self.path}: cannot read it as a results table ({e})") from None

    def finished(self, run: Run) -> bool:
        row = self.rows.get(run.key)
        return row is not None and row["status"] != "failed"

    def add(self, row: dict) -> None:
        """Keep `row` (a malformed one becomes a `failed` row saying why) and write the table."""
        problem = row_problem([row.get(c, "") for c in COLUMNS])
        if problem:
            row = {**{c: row.get(c, "") for c in COLUMNS[:5]}, **{c: "" for c in COLUMNS[5:]},
                   "status": "failed", "laps_done": "0", "error": f"the run's result row is malformed: {problem}"}
        self.rows[_key(row)] = row
        self._write(list(self.rows))

    def rewrite(self, runs: Sequence[Run]) -> None:
        """The rows of `runs` in their order, then any other rows kept from earlier sweeps."""
        keys = [r.key for r in runs if r.key in self.rows]
        chosen = set(keys)
        self._write(keys + [k for k in self.rows if k not in chosen])

    def _write(self, keys: Sequence[tuple]) -> None:
        if self.damaged:  # set aside once, before the table drops them
            new = not self.damaged_path.exists()
            with self.damaged_path.open("a", newline="", encoding="utf-8") as f:
                writer = csv.writer(f)
                if new:
                    writer.writerow(COLUMNS)
                writer.writerows(fields for _, _, fields in self.damaged)
            self.damaged = []
        tmp = self.path.with_name(self.path.name + ".tmp")
        with tmp.open("w", newline="", encoding="utf-8") as f:
            writer = csv.DictWriter(f, COLUMNS)
            writer.writeheader()
            writer.writerows(self.rows[k] for k in keys)
        os.replace(tmp, self.path)

    def of(self, runs: Iterable[Run]) -> list[dict]:
        return [self.rows[r.key] for r in runs if r.key in self.rows]


STATUSES = ("ok", "incomplete", "failed")


def row_problem(fields: Sequence[str]) -> str | None:
    """What makes a table row unreadable, in a few words; None for a row the tool wrote."""
    if len(fields) != len(COLUMNS):
        return f"{len(fields)} fields where a row has {len(COLUMNS)}"
    row = dict(zip(COLUMNS, fields))
    if not row["track"] or not row["robot"]:
        return "no track or robot"
    if row["status"] not in STATUSES:
        return f"status {shown(row['status'])} is none of {', '.join(STATUSES)}"
    numbers = {"k_dd_s": float, "margin": float, "laps": int}
    if row["status"] != "failed":
        numbers |= {"laps_done": int, "limit_lap_s": float, "wall_contacts": int, "max_cross_track_m": float}
        if row["laps_done"] not in ("", "0"):
            numbers |= {"best_lap_s": float, "best_ratio": float}
    for column, kind in numbers.items():
        try:
            value = kind(row[column])
        except ValueError:
            return f"{column} {shown(row[column])} is not {'a whole number' if kind is int else 'a number'}"
        if not math.isfinite(value) or value < 0:
            return f"{column} {shown(row[column])} is not a finite number >= 0"
    if row["status"] != "failed" and (int(row["laps_done"]) >= int(row["laps"])) != (row["status"] == "ok"):
        return f"status {row['status']} with {row['laps_done']} of {row['laps']} laps"
    return None


def _key(row: dict) -> tuple:
    return row["track"], row["robot"], float(row["k_dd_s"]), float(row["margin"]), int(row["laps"])


def sweep(runs: Sequence[Run], table: Table, fn: Callable[[Run], dict] | None = None, serial: bool = False,
          address: str | None = None, workers: int | None = None, progress: bool = False,
          ray: bool = False) -> list[dict]:
    """Run each of `runs` not yet finished in `table` -- on `workers` processes forked from this
    one (default: one per core), as Ray tasks (the cluster at `address`, or a local Ray with
    `workers` CPUs when ray; a Ray session already open in this process is used as it is), or one
    after another here with serial -- adding each row as it comes; returns the rows of `runs`, in
    their order. fn(run) -> row (default race_run) must be picklable for Ray."""
    fn = fn or race_run
    todo = [r for r in runs if not table.finished(r)]
    bar = _bar(len(runs), len(runs) - len(todo)) if progress else None
    if serial:
        rows_of = _serial
    elif address is not None or ray:
        rows_of = lambda todo, fn: _on_ray(todo, fn, address, workers)  # noqa: E731
    else:
        rows_of = lambda todo, fn: _on_processes(todo, fn, workers)  # noqa: E731
    try:
        if todo:
            with closing(rows_of(todo, fn)) as rows:
                for row in rows:  # as each run finishes
                    table.add(_strings(row))
                    if bar:
                        bar.update(1)
    finally:
        if bar:
            bar.close()
        if table.rows:
            table.rewrite(runs)
    return table.of(runs)


def _strings(row: dict) -> dict:
    """The row as the CSV holds it (repr for floats: they read back exactly)."""
    return {c: repr(v) if isinstance(v, float) else str(v) for c, v in ((c, row.get(c, "")) for c in COLUMNS)}


def _serial(todo: Sequence[Run], fn: Callable[[Run], dict]):
    for run in todo:
        yield attempt(fn, run)


DIED = "the worker running it died (its process ended)"


def _on_processes(todo: Sequence[Run], fn: Callable[[Run], dict], workers: int | None):
    """Rows as runs finish on `workers` processes forked from this one, each taking run after run.
    A process that dies breaks the pool (every run it held fails with it): those runs are then
    run again each in a process of its own, so only the one that kills its process fails."""
    import concurrent.futures as futures

    from roar_sim.runs import race  # noqa: F401 -- imported once here, inherited by every fork

    context = fork_context()
    count = max(1, min(workers or len(cores()), len(todo)))
    suspects: list[Run] = []
    with _sigint_kept_from_children():  # (Ctrl-C is ours: we end the processes)
        pool = futures.ProcessPoolExecutor(count, mp_context=context)
        pending = {pool.submit(attempt, fn, run): run for run in todo}
    try:
        for done in futures.as_completed(pending):
            try:
                yield done.result()
            except futures.process.BrokenProcessPool:
                suspects.append(pending[done])
        for run in suspects:
            with _sigint_kept_from_children():
                alone = futures.ProcessPoolExecutor(1, mp_context=context)
            try:
                yield alone.submit(attempt, fn, run).result()
            except futures.process.BrokenProcessPool:
                yield failed_row(run, f"BrokenProcessPool: {DIED}")
            finally:
                alone.shutdown()
    finally:
        _end_pool(pool)


def _end_pool(pool) -> None:
    """The pool's processes ended at once (after Ctrl-C, or a generator closed early)."""
    processes = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        if process.is_alive():
            process.kill()
    for process in processes:
        process.join(timeout=5)


def _on_ray(todo: Sequence[Run], fn: Callable[[Run], dict], address: str | None, workers: int | None):
    ray = _import_ray()
    ours = not ray.is_initialized()  # else: the caller's Ray session, left running
    if ours:
        start_ray(address, workers)
    interrupted = False
    try:
        task = ray.remote(num_cpus=1, max_retries=0)(attempt)
        pending = {task.remote(fn, run): run for run in todo}
        while pending:
            # a short timeout: Ray's wait blocks in C++, where Ctrl-C waits until it returns
            ready, _ = ray.wait(list(pending), num_returns=1, timeout=WAIT_SLICE_S)
            for ref in ready:
                run = pending.pop(ref)
                try:
                    yield ray.get(ref)
                except ray.exceptions.RayError as e:  # the worker died: no row from it
                    yield failed_row(run, f"{type(e).__name__}: {DIED}")
    except KeyboardInterrupt:
        interrupted = True
        raise
    finally:
        if ours:
            if address is None:
                _without_grace(ray)
            if address is None and interrupted:
                _shutdown_at_once(ray)
            else:
                ray.shutdown()


def _shutdown_at_once(ray) -> None:
    """ray.shutdown() after Ctrl-C, ended within about 2 x RAY_GOODBYE_S however busy the machine:
    the driver's goodbye to its raylet (which stops the workers of the job) takes 0.25 s on an
    idle machine and was seen to take seconds on a busy one. If it has not ended by then, the
    local Ray's processes are killed, which ends it; should it still hang, the process leaves it
    behind (and Ray's own shutdown at exit, which would wait for it again)."""
    goodbye = threading.Thread(target=ray.shutdown, name="ray-shutdown", daemon=True)
    goodbye.start()
    goodbye.join(RAY_GOODBYE_S)
    if goodbye.is_alive():
        _kill_local_ray(ray)
        goodbye.join(RAY_GOODBYE_S)
    if goodbye.is_alive():
        atexit.unregister(ray.shutdown)


def _node(ray):
    """The local Ray's node handle (not public API: None where it is not as expected)."""
    node = getattr(getattr(getattr(ray, "_private", None), "worker", None), "_global_node", None)
    return node if isinstance(getattr(node, "all_processes", None), dict) else None


def _kill_local_ray(ray) -> None:
    """SIGKILL to the local Ray's processes and all they started."""
    node = _node(ray)
    for infos in node.all_processes.values() if node else ():
        for info in infos:
            for pid in [*_descendants(info.process.pid), info.process.pid]:
                with suppress(OSError):
                    os.kill(pid, signal.SIGKILL)


def _without_grace(ray) -> None:
    """Have ray.shutdown() stop the processes of the local Ray this sweep started all together:
    SIGTERM to all (each ends what it started), killed if not gone within RAY_STOP_S. By default
    shutdown gives each a second, one after another -- seconds after a Ctrl-C. (The driver still
    says goodbye to them first. Ray's node handle is not public API: without it, the default.)"""
    node = _node(ray)
    if node is None:
        return
    kill = node.kill_all_processes

    def stop_together(**_) -> None:
        processes = [info.process for infos in node.all_processes.values() for info in infos
                     if info.process.poll() is None]
        for process in processes:
            process.terminate()
        deadline = time.monotonic() + RAY_STOP_S
        for process in processes:
            try:
                process.wait(max(0.0, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:  # it and what it started (the raylet's agents)
                for pid in [*_descendants(process.pid), process.pid]:
                    with suppress(OSError):
                        os.kill(pid, signal.SIGKILL)
        kill(check_alive=False, allow_graceful=False, wait=False)  # Ray's bookkeeping

    node.kill_all_processes = stop_together


def _descendants(pid: int) -> list[int]:
    """The processes `pid` started, and theirs (Linux's /proc; none elsewhere)."""
    parents = {}
    for entry in os.listdir("/proc") if os.path.isdir("/proc") else ():
        with suppress(OSError, ValueError, IndexError):
            with open(f"/proc/{entry}/stat") as f:
                parents[int(entry)] = int(f.read().rsplit(")", 1)[1].split()[1])
    found, todo = [], [pid]
    while todo:
        of = todo.pop()
        children = [p for p, parent in parents.items() if parent == of]
        found += children
        todo += children
    return found


@contextmanager
def _sigint_kept_from_children():
    """Processes (and threads) started within block SIGINT for good: a terminal's Ctrl-C, sent to
    the whole process group, reaches the sweep alone, which then ends its local Ray at once,
    instead of killing Ray's servers under their clients. A Ctrl-C meanwhile waits, pending,
    until the end of the block, and interrupts there."""
    before = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, before)


def start_ray(address: str | None, workers: int | None):
    """Ray, connected: a new local Ray with `workers` CPUs (default: all), or the cluster at
    `address` ("auto": the one started on this machine with `ray start`). SweepError if not."""
    ray = _import_ray()
    if address not in (None, "auto"):
        _reachable(address)
    os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")  # nothing leaves the machine unasked
    try:
        if address is None:
            with _sigint_kept_from_children():
                ray.init(num_cpus=workers or os.cpu_count(), include_dashboard=False, log_to_driver=False,
                         logging_level=logging.ERROR)
        else:
            ray.init(address=address, log_to_driver=False, logging_level=logging.ERROR)
    except (ConnectionError, RuntimeError, ValueError) as e:
        where = f"connect to the Ray cluster at {address}" if address else "start a local Ray"
        hint = (" (a cluster with token authentication, `ray start`'s default, needs RAY_AUTH_MODE=token here "
                "and its token in ~/.ray/auth_token or RAY_AUTH_TOKEN)"
                if address and "RAY_AUTH_MODE" not in os.environ else "")
        raise SweepError(f"cannot {where}: {str(e).strip().splitlines()[0]}{hint}") from None
    return ray


def _reachable(address: str) -> None:
    """SweepError at once if nothing listens at HOST:PORT (Ray itself would retry for minutes)."""
    host, _, port = address.removeprefix("ray://").rpartition(":")
    if not host or not port.isdigit():
        raise SweepError(f"--address {address}: give HOST:PORT (or ray://HOST:PORT, or auto)")
    try:
        socket.create_connection((host.strip("[]"), int(port)), timeout=CONNECT_TIMEOUT_S).close()
    except OSError as e:
        raise SweepError(f"cannot reach the Ray cluster at {address}: {e.strerror or e}") from None


def _import_ray():
    try:
        import ray
    except ImportError:
        raise SweepError("--address and --ray run on Ray: pip install 'roar-platform[sweep]' "
                         "(without either, the sweep runs on this machine's cores)") from None
    return ray


def _bar(total: int, done: int):
    from tqdm import tqdm

    return tqdm(total=total, initial=done, desc="sweep", unit="run", file=sys.stderr, mininterval=0.5)


def best(rows: Iterable[dict], track: str) -> dict | None:
    """The row of `track` with the lowest best-lap ratio among runs that drove every lap
    without touching a wall; None if there is none."""
    clean = [r for r in rows if r["track"] == track and r["status"] == "ok" and r["wall_contacts"] == "0"]
    return min(clean, key=lambda r: float(r["best_ratio"]), default=None)


def report(rows: Sequence[dict], tracks: Sequence[str]) -> str:
    lines = []
    failed = [r for r in rows if r["status"] == "failed"]
    incomplete = sum(r["status"] == "incomplete" for r in rows)
    lines.append(f"{_count(len(rows), 'run')}: {len(rows) - len(failed) - incomplete} drove every lap, {incomplete} "
                 f"incomplete, {len(failed)} failed")
    for track in tracks:
        b = best(rows, track)
        if b is None:
            lines.append(f"{track}: no run drove every lap without touching a wall")
        else:
            lines.append(f"{track}: best K_dd {float(b['k_dd_s']):g} s, margin {float(b['margin']):g}: best lap "
                         f"{float(b['best_lap_s']):.2f} s = {float(b['best_ratio']):.3f} x the physical limit "
                         f"({float(b['limit_lap_s']):.2f} s)")
    for r in failed:
        lines.append(f"failed: {printable(r['track'])} K_dd {float(r['k_dd_s']):g} margin {float(r['margin']):g}: "
                     f"{printable(r['error'], 200)}")
    return "\n".join(lines)


def _count(n: int, thing: str) -> str:
    return f"{n} {thing}{'s' if n != 1 else ''}"


def plot(rows: Sequence[dict], tracks: Sequence[str]):
    """A heat map per track: best lap / physical-limit lap over K_dd x margin; runs that touched
    a wall, did not finish or failed are marked in their cells."""
    import numpy as np

    fig, axes = plotting.subplots(ncols=len(tracks), figsize=(5.5 * len(tracks) + 1, 4.8), squeeze=False)
    for ax, track in zip(axes[0], tracks):
        mine = [r for r in rows if r["track"] == track]
        ks = sorted({float(r["k_dd_s"]) for r in mine})
        ms = sorted({float(r["margin"]) for r in mine})
        ratio = np.full((len(ms), len(ks)), np.nan)
        marks = {}
        for r in mine:
            i, j = ms.index(float(r["margin"])), ks.index(float(r["k_dd_s"]))
            clean = r["status"] == "ok" and r["wall_contacts"] == "0"
            if clean:
                ratio[i, j] = float(r["best_ratio"])
            marks[i, j] = (f"{float(r['best_ratio']):.3f}" if clean else "failed" if r["status"] == "failed" else
                           f"wall\n{float(r['best_ratio']):.3f}" if r["status"] == "ok" else "laps\nshort")
        image = ax.imshow(np.ma.masked_invalid(ratio), origin="lower", cmap="viridis_r", aspect="auto")
        for (i, j), mark in marks.items():  # light text on the dark (slow) end of the colour map
            dark = np.isfinite(ratio[i, j]) and image.norm(ratio[i, j]) > 0.6
            ax.text(j, i, mark, ha="center", va="center", fontsize=8,
                    color="firebrick" if not np.isfinite(ratio[i, j]) else "white" if dark else "black")
        fig.colorbar(image, ax=ax, label="best lap / physical-limit lap")
        ax.set_xticks(range(len(ks)), [f"{k:g}" for k in ks])
        ax.set_yticks(range(len(ms)), [f"{m:g}" for m in ms])
        ax.set_xlabel("pure pursuit K_dd [s]")
        ax.set_ylabel("speed margin (fraction of the limits)")
        b = best(rows, track)
        ax.set_title(f"{track}: best {float(b['best_ratio']):.3f} x (K_dd {float(b['k_dd_s']):g}, margin "
                     f"{float(b['margin']):g})" if b else f"{track}: no clean run", fontsize=10)
    return fig


def parser() -> argparse.ArgumentParser:
    p = ArgumentParser(prog="roar sweep", description=__doc__)
    p.add_argument("--track", default=DEFAULT_TRACKS,
                   help=f"tracks, comma-separated: {FORMS}; a seed range random:A-B is each seed (default: "
                        f"{DEFAULT_TRACKS})")
    p.add_argument("--k-dd", default=DEFAULT_K_DD_S, metavar="LIST",
                   help=f"pure pursuit's look-ahead per m/s [s] (default: {DEFAULT_K_DD_S})")
    p.add_argument("--margin", default=DEFAULT_MARGINS, metavar="LIST",
                   help=f"fractions of the robot's limits to drive at (default: {DEFAULT_MARGINS})")
    p.add_argument("--laps", type=int, default=2, help="laps per race; the best counts (default: 2)")
    p.add_argument("--robot", choices=robots.names(), default="esc", help="which robot races (default: the ESC car)")
    p.add_argument("--out", type=path_option, default=Path("out/sweep"), metavar="DIR",
                   help="results.csv and sweep.png go here (default: out/sweep); an existing results.csv "
                        "is resumed")
    p.add_argument("--address", metavar="HOST:PORT",
                   help="run on this Ray cluster ('auto': the one `ray start` began on this machine); "
                        "default: processes on this machine's cores")
    p.add_argument("--ray", action="store_true", help="run on a local Ray started for this sweep alone")
    p.add_argument("--workers", type=int, metavar="N",
                   help="processes (or the local Ray's CPUs) on this machine (default: one per core)")
    p.add_argument("--serial", action="store_true", help="run here, one race after another")
    return p


def main(argv: list[str] | None = None) -> int:
    from roar_sim.runs.race import K_DD_RANGE_S, MARGIN_RANGE

    p = parser()
    args = p.parse_args(argv)
    if not 1 <= args.laps <= 20:
        p.error("--laps must be 1..20")
    if args.workers is not None and not 1 <= args.workers <= 1024:
        p.error("--workers must be 1..1024")
    if args.workers is not None and (args.address or args.serial):
        p.error("--workers sizes this machine's share: not with --address or --serial")
    if sum(map(bool, (args.address, args.ray, args.serial))) > 1:
        p.error("--address, --ray and --serial each say where to run: give one")
    try:
        runs, tracks = _runs(args, K_DD_RANGE_S, MARGIN_RANGE)
        if args.address not in (None, "auto"):
            _reachable(args.address)
        problem = unusable_folder(args.out)
        if problem:
            raise SweepError(f"--out {problem}")
        table = Table(args.out / "results.csv")
        for line, problem, _ in table.damaged[:MAX_DAMAGED_SHOWN]:
            print(f"{table.path} line {line}: {problem}: set aside in {table.damaged_path.name} "
                  f"(its run, if in this sweep, runs again)", file=sys.stderr)
        if len(table.damaged) > MAX_DAMAGED_SHOWN:
            print(f"{table.path}: {len(table.damaged) - MAX_DAMAGED_SHOWN} more damaged rows set aside",
                  file=sys.stderr)
        before = sum(table.finished(r) for r in runs)
        print(f"{_count(len(runs), 'run')} ({_count(len(tracks), 'track')} x {_count(len(runs) // len(tracks), 'parameter point')}); "
              f"{before} already in {table.path}, {len(runs) - before} to run "
              f"{_where(args)}", file=sys.stderr)
        rows = sweep(runs, table, serial=args.serial, address=args.address, workers=args.workers, progress=True,
                     ray=args.ray)
    except OSError as e:
        raise SweepError(f"{args.out}: {e.strerror or e}") from None
    except KeyboardInterrupt as e:
        print(f"interrupted: the finished runs are in {args.out / 'results.csv'}; the same command resumes",
              file=sys.stderr)
        return stopped_status(e)
    print(report(rows, tracks))
    print(f"table: {table.path}")
    if not plotting.save(lambda: plot(rows, tracks), args.out / "sweep.png"):
        return ExitStatus.ERROR
    return ExitStatus.SHORT if any(r["status"] == "failed" for r in rows) else ExitStatus.OK


def _where(args) -> str:
    if args.serial:
        return "here"
    if args.address:
        return f"on Ray at {args.address}"
    if args.ray:
        return "on a local Ray"
    n = args.workers or len(cores())
    return f"on {n} local process{'es' if n != 1 else ''}"


def _runs(args, k_range: tuple[float, float], m_range: tuple[float, float]) -> tuple[list[Run], list[str]]:
    from roar.tracks import TrackError, get
    from roar.tracks.names import split_names

    tracks = split_names(args.track)
    if not tracks:
        raise SweepError("--track: no tracks")
    for t in tracks:
        try:
            get(t)
        except TrackError as e:
            raise SweepError(str(e)) from None
    runs = grid(tracks, parse_values(args.k_dd, "k-dd", *k_range), parse_values(args.margin, "margin", *m_range),
                args.laps, args.robot)
    if len(runs) > MAX_RUNS:
        raise SweepError(f"the grid has {len(runs)} runs; more than {MAX_RUNS} is surely a typo")
    return runs, tracks


if __name__ == "__main__":
    sys.exit(run_command("roar sweep", main))
