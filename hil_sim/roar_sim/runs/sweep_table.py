"""A sweep's runs and its results table: a Run is one grid point, a row its result, the Table the
CSV the rows go into as runs finish (resumed by the next sweep; damaged rows set aside)."""

from __future__ import annotations

import csv
import math
import os
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

from roar.checks import shown
from roar_sim import SweepError

COLUMNS = ("track", "robot", "k_dd_s", "margin", "laps", "status", "laps_done", "best_lap_s", "limit_lap_s",
           "best_ratio", "wall_contacts", "max_cross_track_m", "error")


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


def attempt(fn: Callable[[Run], dict], run: Run) -> dict:
    """fn(run), or a `failed` row saying why in one line: the same in a Ray worker and here."""
    try:
        return fn(run)
    except Exception as e:  # noqa: BLE001 -- any failure of one run is reported, the sweep goes on
        return failed_row(run, f"{type(e).__name__}: {str(e).strip().splitlines()[0] if str(e).strip() else ''}")


def failed_row(run: Run, why: str) -> dict:
    return {**run_columns(run), "status": "failed", "laps_done": 0, "best_lap_s": "", "limit_lap_s": "",
            "best_ratio": "", "wall_contacts": "", "max_cross_track_m": "", "error": why.replace("\n", " ")}


def run_columns(run: Run) -> dict:
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
                        self.rows[row_key(row)] = row
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
        self.rows[row_key(row)] = row
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


def row_key(row: dict) -> tuple:
    return row["track"], row["robot"], float(row["k_dd_s"]), float(row["margin"]), int(row["laps"])


def as_strings(row: dict) -> dict:
    """The row as the CSV holds it (repr for floats: they read back exactly)."""
    return {c: repr(v) if isinstance(v, float) else str(v) for c, v in ((c, row.get(c, "")) for c in COLUMNS)}


