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
import math
import sys
from collections.abc import Callable, Iterable, Sequence
from contextlib import closing
from pathlib import Path

from roar.checks import printable
from roar.cli.sdk import ArgumentParser, ExitStatus, path_option, run_command, stopped_status
from roar.tracks.names import FORMS
from roar.user_files import unusable_folder
from roar_sim import SweepError, robots
from roar_sim.runs.processes import cores
from roar_sim.runs.sweep_table import COLUMNS, Run, Table, as_strings, failed_row, run_columns  # noqa: F401
from roar_sim.runs.sweep_workers import reachable, rows_here, rows_on_processes, rows_on_ray
from roar_sim.world import plotting

DEFAULT_K_DD_S = "0.2,0.4,0.6,0.8"  # [s] pure pursuit's look-ahead per m/s
DEFAULT_MARGINS = "0.85,0.9,0.95,1.0"  # fractions of the car's limits
DEFAULT_TRACKS = "figure-eight"
MAX_RUNS = 10_000  # a grid larger than this is a typo
MAX_DAMAGED_SHOWN = 5  # damaged table rows reported one per line; the rest counted


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
    return {**run_columns(run), "status": "ok" if done >= run.laps else "incomplete", "laps_done": done,
            "best_lap_s": min(result.lap_times_s) if done else "", "limit_lap_s": result.limit_lap_s,
            "best_ratio": result.best_ratio if done else "", "wall_contacts": result.wall_contacts,
            "max_cross_track_m": result.max_cross_track_m, "error": ""}


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
        rows_of = rows_here
    elif address is not None or ray:
        rows_of = lambda todo, fn: rows_on_ray(todo, fn, address, workers)  # noqa: E731
    else:
        rows_of = lambda todo, fn: rows_on_processes(todo, fn, workers)  # noqa: E731
    try:
        if todo:
            with closing(rows_of(todo, fn)) as rows:
                for row in rows:  # as each run finishes
                    table.add(as_strings(row))
                    if bar:
                        bar.update(1)
    finally:
        if bar:
            bar.close()
        if table.rows:
            table.rewrite(runs)
    return table.of(runs)


def _bar(total: int, done: int):
    from roar_sim.runs.progress import bar

    return bar(total=total, initial=done, desc="sweep", unit="run")


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
            reachable(args.address)
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
